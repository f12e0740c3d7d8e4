//! MuJoCo's impedance as added inertia, where it acts ([`LimitLaw::Impedance`](crate::dynamics::limit::LimitLaw)):
//! on a joint's limit, one diagonal entry of the mass matrix; on a tendon's limit or an
//! equality, whose coordinate couples joints across the tree's branches, rows added to the
//! tree's factor ([`CoupledFactor`]); and the limits' let-go, where the whole force of a limit
//! with an added inertia would pull (docs/mjcf.md, "Joint limits" and "Equality constraints").
//!
//! The shares the limits hold ([`Forward::holds`]) are one per joint, then one per fixed
//! tendon, then one per spatial tendon ([`Model::limit_slots`]).

use super::*;
use crate::dynamics::limit::JointLimit;
use crate::dynamics::{CoupledFactor, Row, TreeMatrix};

/// A tendon's limit with an added inertia, at one evaluation.
struct TendonLimit<T: Scalar> {
    /// Its place among the shares ([`Model::limit_slots`]).
    slot: usize,
    limit: JointLimit,
    /// The tendon's length and rate.
    length: T,
    rate: T,
    /// `∂L/∂q`: the tendon's row.
    row: DVector<T>,
    /// `h` where the step takes the limit's damping implicitly along the row (damped Euler).
    damped: Option<T>,
}

/// The coupled constraints with an added inertia at one configuration ([`Model::coupled_at`]).
pub(crate) struct Coupled<T: Scalar> {
    limits: Vec<TendonLimit<T>>,
    /// The equalities' rows, each with its added inertia (they always hold).
    equalities: Vec<Row<T>>,
    /// Each equality row's turning `J̇ v`, in the order of `equalities`.
    turnings: Vec<T>,
}

impl<T: Scalar> Coupled<T> {
    /// Every row with its added inertia, a tendon limit's weighed as it pushes and by the
    /// share it holds (`holds`, [`Model::limit_slots`]; `None`: in all), with `h` times its
    /// damping slope where the step takes its damping implicitly.
    pub(crate) fn rows(&self, holds: Option<&[T]>) -> Vec<Row<T>> {
        let limits = self.limits.iter().map(|t| {
            let g = holds.map_or(T::one(), |h| h[t.slot]);
            let mut inertia = t.limit.added_inertia(t.length, t.rate);
            if let Some(h) = t.damped {
                inertia += t.limit.damping_slope(t.length, t.rate) * h;
            }
            Row {
                jacobian: t.row.clone(),
                inertia: inertia * g,
            }
        });
        limits.chain(self.equalities.iter().cloned()).collect()
    }

    /// Adds the force of the equalities' rows turning, `-Σ aᵢ Jᵢᵀ (J̇ᵢ v)`, to `rhs`: the added
    /// inertia `aᵢ` resists the row's whole acceleration `Jᵢ v̇ + J̇ᵢ v`, so that the count
    /// `½ vᵀ (M + Σ aᵢ Jᵢᵀ Jᵢ) v` plus the springs is what the motion conserves
    /// ([`Model::added_kinetic`]). MuJoCo's constraint reads `J v̇` alone; without this term an
    /// undamped joint equality and connect on one body pumped energy, 6.6 J into a 19.6 J swing
    /// in 1 s (docs/mjcf.md, "Equality constraints").
    pub(crate) fn add_turning_force(&self, rhs: &mut DVector<T>) {
        for (row, &turning) in self.equalities.iter().zip(&self.turnings) {
            rhs.axpy(-(turning * row.inertia), &row.jacobian, T::one());
        }
    }

    /// `M + Jᵀ A J` factored, from `m` (the tree's part, with the joints' own added inertia)
    /// and the rows at the shares `holds`.
    pub(crate) fn factor(
        &self,
        model: &Model,
        m: TreeMatrix<T>,
        holds: Option<&[T]>,
    ) -> Result<CoupledFactor<T>, DynamicsError> {
        let tree = model.tree.factor(m).ok_or(DynamicsError::Singular)?;
        Ok(CoupledFactor::new(tree, &self.rows(holds)))
    }
}

impl Model {
    /// The number of shares the limits hold ([`Forward::holds`]): one per joint, fixed tendon
    /// and spatial tendon.
    pub(crate) fn limit_slots(&self) -> usize {
        self.tree.joints.len() + self.tendons.len() + self.spatial_tendons.len()
    }

    /// Each tendon's limit with an added inertia, with its slot among the shares.
    fn tendon_limits(&self) -> impl Iterator<Item = (usize, JointLimit)> + '_ {
        let n = self.tree.joints.len();
        let fixed = self.tendons.iter().map(|t| t.limit);
        let spatial = self.spatial_tendons.iter().map(|t| t.law.limit);
        fixed
            .chain(spatial)
            .enumerate()
            .filter_map(move |(k, l)| l.filter(|l| l.impedance > 0.0).map(|l| (n + k, l)))
    }

    /// The coupled constraints with an added inertia at the configuration of `kin` (positions
    /// `q`, velocities `v`): each tendon limit's row and each equality's rows; with
    /// `implicit_damping` `Some(h)` outside damped RK4 (damped Euler), a tendon limit's row
    /// also carries `h` times its damping slope (its damping implicit, as a joint's limit's in
    /// `D`; [`crate::dynamics::limit::LimitLaw::under`]). A spatial tendon's row, and a
    /// connect's or weld's, is the generalized force of its unit wrenches
    /// ([`crate::dynamics::Tree::wrench_forces`]).
    pub(crate) fn coupled_at<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        q: &[T],
        v: &[T],
        implicit_damping: Option<T>,
    ) -> Coupled<T> {
        let (nv, nj, nt) = (self.tree.nv, self.tree.joints.len(), self.tendons.len());
        let unit_row = |add: &dyn Fn(&mut [Wrench<T>])| {
            let mut w = vec![Wrench::zero(); self.tree.bodies.len()];
            add(&mut w);
            self.tree.wrench_forces(kin, &w)
        };
        let tendon_at = |slot: usize| -> (T, T, DVector<T>) {
            match self.tendons.get(slot - nj) {
                Some(t) => {
                    let mut row = DVector::zeros(nv);
                    for &(_, vi, coef) in &t.joints {
                        row[vi] += c::<T>(coef);
                    }
                    (t.length(q), t.velocity(v), row)
                }
                None => {
                    let t = &self.spatial_tendons[slot - nj - nt];
                    let (length, rate) = t.length_and_rate(&kin.frames);
                    let row = unit_row(&|w| t.add_force_wrenches(&kin.frames, T::one(), w));
                    (length, rate, row)
                }
            }
        };
        let damped = implicit_damping.filter(|_| self.integrator != Integrator::DampedRk4);
        let limits = (self.tendon_limits())
            .map(|(slot, limit)| {
                let (length, rate, row) = tendon_at(slot);
                TendonLimit {
                    slot,
                    limit,
                    length,
                    rate,
                    row,
                    damped,
                }
            })
            .collect();
        let scalar = self.equalities.iter().filter(|e| e.impedance > 0.0);
        let (mut equalities, mut turnings): (Vec<Row<T>>, Vec<T>) = scalar
            .map(|e| {
                let row = Row {
                    jacobian: e.row(q, nv),
                    inertia: c(e.impedance),
                };
                (row, e.turning(q, v))
            })
            .unzip();
        let mut bias = None;
        for k in &self.connects {
            let mut rows = k.rows().peekable();
            if rows.peek().is_none() {
                continue;
            }
            let bias = bias.get_or_insert_with(|| self.tree.bias_accelerations(kin));
            let turning = k.row_turnings(&kin.frames, bias);
            for (row, inertia) in rows {
                equalities.push(Row {
                    jacobian: unit_row(&|w| k.add_row_wrenches(&kin.frames, row, w)),
                    inertia: c(inertia),
                });
                turnings.push(turning[row]);
            }
        }
        Coupled {
            limits,
            equalities,
            turnings,
        }
    }

    /// The kinetic energy of the inertia MuJoCo's impedance adds along the equalities' rows,
    /// `½ Σ aᵢ (Jᵢ v)²`. An equality always holds, so with it and its spring at the gains
    /// that act the total is what its motion conserves, under a load too (where counting the
    /// spring at its reference gains, as a limit's, drifts by `(1 - 1/statics)` of the load's
    /// work: ±4.8 J a swing on a body hung 2.2 m from its weld's point, measured), the rows'
    /// turning included ([`Coupled::add_turning_force`]).
    pub(crate) fn added_kinetic<T: Scalar>(&self, kin: &Kinematics<T>, q: &[T], v: &[T]) -> T {
        let mut out = T::zero();
        // Made only where an equality has an added inertia (a scene without any allocates nothing).
        let mut vs = None;
        for e in self.equalities.iter().filter(|e| e.impedance > 0.0) {
            let vs = vs.get_or_insert_with(|| DVector::from_column_slice(v));
            let rate = e.row(q, self.tree.nv).dot(vs);
            out += rate * rate * (0.5 * e.impedance);
        }
        for k in &self.connects {
            let rates = k.row_rates(&kin.frames);
            for (row, a) in k.rows() {
                out += rates[row] * rates[row] * (0.5 * a);
            }
        }
        out
    }

    /// Whether a limit has MuJoCo's impedance, an added inertia, and so may let go
    /// ([`JointLimit::hold`]).
    pub(crate) fn limits_can_let_go(&self) -> bool {
        let with = |j: &crate::dynamics::Joint| j.limit.is_some_and(|l| l.impedance > 0.0);
        self.tree.joints.iter().any(with) || self.tendon_limits().next().is_some()
    }

    /// The share each limit holds given the accelerations `vdot` solved with every limit held
    /// ([`JointLimit::hold`]), one per slot ([`Model::limit_slots`]), or `None` where every
    /// limit holds in all. The caller then solves again with them ([`Model::let_go`]): two
    /// solves where a limit lets go, as MuJoCo's solver finds a limit inactive. The share is
    /// read from the first solve, so a limit let go in part changes the others' only through
    /// the second. A tendon's acceleration is its row times `vdot` (MuJoCo's constraint reads
    /// `J v̇` too).
    pub(crate) fn release_limits<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        vdot: &DVector<T>,
        coupled: &Coupled<T>,
    ) -> Option<Vec<T>> {
        let mut holds: Vec<T> = vec![T::one(); self.limit_slots()];
        for (j, g) in self.tree.joints.iter().zip(&mut holds) {
            if let Some(l) = j.limit.as_ref().filter(|l| l.impedance > 0.0) {
                *g = l.hold(q[j.qadr], v[j.dadr], vdot[j.dadr]);
            }
        }
        for t in &coupled.limits {
            holds[t.slot] = t.limit.hold(t.length, t.rate, t.row.dot(vdot));
        }
        holds.iter().any(|g| g.re() < 1.0).then_some(holds)
    }

    /// Takes each joint's limit at the share `holds` of its added inertia (in `m`) and of its
    /// force (in `rhs`), and each tendon's limit at its share of its force (its inertia's
    /// share is taken by [`Coupled::rows`]).
    pub(crate) fn let_go<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        holds: &[T],
        coupled: &Coupled<T>,
        m: &mut TreeMatrix<T>,
        rhs: &mut DVector<T>,
    ) {
        for (j, &g) in self.tree.joints.iter().zip(holds) {
            let Some(l) = j.limit.as_ref().filter(|l| l.impedance > 0.0) else {
                continue;
            };
            if g.re() < 1.0 {
                let (qi, vi, d) = (q[j.qadr], v[j.dadr], j.dadr);
                let lost = -g + 1.0;
                *m.entry_mut(d, d) -= l.added_inertia(qi, vi) * lost;
                rhs[d] -= l.force(qi, vi) * lost;
            }
        }
        for t in &coupled.limits {
            let g = holds[t.slot];
            if g.re() < 1.0 {
                let lost = t.limit.force(t.length, t.rate) * (-g + 1.0);
                rhs.axpy(-lost, &t.row, T::one());
            }
        }
    }

    /// What the limits and the coupled constraints add to the inverse dynamics at `vdot`:
    /// `Σ aᵢ Jᵢᵀ (Jᵢ v̇)` over the rows and each joint's added inertia times its acceleration,
    /// a limit at the share it holds there (its inertia and its force: the share let go is
    /// taken back from the passive force the caller subtracted).
    pub(crate) fn add_impedance_forces<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        q: &[T],
        v: &[T],
        vdot: &[T],
        tau: &mut DVector<T>,
    ) {
        for j in &self.tree.joints {
            if let Some(l) = j.limit.as_ref().filter(|l| l.impedance > 0.0) {
                let (qi, vi, d) = (q[j.qadr], v[j.dadr], j.dadr);
                let g = l.hold(qi, vi, vdot[d]);
                tau[d] += vdot[d] * l.added_inertia(qi, vi) * g + l.force(qi, vi) * (-g + 1.0);
            }
        }
        let coupled = self.coupled_at(kin, q, v, None);
        let vdot = DVector::from_column_slice(vdot);
        let mut holds = vec![T::one(); self.limit_slots()];
        for t in &coupled.limits {
            let g = t.limit.hold(t.length, t.rate, t.row.dot(&vdot));
            holds[t.slot] = g;
            let lost = t.limit.force(t.length, t.rate) * (-g + 1.0);
            tau.axpy(lost, &t.row, T::one());
        }
        for r in coupled.rows(Some(&holds)) {
            let along = r.jacobian.dot(&vdot) * r.inertia;
            tau.axpy(along, &r.jacobian, T::one());
        }
        // The rows' turning, which the forward dynamics take as a force (`-Σ aᵢ Jᵢᵀ J̇ᵢ v`).
        let mut turning = DVector::zeros(tau.len());
        coupled.add_turning_force(&mut turning);
        *tau -= turning;
    }
}
