//! Newton's method for the implicit steps (implicit Euler's step equation, damped Euler's
//! velocity-implicit contact): a real Jacobian kept while it serves, backtracking on the
//! residual's norm, and a fresh Jacobian at every iteration on dual numbers so that the
//! derivatives of the solution are exact.

use crate::linalg::block_inverse;
use crate::model::DynamicsError;
use crate::scalar::Scalar;
use nalgebra::DMatrix;
use std::any::TypeId;

/// Newton iterations of an implicit stage: tolerance and limits.
const NEWTON_TOL: f64 = 1e-10;
const NEWTON_MAX_ITER: usize = 40;

/// A residual function of the implicit step, on the scalar type.
type Residual<'a, T> = dyn Fn(&[T]) -> Result<Vec<T>, DynamicsError> + 'a;
/// The Jacobian of a residual at real values.
type RealJacobian<'a> = dyn Fn(&[f64]) -> Result<DMatrix<f64>, DynamicsError> + 'a;

/// A real Newton Jacobian kept from step to step while it serves, with its inverse, computed
/// when first needed and kept with it: for 32 free boxes (192 velocities) inverting the
/// Jacobian at every step cost about a fifth of the implicit step. The inverse is taken island
/// by island (the groups of velocities no nonzero entry joins: trees that no pair in reach,
/// tendon or equality couples), each block's LU. It is a function of the matrix, so a Jacobian
/// restored from an FMU state gives the same iterates to the bit; it is neither compared nor
/// serialized.
#[derive(Clone, Debug)]
pub(crate) struct WarmJacobian {
    matrix: DMatrix<f64>,
    inverse: Option<DMatrix<f64>>,
}

impl WarmJacobian {
    pub(crate) fn new(matrix: DMatrix<f64>) -> Self {
        WarmJacobian {
            matrix,
            inverse: None,
        }
    }

    pub(crate) fn matrix(&self) -> &DMatrix<f64> {
        &self.matrix
    }

    /// The inverse, computed on the first call; `None` for a singular matrix.
    fn inverse(&mut self) -> Option<&DMatrix<f64>> {
        if self.inverse.is_none() {
            // Island by island: trees no pair in reach couples (`crate::linalg`).
            self.inverse = block_inverse(&self.matrix, |b| b.lu().try_inverse());
        }
        self.inverse.as_ref()
    }
}

impl PartialEq for WarmJacobian {
    fn eq(&self, other: &Self) -> bool {
        self.matrix == other.matrix
    }
}

/// Newton's method for `residual(x) = 0` from `guess`, with a real Jacobian (see
/// [`Integrator::ImplicitEuler`](crate::integrator::Integrator::ImplicitEuler)): backtracking
/// line search; in `f64` a Jacobian is kept (also from the caller's `jac`) while the iterations
/// contract by 4 or more per step and reach the tolerance sooner than a fresh one would
/// ([`worth_keeping`]); with dual numbers a fresh one every iteration.
pub(super) fn newton<T: Scalar>(
    residual: &Residual<T>,
    real_jacobian: &RealJacobian,
    guess: Vec<T>,
    jac: &mut Option<WarmJacobian>,
) -> Result<Vec<T>, DynamicsError> {
    if guess.is_empty() {
        return Ok(guess);
    }
    let r = residual(&guess)?;
    newton_from(residual, real_jacobian, guess, r, jac)
}

/// [`newton`] with the residual at `guess` known (`r`: the same bits `residual(guess)` gives,
/// where the caller has it already: damped Euler's frozen evaluation at the start velocity).
pub(super) fn newton_from<T: Scalar>(
    residual: &Residual<T>,
    real_jacobian: &RealJacobian,
    guess: Vec<T>,
    r: Vec<T>,
    jac: &mut Option<WarmJacobian>,
) -> Result<Vec<T>, DynamicsError> {
    let n = guess.len();
    if n == 0 {
        return Ok(guess);
    }
    let exact_each_iteration = TypeId::of::<T>() != TypeId::of::<f64>();
    let fail = |iterations: usize, r: &[T]| DynamicsError::NewtonFailed {
        iterations,
        residual: inf_norm(&re_vec(r)),
    };
    let mut x = guess;
    let mut r = r;
    if jac.as_ref().is_some_and(|j| j.matrix.nrows() != n) {
        *jac = None;
    }
    // `refresh`: take a new Jacobian at the current iterate before the next update.
    let mut refresh = jac.is_none();
    let mut last_dx = f64::INFINITY;
    // Whether the last update was a full Newton step (its size then measures the contraction).
    let mut last_full = false;
    let mut crawling = 0;
    // The inverse as this call's secant updates left it (`f64` only), and the last update's
    // `c` (`Secant::update`): the convergence tests read the step over `min(c, 1)`.
    let mut secant: Option<Secant> = None;
    let mut shrunk = 1.0f64;
    for it in 1..=NEWTON_MAX_ITER {
        let fresh = refresh || exact_each_iteration;
        if fresh {
            *jac = Some(WarmJacobian::new(real_jacobian(&re_vec(&x))?));
            secant = None;
            shrunk = 1.0;
            refresh = false;
        }
        let jinv = match &secant {
            Some(s) => &s.inverse,
            None => jac
                .as_mut()
                .expect("a Jacobian was computed")
                .inverse()
                .ok_or_else(|| fail(it, &r))?,
        };
        // dx = J⁻¹ r, in the scalar type (J is real).
        let dx: Vec<T> = (0..n)
            .map(|i| (0..n).fold(T::zero(), |s, k| s + r[k] * jinv[(i, k)]))
            .collect();
        let dx_re = inf_norm(&re_vec(&dx)) / shrunk.min(1.0);
        // Converged, tested on the full step before the residual at its end is evaluated (that
        // residual would serve the line search only): a full step within the tolerance, taken
        // with a Jacobian at this iterate or after a full step (a Jacobian kept from an earlier
        // step that is much stiffer than the residual's makes a small step where the residual
        // is not small: that first step goes through the line search); or, where this and the
        // last full step with the same Jacobian (or its secant update: `shrunk`) show the
        // iterations contracting at a rate θ < 1, the step's end within the tolerance of the solution, at most θ/(1-θ) times the
        // step from it (a contraction's tail: the stopping rule of the implicit Runge–Kutta
        // codes, which saves the last iteration when the rate is fast). A NaN step passes
        // neither (`inf_norm` keeps NaN).
        let mut x_end: Vec<T> = (0..n).map(|i| x[i] - dx[i]).collect();
        let scale_end = 1.0 + inf_norm(&re_vec(&x_end));
        let theta = dx_re / last_dx;
        let tail_small = last_full
            && !fresh
            && theta < 1.0
            && theta / (1.0 - theta) * dx_re <= NEWTON_TOL * scale_end;
        // Or, whatever the Jacobian, the step equation already holds at this iterate within
        // the tolerance (`r` is its defect, in the unknowns' own units) and the step to take is
        // within it too: an extrapolated start that is the solution to rounding (free flight
        // under implicit Euler) needs no second residual to show it.
        let holds = inf_norm(&re_vec(&r)) <= NEWTON_TOL * scale_end;
        if ((fresh || last_full || holds) && dx_re <= NEWTON_TOL * scale_end) || tail_small {
            return Ok(x_end);
        }
        // Backtracking (Armijo on the merit ½|r|², for which the Newton direction descends):
        // halve the step while the merit does not decrease enough.
        let merit = sq_norm(&re_vec(&r));
        let mut alpha = 1.0;
        let (mut x_new, mut r_new);
        loop {
            x_new = if alpha == 1.0 {
                std::mem::take(&mut x_end)
            } else {
                (0..n).map(|i| x[i] - dx[i] * alpha).collect::<Vec<T>>()
            };
            r_new = residual(&x_new);
            let ok = match &r_new {
                Ok(rn) => {
                    let m = sq_norm(&re_vec(rn));
                    m.is_finite()
                        && (m <= (1.0 - 1e-4 * alpha) * merit || m <= 1e-24 * (1.0 + merit))
                }
                Err(_) => false,
            };
            if ok || alpha < 1e-3 {
                break;
            }
            alpha *= 0.5;
        }
        let r_next = r_new?;
        let scale = 1.0 + inf_norm(&re_vec(&x_new));
        let step = dx_re * alpha;
        // The step and the residual's change, for the secant update.
        let change = |to: &[T], from: &[T]| -> Vec<f64> {
            to.iter().zip(from).map(|(a, b)| a.re() - b.re()).collect()
        };
        let secant_pair =
            (!exact_each_iteration).then(|| (change(&x_new, &x), change(&r_next, &r)));
        x = x_new;
        r = r_next;
        if !inf_norm(&re_vec(&r)).is_finite() {
            return Err(fail(it, &r));
        }
        // Also converged: with a Jacobian taken at the last iterate, a small full step that no
        // longer contracts (the rounding floor of a stiff residual).
        let contraction = step / last_dx;
        if alpha == 1.0 && fresh && step <= 1e-7 * scale && contraction > 0.5 {
            return Ok(x);
        }
        // Slow contraction, a damped step, or a kept Jacobian's rate (two full steps with it)
        // that would take more iterations to the tolerance than a fresh one costs: a fresh
        // Jacobian next time.
        let slow = !fresh && last_full && !worth_keeping(contraction, step, scale, n);
        if alpha < 1.0 || contraction > 0.25 || slow {
            refresh = true;
        }
        // The inverse the next iteration steps with, updated by the secant where it is kept.
        if let (Some((s, y)), false) = (secant_pair, refresh) {
            let warm = jac.as_mut().expect("a Jacobian was computed");
            shrunk = secant
                .get_or_insert_with(|| Secant::of(warm))
                .update(&s, &y);
        }
        // Heavily damped steps one after another: the iterate is far from the solution's basin
        // (contact onset within the step); give up early, the caller subdivides the step.
        crawling = if alpha < 1.0 / 64.0 { crawling + 1 } else { 0 };
        if crawling >= 4 {
            return Err(fail(it, &r));
        }
        last_dx = step;
        last_full = alpha == 1.0;
    }
    Err(fail(NEWTON_MAX_ITER, &r))
}

/// A kept Jacobian's inverse updated within one Newton solve by Broyden's rank-one secant
/// update (his "good" method, on the inverse by Sherman and Morrison): after an iteration
/// whose Jacobian is kept for the next, `H` changes least (in the Frobenius norm of the
/// Jacobian it inverts) so that it maps the residual's change `y` to the step `s` just taken.
/// A kept Jacobian then typically converges faster than at its fixed rate, and fewer fresh
/// ones are taken (docs/dynamics.md, "Newton's iterations, secant updates"). Dense: a
/// Jacobian kept while two islands were apart knows nothing of a pair come into reach since
/// (an update per island stopped Newton short, tested). Within the call only: the Jacobian
/// carried on (and into an FMU state) is the one computed, so a restored state iterates alike.
struct Secant {
    inverse: DMatrix<f64>,
}

impl Secant {
    /// The inverse of the warm Jacobian (computed there already: Newton stepped with it).
    fn of(warm: &mut WarmJacobian) -> Self {
        let inverse = warm
            .inverse()
            .cloned()
            .expect("Newton stepped with this inverse");
        Secant { inverse }
    }

    /// For the step `s` whose residual changed by `y`: `H += (s - H y) (sᵀ H) / (sᵀ H y)`,
    /// only where `0.1 |s|² ≤ sᵀ H y ≤ 10 |s|²` (after Powell; off that the update is large
    /// and unreliable). Returns `c = |s|² / sᵀ H y` (1 without an update): after a full step
    /// the next step is `c` times the kept inverse's, `H⁺ r = c H r`.
    fn update(&mut self, s: &[f64], y: &[f64]) -> f64 {
        let h = &mut self.inverse;
        let n = s.len();
        let hy: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|k| h[(i, k)] * y[k]).sum())
            .collect();
        let den: f64 = s.iter().zip(&hy).map(|(a, b)| a * b).sum();
        let ss: f64 = s.iter().map(|a| a * a).sum();
        // (NaN fails the test.)
        let near = ss > 0.0 && den >= 0.1 * ss && den <= 10.0 * ss;
        if !near {
            return 1.0;
        }
        let sh: Vec<f64> = (0..n)
            .map(|k| (0..n).map(|i| s[i] * h[(i, k)]).sum())
            .collect();
        for i in 0..n {
            let u = (s[i] - hy[i]) / den;
            for k in 0..n {
                h[(i, k)] += u * sh[k];
            }
        }
        ss / den
    }
}

/// What one pass of dual numbers of [`jacobian`](crate::autodiff::jacobian) costs, in
/// evaluations of the residual: about 3.5 on robosuite's xArm7 (7 velocities, one pass of
/// width 8; its residual about 5.8 ms), from the totals of runs under three refresh rules.
const JACOBIAN_PASS_COST: f64 = 4.0;

/// Whether a kept Jacobian whose last full step contracted by `theta` to `step` is cheaper to
/// go on with than a fresh one. At that rate the tolerance is `ln(tol / step) / ln θ`
/// iterations away; a fresh Jacobian costs about two quadratic iterations and its passes
/// (`⌈n/8⌉`, [`JACOBIAN_PASS_COST`] each), half of which is counted against this step because
/// it also serves the next ones (on the xArm7 a fresh one contracts by about 0.03 at the next
/// step). Under the rule of 0.25 alone, a kept Jacobian contracting by 0.19 at every step took
/// the xArm7 nine residuals a step (61 ms a step, 0.1 s in 3.05 s); with this rule 3.2
/// residuals and 0.12 Jacobians a step (1.41 s). A rate not in (0, 1) or a step within the
/// tolerance keeps it (the other tests decide).
fn worth_keeping(theta: f64, step: f64, scale: f64, n: usize) -> bool {
    let tol = NEWTON_TOL * scale;
    if !(theta > 0.0 && theta < 1.0) || step <= tol {
        return true;
    }
    let to_go = (tol / step).ln() / theta.ln();
    let fresh = 2.0 + 0.5 * JACOBIAN_PASS_COST * n.div_ceil(8) as f64;
    to_go <= fresh
}

pub(super) fn re_vec<T: Scalar>(x: &[T]) -> Vec<f64> {
    x.iter().map(|a| a.re()).collect()
}

fn sq_norm(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum()
}

/// The largest magnitude; NaN if any entry is NaN (`f64::max` would skip it, and a NaN step
/// would then read as converged).
pub(super) fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .map(|a| a.abs())
        .fold(0.0f64, |m, a| if a > m || a.is_nan() { a } else { m })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// With a Jacobian that is off by a factor (as one kept from an earlier step is), the
    /// iterations contract linearly at θ = 1 - 1/off; stopping on the contraction's tail must
    /// return a point within the tolerance of the solution, and with fewer residuals than
    /// waiting for a step below the tolerance (counted here by replaying the same iteration).
    #[test]
    fn a_kept_jacobian_stops_on_the_tail_within_the_tolerance() {
        // r(x) = x + 0.3 x³ - b, component by component: the solution by bisection.
        let b = [0.7, -1.3, 2.1];
        let solution: Vec<f64> = b
            .iter()
            .map(|&bi| {
                let (mut lo, mut hi) = (-10.0f64, 10.0f64);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if mid + 0.3 * mid.powi(3) < bi {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                0.5 * (lo + hi)
            })
            .collect();
        let r_of =
            |x: &[f64]| -> Vec<f64> { (0..3).map(|i| x[i] + 0.3 * x[i].powi(3) - b[i]).collect() };
        let exact = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            Ok(DMatrix::from_diagonal(&nalgebra::DVector::from_fn(
                3,
                |i, _| 1.0 + 0.9 * x[i] * x[i],
            )))
        };
        for off in [1.02, 1.05, 1.1, 1.2] {
            let kept = exact(&solution).unwrap() * off;
            let start: Vec<f64> = solution.iter().map(|x| x + 1e-3).collect();
            let evaluations = Cell::new(0);
            let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
                evaluations.set(evaluations.get() + 1);
                Ok(r_of(x))
            };
            let mut jac = Some(WarmJacobian::new(kept.clone()));
            let x = newton(&residual, &exact, start.clone(), &mut jac).unwrap();
            let scale = 1.0 + inf_norm(&x);
            let error = inf_norm(&(0..3).map(|i| x[i] - solution[i]).collect::<Vec<_>>());
            assert!(
                error <= NEWTON_TOL * scale,
                "off by {off}: error {error:e} after {} residuals",
                evaluations.get()
            );
            // The same iteration, stopped when a step is below the tolerance.
            let inverse = kept.clone().lu().try_inverse().unwrap();
            let (mut y, mut waiting) = (start, 1);
            loop {
                let dy = &inverse * nalgebra::DVector::from_vec(r_of(&y));
                y = (0..3).map(|i| y[i] - dy[i]).collect();
                waiting += 1;
                if dy.amax() <= NEWTON_TOL * (1.0 + inf_norm(&y)) {
                    break;
                }
            }
            assert!(
                evaluations.get() < waiting,
                "off by {off}: {} residuals, {waiting} waiting for a tiny step",
                evaluations.get()
            );
        }
    }

    /// A start at which the step equation already holds within the tolerance (implicit
    /// Euler's extrapolated start in free flight) returns after its one residual, even with a
    /// kept Jacobian that is off by half; a start whose defect is ten times the tolerance still
    /// iterates, and ends within the tolerance of the solution.
    #[test]
    fn a_start_that_solves_the_equation_costs_one_residual() {
        let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, -1.0, 0.0, -1.0, 2.0]);
        let b = nalgebra::DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let solution = a.clone().lu().solve(&b).unwrap();
        let exact = |_: &[f64]| -> Result<DMatrix<f64>, DynamicsError> { Ok(a.clone()) };
        for (shift, residuals) in [(0.0, 1), (1e-3 * NEWTON_TOL, 1), (10.0 * NEWTON_TOL, 2)] {
            let evaluations = Cell::new(0);
            let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
                evaluations.set(evaluations.get() + 1);
                let r = &a * nalgebra::DVector::from_column_slice(x) - &b;
                Ok(r.iter().copied().collect())
            };
            let start: Vec<f64> = solution.iter().map(|x| x + shift).collect();
            let mut jac = Some(WarmJacobian::new(&a * 1.5));
            let x = newton(&residual, &exact, start, &mut jac).unwrap();
            let error = inf_norm(&(0..3).map(|i| x[i] - solution[i]).collect::<Vec<_>>());
            assert!(
                error <= NEWTON_TOL * (1.0 + inf_norm(&x)),
                "shift {shift:e}: error {error:e}"
            );
            assert!(
                evaluations.get() >= residuals,
                "shift {shift:e}: {} residuals",
                evaluations.get()
            );
            if residuals == 1 {
                assert_eq!(evaluations.get(), 1, "shift {shift:e}");
            }
        }
    }

    /// A kept Jacobian that contracts slowly enough to need more iterations than a fresh one
    /// costs is replaced after the iteration that shows its rate ([`worth_keeping`]); one that
    /// contracts fast is kept. A linear residual `A x - b` with `A / (1 - θ)` kept contracts
    /// at exactly `θ`: at 0.19 (the xArm7's) it took ten residuals and no Jacobian under the
    /// rule of 0.25 alone; now one fresh Jacobian and four residuals. At 0.01, none.
    #[test]
    fn a_slowly_contracting_kept_jacobian_is_replaced() {
        let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, -1.0, 0.0, -1.0, 2.0]);
        let b = nalgebra::DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let solution = a.clone().lu().solve(&b).unwrap();
        let (evaluations, jacobians) = (Cell::new(0), Cell::new(0));
        let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
            evaluations.set(evaluations.get() + 1);
            let r = &a * nalgebra::DVector::from_column_slice(x) - &b;
            Ok(r.iter().copied().collect())
        };
        let exact = |_: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            jacobians.set(jacobians.get() + 1);
            Ok(a.clone())
        };
        for (theta, fresh, most) in [(0.19, 1, 4), (0.01, 0, 4)] {
            evaluations.set(0);
            jacobians.set(0);
            let mut jac = Some(WarmJacobian::new(a.clone() / (1.0 - theta)));
            let start: Vec<f64> = solution.iter().map(|x| x + 1e-3).collect();
            let x = newton(&residual, &exact, start, &mut jac).unwrap();
            assert!((0..3).all(|i| (x[i] - solution[i]).abs() <= 1e-9));
            assert_eq!(jacobians.get(), fresh, "θ = {theta}: fresh Jacobians");
            assert!(
                evaluations.get() <= most,
                "θ = {theta}: {} residuals, {} Jacobians",
                evaluations.get(),
                jacobians.get()
            );
        }
    }

    /// Convergence is tested on the full step before the residual at its end is evaluated:
    /// a linear residual with its exact Jacobian costs two residuals (the start, and the
    /// solution, whose next step is below the tolerance), not a third at the last step's end.
    /// Started at the solution with that Jacobian kept, one: a kept Jacobian's small step is
    /// not trusted alone, but the defect there is within the tolerance too.
    /// A NaN residual is a failure, not a converged NaN.
    #[test]
    fn no_residual_is_evaluated_at_the_accepted_point() {
        let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, -1.0, 0.0, -1.0, 2.0]);
        let b = nalgebra::DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let evaluations = Cell::new(0);
        let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
            evaluations.set(evaluations.get() + 1);
            let r = &a * nalgebra::DVector::from_column_slice(x) - &b;
            Ok(r.iter().copied().collect())
        };
        let exact = |_: &[f64]| -> Result<DMatrix<f64>, DynamicsError> { Ok(a.clone()) };
        let mut jac = None;
        let x = newton(&residual, &exact, vec![3.0, -1.0, 7.0], &mut jac).unwrap();
        let solution = a.clone().lu().solve(&b).unwrap();
        for i in 0..3 {
            assert!((x[i] - solution[i]).abs() <= 1e-12);
        }
        assert_eq!(evaluations.get(), 2, "the start and the first update's end");
        // From the solution itself, with the Jacobian kept: one.
        evaluations.set(0);
        let again = newton(&residual, &exact, x.clone(), &mut jac).unwrap();
        assert_eq!(evaluations.get(), 1);
        assert!((0..3).all(|i| (again[i] - x[i]).abs() <= 1e-12));
        // A residual that turns NaN: an error, with a fresh Jacobian and with a kept one.
        let nan = |_: &[f64]| -> Result<Vec<f64>, DynamicsError> { Ok(vec![f64::NAN, 0.0, 0.0]) };
        for mut kept in [None, Some(WarmJacobian::new(a.clone()))] {
            assert!(newton(&nan, &exact, vec![1.0, 2.0, 3.0], &mut kept).is_err());
        }
    }

    /// The secant update makes `H y = s`; it is not made where `sᵀ H y` is outside
    /// `[0.1, 10] |s|²` or there is no step.
    #[test]
    fn a_secant_update_maps_the_change_of_residual_to_the_step() {
        let m = DMatrix::from_row_slice(3, 3, &[4.0, 0.0, 1.0, 0.0, 2.0, 0.0, -1.0, 0.0, 3.0]);
        let mut secant = Secant::of(&mut WarmJacobian::new(m.clone()));
        let (s, y) = ([0.3, 0.1, -0.2], [1.0, 0.1, -0.9]);
        secant.update(&s, &y);
        let hy = &secant.inverse * nalgebra::DVector::from_column_slice(&y);
        for i in 0..3 {
            assert!((hy[i] - s[i]).abs() <= 1e-14, "H y = {hy}, s = {s:?}");
        }
        // A change of residual the inverse maps to 50 times the step, one it maps against the
        // step, and no step: the inverse is left as it was.
        let before = Secant::of(&mut WarmJacobian::new(m.clone())).inverse;
        for (s, y) in [
            ([0.01, 0.0, 0.0], [2.0, 0.0, -0.5]),
            ([0.3, 0.0, 0.0], [-1.2, 0.0, 0.3]),
            ([0.0; 3], [1.0, 0.0, 0.0]),
        ] {
            let mut kept = Secant::of(&mut WarmJacobian::new(m.clone()));
            kept.update(&s, &y);
            assert_eq!(kept.inverse, before, "s = {s:?}, y = {y:?}");
        }
    }

    /// A Jacobian kept while two unknowns were uncoupled (identity), where the residual now
    /// couples them, `r = (x0 - 0.3 + 0.5 (x1 - 2), x1 - 2)`: the second unknown's step changes
    /// the first's residual. Newton with the secant updates still ends at the solution. (An
    /// update restricted to the kept Jacobian's islands made the first island's inverse map that
    /// change to almost nothing and stopped with a residual of 0.5.)
    #[test]
    fn secant_updates_end_at_the_solution_when_a_coupling_appears() {
        let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
            Ok(vec![x[0] - 0.3 + 0.5 * (x[1] - 2.0), x[1] - 2.0])
        };
        let exact = |_: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            Ok(DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]))
        };
        let mut jac = Some(WarmJacobian::new(DMatrix::identity(2, 2)));
        let x = newton(&residual, &exact, vec![-0.2 + 1e-6, 3.0], &mut jac).unwrap();
        let r = residual(&x).unwrap();
        assert!(
            inf_norm(&r) <= NEWTON_TOL * (1.0 + inf_norm(&x)),
            "x = {x:?}, r = {r:?}"
        );
    }

    /// A Jacobian kept from an earlier step and off by 20 % (contracting at about 0.17) on
    /// `x + 0.3 x³ = b`, from 0.05 off: with the secant updates, within the tolerance after one
    /// fresh Jacobian and four residuals; with them skipped it took two and five (the second
    /// Jacobian as one iteration contracted by 0.251, just above the 0.25 that asks for one).
    #[test]
    fn secant_updates_let_a_kept_jacobian_converge_in_fewer_residuals() {
        let b = [0.7, -1.3, 2.1];
        let r_of =
            |x: &[f64]| -> Vec<f64> { (0..3).map(|i| x[i] + 0.3 * x[i].powi(3) - b[i]).collect() };
        let slope = |x: f64| 1.0 + 0.9 * x * x;
        let jacobians = Cell::new(0);
        let exact = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            jacobians.set(jacobians.get() + 1);
            Ok(DMatrix::from_diagonal(&nalgebra::DVector::from_fn(
                3,
                |i, _| slope(x[i]),
            )))
        };
        // The solution, by Newton's method to rounding.
        let mut solution = vec![0.0; 3];
        for _ in 0..60 {
            let r = r_of(&solution);
            solution = (0..3)
                .map(|i| solution[i] - r[i] / slope(solution[i]))
                .collect();
        }
        let start: Vec<f64> = solution.iter().map(|x| x + 0.05).collect();
        let kept =
            DMatrix::from_diagonal(&nalgebra::DVector::from_fn(3, |i, _| 1.2 * slope(start[i])));
        let evaluations = Cell::new(0);
        let residual = |x: &[f64]| -> Result<Vec<f64>, DynamicsError> {
            evaluations.set(evaluations.get() + 1);
            Ok(r_of(x))
        };
        let mut jac = Some(WarmJacobian::new(kept));
        let x = newton(&residual, &exact, start, &mut jac).unwrap();
        let scale = 1.0 + inf_norm(&x);
        let error = inf_norm(&(0..3).map(|i| x[i] - solution[i]).collect::<Vec<_>>());
        assert!(error <= NEWTON_TOL * scale, "error {error:e}");
        assert!(
            jacobians.get() <= 1 && evaluations.get() <= 4,
            "{} fresh Jacobians and {} residuals",
            jacobians.get(),
            evaluations.get()
        );
    }
}
