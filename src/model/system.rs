//! The assembled system: named degrees of freedom with lumped masses, linear spring–dampers
//! between them (or to ground), constant external forces, and nonlinear or time-varying force
//! elements. Components (shafts, bearings, gear meshes, casing modes, a future Craig–Bampton
//! casing or planetary set) only add DOFs, springs and elements through this interface.

use super::error::ModelError;
use nalgebra::{DMatrix, DVector};

/// A force element: adds generalised forces for a state. It must be a pure function of
/// `(t, q, v)` so the integrator can evaluate it at any stage; randomness (slip, roughness) is
/// drawn at construction from the machine seed.
pub trait ForceElement: Send + Sync {
    /// A name for messages (e.g. `bearing test`).
    fn name(&self) -> &str;
    /// Adds this element's forces at time `t` (s), displacements `q` (m or rad) and velocities
    /// `v` to `f` (N or N·m).
    fn add_forces(&self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]);
    /// Potential energy (J) of the element's velocity-independent forces at time `t`, frozen
    /// in time: a `V(t, q)` with `−∂V/∂q = f(t, q, v = 0)` for the forces [`Self::add_forces`]
    /// adds. `None` (the default) when the element cannot give one; then
    /// [`System::potential_energy`] is `None` too. Damping is not included (it only dissipates).
    ///
    /// Energy is conserved along a trajectory only if `V` does not depend on `t` (e.g. a
    /// bearing whose cage does not move, a gear mesh of constant stiffness, no order forces).
    fn potential_energy(&self, t: f64, q: &[f64]) -> Option<f64> {
        let _ = (t, q);
        None
    }
}

/// A linear spring–damper between DOF `a` and DOF `b` (or ground).
#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    /// First DOF.
    pub a: usize,
    /// Second DOF, or ground.
    pub b: Option<usize>,
    /// Stiffness, N/m (or N·m/rad).
    pub k: f64,
    /// Damping, N·s/m (or N·m·s/rad).
    pub c: f64,
}

/// DOFs, masses, springs, constant forces and force elements.
#[derive(Default)]
pub struct System {
    /// DOF names, e.g. `motor.y`, `test.pedestal.y`.
    pub dof_names: Vec<String>,
    /// Lumped mass (kg) or inertia (kg·m²) of each DOF.
    pub mass: Vec<f64>,
    /// Linear spring–dampers.
    pub springs: Vec<Spring>,
    /// Constant external force on each DOF (N or N·m).
    pub static_force: Vec<f64>,
    /// Nonlinear / time-varying elements.
    pub elements: Vec<Box<dyn ForceElement>>,
}

impl System {
    /// Adds a DOF and returns its index; names must be unique.
    pub fn add_dof(&mut self, name: impl Into<String>, mass: f64) -> usize {
        self.dof_names.push(name.into());
        self.mass.push(mass);
        self.static_force.push(0.0);
        self.dof_names.len() - 1
    }

    /// Index of a DOF by name.
    pub fn dof(&self, name: &str) -> Option<usize> {
        self.dof_names.iter().position(|n| n == name)
    }

    /// Number of DOFs.
    pub fn n(&self) -> usize {
        self.mass.len()
    }

    /// Adds a spring–damper.
    pub fn add_spring(&mut self, a: usize, b: Option<usize>, k: f64, c: f64) {
        self.springs.push(Spring { a, b, k, c });
    }

    /// Total generalised force at a state (external + springs + elements).
    pub fn forces(&self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        f.copy_from_slice(&self.static_force);
        for s in &self.springs {
            let (dq, dv) = match s.b {
                Some(b) => (q[s.a] - q[b], v[s.a] - v[b]),
                None => (q[s.a], v[s.a]),
            };
            let force = s.k * dq + s.c * dv;
            f[s.a] -= force;
            if let Some(b) = s.b {
                f[b] += force;
            }
        }
        for e in &self.elements {
            e.add_forces(t, q, v, f);
        }
    }

    /// Accelerations `a = M⁻¹ F(t, q, v)`.
    pub fn accelerations(&self, t: f64, q: &[f64], v: &[f64], a: &mut [f64]) {
        self.forces(t, q, v, a);
        for (ai, m) in a.iter_mut().zip(&self.mass) {
            *ai /= m;
        }
    }

    /// Kinetic energy `½ Σ m_i v_i²`, J.
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        0.5 * self.mass.iter().zip(v).map(|(m, v)| m * v * v).sum::<f64>()
    }

    /// Potential energy at `(t, q)`, J: the linear springs `½ k (q_a − q_b)²`, the constant
    /// external forces `−F · q`, and each element's [`ForceElement::potential_energy`] (Hertzian
    /// contacts `K δ^(n+1)/(n+1)` per loaded ball, `½ k δ²` for linear contacts and the gear
    /// mesh). `None` if an element has none.
    ///
    /// # Notes
    /// The zero of potential is `q = 0` (and unloaded contacts). With the damping of springs
    /// and elements set to zero and no explicit time dependence, `E = T + V` is a first
    /// integral of [`System::accelerations`]: `dE/dt = v·(M a − F) = 0`.
    pub fn potential_energy(&self, t: f64, q: &[f64]) -> Option<f64> {
        let mut e = 0.0;
        for s in &self.springs {
            let dq = match s.b {
                Some(b) => q[s.a] - q[b],
                None => q[s.a],
            };
            e += 0.5 * s.k * dq * dq;
        }
        e -= self.static_force.iter().zip(q).map(|(f, q)| f * q).sum::<f64>();
        for el in &self.elements {
            e += el.potential_energy(t, q)?;
        }
        Some(e)
    }

    /// Total mechanical energy `T + V` at `(t, q, v)`, J (see [`System::potential_energy`]).
    pub fn mechanical_energy(&self, t: f64, q: &[f64], v: &[f64]) -> Option<f64> {
        Some(self.kinetic_energy(v) + self.potential_energy(t, q)?)
    }

    /// Linear stiffness matrix of the springs alone.
    pub fn spring_stiffness(&self) -> DMatrix<f64> {
        let n = self.n();
        let mut k = DMatrix::zeros(n, n);
        for s in &self.springs {
            k[(s.a, s.a)] += s.k;
            if let Some(b) = s.b {
                k[(b, b)] += s.k;
                k[(s.a, b)] -= s.k;
                k[(b, s.a)] -= s.k;
            }
        }
        k
    }

    /// Tangent stiffness `K = −∂F/∂q` at `(t, q)` with `v = 0`, by central differences with a
    /// step of `h` (m). Symmetrised.
    pub fn tangent_stiffness(&self, t: f64, q: &[f64], h: f64) -> DMatrix<f64> {
        let n = self.n();
        let v = vec![0.0; n];
        let mut k = DMatrix::zeros(n, n);
        let mut qp = q.to_vec();
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            qp[j] = q[j] + h;
            self.forces(t, &qp, &v, &mut fp);
            qp[j] = q[j] - h;
            self.forces(t, &qp, &v, &mut fm);
            qp[j] = q[j];
            for i in 0..n {
                k[(i, j)] = -(fp[i] - fm[i]) / (2.0 * h);
            }
        }
        (&k + k.transpose()) * 0.5
    }

    /// Undamped natural frequencies (Hz, ascending) of the system linearised at `q`:
    /// the eigenvalues of `M^{-1/2} K M^{-1/2}`.
    pub fn natural_frequencies_hz(&self, t: f64, q: &[f64]) -> Vec<f64> {
        let k = self.tangent_stiffness(t, q, 1e-9);
        let n = self.n();
        let s = DVector::from_iterator(n, self.mass.iter().map(|m| 1.0 / m.sqrt()));
        let a = DMatrix::from_fn(n, n, |i, j| s[i] * k[(i, j)] * s[j]);
        let eig = a.symmetric_eigen();
        let mut f: Vec<f64> = eig.eigenvalues.iter().map(|l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI)).collect();
        f.sort_by(|a, b| a.total_cmp(b));
        f
    }

    /// Static equilibrium at time `t` (velocities zero) from the guess `q0`, by a
    /// Levenberg–Marquardt iteration on the force balance. Returns `q` with
    /// `‖F(q)‖∞ ≤ tol_n` newtons.
    ///
    /// # Notes
    /// A step is accepted when it lowers the force residual. Inside a bearing clearance that
    /// rule stalls: the shaft meets no stiffness and a constant load, so no step lowers the
    /// residual until the far race is reached (a load pointing away from the guess). The
    /// static problem is also the minimum of the potential energy `V(t, q)`
    /// ([`System::potential_energy`]), which does fall along the load; if the residual rule
    /// stalls, the search descends `V` first (accepting steps that lower it) and then polishes
    /// with the residual rule. Cases the residual rule solves are unchanged.
    pub fn static_equilibrium(&self, t: f64, q0: &[f64], tol_n: f64) -> Result<Vec<f64>, ModelError> {
        let (q, f, done) = self.levenberg_marquardt(t, q0, tol_n, false);
        if done {
            return Ok(q);
        }
        if f.iter().any(|x| !x.is_finite()) {
            return Err(ModelError::NoEquilibrium("non-finite force".into()));
        }
        if self.potential_energy(t, q0).is_some() {
            let (q1, _, done) = self.levenberg_marquardt(t, q0, tol_n, true);
            if done {
                return Ok(q1);
            }
            let (q2, _, done) = self.levenberg_marquardt(t, &q1, tol_n, false);
            if done {
                return Ok(q2);
            }
        }
        let worst = f.iter().enumerate().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())).map(|(i, v)| (i, *v)).unwrap_or((0, 0.0));
        Err(ModelError::NoEquilibrium(format!(
            "residual {:.3e} N at DOF `{}`; check that every DOF is supported (a bearing or a coupling to ground)",
            worst.1,
            self.dof_names.get(worst.0).cloned().unwrap_or_default()
        )))
    }

    /// Levenberg–Marquardt on `F(t, q) = 0` from `q0`: steps `(K + λ s I) Δq = F` with `K` the
    /// tangent stiffness and `s` its largest diagonal term, accepted when they lower `‖F‖∞`
    /// (or, with `descend_potential`, the potential energy). Returns the last `q`, its forces
    /// and whether `‖F‖∞ ≤ tol_n` was reached.
    fn levenberg_marquardt(&self, t: f64, q0: &[f64], tol_n: f64, descend_potential: bool) -> (Vec<f64>, Vec<f64>, bool) {
        let n = self.n();
        let v = vec![0.0; n];
        let mut q = q0.to_vec();
        let mut f = vec![0.0; n];
        self.forces(t, &q, &v, &mut f);
        let norm = |f: &[f64]| f.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let energy = |q: &[f64]| self.potential_energy(t, q).unwrap_or(f64::NAN);
        let mut e = if descend_potential { energy(&q) } else { 0.0 };
        let mut lambda = 1e-6;
        for _ in 0..200 {
            let r = norm(&f);
            if !r.is_finite() {
                return (q, f, false);
            }
            if r <= tol_n {
                return (q, f, true);
            }
            let k = self.tangent_stiffness(t, &q, 1e-10);
            let scale = (0..n).map(|i| k[(i, i)].abs()).fold(0.0f64, f64::max).max(1.0);
            let rhs = DVector::from_column_slice(&f);
            let mut improved = false;
            for _ in 0..30 {
                let a = &k + DMatrix::identity(n, n) * (lambda * scale);
                let Some(dq) = a.lu().solve(&rhs) else {
                    lambda *= 10.0;
                    continue;
                };
                let trial: Vec<f64> = q.iter().zip(dq.iter()).map(|(a, b)| a + b).collect();
                let mut ft = vec![0.0; n];
                self.forces(t, &trial, &v, &mut ft);
                let better = if descend_potential {
                    let et = energy(&trial);
                    let lower = et < e;
                    if lower {
                        e = et;
                    }
                    lower
                } else {
                    norm(&ft) < r
                };
                if better {
                    q = trial;
                    f = ft;
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = true;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        let done = norm(&f) <= tol_n;
        (q, f, done)
    }

    /// Checks that every DOF has stiffness to something (no free rigid-body motion).
    pub fn check_supported(&self, q: &[f64]) -> Result<(), ModelError> {
        // Time-varying elements (a bearing's balls move with the cage) can leave a DOF without
        // stiffness at one instant — a single loaded ball exactly under the shaft has no
        // lateral stiffness — while it is held over a ball pass. A DOF is unsupported only if it
        // has no stiffness at any of these instants (0 to 50 ms).
        let n = self.n();
        let mut kmax = vec![f64::NEG_INFINITY; n];
        for step in 0..=10 {
            let k = self.tangent_stiffness(0.005 * step as f64, q, 1e-9);
            for (i, km) in kmax.iter_mut().enumerate() {
                let kii = k[(i, i)];
                *km = if kii.is_nan() { f64::NAN } else { km.max(kii) };
            }
        }
        for (i, &kii) in kmax.iter().enumerate() {
            if kii.is_nan() || kii <= 0.0 {
                return Err(ModelError::NoEquilibrium(format!(
                    "DOF `{}` has no stiffness: support it with a bearing or a `[[coupling]]` to ground",
                    self.dof_names[i]
                )));
            }
        }
        Ok(())
    }
}
