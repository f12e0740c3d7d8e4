//! The forward dynamics of damped Euler's step equation at one configuration: positions,
//! start velocity and inputs fixed, the contact forces taken at a trial end velocity `V`
//! (`Model::forward_at` with the contact velocity `V`). Newton's iterations evaluate it at
//! several `V` per step; here everything that does not depend on `V` is computed once: the
//! kinematics, the damped mass matrix and its factorization, the passive and actuator forces,
//! and each pair's contact terms ([`PairTape`]), so an evaluation costs the point–plane forces
//! and one pass of the tree. Newton's Jacobian of the step equation comes from the same tapes
//! ([`FrozenForward::contact_force`], [`FrozenForward::step_jacobian`]): only the contact
//! forces depend on `V`, so only they are differentiated, where a Jacobian through
//! `Model::forward_at` on dual numbers would find the contact again and build the mass matrix
//! on dual numbers in every pass.

use super::pairs::{add_pair_wrenches, PairVisit, Pick};
use super::*;
use crate::collision::Frame;
use crate::contact::{PairTape, Seeds};
use crate::dynamics::{BodyColumn, CoupledFactor};
use crate::scalar::{derivatives, seeded};
use nalgebra::{DMatrix, SMatrix};

/// [`Model::forward_at`] on `f64` with a contact velocity, frozen at a configuration (see the
/// module).
pub struct FrozenForward<'m> {
    model: &'m Model,
    /// The positions, read where the caller keeps them (a step's start state), not copied.
    q: &'m [f64],
    /// The start velocity.
    v: &'m [f64],
    mocap: &'m [f64],
    /// Kinematics at the start velocity (what every term but the contact is taken at).
    kin: Kinematics<f64>,
    /// RNEA's forward pass at `kin` ([`crate::dynamics::Tree::rnea_forces`]): each
    /// evaluation takes its wrenches from it and runs the backward pass alone.
    bias_forces: Vec<nalgebra::Vector6<f64>>,
    rhs: DVector<f64>,
    /// The damped mass matrix with MuJoCo's impedance along the coupled constraints' rows.
    mass: CoupledFactor<f64>,
    /// Each pair in reach: its bodies, its parameters and its recorded contact.
    tapes: Vec<(usize, usize, ContactParams<f64>, PairTape)>,
    /// The contact of every pair where it was recorded (at the start velocity), in pair order:
    /// `None` for a pair out of reach, as [`Forward::contacts`], or without a collider.
    contacts: Vec<Option<PairContact<f64>>>,
    /// The stiction velocity of the tendons' dry friction.
    stiction_velocity: f64,
    /// The share each limit holds, where one lets go ([`Forward::holds`]).
    holds: Option<Vec<f64>>,
}

impl Model {
    /// Freezes `forward_at(at, prm, ForwardOptions { contact_velocity: Some(V),
    /// implicit_damping: Some(h), reuse, .. })` at everything but `V`; the pairs in reach and
    /// their contact terms are recorded at `V = v` through the same pair loop as the forward
    /// dynamics (`Model::visit_pairs`). Returns it with its accelerations there.
    pub fn frozen_forward<'m>(
        &'m self,
        at: EvalPoint<'m, f64>,
        prm: &ContactParams<f64>,
        h: f64,
        reuse: Reuse,
    ) -> Result<(FrozenForward<'m>, Vec<f64>), DynamicsError> {
        match self.frozen_start(at, prm, h, reuse, None, false)? {
            FrozenStart::Recorded(frozen, vdot) => Ok((frozen, vdot)),
            FrozenStart::Free { .. } => unreachable!("a free start is only made where asked"),
        }
    }

    /// [`Model::frozen_forward`] from `known`, the kinematics of `at`'s positions and velocities
    /// if the caller has them already (the energy guard's of the state it checked: the same
    /// bits, one kinematics pass fewer); and with `free`, where no pair is in reach and no limit
    /// can let go, only what a step without contact reads of it ([`FrozenStart::Free`]: the
    /// same accelerations to the bit, without the frozen evaluation a step without contact
    /// would build, move and drop, nor the copy of the bias forces its later evaluations keep:
    /// `floating3`, callgrind, 29.6 k → 29.0 k instructions a step under damped Euler, 112.8 k →
    /// 109.8 k under damped RK4).
    pub(crate) fn frozen_start<'m>(
        &'m self,
        at: EvalPoint<'m, f64>,
        prm: &ContactParams<f64>,
        h: f64,
        reuse: Reuse,
        known: Option<Kinematics<f64>>,
        free: bool,
    ) -> Result<FrozenStart<'m>, DynamicsError> {
        let EvalPoint {
            q,
            v,
            tau,
            mocap,
            pulls,
        } = at;
        let mut reuse = reuse;
        reuse.fit(self.pairs.len());
        self.check_finite(q, v)?;
        let kin = known.unwrap_or_else(|| self.tree.kinematics_with(q, v, mocap));
        // `τ + τ_passive`, into the passive forces' vector (the same sums: addition commutes).
        let mut rhs = self.passive_forces(q, v, prm.stiction_velocity);
        for (r, t) in rhs.iter_mut().zip(tau) {
            *r += t;
        }
        let matrix = self.damped_mass_matrix(&kin, q, v, prm, Some(h));
        let coupled = self.coupled_at(&kin, q, v, Some(h));
        coupled.add_turning_force(&mut rhs);
        // Kept for a second factorization where a limit lets go.
        let unfactored = self.limits_can_let_go().then(|| matrix.clone());
        let mass = coupled.factor(self, matrix, None)?;
        // Boxed: a visit is two words, not the record's few hundred bytes, so the visits of a
        // step with nothing in reach fit the allocator's small-block cache; a pair in reach
        // costs one allocation more (`box_stack` and `t_push` under damped Euler: 0.99-1.00).
        let visits = self.visit_pairs(&kin, prm, pulls, Pick::InReach, reuse, |p, scratch| {
            let ([ca, cb], [a, b]) = (p.sides, p.bodies);
            let (fa, fb) = (&kin.frames[a], &kin.frames[b]);
            Box::new((
                a,
                b,
                p.prm,
                PairTape::record(ca, fa, cb, fb, &p.prm, p.candidates, scratch),
            ))
        });
        let mut tapes = Vec::new();
        let mut contacts = Vec::with_capacity(visits.len());
        for visit in visits {
            contacts.push(match visit {
                PairVisit::Evaluated(record) => {
                    let (a, b, p, (tape, contact)) = *record;
                    tapes.push((a, b, p, tape));
                    Some(contact)
                }
                PairVisit::NoCollider | PairVisit::OutOfReach => None,
            });
        }
        let wrenches = self.pair_wrenches(&contacts);
        let bias_forces = self.tree.rnea_forces(&kin, &[]);
        if free && tapes.is_empty() && unfactored.is_none() {
            let stiction = prm.stiction_velocity;
            let vdot = solve_at(self, &kin, stiction, bias_forces, &rhs, &mass, wrenches);
            return Ok(FrozenStart::Free {
                vdot,
                kin,
                contacts,
            });
        }
        let mut frozen = FrozenForward {
            model: self,
            q,
            v,
            mocap,
            kin,
            bias_forces,
            rhs,
            mass,
            tapes,
            contacts,
            stiction_velocity: prm.stiction_velocity,
            holds: None,
        };
        let Some(matrix) = unfactored else {
            let vdot = frozen.solve(wrenches);
            return Ok(FrozenStart::Recorded(frozen, vdot));
        };
        let held = frozen.solve(wrenches.clone());
        // A limit that would pull is let go as `forward_at` lets it go, its share read here,
        // at the start velocity, for every trial end velocity (the dual-number path takes the
        // same shares from its start: `ForwardOptions::holds`).
        let held_vdot = DVector::from_vec(held.clone());
        let Some(holds) = self.release_limits(q, v, &held_vdot, &coupled) else {
            return Ok(FrozenStart::Recorded(frozen, held));
        };
        let (mut matrix, mut rhs) = (matrix, frozen.rhs.clone());
        self.let_go(q, v, &holds, &coupled, &mut matrix, &mut rhs);
        frozen.mass = coupled.factor(self, matrix, Some(&holds))?;
        frozen.rhs = rhs;
        frozen.holds = Some(holds);
        let vdot = frozen.solve(wrenches);
        Ok(FrozenStart::Recorded(frozen, vdot))
    }
}

/// What [`Model::frozen_start`] finds at a step's start.
// Returned once a step and taken apart at once: boxing the larger variant would cost a step in
// contact an allocation to save a few hundred bytes of moves.
#[allow(clippy::large_enum_variant)]
pub(crate) enum FrozenStart<'m> {
    /// No pair in reach and no limit that can let go: the accelerations, the kinematics they
    /// were read from (for their buffers) and every pair's contact (`None` each: as
    /// [`FrozenForward::contacts`]).
    Free {
        vdot: Vec<f64>,
        kin: Kinematics<f64>,
        contacts: Vec<Option<PairContact<f64>>>,
    },
    /// The frozen evaluation and its accelerations at the start.
    Recorded(FrozenForward<'m>, Vec<f64>),
}

/// `(M + h D)⁻¹ (rhs - c + Σ Jᵀ f)`, `c` the bias forces at `kin` from RNEA's forward pass
/// `bias_forces` (consumed), `f` the contact `wrenches` and the bodies' own forces, `mass` the
/// factorization: [`FrozenForward::solve`], and a free start's one solve.
fn solve_at(
    m: &Model,
    kin: &Kinematics<f64>,
    stiction_velocity: f64,
    bias_forces: Vec<nalgebra::Vector6<f64>>,
    rhs: &DVector<f64>,
    mass: &CoupledFactor<f64>,
    mut wrenches: Vec<Wrench<f64>>,
) -> Vec<f64> {
    m.add_body_forces(kin, stiction_velocity, &mut wrenches);
    // `rhs - c`, into the bias forces' vector (the same differences), and the solution's own
    // vector handed out.
    let mut out = (m.tree).rnea_with(kin, bias_forces, &wrenches);
    for (b, r) in out.iter_mut().zip(rhs.iter()) {
        *b = r - *b;
    }
    mass.solve(&out).data.into()
}

impl FrozenForward<'_> {
    /// Whether no pair was in reach where the contact was recorded (no force depends on the
    /// end velocity).
    pub fn contact_free(&self) -> bool {
        self.tapes.is_empty()
    }

    /// The kinematics of the step's start it was made from, for their buffers
    /// ([`crate::dynamics::Tree::kinematics_into`]) once it is done with.
    pub fn into_kinematics(self) -> Kinematics<f64> {
        self.kin
    }

    /// Each pair's contact where it was recorded (the start velocity), in pair order, `None`
    /// out of reach or without a collider: the same bits as the forward dynamics'
    /// [`Forward::contacts`] there for every pair whose bodies both have a collider.
    pub fn contacts(&self) -> &[Option<PairContact<f64>>] {
        &self.contacts
    }

    /// [`FrozenForward::contacts`], taken out: [`FrozenForward::contacts`] is empty after
    /// (nothing else of the evaluation reads them).
    pub fn take_contacts(&mut self) -> Vec<Option<PairContact<f64>>> {
        std::mem::take(&mut self.contacts)
    }

    /// The share each limit holds where one lets go at the start velocity, one per slot
    /// ([`Forward::holds`]).
    pub fn holds(&self) -> Option<&[f64]> {
        self.holds.as_deref()
    }

    /// The accelerations with the contact forces taken at the end velocity `v_contact`.
    pub fn vdot(&self, v_contact: &[f64]) -> Vec<f64> {
        let frames = (self.model.tree).frames_at_velocity(&self.kin, v_contact, self.mocap);
        self.solve(self.contact_wrenches(&frames, |p| *p))
    }

    /// The generalized contact force `τ_c(V) = Σ Jᵀ Λ(V)` at the end velocity `v_contact`,
    /// plus terms that do not depend on it (gravity, the velocity products at the start
    /// velocity): the only part of the step equation that depends on `V`. On dual numbers (the
    /// positions carry none) the tapes replay the contact's velocity derivatives, and `Jᵀ` is
    /// the recursive Newton–Euler pass at the start kinematics.
    pub fn contact_force<T: Scalar>(&self, v_contact: &[T]) -> Vec<T> {
        let lift = |v: &[f64]| v.iter().map(|&a| c::<T>(a)).collect::<Vec<T>>();
        let (q, v, mocap) = (lift(self.q), lift(self.v), lift(self.mocap));
        let tree = &self.model.tree;
        let at = tree.kinematics_with(&q, v_contact, &mocap);
        let wrenches = self.contact_wrenches(&at.frames, |p| p.lift());
        let start = tree.kinematics_with(&q, &v, &mocap);
        // The bias with vdot = 0 is c(q, v) - Σ Jᵀ f_ext: its negative carries Σ Jᵀ Λ(V).
        let bias = tree.rnea(&start, &[], &wrenches);
        bias.iter().map(|&b| -b).collect()
    }

    /// `∂τ_c/∂V` at the end velocity `v_contact`: the Jacobian of
    /// [`FrozenForward::contact_force`], pair by pair. Each recorded pair's wrenches depend on
    /// `V` only through its two bodies' frame velocities, so its tape is replayed once on dual
    /// numbers of width 12 seeded on those (the 12 × 12 `K` of its wrenches against the two
    /// bodies' velocities; each point force on width 3, [`PairTape::replay_seeded`]), and `Σ Jᵀ K J` is gathered over the columns of the two bodies'
    /// Jacobians ([`crate::dynamics::Tree::body_jacobian`], at the recorded positions). The
    /// same derivatives as [`FrozenForward::contact_force`] on dual numbers of every velocity,
    /// which replays every tape once per pass of 8 velocities: on MuJoCo's stonehenge (456
    /// velocities, 57 passes) those replays were 85 % of a run.
    pub fn contact_force_jacobian(&self, v_contact: &[f64]) -> DMatrix<f64> {
        type D = Seeds;
        let m = self.model;
        let n = m.tree.nv;
        let frames = m.tree.frames_at_velocity(&self.kin, v_contact, self.mocap);
        // Each body's Jacobian columns, found once (positions are those of `self.kin`).
        let mut columns: Vec<Option<Vec<BodyColumn<f64>>>> = vec![None; m.tree.bodies.len()];
        let mut out = DMatrix::zeros(n, n);
        let seeded_frame = |f: &Frame<f64>, first: usize| Frame::<D> {
            rotation: f.rotation.map(D::from_re),
            origin: f.origin.map(D::from_re),
            linvel: Vector3::from_fn(|k, _| seeded(f.linvel[k], Some(first + k))),
            angvel: Vector3::from_fn(|k, _| seeded(f.angvel[k], Some(first + 3 + k))),
        };
        for (a, b, p, tape) in &self.tapes {
            let (Some(ca), Some(cb)) = (&m.colliders[*a], &m.colliders[*b]) else {
                unreachable!("a recorded pair has both colliders")
            };
            let (fa, fb) = (seeded_frame(&frames[*a], 0), seeded_frame(&frames[*b], 6));
            let [on_a, on_b] = tape.replay_seeded(ca, &fa, cb, &fb, p);
            // Rows: force and torque on a, then on b; columns: a's linear and angular
            // velocity, then b's.
            let mut k = SMatrix::<f64, 12, 12>::zeros();
            let rows = [on_a.force, on_a.torque, on_b.force, on_b.torque];
            for (r, v) in rows.iter().enumerate() {
                for i in 0..3 {
                    k.row_mut(3 * r + i).copy_from_slice(&derivatives(&v[i]));
                }
            }
            for body in [*a, *b] {
                if columns[body].is_none() {
                    columns[body] = Some(m.tree.body_jacobian(&self.kin, body));
                }
            }
            let sides = [(0, *a), (6, *b)];
            for (cs, cbody) in sides {
                for (dc, lc, ac) in columns[cbody].as_deref().unwrap_or_default() {
                    // The pair's wrenches for a unit velocity of coordinate dc.
                    let u = k.fixed_columns::<3>(cs) * lc + k.fixed_columns::<3>(cs + 3) * ac;
                    for (rs, rbody) in sides {
                        for (dr, lr, ar) in columns[rbody].as_deref().unwrap_or_default() {
                            out[(*dr, *dc)] +=
                                lr.dot(&u.fixed_rows::<3>(rs)) + ar.dot(&u.fixed_rows::<3>(rs + 3));
                        }
                    }
                }
            }
        }
        out
    }

    /// The Jacobian `∂r/∂V = I - h (M + h D)⁻¹ ∂τ_c/∂V` of damped Euler's step equation
    /// `r(V) = V - v - h v̇(V)`, from `force_jacobian`, the Jacobian of
    /// [`FrozenForward::contact_force`] at the same `V`: exact for [`FrozenForward::vdot`].
    pub fn step_jacobian(&self, force_jacobian: &DMatrix<f64>, h: f64) -> DMatrix<f64> {
        let n = force_jacobian.ncols();
        let mut out = DMatrix::identity(n, n);
        for k in 0..n {
            // A velocity no recorded pair reads leaves its column the identity's.
            if force_jacobian.column(k).iter().all(|x| *x == 0.0) {
                continue;
            }
            let column = self.mass.solve(&force_jacobian.column(k).into_owned());
            out.column_mut(k).axpy(-h, &column, 1.0);
        }
        out
    }

    /// Each recorded pair's wrenches at the bodies' frames `at` (the recorded positions), on
    /// the bodies; `prm` gives a pair's parameters on `at`'s scalar.
    fn contact_wrenches<T: Scalar>(
        &self,
        at: &[Frame<T>],
        prm: impl Fn(&ContactParams<f64>) -> ContactParams<T>,
    ) -> Vec<Wrench<T>> {
        let m = self.model;
        let mut wrenches = vec![Wrench::zero(); m.tree.bodies.len()];
        for (a, b, p, tape) in &self.tapes {
            let (Some(ca), Some(cb)) = (&m.colliders[*a], &m.colliders[*b]) else {
                unreachable!("a recorded pair has both colliders")
            };
            let (fa, fb) = (&at[*a], &at[*b]);
            let [on_a, on_b] = tape.replay(ca, fa, cb, fb, &prm(p));
            add_pair_wrenches(&mut wrenches, *a, *b, [&on_a, &on_b]);
        }
        wrenches
    }

    /// `(M + h D)⁻¹ (τ + τ_passive - c + Σ Λ)` for the contact wrenches `wrenches`.
    fn solve(&self, wrenches: Vec<Wrench<f64>>) -> Vec<f64> {
        let bias = self.bias_forces.clone();
        let (kin, stiction) = (&self.kin, self.stiction_velocity);
        solve_at(
            self.model, kin, stiction, bias, &self.rhs, &self.mass, wrenches,
        )
    }
}
