//! Rolling-element bearing force element after Sawalhi & Randall (2008, MSSP 22 "Simulating
//! gear and bearing interactions in the presence of faults", parts I–II) and the 15-DOF
//! bearing–gear model: balls as nonlinear Hertzian springs between the shaft and the pedestal,
//! ball positions from the cage kinematics (with random slip), and spalls entering the contact
//! deflection while a ball is over them.

use super::machine::FaultLocation;
use super::system::ForceElement;
use std::f64::consts::{PI, TAU};
use std::sync::LazyLock;

/// Prescribed rotation of a shaft: mean speed plus an optional sinusoidal fluctuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShaftMotion {
    /// Mean speed, Hz.
    pub mean_hz: f64,
    /// Peak relative speed deviation (e.g. 0.01 for 1 %).
    pub fluctuation: f64,
    /// Fluctuation frequency, Hz.
    pub fluctuation_hz: f64,
}

impl ShaftMotion {
    /// Constant speed.
    pub fn constant(mean_hz: f64) -> Self {
        Self { mean_hz, fluctuation: 0.0, fluctuation_hz: 1.0 }
    }

    /// Rotation angle in rad: `2π f₀ t + (a f₀ / f_m) sin 2π f_m t`.
    pub fn angle(&self, t: f64) -> f64 {
        // At constant speed the second term is an exact zero: skip its sine (the bearing
        // elements call this once per force evaluation).
        if self.fluctuation == 0.0 {
            return TAU * self.mean_hz * t;
        }
        TAU * self.mean_hz * t + self.fluctuation * self.mean_hz / self.fluctuation_hz * (TAU * self.fluctuation_hz * t).sin()
    }

    /// Instantaneous speed in Hz: `f₀ (1 + a cos 2π f_m t)`.
    pub fn speed_hz(&self, t: f64) -> f64 {
        // At constant speed `1 + 0 · cos(…)` is exactly 1 (the cosine is finite): skip it.
        if self.fluctuation == 0.0 {
            return self.mean_hz;
        }
        self.mean_hz * (1.0 + self.fluctuation * (TAU * self.fluctuation_hz * t).cos())
    }
}

/// A depth profile along a race or a ball, as a function of the arc position `s` (m) measured
/// from the fault's leading edge, with `s ∈ [0, length)`.
#[derive(Debug, Clone, PartialEq)]
pub enum DepthProfile {
    /// A localised spall of `length` and `depth`: the ball centre drops as it rolls over the
    /// entry edge, `h(s) = r − √(r² − a²)` with `a = min(s, L − s)`, capped at the depth
    /// (the ball cannot reach the bottom of a short spall; Sawalhi & Randall 2008).
    Spall { length_m: f64, depth_m: f64, ball_radius_m: f64 },
    /// An extended fault: linear entry and exit ramps, a flat bottom with roughness sampled on
    /// a table (interpolated linearly), never below zero. `roughness_m` holds one profile, the
    /// same on every pass of a ball, or several: then each pass of a ball over the fault (see
    /// [`DepthProfile::depth_on_pass`]) meets one of them, picked by hashing the ball and the
    /// pass, so the roughness response is random from pass to pass (second-order
    /// cyclostationary, as Sawalhi, Deshpande & Randall describe an extended fault's signal)
    /// instead of a fixed pattern repeating at the fault's rotation.
    Extended { length_m: f64, depth_m: f64, ramp_m: f64, roughness_m: Vec<Vec<f64>> },
}

impl DepthProfile {
    /// Fault length along the rolling direction, m.
    pub fn length_m(&self) -> f64 {
        match self {
            DepthProfile::Spall { length_m, .. } | DepthProfile::Extended { length_m, .. } => *length_m,
        }
    }

    /// Whether [`DepthProfile::depth_at`] is ≥ 0 everywhere: a spall of non-negative depth
    /// and ball radius (its curvature limit `r − √(r² − a²)` is then ≥ 0), an extended fault
    /// always (its depth is clipped at 0).
    pub fn never_negative(&self) -> bool {
        match self {
            DepthProfile::Spall { depth_m, ball_radius_m, .. } => *depth_m >= 0.0 && *ball_radius_m >= 0.0,
            DepthProfile::Extended { .. } => true,
        }
    }

    /// Depth (m) at arc position `s` (m) from the leading edge; 0 outside the fault. An
    /// extended fault with several roughness profiles shows the one of pass key 0.
    pub fn depth_at(&self, s: f64) -> f64 {
        self.depth_on_pass(s, 0)
    }

    /// Depth (m) at arc position `s` (m) on the pass keyed `pass`: an extended fault with
    /// several roughness profiles uses profile `mix(pass) mod count`; otherwise the pass does
    /// not matter.
    pub fn depth_on_pass(&self, s: f64, pass: u64) -> f64 {
        match self {
            DepthProfile::Spall { length_m, depth_m, ball_radius_m } => {
                if s <= 0.0 || s >= *length_m {
                    return 0.0;
                }
                let a = s.min(length_m - s).min(*ball_radius_m);
                (ball_radius_m - (ball_radius_m * ball_radius_m - a * a).sqrt()).min(*depth_m)
            }
            DepthProfile::Extended { length_m, depth_m, ramp_m, roughness_m } => {
                if s <= 0.0 || s >= *length_m {
                    return 0.0;
                }
                let ramp = if *ramp_m > 0.0 { (s / ramp_m).min((length_m - s) / ramp_m).min(1.0) } else { 1.0 };
                let row: &[f64] = match roughness_m.len() {
                    0 => &[],
                    1 => &roughness_m[0],
                    n => &roughness_m[(mix64(pass) % n as u64) as usize],
                };
                let rough = if row.len() >= 2 {
                    let x = s / length_m * (row.len() - 1) as f64;
                    let i = (x.floor() as usize).min(row.len() - 2);
                    let fr = x - i as f64;
                    row[i] * (1.0 - fr) + row[i + 1] * fr
                } else {
                    0.0
                };
                (depth_m * ramp + rough * ramp).max(0.0)
            }
        }
    }
}

/// SplitMix64's finaliser: a well-mixed 64-bit hash of `x` (Steele, Lea & Flood 2014).
#[inline]
fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Key of one pass of ball `j` over a race fault: the ball and the whole turns of its angle
/// `rel` past the fault's leading edge, which stay the same while the ball is over the fault
/// (the fault spans `[0, length)` of the wrapped angle).
#[inline]
fn pass_key(j: usize, rel: f64) -> u64 {
    let turns = (rel / TAU).floor() as i64;
    ((j as u64) << 48) ^ (turns as u64)
}

/// A fault on a race or a ball.
#[derive(Debug, Clone, PartialEq)]
pub struct BearingFault {
    /// Outer race, inner race or ball.
    pub location: FaultLocation,
    /// Depth along the rolling direction.
    pub profile: DepthProfile,
    /// Angular position at t = 0, rad (outer: from the load direction; inner: on the inner race;
    /// ball: spin angle of ball 0).
    pub position_rad: f64,
}

/// Contact law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactLaw {
    /// `Q = K δⁿ` for δ > 0.
    Hertz { k: f64, n: f64 },
    /// `Q = k δ` for δ > 0.
    Linear { k: f64 },
}

/// The bearing element between shaft DOFs (x, y) and pedestal DOFs (x, y).
#[derive(Debug, Clone)]
pub struct BearingElement {
    /// Name for messages.
    pub name: String,
    /// Shaft x, y DOFs.
    pub shaft: (usize, usize),
    /// Pedestal x, y DOFs.
    pub pedestal: (usize, usize),
    /// Number of rolling elements.
    pub balls: usize,
    /// Ball diameter, m.
    pub ball_diameter_m: f64,
    /// Pitch diameter, m.
    pub pitch_diameter_m: f64,
    /// `d/D cos φ`.
    pub ratio: f64,
    /// Effective radial clearance, m (negative = preload interference).
    pub clearance_m: f64,
    /// Contact law.
    pub law: ContactLaw,
    /// Shaft rotation.
    pub motion: ShaftMotion,
    /// Faults (a localised one and/or an extended one).
    pub faults: Vec<BearingFault>,
    /// Slip table: `slip[j][m]` = angular offset (rad) of ball `j` at cage revolution `m`.
    pub slip: Vec<Vec<f64>>,
    /// This element's key in the per-thread memo of what its forces take from time alone
    /// (`Default::default()`).
    pub memo: super::memo::MemoId,
}

/// What a bearing's force evaluation takes from time alone: the shaft and cage angles, the
/// balls that may meet a fault, the cage revolutions, the cage angle's sine and cosine, and,
/// for a bearing of at most [`TimeState::TABLED_BALLS`] balls, each ball's direction and fault
/// depth ([`TimeState::balls`]).
#[derive(Clone, Copy)]
struct TimeState {
    shaft_angle: f64,
    cage: f64,
    windows: FaultWindows,
    rev: f64,
    sin_cage: f64,
    cos_cage: f64,
    balls: BallTable,
}

/// Per ball j, at one time: `(sin φ_j, cos φ_j)` and the fault depth `h_j` under it (0 for a
/// ball no fault window holds; `δ − 0 = δ` exactly, so subtracting it changes nothing).
#[derive(Clone, Copy)]
struct BallTable {
    sin: [f64; TimeState::TABLED_BALLS],
    cos: [f64; TimeState::TABLED_BALLS],
    depth: [f64; TimeState::TABLED_BALLS],
}

impl TimeState {
    /// The most balls whose directions and depths are tabled per time; a bearing with more
    /// computes them in every evaluation.
    const TABLED_BALLS: usize = 32;

    /// The value of an empty memo slot, never read.
    const PLACEHOLDER: Self = Self {
        shaft_angle: 0.0,
        cage: 0.0,
        windows: FaultWindows { race: [(0.0, 0.0); FaultWindows::MAX_RACE], n_race: 0, eps: 0.0, ball0: false, every_ball: false },
        rev: 0.0,
        sin_cage: 0.0,
        cos_cage: 0.0,
        balls: BallTable { sin: [0.0; Self::TABLED_BALLS], cos: [0.0; Self::TABLED_BALLS], depth: [0.0; Self::TABLED_BALLS] },
    };
}

/// Smallest non-negative representative of `a` modulo 2π.
fn wrap(a: f64) -> f64 {
    a.rem_euclid(TAU)
}

/// Depth of a race fault under ball `j` at angle `rel` (rad) past the fault's leading edge,
/// on a race of rolling radius `r` (m): `profile.depth_on_pass(wrap(rel) · r, pass_key(j, rel))`
/// (the pass matters only to an extended fault with several roughness profiles). A fault covers a few
/// degrees, so most balls are far from it; a cheap reduction (a few ulps of `rel` off the
/// exact remainder) decides that first, with a 1e-9 rad margin, and only a ball near the
/// fault pays for the exact `rem_euclid` (a software `fmod`). The result is bit-identical.
#[inline]
fn race_depth(profile: &DepthProfile, rel: f64, r: f64, j: usize) -> f64 {
    const MARGIN_RAD: f64 = 1e-9;
    let approx = reduce_turns(rel);
    if (approx - MARGIN_RAD) * r >= profile.length_m() && approx <= TAU - MARGIN_RAD {
        return 0.0;
    }
    profile.depth_on_pass(wrap(rel) * r, pass_key(j, rel))
}

/// `sin_cos(2π / balls)`, the rotation between neighbouring balls, tabled once for the ball
/// counts bearings have (the same libm call, so the same bits as computing it per evaluation).
fn spacing_sin_cos(balls: usize) -> (f64, f64) {
    const TABLED: usize = 64;
    static TABLE: LazyLock<Vec<(f64, f64)>> = LazyLock::new(|| (0..=TABLED).map(|z| (TAU / z as f64).sin_cos()).collect());
    if balls <= TABLED {
        TABLE[balls]
    } else {
        (TAU / balls as f64).sin_cos()
    }
}

/// Which balls may be over a race fault in one force evaluation, decided once for all balls.
///
/// Ball j is at `φ_j = cage + o_j` with `o_j = j·spacing + ξ_j`; a race fault's leading edge is
/// at `θ_f` (outer race: fixed; inner race: turning with the shaft), and it covers
/// `w = L / r` rad. The ball can see a depth only if `(o_j − (θ_f − cage)) mod 2π` lies in
/// `[−ε, w + ε]`. `ε` (1e-6 rad plus 1e-12 of the angles' size) is far above the rounding
/// of either side, so a ball declared far would have got exactly zero depth from
/// [`race_depth`]: skipping it leaves every force bit-identical. A ball fault is seen by
/// ball 0 only.
#[derive(Clone, Copy)]
struct FaultWindows {
    /// Per race fault: `(θ_f − cage)` reduced to about [0, 2π), and `w + ε`.
    race: [(f64, f64); Self::MAX_RACE],
    n_race: usize,
    eps: f64,
    /// A ball fault: ball 0 is always a candidate.
    ball0: bool,
    /// Too many faults to table: every ball is a candidate.
    every_ball: bool,
}

impl FaultWindows {
    const MAX_RACE: usize = 4;

    fn new(faults: &[BearingFault], cage: f64, shaft_angle: f64, (r_outer, r_inner): (f64, f64)) -> Self {
        let mut w = Self { race: [(0.0, 0.0); Self::MAX_RACE], n_race: 0, eps: 0.0, ball0: false, every_ball: false };
        let mut size = cage.abs();
        for f in faults {
            let (fault_angle, r) = match f.location {
                FaultLocation::Outer => (f.position_rad, r_outer),
                FaultLocation::Inner => (f.position_rad + shaft_angle, r_inner),
                FaultLocation::Ball => {
                    w.ball0 = true;
                    continue;
                }
            };
            if w.n_race == Self::MAX_RACE {
                w.every_ball = true;
                return w;
            }
            size = size.max(fault_angle.abs());
            w.race[w.n_race] = (reduce_turns(fault_angle - cage), f.profile.length_m() / r);
            w.n_race += 1;
        }
        w.eps = 1e-6 + 1e-12 * size;
        for (_, width) in &mut w.race[..w.n_race] {
            *width += w.eps;
        }
        w
    }

    /// Whether ball `j`, at `offset` = `j·spacing + ξ_j` rad past the cage, may be over a fault.
    #[inline]
    fn may_touch(&self, j: usize, offset: f64) -> bool {
        if self.every_ball || (self.ball0 && j == 0) {
            return true;
        }
        self.race[..self.n_race].iter().any(|&(base, width)| {
            let d = reduce_turns(offset - base);
            d <= width || d >= TAU - self.eps
        })
    }
}

/// `a` less a whole number of turns, in about [0, 2π) (a few ulps of `a` off the exact
/// remainder). No division and no `f64::floor` (a library call without SSE4.1): whole turns
/// by truncation, corrected below zero.
#[inline]
fn reduce_turns(a: f64) -> f64 {
    let turns = a * (1.0 / TAU);
    let mut whole = turns as i64 as f64;
    if whole > turns {
        whole -= 1.0;
    }
    a - TAU * whole
}

impl BearingElement {
    /// Cage angle (rad) at time t: `(FTF/f_r) θ_shaft(t)`.
    pub fn cage_angle(&self, t: f64) -> f64 {
        self.cage_angle_of(self.motion.angle(t))
    }

    /// `read` of what a force evaluation at `t` takes from time alone ([`TimeState`]),
    /// through the per-thread memo ([`super::memo`]), lent rather than copied.
    #[inline]
    fn with_time_state<R>(&self, t: f64, read: impl FnOnce(&TimeState) -> R) -> R {
        thread_local! {
            static LAST: super::memo::Slots<TimeState> = const { super::memo::Slots::new(TimeState::PLACEHOLDER) };
        }
        super::memo::with_at_time(
            &LAST,
            &self.memo,
            t,
            |state| {
                let shaft_angle = self.motion.angle(t);
                let cage = self.cage_angle_of(shaft_angle);
                let windows = FaultWindows::new(&self.faults, cage, shaft_angle, self.race_radii_m());
                let rev = Self::cage_revolutions(cage);
                let (sin_cage, cos_cage) = cage.sin_cos();
                (state.shaft_angle, state.cage, state.windows, state.rev, state.sin_cage, state.cos_cage) = (shaft_angle, cage, windows, rev, sin_cage, cos_cage);
                if self.balls <= TimeState::TABLED_BALLS {
                    let table = &mut state.balls;
                    self.for_each_ball(cage, rev, (sin_cage, cos_cage), |j, s, c, offset, phi| {
                        table.sin[j] = s;
                        table.cos[j] = c;
                        table.depth[j] = if windows.may_touch(j, offset) { self.fault_depth(j, phi, shaft_angle) } else { 0.0 };
                    });
                }
            },
            read,
        )
    }

    /// `each(j, sin φ_j, cos φ_j, o_j, φ_j)` for every ball j at a cage angle `cage` (rad;
    /// `rev` cage revolutions, `sin_cos_cage` its sine and cosine), where `φ_j = cage + o_j`
    /// and `o_j = j·spacing + ξ_j` (ξ_j its slip offset).
    ///
    /// One sin_cos for the cage (given), then a rotation recurrence by the spacing, and a
    /// 4th-order Taylor rotation by the small slip offset (|ξ| ≲ 0.05 rad, error < 3e-9),
    /// instead of a sin_cos per ball.
    #[inline]
    fn for_each_ball(&self, cage: f64, rev: f64, sin_cos_cage: (f64, f64), mut each: impl FnMut(usize, f64, f64, f64, f64)) {
        let spacing = TAU / self.balls as f64;
        let has_slip = !self.slip.is_empty();
        let (mut s0, mut c0) = sin_cos_cage;
        let (ds, dc) = spacing_sin_cos(self.balls);
        let mut jf = 0.0; // j as f64, counted (exact) rather than converted from usize
        for j in 0..self.balls {
            let (mut s, mut c) = (s0, c0);
            let mut offset = spacing * jf;
            let mut phi = cage + offset;
            jf += 1.0;
            if has_slip {
                let xi = self.slip_offset_at(j, rev);
                let x2 = xi * xi;
                let (sx, cx) = (xi * (1.0 - x2 / 6.0), 1.0 - x2 / 2.0 + x2 * x2 / 24.0);
                (s, c) = (s * cx + c * sx, c * cx - s * sx);
                phi += xi;
                offset += xi;
            }
            each(j, s, c, offset, phi);
            (s0, c0) = (s0 * dc + c0 * ds, c0 * dc - s0 * ds);
        }
    }

    /// Cage angle (rad) for a shaft angle (rad).
    #[inline]
    fn cage_angle_of(&self, shaft_angle: f64) -> f64 {
        0.5 * (1.0 - self.ratio) * shaft_angle
    }

    /// Angular position of ball `j` at time `t`, rad, from the load direction.
    pub fn ball_angle(&self, j: usize, t: f64) -> f64 {
        let cage = self.cage_angle(t);
        cage + TAU * j as f64 / self.balls as f64 + self.slip_offset(j, cage)
    }

    fn slip_offset(&self, j: usize, cage: f64) -> f64 {
        self.slip_offset_at(j, Self::cage_revolutions(cage))
    }

    /// Cage revolutions completed at a cage angle (rad), ≥ 0: the slip table's abscissa.
    #[inline]
    fn cage_revolutions(cage: f64) -> f64 {
        (cage / TAU).max(0.0)
    }

    /// Slip offset of ball `j` (rad) after `rev` cage revolutions (≥ 0), interpolated linearly
    /// in its table.
    #[inline]
    fn slip_offset_at(&self, j: usize, rev: f64) -> f64 {
        let Some(table) = self.slip.get(j) else { return 0.0 };
        if table.len() < 2 {
            return 0.0;
        }
        // `rev ≥ 0`, so truncation is the floor (without a libm call).
        let m = (rev as usize).min(table.len() - 2);
        let fr = (rev - m as f64).clamp(0.0, 1.0);
        table[m] * (1.0 - fr) + table[m + 1] * fr
    }

    /// Rolling radii of the outer and inner race (m): `(D ± d) / 2`.
    #[inline]
    fn race_radii_m(&self) -> (f64, f64) {
        (0.5 * (self.pitch_diameter_m + self.ball_diameter_m), 0.5 * (self.pitch_diameter_m - self.ball_diameter_m))
    }

    /// Fault depth seen by ball `j` at angle `phi` when the shaft has turned by `shaft_angle`
    /// (rad), m.
    fn fault_depth(&self, j: usize, phi: f64, shaft_angle: f64) -> f64 {
        let mut depth = 0.0;
        for f in &self.faults {
            let d = match f.location {
                FaultLocation::Outer => race_depth(&f.profile, phi - f.position_rad, self.race_radii_m().0, j),
                FaultLocation::Inner => {
                    let r = self.race_radii_m().1;
                    let fault_angle = f.position_rad + shaft_angle;
                    race_depth(&f.profile, phi - fault_angle, r, j)
                }
                FaultLocation::Ball => {
                    if j != 0 {
                        0.0
                    } else {
                        // Spin angle: BSF/f_r · θ_shaft. The spall meets the outer race at spin
                        // angle 0 and the inner race at π: two strikes per spin revolution.
                        let spin = f.position_rad + self.pitch_diameter_m / (2.0 * self.ball_diameter_m) * (1.0 - self.ratio * self.ratio) * shaft_angle;
                        let rb = 0.5 * self.ball_diameter_m;
                        let s = wrap(spin) % PI;
                        f.profile.depth_at(s * rb)
                    }
                }
            };
            depth += d;
        }
        depth
    }

    /// Contact load of each ball at a state (for tests and load-distribution checks), N.
    pub fn ball_loads(&self, t: f64, q: &[f64]) -> Vec<f64> {
        self.ball_deflections(t, q).into_iter().map(|d| self.contact_force(d)).collect()
    }

    /// Contact deflection of each ball at a state, m (positive = compressed): `δ_j = (x_s − x_p)
    /// sin φ_j − (y_s − y_p) cos φ_j − c − h_j`, with `h_j` the fault depth under the ball.
    pub fn ball_deflections(&self, t: f64, q: &[f64]) -> Vec<f64> {
        let dx = q[self.shaft.0] - q[self.pedestal.0];
        let dy = q[self.shaft.1] - q[self.pedestal.1];
        let shaft_angle = self.motion.angle(t);
        (0..self.balls)
            .map(|j| {
                let phi = self.ball_angle(j, t);
                dx * phi.sin() - dy * phi.cos() - self.clearance_m - self.fault_depth(j, phi, shaft_angle)
            })
            .collect()
    }

    /// Potential energy stored in one contact at deflection `delta` (m), J:
    /// `K δ^(n+1)/(n+1)` (Hertz) or `½ k δ²` (linear); 0 when unloaded.
    #[inline]
    fn contact_potential(&self, delta: f64) -> f64 {
        if delta <= 0.0 {
            return 0.0;
        }
        match self.law {
            ContactLaw::Hertz { k, n } => k * delta.powf(n + 1.0) / (n + 1.0),
            ContactLaw::Linear { k } => 0.5 * k * delta * delta,
        }
    }

    #[inline]
    fn contact_force(&self, delta: f64) -> f64 {
        if delta <= 0.0 {
            return 0.0;
        }
        match self.law {
            ContactLaw::Hertz { k, n } => {
                if n == 1.5 {
                    k * delta * delta.sqrt()
                } else {
                    k * delta.powf(n)
                }
            }
            ContactLaw::Linear { k } => k * delta,
        }
    }
}

impl BearingElement {
    /// The contact force `(F_x, F_y)` of all balls on the shaft, N, at the time of `ts` and the
    /// relative displacement `(dx, dy)` (shaft − pedestal, m), with each ball's direction and
    /// depth read from `ts`'s table (at most [`TimeState::TABLED_BALLS`] balls). The same
    /// values in the same operations as [`Self::contact_forces_untabled`], so the same forces
    /// to the bit.
    #[inline]
    fn contact_forces_tabled(&self, ts: &TimeState, dx: f64, dy: f64) -> (f64, f64) {
        let (mut fx, mut fy) = (0.0, 0.0);
        let b = &ts.balls;
        for j in 0..self.balls {
            let (s, c) = (b.sin[j], b.cos[j]);
            // Unit vector from the bearing centre to ball j: (sin φ, −cos φ); φ = 0 is the load
            // direction (−y, "6 o'clock").
            let qj = self.contact_force(dx * s - dy * c - self.clearance_m - b.depth[j]);
            if qj > 0.0 {
                fx += qj * s;
                fy -= qj * c;
            }
        }
        (fx, fy)
    }

    /// [`Self::contact_forces_tabled`], with each ball's direction and depth computed here:
    /// for bearings with more balls than the table holds.
    fn contact_forces_untabled(&self, ts: &TimeState, dx: f64, dy: f64) -> (f64, f64) {
        let (mut fx, mut fy) = (0.0, 0.0);
        // Of the balls in contact, only those near a fault can see a depth: which they are is
        // decided once per time (`FaultWindows`), so the others skip it too. A fault only
        // deepens the gap (depth h ≥ 0): a ball out of contact without it, δ ≤ 0, stays out
        // with it (δ − h ≤ δ ≤ 0 exactly in floating point), so its fault depth is skipped.
        let skip_unloaded = self.faults.iter().all(|f| f.profile.never_negative());
        self.for_each_ball(ts.cage, ts.rev, (ts.sin_cage, ts.cos_cage), |j, s, c, offset, phi| {
            let mut delta = dx * s - dy * c - self.clearance_m;
            if ts.windows.may_touch(j, offset) && !(skip_unloaded && delta <= 0.0) {
                delta -= self.fault_depth(j, phi, ts.shaft_angle);
            }
            let qj = self.contact_force(delta);
            if qj > 0.0 {
                fx += qj * s;
                fy -= qj * c;
            }
        });
        (fx, fy)
    }
}

impl ForceElement for BearingElement {
    fn name(&self) -> &str {
        &self.name
    }

    fn add_forces(&self, t: f64, q: &[f64], _v: &[f64], f: &mut [f64]) {
        let dx = q[self.shaft.0] - q[self.pedestal.0];
        let dy = q[self.shaft.1] - q[self.pedestal.1];
        let (fx, fy) = self.with_time_state(t, |ts| if self.balls <= TimeState::TABLED_BALLS { self.contact_forces_tabled(ts, dx, dy) } else { self.contact_forces_untabled(ts, dx, dy) });
        f[self.shaft.0] -= fx;
        f[self.shaft.1] -= fy;
        f[self.pedestal.0] += fx;
        f[self.pedestal.1] += fy;
    }

    /// `Σ_j K δ_j^(n+1)/(n+1)` over the loaded balls (or `½ k δ_j²` for a linear contact), J,
    /// with the ball positions and fault depths frozen at `t`.
    fn potential_energy(&self, t: f64, q: &[f64]) -> Option<f64> {
        Some(self.ball_deflections(t, q).into_iter().map(|d| self.contact_potential(d)).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform draws in [0, 1) from a xorshift generator seeded with `x` (deterministic).
    fn uniform(mut x: u64) -> impl FnMut() -> f64 {
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn an_extended_fault_with_profiles_per_pass_meets_a_random_one_on_each_pass() {
        // 128 roughness profiles of RMS σ: inside one pass of a ball the profile does not
        // change; from pass to pass (and ball to ball) it is picked at random, so at the
        // fault's middle the depth over many passes scatters as the profiles do, mean h and
        // standard deviation σ; with one profile every pass meets the same depth.
        let (length, depth, sigma, r) = (15e-3, 20e-6, 2e-6, 0.0128);
        let rows: Vec<Vec<f64>> = (0..128).map(|i| crate::signal::synth::white_noise(61, sigma, 0x5DEECE66D + i)).collect();
        let per_pass = DepthProfile::Extended { length_m: length, depth_m: depth, ramp_m: 2e-3, roughness_m: rows.clone() };
        let fixed = DepthProfile::Extended { length_m: length, depth_m: depth, ramp_m: 2e-3, roughness_m: vec![rows[5].clone()] };
        let mid = 0.5 * length / r;
        let mut seen = Vec::new();
        for j in 0..8 {
            for turns in -300..300 {
                let rel = TAU * turns as f64 + mid;
                let d = race_depth(&per_pass, rel, r, j);
                // 1 µm further on the same pass: the same profile, so the depth moves only by
                // the profile's slope over 1 µm (under 8σ per 0.25 mm sample: 0.032σ), where
                // another profile would differ by about σ√2.
                let later = race_depth(&per_pass, rel + 1e-6 / r, r, j);
                assert!((later - d).abs() < 0.05 * sigma, "pass {turns} ball {j}: {d} then {later}");
                seen.push(d);
                // One profile: every pass and ball meets the same depth (up to the rounding of
                // `rel` at large turns).
                assert_eq!(race_depth(&fixed, rel, r, j).to_bits(), fixed.depth_at(wrap(rel) * r).to_bits());
                assert!((race_depth(&fixed, rel, r, j) - fixed.depth_at(mid * r)).abs() < 1e-6 * sigma);
            }
        }
        let n = seen.len() as f64;
        let mean = seen.iter().sum::<f64>() / n;
        let sd = (seen.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!((mean - depth).abs() < 0.25 * sigma, "mean {mean}");
        assert!((sd / sigma - 1.0).abs() < 0.25, "sd {sd} for σ {sigma}");
        // Different passes meet different profiles: most consecutive passes differ.
        let changes = seen.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(changes as f64 > 0.95 * (n - 1.0), "{changes} changes in {n} passes");
    }

    #[test]
    fn spall_profile_is_limited_by_ball_curvature() {
        let p = DepthProfile::Spall { length_m: 1e-3, depth_m: 1e-3, ball_radius_m: 4e-3 };
        // At mid-spall the drop is r − √(r² − (L/2)²) = 4 − √(16 − 0.25) mm ≈ 31.4 µm.
        let mid = p.depth_at(0.5e-3);
        assert!((mid - (4e-3 - (16e-6f64 - 0.25e-6).sqrt())).abs() < 1e-12, "{mid}");
        assert_eq!(p.depth_at(-1e-6), 0.0);
        assert_eq!(p.depth_at(1.1e-3), 0.0);
        let shallow = DepthProfile::Spall { length_m: 1e-3, depth_m: 10e-6, ball_radius_m: 4e-3 };
        assert_eq!(shallow.depth_at(0.5e-3), 10e-6);
    }

    #[test]
    fn race_depth_is_the_exact_wrapped_depth() {
        // The cheap reduction only decides which balls are far from the fault; near it, and at
        // the 0/2π seam, the exact remainder decides, so the result equals the plain formula
        // bit for bit, for negative and large angles (a long simulation) alike.
        let r = 0.0156;
        let profiles = [
            DepthProfile::Spall { length_m: 0.178e-3, depth_m: 1e-4, ball_radius_m: 3.97e-3 },
            DepthProfile::Extended { length_m: 15e-3, depth_m: 20e-6, ramp_m: 1e-3, roughness_m: vec![vec![0.0, 2e-6, -1e-6, 3e-6]] },
        ];
        let mut next = uniform(0x9E3779B97F4A7C15);
        for p in &profiles {
            let edge = p.length_m() / r;
            for turns in [-3.0, 0.0, 1.0, 57.0, 4.0e4] {
                let base = TAU * turns;
                let specials = [0.0, edge, -1e-15, 1e-15, edge - 1e-12, edge + 1e-12, TAU - 1e-15, 0.5 * edge];
                for d in specials.into_iter().chain((0..2000).map(|_| (next() - 0.5) * 2.0 * TAU)) {
                    let rel = base + d;
                    let exact = p.depth_at(wrap(rel) * r);
                    assert_eq!(race_depth(p, rel, r, 0).to_bits(), exact.to_bits(), "rel {rel}");
                }
            }
        }
    }

    #[test]
    fn the_time_memo_of_each_bearing_gives_its_own_forces() {
        // Several bearings (more than the memo's four slots, so keys share slots), each
        // evaluated at the same times in turn, with other displacements at a repeated time (as
        // RK4's stages 2 and 3 are): every force must be bit for bit what a fresh element (a new
        // key, nothing remembered) gives, so no bearing ever reads another's angles or windows.
        let spall = DepthProfile::Spall { length_m: 0.533e-3, depth_m: 1e-4, ball_radius_m: 3.97e-3 };
        let make = |i: usize| BearingElement {
            name: format!("b{i}"),
            shaft: (0, 1),
            pedestal: (2, 3),
            balls: 8 + i,
            ball_diameter_m: 7.94e-3,
            pitch_diameter_m: 39.04e-3,
            ratio: 7.94 / 39.04 * (1.0 + 0.05 * i as f64),
            clearance_m: 1e-6 * i as f64,
            law: ContactLaw::Hertz { k: 8e9, n: 1.5 },
            motion: ShaftMotion::constant(20.0 + 3.0 * i as f64),
            faults: vec![BearingFault { location: if i.is_multiple_of(2) { FaultLocation::Inner } else { FaultLocation::Outer }, profile: spall.clone(), position_rad: 0.4 * i as f64 }],
            slip: vec![],
            memo: Default::default(),
        };
        let bearings: Vec<BearingElement> = (0..6).map(make).collect();
        let forces = |b: &BearingElement, t: f64, q: &[f64]| {
            let mut f = [0.0; 4];
            b.add_forces(t, q, &[0.0; 4], &mut f);
            f.map(f64::to_bits)
        };
        let mut loaded = 0;
        for step in 0..400 {
            let t = step as f64 * 3.1e-4;
            for (k, dy) in [(0, -9e-6), (1, -1.2e-5), (2, -1.1e-5)] {
                let q = [1e-7 * k as f64, dy, 0.0, 0.0];
                for b in bearings.iter().chain(bearings.iter().rev()) {
                    let fresh = BearingElement { memo: Default::default(), ..b.clone() };
                    let got = forces(b, t, &q);
                    assert_eq!(got, forces(&fresh, t, &q), "{} at t = {t}", b.name);
                    loaded += usize::from(got[1] != 0);
                }
            }
        }
        assert!(loaded > 1000, "the balls must carry load for the check to mean anything: {loaded}");
    }

    #[test]
    fn the_tabled_ball_directions_and_depths_give_the_computed_forces_to_the_bit() {
        // A bearing of up to `TABLED_BALLS` balls reads each ball's direction and fault depth
        // from its time state's table; one with more computes them per evaluation. Both must
        // give the same forces to the bit: checked on the same bearings through both paths,
        // at random times (long runs too) and displacements that load some balls and not
        // others, with slip, for inner, outer, ball and rough extended faults, several at
        // once, and a spall of negative depth (a bump: its depth may not be skipped for an
        // unloaded ball, the untabled path's other branch).
        let mut next = uniform(0x853C49E6748FEA9B);
        let spall = DepthProfile::Spall { length_m: 0.533e-3, depth_m: 1e-4, ball_radius_m: 3.97e-3 };
        let extended = DepthProfile::Extended { length_m: 15e-3, depth_m: 20e-6, ramp_m: 1e-3, roughness_m: vec![vec![0.0, 2e-6, -3e-5, 3e-6]; 3] };
        let fault = |location, profile: &DepthProfile, position_rad| BearingFault { location, profile: profile.clone(), position_rad };
        let sets = [
            vec![fault(FaultLocation::Inner, &spall, 0.3)],
            vec![fault(FaultLocation::Outer, &spall, -1.0)],
            vec![fault(FaultLocation::Ball, &spall, 0.2)],
            vec![fault(FaultLocation::Outer, &extended, 0.1)],
            vec![fault(FaultLocation::Outer, &spall, 0.0), fault(FaultLocation::Inner, &extended, 2.0), fault(FaultLocation::Ball, &spall, 1.0)],
            vec![fault(FaultLocation::Inner, &DepthProfile::Spall { length_m: 2e-3, depth_m: -3e-6, ball_radius_m: 3.97e-3 }, 0.5)],
        ];
        let (mut loaded, mut faulted, mut total) = (0usize, 0usize, 0usize);
        for (set, faults) in sets.into_iter().enumerate() {
            for slipping in [false, true] {
                let balls = 9;
                let slip = if slipping { (0..balls).map(|_| (0..4000).map(|_| (next() - 0.5) * 0.06).collect()).collect() } else { vec![] };
                let b = BearingElement {
                    name: format!("set {set}"),
                    shaft: (0, 1),
                    pedestal: (2, 3),
                    balls,
                    ball_diameter_m: 7.94e-3,
                    pitch_diameter_m: 39.04e-3,
                    ratio: 7.94 / 39.04,
                    clearance_m: 1e-6,
                    law: ContactLaw::Hertz { k: 8e9, n: 1.5 },
                    motion: ShaftMotion { mean_hz: 29.95, fluctuation: 0.01, fluctuation_hz: 0.7 },
                    faults: faults.clone(),
                    slip,
                    memo: Default::default(),
                };
                for scale in [0.1, 10.0, 100.0] {
                    for _ in 0..3000 {
                        let t = next() * scale;
                        let (dx, dy) = ((next() - 0.5) * 2e-5, -next() * 2.5e-5);
                        let (tabled, untabled) = b.with_time_state(t, |ts| (b.contact_forces_tabled(ts, dx, dy), b.contact_forces_untabled(ts, dx, dy)));
                        assert_eq!((tabled.0.to_bits(), tabled.1.to_bits()), (untabled.0.to_bits(), untabled.1.to_bits()), "{} (slip {slipping}) at t = {t}, ({dx}, {dy})", b.name);
                        let depths = b.with_time_state(t, |ts| ts.balls.depth[..balls].iter().filter(|&&d| d != 0.0).count());
                        total += 1;
                        loaded += usize::from(tabled.1 != 0.0);
                        faulted += usize::from(depths > 0);
                    }
                }
            }
        }
        // The check means something only if balls carry load and meet faults.
        assert!(loaded * 2 > total && faulted * 20 > total, "{loaded} loaded and {faulted} with a fault depth of {total}");
    }

    #[test]
    fn a_ball_the_fault_windows_pass_over_sees_no_fault_depth() {
        // `FaultWindows` lets `add_forces` skip the fault depth of balls far from every fault;
        // that is bit-identical only if each skipped ball's depth is exactly zero. Checked on
        // random cage and shaft angles (long runs too), with slip offsets, for inner, outer
        // and extended faults, and near the windows' edges; the windows must also pass over
        // most balls, or they save nothing.
        let mut next = uniform(0x2545F4914F6CDD1D);
        let spall = DepthProfile::Spall { length_m: 0.533e-3, depth_m: 1e-4, ball_radius_m: 3.97e-3 };
        let extended = DepthProfile::Extended { length_m: 15e-3, depth_m: 20e-6, ramp_m: 1e-3, roughness_m: vec![vec![0.0, 2e-6, -1e-6, 3e-6]] };
        let sets = [
            vec![BearingFault { location: FaultLocation::Inner, profile: spall.clone(), position_rad: 0.3 }],
            vec![BearingFault { location: FaultLocation::Outer, profile: spall.clone(), position_rad: -1.0 }],
            vec![
                BearingFault { location: FaultLocation::Outer, profile: spall.clone(), position_rad: 0.0 },
                BearingFault { location: FaultLocation::Inner, profile: extended.clone(), position_rad: 2.0 },
            ],
        ];
        let (mut skipped, mut total) = (0usize, 0usize);
        for faults in sets {
            let b = BearingElement {
                name: "b".into(),
                shaft: (0, 1),
                pedestal: (2, 3),
                balls: 9,
                ball_diameter_m: 7.94e-3,
                pitch_diameter_m: 39.04e-3,
                ratio: 7.94 / 39.04,
                clearance_m: 0.0,
                law: ContactLaw::Hertz { k: 8e9, n: 1.5 },
                motion: ShaftMotion::constant(29.95),
                faults,
                slip: vec![],
                memo: Default::default(),
            };
            let spacing = TAU / 9.0;
            for scale in [1.0, 1e3, 1e5] {
                for _ in 0..4000 {
                    let shaft_angle = (next() - 0.2) * scale;
                    let cage = b.cage_angle_of(shaft_angle);
                    let windows = FaultWindows::new(&b.faults, cage, shaft_angle, b.race_radii_m());
                    for j in 0..9 {
                        // Slip offsets, and offsets put just beside each window's edges.
                        let mut offsets = vec![spacing * j as f64, spacing * j as f64 + (next() - 0.5) * 0.1];
                        for &(base, width) in &windows.race[..windows.n_race] {
                            for edge in [base, base + width - windows.eps] {
                                offsets.push(edge + (next() - 0.5) * 1e-5);
                            }
                        }
                        for offset in offsets {
                            total += 1;
                            if !windows.may_touch(j, offset) {
                                skipped += 1;
                                let depth = b.fault_depth(j, cage + offset, shaft_angle);
                                assert_eq!(depth.to_bits(), 0f64.to_bits(), "ball {j} at offset {offset}, shaft {shaft_angle}");
                            }
                        }
                    }
                }
            }
        }
        assert!(skipped * 2 > total, "the windows skip only {skipped} of {total}");
    }

    #[test]
    fn shaft_motion_integrates_speed() {
        let m = ShaftMotion { mean_hz: 30.0, fluctuation: 0.02, fluctuation_hz: 2.0 };
        let dt = 1e-5;
        let num = (m.angle(0.3 + dt) - m.angle(0.3 - dt)) / (2.0 * dt) / TAU;
        assert!((num - m.speed_hz(0.3)).abs() < 1e-6);
    }
}
