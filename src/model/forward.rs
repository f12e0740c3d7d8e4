//! The forward dynamics (paper eq. 28), evaluated in one place: [`Model::forward_at`]. Every
//! caller (the plain dynamics, the integrators' stages, damped Euler's contact at the end
//! velocity on dual numbers and for its Jacobian, implicit Euler's Newton iterations) says
//! through [`ForwardOptions`] what it takes differently from the plain dynamics and what it may
//! reuse; [`Model::forward`] and [`Model::forward_with`] only turn the inputs `u` into the
//! generalized force first. The one other evaluation is damped Euler's values-only step,
//! [`Model::frozen_forward`] (src/model/frozen.rs), which computes the same terms once per step
//! and shares the loop over the pairs.

use super::pairs::Pick;
use super::*;

/// Where the forward dynamics is evaluated: the state, the generalized applied force and the
/// mocap bodies' inputs.
#[derive(Clone, Copy, Debug)]
pub struct EvalPoint<'a, T> {
    /// Positions.
    pub q: &'a [T],
    /// Velocities.
    pub v: &'a [T],
    /// Generalized applied force: the actuators' ([`Model::actuator_forces_at`]) and any other.
    pub tau: &'a [T],
    /// [`MOCAP_INPUTS`] per mocap body, or empty (the bodies at their scene poses, at rest).
    pub mocap: &'a [T],
    /// The adhesion actuators' pull per body ([`Model::pulls`]), or empty (none).
    pub pulls: &'a [Option<T>],
}

/// What an evaluation of the forward dynamics takes differently from the plain dynamics, and
/// what it may reuse. The default is the plain dynamics, reusing nothing.
pub struct ForwardOptions<'a, T: Scalar> {
    /// The velocity the contact forces are taken at (`None`: at `v`; every other term is taken
    /// at `v`): damped Euler's contact, implicit in the end velocity
    /// ([`Integrator::DampedEuler`]).
    pub contact_velocity: Option<&'a [T]>,
    /// `Some(h)`: the joints' viscous damping taken implicitly over a step `h`,
    /// `v̇ = (M + h D)⁻¹ (…)`: `D` the diagonal of the joints' damping per degree of freedom plus
    /// the slope of their smooth frictionloss at `v` and their limits' damping where they push
    /// (MuJoCo's `Euler`, [`Integrator::DampedEuler`]), but not a limit's with an added
    /// inertia (MuJoCo's impedance, whose pace an explicit step carries); without the viscous
    /// damping when the model's integrator is [`Integrator::DampedRk4`], whose stages leave it
    /// explicit as MuJoCo's RK4 does.
    pub implicit_damping: Option<T>,
    /// What the pairs may use of what they keep across calls ([`Reuse`]). With
    /// [`Reuse::All`], the result can differ from the plain dynamics' only where a pair's
    /// forces are below the bound of [`crate::collision::out_of_reach`] (a kept proof switches
    /// off a pair that a fresh proof might not); kept candidate planes change no bit.
    pub reuse: Reuse<'a>,
    /// The kinematics of `(q, v, mocap)`, if the caller has them already (they are the same
    /// bits as those computed here).
    pub kinematics: Option<Kinematics<T>>,
    /// Whether the result lists every pair's contact ([`Forward::contacts`]); without, it is
    /// empty and the accelerations are the same bits (a residual that reads only them).
    pub list_contacts: bool,
    /// The share each limit holds, one per joint, fixed tendon and spatial tendon
    /// (`Model::limit_slots`), if the caller decided them ([`Forward::holds`] of an earlier
    /// evaluation: damped Euler's iterations take them from the step's start, as its frozen
    /// evaluation does); `None`: decided here (`Model::release_limits`).
    pub holds: Option<&'a [T]>,
}

impl<T: Scalar> Default for ForwardOptions<'_, T> {
    fn default() -> Self {
        ForwardOptions {
            contact_velocity: None,
            implicit_damping: None,
            reuse: Reuse::Nothing,
            kinematics: None,
            holds: None,
            list_contacts: true,
        }
    }
}

/// Every pair's contact ([`Forward::contacts`]) and the kinematics they were found at.
pub(crate) type ContactsAt = (Vec<Option<PairContact<f64>>>, Kinematics<f64>);

impl Model {
    /// Forward dynamics (paper eq. 28) for inputs `u` (actuator controls, then the mocap
    /// bodies' inputs, see [`Model::nu`]; [`Simulation::inputs`](crate::sim::Simulation::inputs)
    /// gives them for a running simulation): `v̇ = M⁻¹ (τ_act(u) + τ_passive - c + Σ Λ)`.
    ///
    /// # Example
    ///
    /// A free box far above a floor falls at `g`, and exact derivatives come from the same call
    /// with dual numbers: `∂v̇/∂v = 0` for the free fall.
    ///
    /// ```
    /// use num_dual::Dual64;
    /// use std::path::Path;
    ///
    /// let xml = r#"<mujoco>
    ///   <worldbody>
    ///     <geom type="plane" size="1 1 0.1"/>
    ///     <body pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="2"/></body>
    ///   </worldbody>
    /// </mujoco>"#;
    /// let model = scm::scene::load_str(xml, Path::new("box.xml"))?.model;
    /// let f = model.forward(&model.q0, &model.v0, &model.u0(), &model.contact)?;
    /// assert!((f.vdot[2] + 9.81).abs() < 1e-9); // gravity, nothing else
    ///
    /// // The same dynamics on dual numbers: seed the box's vertical velocity.
    /// let q: Vec<Dual64> = model.q0.iter().map(|&x| Dual64::from(x)).collect();
    /// let mut v: Vec<Dual64> = model.v0.iter().map(|&x| Dual64::from(x)).collect();
    /// v[2] = Dual64::new(0.0, 1.0);
    /// let prm = model.contact.lift::<Dual64>();
    /// let fd = model.forward(&q, &v, &[], &prm)?;
    /// assert_eq!(fd.vdot[2].eps, 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn forward<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
    ) -> Result<Forward<T>, DynamicsError> {
        self.forward_with(q, v, u, prm, ForwardOptions::default())
    }

    /// [`Model::forward`] with `opts` ([`ForwardOptions`]): the actuator forces of the inputs
    /// `u` at `(q, v)`, then [`Model::forward_at`].
    pub fn forward_with<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
        opts: ForwardOptions<'_, T>,
    ) -> Result<Forward<T>, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        let tau = self.actuator_forces_at(q, v, ctrl, mocap);
        let pulls = self.pulls(ctrl);
        let at = EvalPoint {
            q,
            v,
            tau: tau.as_slice(),
            mocap,
            pulls: &pulls,
        };
        self.forward_at(at, prm, opts)
    }

    /// The contacts [`Model::forward_with`] lists ([`Forward::contacts`], the same bits, the
    /// pairs' kept proofs and candidates used and updated alike), without the dynamics that
    /// follow them: what implicit Euler's energy guard reads at a call's start where the ledger
    /// it carries on holds no estimate of their energy, and where the
    /// accelerations would be thrown away (on three free bodies out of reach the mass matrix,
    /// its factor and the bias forces were a fifth of the step).
    pub fn contacts_only(
        &self,
        q: &[f64],
        v: &[f64],
        u: &[f64],
        prm: &ContactParams<f64>,
        opts: ForwardOptions<'_, f64>,
    ) -> Result<Vec<Option<PairContact<f64>>>, DynamicsError> {
        Ok(self.contacts_only_at(q, v, u, prm, opts)?.0)
    }

    /// [`Model::contacts_only`], with the kinematics it read handed back (as
    /// [`Forward::kinematics`]).
    pub(crate) fn contacts_only_at(
        &self,
        q: &[f64],
        v: &[f64],
        u: &[f64],
        prm: &ContactParams<f64>,
        opts: ForwardOptions<'_, f64>,
    ) -> Result<ContactsAt, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        let pulls = self.pulls(ctrl);
        let mut opts = opts;
        let kin = self.evaluation_start(q, v, mocap, &mut opts)?;
        let contacts = (self.contacts_with(&kin, prm, &pulls, Pick::InReach, opts.reuse)).1;
        Ok((contacts, kin))
    }

    /// What every evaluation at `(q, v)` starts with: the pairs' reuse in `opts` fitted to
    /// the model's pairs, the state checked finite, and the kinematics `opts` carries (taken)
    /// or computed here.
    fn evaluation_start<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        mocap: &[T],
        opts: &mut ForwardOptions<'_, T>,
    ) -> Result<Kinematics<T>, DynamicsError> {
        opts.reuse.fit(self.pairs.len());
        self.check_finite(q, v)?;
        Ok(opts
            .kinematics
            .take()
            .unwrap_or_else(|| self.tree.kinematics_with(q, v, mocap)))
    }

    /// The forward dynamics at `at` for a generalized applied force: `v̇ = FD(q, v, τ) =
    /// (M + M_a + h D)⁻¹ (τ + τ_passive - c + Σ Λ)`, contact included, `M_a` the inertia
    /// MuJoCo's impedance adds where a limit pushes and along an equality's rows
    /// (src/model/coupled.rs), `h D` only with
    /// [`ForwardOptions::implicit_damping`]; the one evaluation every other entry calls. Order:
    /// kinematics, contact (`Model::visit_pairs`: proofs, then the pairs in reach), the
    /// forces on the bodies, RNEA, the (damped) mass matrix, its factorization and solve; where
    /// a limit would pull, a second solve with it let go (`Model::release_limits`).
    pub fn forward_at<T: Scalar>(
        &self,
        at: EvalPoint<'_, T>,
        prm: &ContactParams<T>,
        opts: ForwardOptions<'_, T>,
    ) -> Result<Forward<T>, DynamicsError> {
        let EvalPoint {
            q,
            v,
            tau,
            mocap,
            pulls,
        } = at;
        let mut opts = opts;
        let kin = self.evaluation_start(q, v, mocap, &mut opts)?;
        let contact_kin = opts
            .contact_velocity
            .map(|vc| self.tree.kinematics_with(q, vc, mocap));
        // With a contact velocity, the same positions, so the wrenches are in the same frames.
        let at = contact_kin.as_ref().unwrap_or(&kin);
        let (mut wrenches, contacts) = if opts.list_contacts {
            self.contacts_with(at, prm, pulls, Pick::InReach, opts.reuse)
        } else {
            let wrenches = self.wrenches_with(at, prm, pulls, Pick::InReach, opts.reuse);
            (wrenches, Vec::new())
        };
        self.add_body_forces(&kin, prm.stiction_velocity, &mut wrenches);
        let bias = self.tree.rnea(&kin, &[], &wrenches);
        // `τ + τ_passive - c`, into the passive forces' vector (the same sums: addition
        // commutes).
        let mut rhs = self.passive_forces(q, v, prm.stiction_velocity);
        for (r, &t) in rhs.iter_mut().zip(tau) {
            *r += t;
        }
        rhs -= bias;
        let mut m = self.damped_mass_matrix(&kin, q, v, prm, opts.implicit_damping);
        let coupled = self.coupled_at(&kin, q, v, opts.implicit_damping);
        coupled.add_turning_force(&mut rhs);
        let solve = |m, rhs: &DVector<T>, holds: Option<&[T]>| {
            Ok::<_, DynamicsError>(coupled.factor(self, m, holds)?.solve(rhs))
        };
        let (vdot, holds) = match opts.holds {
            Some(holds) => {
                self.let_go(q, v, holds, &coupled, &mut m, &mut rhs);
                (solve(m, &rhs, Some(holds))?, None)
            }
            None if !self.limits_can_let_go() => (solve(m, &rhs, None)?, None),
            None => {
                let held = solve(m.clone(), &rhs, None)?;
                match self.release_limits(q, v, &held, &coupled) {
                    None => (held, None),
                    Some(holds) => {
                        self.let_go(q, v, &holds, &coupled, &mut m, &mut rhs);
                        (solve(m, &rhs, Some(&holds))?, Some(holds))
                    }
                }
            }
        };
        Ok(Forward {
            vdot,
            contacts,
            holds,
            kinematics: kin,
        })
    }

    /// An error naming the first joint whose position or velocity is not finite.
    pub(crate) fn check_finite<T: Scalar>(&self, q: &[T], v: &[T]) -> Result<(), DynamicsError> {
        for j in &self.tree.joints {
            let bad = |x: &[T]| x.iter().any(|x| !x.re().is_finite());
            if bad(&q[j.qadr..j.qadr + j.kind.nq()]) {
                return Err(DynamicsError::NonFinite(format!(
                    "the position of joint {}",
                    j.name
                )));
            }
            if bad(&v[j.dadr..j.dadr + j.kind.nv()]) {
                return Err(DynamicsError::NonFinite(format!(
                    "the velocity of joint {}",
                    j.name
                )));
            }
        }
        Ok(())
    }

    /// The mass matrix at `kin` with the inertia the limits add where they push
    /// ([`crate::dynamics::limit::JointLimit::added_inertia`], MuJoCo's impedance), and `h D` added when `implicit_damping` is `Some(h)`: `D` the
    /// joints' viscous damping plus the slope of their smooth frictionloss at `v` and the
    /// damping of their limits where they push at `(q, v)`
    /// ([`crate::dynamics::limit::JointLimit::damping_slope`]).
    pub(crate) fn damped_mass_matrix<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        q: &[T],
        v: &[T],
        prm: &ContactParams<T>,
        implicit_damping: Option<T>,
    ) -> crate::dynamics::TreeMatrix<T> {
        let mut m = self.tree.mass_matrix_sparse(kin);
        for j in &self.tree.joints {
            if let Some(l) = &j.limit {
                *m.entry_mut(j.dadr, j.dadr) += l.added_inertia(q[j.qadr], v[j.dadr]);
            }
        }
        if let Some(h) = implicit_damping {
            let vs2 = prm.stiction_velocity * prm.stiction_velocity;
            // MuJoCo's RK4 takes the joints' viscous damping (a passive force) explicitly, and
            // its constraints (frictionloss, limits, contact) in its solver at every stage: so
            // under damped RK4 the viscous damping stays explicit, in `f` alone.
            let viscous = if self.integrator == Integrator::DampedRk4 {
                0.0
            } else {
                1.0
            };
            for j in &self.tree.joints {
                // Neither damper: `h d` is zero and the diagonal (positive: a mass) unchanged
                // (`floating3` under damped Euler: 1.6 % of its instructions in the sparse
                // entries' lookups, docs/performance.md).
                let damps = viscous * j.damping != 0.0 || j.frictionloss > 0.0;
                let damped = if damps { j.kind.nv() } else { 0 };
                for k in 0..damped {
                    let mut d = c::<T>(viscous * j.damping);
                    if j.frictionloss > 0.0 {
                        // The smooth frictionloss -F v / sqrt(v_s² + v²) is a damper of slope
                        // F v_s² / (v_s² + v²)^{3/2} near rest: stiff (F/v_s) when v_s is small,
                        // where MuJoCo's frictionloss is a constraint, solved implicitly.
                        let vi = v[j.dadr + k];
                        let r = vs2 + vi * vi;
                        d += vs2 * j.frictionloss / (r * r.sqrt());
                    }
                    *m.entry_mut(j.dadr + k, j.dadr + k) += h * d;
                }
                // A limit with MuJoCo's impedance (an added inertia) moves at MuJoCo's pace, its
                // damping `2/τ` per unit of that inertia, which the stages carry explicitly as
                // MuJoCo's own RK4 does.
                if let Some(l) = j.limit.as_ref().filter(|l| l.impedance == 0.0) {
                    *m.entry_mut(j.dadr, j.dadr) += h * l.damping_slope(q[j.qadr], v[j.dadr]);
                }
            }
        }
        m
    }
}
