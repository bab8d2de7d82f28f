//! Gear mesh and periodic-force elements.
//!
//! The mesh follows the classic lumped spur-gear model (e.g. Sawalhi & Randall 2008, part I;
//! the 15-DOF bevel model treats the bevel pair as an equivalent spur pair by Tredgold's
//! approximation): one spring along the line of action with a time-varying stiffness, acting on
//! the torsional vibration of both gears and the translation of both shafts along that line.

use super::bearing::ShaftMotion;
use super::memo::{at_time, MemoId, Slots};
use super::system::ForceElement;
use std::f64::consts::TAU;

/// Mesh stiffness as a function of the pinion's rotation: alternating single and double tooth
/// contact, one tooth weakened optionally.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshStiffness {
    /// Mean stiffness, N/m.
    pub mean_n_per_m: f64,
    /// Peak-to-peak variation as a fraction of the mean (0 = constant: `gear_mesh` off).
    pub variation_fraction: f64,
    /// Contact ratio in (1, 2).
    pub contact_ratio: f64,
    /// Pinion teeth.
    pub pinion_teeth: u32,
    /// A weakened pinion tooth: (index, fraction of its pair stiffness lost).
    pub tooth_fault: Option<(u32, f64)>,
}

impl MeshStiffness {
    /// Stiffness at pinion angle `theta` (rad).
    ///
    /// # Notes
    /// Within each mesh period (`2π / z_p` of pinion rotation), a fraction `ε − 1` has two tooth
    /// pairs in contact (stiffness `k_hi`) and the rest one pair (`k_lo`), with
    /// `k_hi − k_lo = variation · mean` and a time average equal to `mean`. The transitions are
    /// smoothed over 5 % of the period (tip relief) so the integrator sees no step. A faulty
    /// tooth multiplies the stiffness by `1 − loss` while that tooth is in contact (the period
    /// in which it is the leading tooth, plus the preceding double-contact zone).
    pub fn at(&self, theta: f64) -> f64 {
        let z = self.pinion_teeth as f64;
        let pos = theta.rem_euclid(TAU) / TAU * z; // mesh periods elapsed in this revolution
        let tooth = pos.floor() as u32 % self.pinion_teeth;
        let frac = pos - pos.floor();
        let double = self.contact_ratio - 1.0;
        let dk = self.variation_fraction * self.mean_n_per_m;
        let k_lo = self.mean_n_per_m - dk * double;
        let k_hi = k_lo + dk;
        let w = 0.05;
        // Smooth step up at 0 and down at `double`.
        let up = smoothstep(frac / w + 0.5);
        let down = smoothstep((frac - double) / w + 0.5);
        let wrap_down = smoothstep((frac - 1.0) / w + 0.5); // the next period's rise
        let two = (up - down + wrap_down).clamp(0.0, 1.0);
        let mut k = k_lo + (k_hi - k_lo) * two;
        if let Some((bad, loss)) = self.tooth_fault {
            if tooth == bad {
                k *= 1.0 - loss;
            }
        }
        k
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The gear mesh element.
#[derive(Debug, Clone)]
pub struct GearMeshElement {
    /// Name for messages.
    pub name: String,
    /// Pinion torsional DOF, gear torsional DOF.
    pub theta: (usize, usize),
    /// Pinion shaft and gear shaft translation along the line of action.
    pub line: (usize, usize),
    /// Base radii, m.
    pub base_radius_m: (f64, f64),
    /// Mesh stiffness law.
    pub stiffness: MeshStiffness,
    /// Mesh damping, N·s/m.
    pub damping_n_s_per_m: f64,
    /// Pinion rotation (phase of the mesh).
    pub pinion_motion: ShaftMotion,
    /// This element's key in the per-thread memo of its stiffness (`Default::default()`).
    pub memo: MemoId,
}

impl GearMeshElement {
    /// The mesh stiffness at time `t`, `stiffness.at(pinion_motion.angle(t))`, through the
    /// per-thread memo ([`super::memo`]).
    fn stiffness_at_time(&self, t: f64) -> f64 {
        thread_local! {
            static LAST: Slots<f64> = const { Slots::new(0.0) };
        }
        at_time(&LAST, &self.memo, t, || self.stiffness.at(self.pinion_motion.angle(t)))
    }

    /// Dynamic transmission error along the line of action, m:
    /// `δ = r_p θ_p − r_g θ_g + y_p − y_g` (torsional vibration angles in each gear's own sense).
    pub fn deflection(&self, q: &[f64]) -> f64 {
        self.base_radius_m.0 * q[self.theta.0] - self.base_radius_m.1 * q[self.theta.1] + q[self.line.0] - q[self.line.1]
    }
}

impl ForceElement for GearMeshElement {
    fn name(&self) -> &str {
        &self.name
    }

    fn add_forces(&self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let d = self.deflection(q);
        let dd = self.base_radius_m.0 * v[self.theta.0] - self.base_radius_m.1 * v[self.theta.1] + v[self.line.0] - v[self.line.1];
        let k = self.stiffness_at_time(t);
        let force = k * d + self.damping_n_s_per_m * dd;
        f[self.theta.0] -= force * self.base_radius_m.0;
        f[self.theta.1] += force * self.base_radius_m.1;
        f[self.line.0] -= force;
        f[self.line.1] += force;
    }

    /// `½ k(t) δ²` with the mesh stiffness frozen at `t`, J.
    fn potential_energy(&self, t: f64, q: &[f64]) -> Option<f64> {
        let d = self.deflection(q);
        Some(0.5 * self.stiffness.at(self.pinion_motion.angle(t)) * d * d)
    }
}

/// A radial force at orders of a shaft's rotation. With two DOFs it rotates:
/// `F(t) = Σ_k A_k [cos(k θ + φ_k), sin(k θ + φ_k)]` on (x, y); with one it pulsates:
/// `F(t) = Σ_k A_k cos(k θ + φ_k)`. Orders need not be integers (a belt-pass order).
#[derive(Debug, Clone)]
pub struct OrderForce {
    /// Name for messages.
    pub name: String,
    /// x DOF and, for a rotating force, the y DOF.
    pub dofs: (usize, Option<usize>),
    /// Shaft rotation.
    pub motion: ShaftMotion,
    /// (order, amplitude N, phase rad, scales with speed²?) terms.
    pub terms: Vec<(f64, f64, f64, bool)>,
    /// This element's key in the per-thread memo of its components (`Default::default()`).
    pub memo: MemoId,
}

impl OrderForce {
    /// Terms whose components the memo holds; a force with more computes them every time.
    const MEMO_TERMS: usize = 4;

    /// Every term's components `(A cos(kθ + φ), A sin(kθ + φ))` at time `t`, in order, `A`
    /// scaled with the speed² where the term says so.
    fn components(&self, t: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let theta = self.motion.angle(t);
        let speed_ratio = self.motion.speed_hz(t) / self.motion.mean_hz;
        self.terms.iter().map(move |&(order, amp, phase, quadratic)| {
            let a = if quadratic { amp * speed_ratio * speed_ratio } else { amp };
            let (s, c) = (order * theta + phase).sin_cos();
            (a * c, a * s)
        })
    }
}

impl ForceElement for OrderForce {
    fn name(&self) -> &str {
        &self.name
    }

    fn add_forces(&self, t: f64, _q: &[f64], _v: &[f64], f: &mut [f64]) {
        let n = self.terms.len();
        let mut add = |(x, y): (f64, f64)| {
            f[self.dofs.0] += x;
            if let Some(dof_y) = self.dofs.1 {
                f[dof_y] += y;
            }
        };
        if n > Self::MEMO_TERMS {
            self.components(t).for_each(add);
            return;
        }
        // Through the per-thread memo ([`super::memo`]): the same components, added in the
        // same order, so the same forces to the bit.
        thread_local! {
            static LAST: Slots<[(f64, f64); OrderForce::MEMO_TERMS]> = const { Slots::new([(0.0, 0.0); OrderForce::MEMO_TERMS]) };
        }
        let components = at_time(&LAST, &self.memo, t, || {
            let mut c = [(0.0, 0.0); Self::MEMO_TERMS];
            c.iter_mut().zip(self.components(t)).for_each(|(ck, v)| *ck = v);
            c
        });
        components[..n].iter().for_each(|&c| add(c));
    }

    /// `−F(t) · q`, the potential of the prescribed force frozen at `t`, J.
    fn potential_energy(&self, t: f64, q: &[f64]) -> Option<f64> {
        let mut f = [0.0; 2];
        for (x, y) in self.components(t) {
            f[0] += x;
            f[1] += y;
        }
        Some(-f[0] * q[self.dofs.0] - self.dofs.1.map_or(0.0, |y| f[1] * q[y]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stiffness_memo_of_each_mesh_gives_its_own_stiffness() {
        // Six meshes (more than the memo's four slots, so keys share slots), one a clone of
        // another changed after cloning, evaluated in turn at the same times, twice each (as
        // RK4's stages 2 and 3 are): each must get its own `at(angle(t))`, bit for bit.
        let base = MeshStiffness { mean_n_per_m: 1e8, variation_fraction: 0.3, contact_ratio: 1.6, pinion_teeth: 18, tooth_fault: Some((3, 0.5)) };
        let make = |i: usize| GearMeshElement {
            name: format!("m{i}"),
            theta: (0, 1),
            line: (2, 3),
            base_radius_m: (0.02, 0.03),
            stiffness: MeshStiffness { variation_fraction: 0.1 * i as f64, pinion_teeth: 18 + i as u32, ..base.clone() },
            damping_n_s_per_m: 0.0,
            pinion_motion: ShaftMotion::constant(15.0 + i as f64),
            memo: MemoId::default(),
        };
        let mut meshes: Vec<GearMeshElement> = (0..5).map(make).collect();
        let mut changed = meshes[2].clone();
        changed.stiffness.variation_fraction = 0.9;
        meshes.push(changed);
        for step in 0..2000 {
            let t = step as f64 * 1.7e-4;
            for m in meshes.iter().chain(meshes.iter().rev()).chain(meshes.iter()) {
                let want = m.stiffness.at(m.pinion_motion.angle(t));
                assert_eq!(m.stiffness_at_time(t).to_bits(), want.to_bits(), "{} at t = {t}", m.name);
            }
        }
    }

    #[test]
    fn the_memo_of_each_order_force_gives_its_own_forces() {
        // Rotating and pulsating forces, one with more terms than the memo holds, more forces
        // than the memo's slots, evaluated in turn at the same times and twice at each (as RK4's
        // stages 2 and 3 are), at constant and fluctuating speed: each must add what the
        // formula gives, term after term, bit for bit.
        let make = |i: usize| OrderForce {
            name: format!("f{i}"),
            dofs: (0, if i % 3 == 2 { None } else { Some(1) }),
            motion: ShaftMotion { mean_hz: 10.0 + i as f64, fluctuation: if i.is_multiple_of(2) { 0.0 } else { 0.02 }, fluctuation_hz: 1.5 },
            terms: (0..(if i == 4 { 6 } else { 1 + i % 3 })).map(|k| (1.0 + 0.5 * k as f64, 3.0 + k as f64, 0.1 * k as f64, k % 2 == 0)).collect(),
            memo: MemoId::default(),
        };
        let forces: Vec<OrderForce> = (0..6).map(make).collect();
        // The formula, as `add_forces` computed it before the memo.
        let reference = |o: &OrderForce, t: f64| {
            let mut f = [0.25, -0.5];
            let theta = o.motion.angle(t);
            let speed_ratio = o.motion.speed_hz(t) / o.motion.mean_hz;
            for &(order, amp, phase, quadratic) in &o.terms {
                let a = if quadratic { amp * speed_ratio * speed_ratio } else { amp };
                let (s, c) = (order * theta + phase).sin_cos();
                f[o.dofs.0] += a * c;
                if let Some(y) = o.dofs.1 {
                    f[y] += a * s;
                }
            }
            f.map(f64::to_bits)
        };
        for step in 0..1000 {
            let t = step as f64 * 2.3e-4;
            for o in forces.iter().chain(forces.iter().rev()).chain(forces.iter()) {
                let mut f = [0.25, -0.5];
                o.add_forces(t, &[0.0; 2], &[0.0; 2], &mut f);
                assert_eq!(f.map(f64::to_bits), reference(o, t), "{} at t = {t}", o.name);
            }
        }
    }

    #[test]
    fn mesh_stiffness_has_the_mean_and_the_period() {
        let m = MeshStiffness { mean_n_per_m: 1e8, variation_fraction: 0.3, contact_ratio: 1.6, pinion_teeth: 18, tooth_fault: None };
        let n = 18 * 2000;
        let ks: Vec<f64> = (0..n).map(|i| m.at(TAU * i as f64 / n as f64)).collect();
        let mean = ks.iter().sum::<f64>() / n as f64;
        assert!((mean - 1e8).abs() / 1e8 < 2e-3, "{mean}");
        let (lo, hi) = ks.iter().fold((f64::MAX, f64::MIN), |(a, b), &k| (a.min(k), b.max(k)));
        assert!(((hi - lo) / 1e8 - 0.3).abs() < 1e-3, "{}", (hi - lo) / 1e8);
        // Periodic at the mesh period.
        let p = TAU / 18.0;
        for x in [0.1, 0.2, 0.33] {
            assert!((m.at(x) - m.at(x + p)).abs() < 1e-6 * 1e8);
        }
        let faulty = MeshStiffness { tooth_fault: Some((3, 0.5)), ..m.clone() };
        assert!((faulty.at(3.5 * p) - 0.5 * m.at(3.5 * p)).abs() < 1.0);
        assert_eq!(faulty.at(5.5 * p), m.at(5.5 * p));
    }
}
