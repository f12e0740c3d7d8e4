//! Exact derivatives of the whole step against central finite differences: Jacobians of forward
//! dynamics and of one step of every integrator with respect to state, inputs and the SCM
//! parameters (embedded and tangent coordinates), Hessians of forward dynamics and of the smooth
//! separation distance, and the C² `smooth` dissipation seen by the second derivatives.

use crate::common::scene;
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};
use scm::contact::{ContactParams, Dissipation};
use scm::derivatives::{
    distance_hessian, forward_hessians, forward_jacobian, jacobian, params_from, params_vec,
    step_jacobian, Coordinates, Point, VectorFunction,
};
use scm::integrate::{Integrator, State};
use scm::model::{DynamicsError, Model};
use scm::scalar::Scalar;

/// Compile-time check of the scalar types the derivative code can use.
#[test]
fn scalar_types() {
    fn is_scalar<T: Scalar>() {}
    use num_dual::*;
    is_scalar::<f64>();
    is_scalar::<Dual64>();
    is_scalar::<DualSVec64<8>>();
    is_scalar::<Dual2_64>();
    is_scalar::<Dual2SVec64<3>>();
    is_scalar::<HyperDual64>();
    is_scalar::<HyperDualSVec64<4, 4>>();
}

fn load(name: &str) -> Model {
    scm::scene::load(&scene(name)).unwrap().model
}

/// Central differences of `f` at `z`, one column per coordinate, with steps relative to the
/// coordinate's size (`rel · max(|z_k|, floor_k)`).
fn fd_jacobian(f: &dyn Fn(&[f64]) -> Vec<f64>, z: &[f64], rel: f64, floor: &[f64]) -> DMatrix<f64> {
    let m = f(z).len();
    let mut out = DMatrix::zeros(m, z.len());
    for k in 0..z.len() {
        let h = rel * z[k].abs().max(floor[k]);
        let (mut a, mut b) = (z.to_vec(), z.to_vec());
        a[k] += h;
        b[k] -= h;
        let (fa, fb) = (f(&a), f(&b));
        for i in 0..m {
            out[(i, k)] = (fa[i] - fb[i]) / (2.0 * h);
        }
    }
    out
}

/// Compares two Jacobians column by column, each column scaled by its input's size `s_k` (so a
/// column is "the output change for a relative change of the input"); entries must agree to
/// `tol` of the largest scaled entry of the column, with a floor of `tol` times the largest
/// scaled entry of the whole matrix (for columns that are almost zero).
fn assert_close(
    what: &str,
    exact: &DMatrix<f64>,
    fd: &DMatrix<f64>,
    scales: &[f64],
    tol: f64,
    names: &[String],
) {
    assert_eq!(exact.shape(), fd.shape(), "{what}");
    let col = |k: usize| fd.column(k).amax() * scales[k];
    let global = (0..fd.ncols()).map(col).fold(0.0, f64::max);
    for k in 0..fd.ncols() {
        for i in 0..fd.nrows() {
            let (e, f) = (exact[(i, k)] * scales[k], fd[(i, k)] * scales[k]);
            assert!(
                (e - f).abs() <= tol * (col(k) + 1e-3 * global),
                "{what}: d out[{i}] / d {}: exact {} vs fd {} (column scale {}, matrix {})",
                names[k],
                exact[(i, k)],
                fd[(i, k)],
                col(k),
                global
            );
        }
    }
}

fn names(model: &Model, point: &Point, coords: Coordinates) -> Vec<String> {
    let nq = if coords == Coordinates::Embedded {
        model.tree.nq
    } else {
        model.tree.nv
    };
    let mut out: Vec<String> = (0..nq).map(|i| format!("q{i}")).collect();
    out.extend((0..model.tree.nv).map(|i| format!("v{i}")));
    out.extend((0..point.u.len()).map(|i| format!("u{i}")));
    out.extend(
        [
            "eps1",
            "eps2",
            "eps3",
            "stiffness",
            "dissipation_velocity",
            "stiction_velocity",
            "friction",
        ]
        .map(String::from),
    );
    out
}

/// `z = [q|δ, v, u, p]` of a point, the evaluation of `(q, v, u, p)` from it, and the floors of
/// the finite-difference steps.
fn unpack(
    model: &Model,
    point: &Point,
    coords: Coordinates,
    z: &[f64],
) -> (Vec<f64>, Vec<f64>, Vec<f64>, ContactParams<f64>) {
    let (nq, nv, nu) = (
        if coords == Coordinates::Embedded {
            model.tree.nq
        } else {
            model.tree.nv
        },
        model.tree.nv,
        point.u.len(),
    );
    let q = match coords {
        Coordinates::Embedded => z[..nq].to_vec(),
        Coordinates::Tangent => model.tree.integrate_q(&point.q, &z[..nq], 1.0),
    };
    (
        q,
        z[nq..nq + nv].to_vec(),
        z[nq + nv..nq + nv + nu].to_vec(),
        params_from(&z[nq + nv + nu..], &point.params),
    )
}

fn z0(model: &Model, point: &Point, coords: Coordinates) -> Vec<f64> {
    let mut z = if coords == Coordinates::Embedded {
        point.q.clone()
    } else {
        vec![0.0; model.tree.nv]
    };
    z.extend_from_slice(&point.v);
    z.extend_from_slice(&point.u);
    z.extend(params_vec(&point.params));
    z
}

/// Floors for the steps: 1e-3 for configurations, velocities and inputs (m, rad, m/s);
/// parameters relative to themselves.
fn floors(z: &[f64], n_state_inputs: usize) -> Vec<f64> {
    z.iter()
        .enumerate()
        .map(|(k, x)| if k < n_state_inputs { 1e-3 } else { x.abs() })
        .collect()
}

/// t_push with the finger pressing 1 mm into the stem, off-centre, everything moving.
fn t_push_point(dissipation: Dissipation) -> (Model, Point) {
    let mut model = load("t_push");
    model.contact.dissipation = dissipation;
    let mut p = Point::start(&model);
    // T: x, y, yaw; finger: x, y. The stem's tip is at y = -0.1375, the finger (r = 1.5 cm)
    // starts at y = -0.25, so it touches at finger_y = 0.0975.
    p.q = vec![0.003, -0.002, 0.05, 0.012, 0.0985];
    p.v = vec![0.02, -0.03, 0.1, -0.05, 0.12];
    p.u = vec![0.02, 0.11];
    model.contact = p.params;
    (model, p)
}

/// mocap_push with the paddle pressing into the box's side while the box, tilted and spinning,
/// sits in the floor.
fn mocap_point() -> (Model, Point) {
    let model = load("mocap_push");
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.02, 0.3));
    p.q = vec![0.001, 0.002, 0.0497, r.w, r.i, r.j, r.k];
    p.v = vec![0.05, -0.02, 0.01, 0.3, -0.2, 0.5];
    let rp = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.2, 0.1));
    p.u = vec![
        -0.0785, 0.004, 0.049, rp.w, rp.i, rp.j, rp.k, 0.1, 0.02, -0.01, 0.0, 0.5, 0.3,
    ];
    (model, p)
}

fn check_forward_jacobian(label: &str, model: &Model, point: &Point, coords: Coordinates) {
    check_forward_jacobian_step(label, model, point, coords, 1e-6);
}

/// [`check_forward_jacobian`] with central differences of relative step `rel` (of the
/// coordinate, or of its floor: 1e-3 for states).
fn check_forward_jacobian_step(
    label: &str,
    model: &Model,
    point: &Point,
    coords: Coordinates,
    rel: f64,
) {
    check_forward_jacobian_values(label, model, point, coords, rel, 1e-12);
}

/// [`check_forward_jacobian_step`] with the dual-number values within `values` of the `f64`
/// ones (relative to the largest acceleration). They differ by rounding only: num-dual divides
/// by multiplying with the reciprocal, `f64` divides, and stiff springs held by a large added
/// inertia cancel most of what they add to the accelerations, which magnifies that rounding.
fn check_forward_jacobian_values(
    label: &str,
    model: &Model,
    point: &Point,
    coords: Coordinates,
    rel: f64,
    values: f64,
) {
    let jac = forward_jacobian(model, point, coords).unwrap();
    let z = z0(model, point, coords);
    let n_state_inputs = z.len() - 7;
    let f = |z: &[f64]| -> Vec<f64> {
        let (q, v, u, p) = unpack(model, point, coords, z);
        model
            .forward(&q, &v, &u, &p)
            .unwrap()
            .vdot
            .iter()
            .copied()
            .collect()
    };
    let fd = fd_jacobian(&f, &z, rel, &floors(&z, n_state_inputs));
    let scales = floors(&z, n_state_inputs);
    let value = DVector::from_vec(f(&z));
    assert!(
        (jac.value.clone() - &value).amax() <= values * value.amax(),
        "{label}: values differ: {} against {}",
        jac.value,
        value
    );
    assert_close(
        &format!("{label} forward Jacobian"),
        &jac.full,
        &fd,
        &scales,
        1e-5,
        &names(model, point, coords),
    );
    // The blocks are the columns of the full Jacobian.
    assert_eq!(
        jac.dv(),
        jac.full.columns(jac.layout.nq, model.tree.nv).into_owned()
    );
}

#[test]
fn forward_jacobians_match_central_differences() {
    for d in [Dissipation::Paper, Dissipation::Smooth] {
        let (model, point) = t_push_point(d);
        // The finger is in contact: the Jacobian sees the contact.
        let f = model
            .forward(&point.q, &point.v, &point.u, &point.params)
            .unwrap();
        let finger = f.contacts[0].as_ref().expect("the finger is in reach");
        assert!(finger.on_a.force.norm() > 1.0, "{:?}", finger.on_a.force);
        check_forward_jacobian(
            &format!("t_push ({})", d.name()),
            &model,
            &point,
            Coordinates::Embedded,
        );
    }
    let (model, point) = mocap_point();
    let f = model
        .forward(&point.q, &point.v, &point.u, &point.params)
        .unwrap();
    assert!(
        f.contacts
            .iter()
            .all(|c| c.as_ref().is_some_and(|c| c.on_a.force.norm() > 0.5)),
        "both contacts active"
    );
    for coords in [Coordinates::Embedded, Coordinates::Tangent] {
        check_forward_jacobian(&format!("mocap_push ({coords:?})"), &model, &point, coords);
    }
    // The box stack at rest, in tangent coordinates (three free bodies, box–box contact).
    let model = load("box_stack");
    let mut point = Point::start(&model);
    point.q[2] -= 0.0008;
    point.q[9] -= 0.0015;
    point.v = (0..18).map(|i| 0.01 * ((i * 7 % 5) as f64 - 2.0)).collect();
    check_forward_jacobian("box_stack (Tangent)", &model, &point, Coordinates::Tangent);
}

#[test]
fn forward_jacobians_with_joint_limits_match_central_differences() {
    // t_push with limits on the T-block's joints: x half-way into the onset (0.5 mm past its
    // upper limit), y 0.5 mm below its lower limit, yaw 10 mrad past its upper limit (beyond
    // the onset, on the linear law), all moving; the finger's joints far inside their ranges.
    use scm::dynamics::limit::JointLimit;
    let (mut model, point) = t_push_point(Dissipation::Smooth);
    let limits = [
        (-0.1, 0.0025),
        (-0.0015, 0.1),
        (-1.0, 0.04),
        (-1.0, 1.0),
        (-1.0, 1.0),
    ];
    for (j, &(lo, hi)) in model.tree.joints.iter_mut().zip(&limits) {
        j.limit = Some(JointLimit::from_solref(lo, hi, [0.02, 1.0], 0.5));
    }
    let tau = model.passive_forces(&point.q, &point.v, point.params.stiction_velocity);
    let mut free = model.clone();
    for j in &mut free.tree.joints {
        j.limit = None;
    }
    let without = free.passive_forces(&point.q, &point.v, point.params.stiction_velocity);
    for k in 0..3 {
        assert!((tau[k] - without[k]).abs() > 1e-3, "limit {k} must act");
    }
    for k in 3..5 {
        assert_eq!(tau[k], without[k], "limit {k} must not act");
    }
    check_forward_jacobian("t_push with limits", &model, &point, Coordinates::Embedded);
}

#[test]
fn damped_euler_step_jacobian_with_stiffened_limits_matches_central_differences() {
    // The T-block's joints past their limits as in the forward test above, with MuJoCo's
    // statics (20 times the reference gains, docs/mjcf.md "Joint limits"): damped Euler takes
    // each limit's damping where it pushes into `M + h D`, so its step depends on the limit
    // through D as well as through the force.
    use scm::dynamics::limit::JointLimit;
    let (mut model, point) = t_push_point(Dissipation::Smooth);
    let limits = [(-0.1, 0.0025), (-0.0015, 0.1), (-1.0, 0.04)];
    for (j, &(lo, hi)) in model.tree.joints.iter_mut().zip(&limits) {
        j.limit = Some(JointLimit::from_solref(lo, hi, [0.02, 1.0], 0.5).stiffened(20.0));
    }
    let slopes: Vec<f64> = model.tree.joints[..3]
        .iter()
        .map(|j| {
            j.limit
                .unwrap()
                .damping_slope(point.q[j.qadr], point.v[j.dadr])
        })
        .collect();
    assert!(
        slopes.iter().all(|&s| s > 0.0),
        "every limit pushes and damps: {slopes:?}"
    );
    for integrator in [Integrator::DampedEuler, Integrator::ImplicitEuler] {
        model.integrator = integrator;
        check_step_jacobian(&model, &point, integrator, 0.002);
    }
}

#[test]
fn jacobians_with_mujocos_impedance_on_the_limits_match_central_differences() {
    // The T-block's joints past their limits as above, acting with MuJoCo's statics and its
    // impedance as an added inertia (docs/mjcf.md, "Joint limits"): the mass matrix then
    // depends on the positions and velocities through each limit's weight, and the forward
    // dynamics solve twice where a limit lets go. Yaw moves back into its range fast enough
    // that its own clamp has let go; x and y push (how much of them holds is checked below).
    use scm::dynamics::limit::{JointLimit, LimitLaw};
    let (mut model, mut point) = t_push_point(Dissipation::Smooth);
    let limits = [(-0.1, 0.0025), (-0.0015, 0.1), (-1.0, 0.04)];
    for (j, &(lo, hi)) in model.tree.joints.iter_mut().zip(&limits) {
        j.limit = Some(
            JointLimit::from_solref(lo, hi, [0.02, 1.0], 0.5)
                .stiffened(20.0)
                .acting(LimitLaw::Impedance),
        );
    }
    let yaw = model.tree.joints[2].dadr;
    point.v[yaw] = -5.0;
    let added: Vec<f64> = model.tree.joints[..3]
        .iter()
        .map(|j| {
            j.limit
                .unwrap()
                .added_inertia(point.q[j.qadr], point.v[j.dadr])
        })
        .collect();
    assert!(added[0] > 0.0 && added[1] > 0.0, "{added:?}");
    assert_eq!(added[2], 0.0, "the yaw limit lets go: {added:?}");
    check_forward_jacobian(
        "t_push with impedance",
        &model,
        &point,
        Coordinates::Embedded,
    );
    // Then with x's limit let go in part, x at rest: the finger's push on the block, along x,
    // pulls x off one of its limits, which lets go where the limit's own push is small (just
    // past it) and holds deep past it; between lies a depth where it holds a share (found by
    // bisection), the band where the share's own derivatives enter.
    let with_x_past = |side: f64, depth: f64| {
        let mut m = model.clone();
        let mut p = point.clone();
        p.v[0] = 0.0;
        let x = p.q[0];
        let (lo, hi) = if side > 0.0 {
            (x - depth - 1.0, x - depth)
        } else {
            (x + depth, x + depth + 1.0)
        };
        m.tree.joints[0].limit = Some(
            JointLimit::from_solref(lo, hi, [0.02, 1.0], 0.5)
                .stiffened(20.0)
                .acting(LimitLaw::Impedance),
        );
        (m, p)
    };
    let x_holds = |side: f64, depth: f64| {
        let (m, p) = with_x_past(side, depth);
        let f = m.forward(&p.q, &p.v, &p.u, &p.params).unwrap();
        f.holds.map_or(1.0, |h| h[0])
    };
    let side = [1.0, -1.0]
        .into_iter()
        .find(|&side| x_holds(side, 1.2e-3) < 1.0)
        .expect("the finger pulls x off one of its limits");
    let (mut shallow, mut deep) = (1.2e-3, 0.5);
    assert_eq!(x_holds(side, deep), 1.0);
    let mut depth = shallow;
    for _ in 0..200 {
        depth = 0.5 * (shallow + deep);
        let g = x_holds(side, depth);
        if (0.2..0.8).contains(&g) {
            break;
        }
        if g < 0.2 {
            shallow = depth;
        } else {
            deep = depth;
        }
    }
    let g = x_holds(side, depth);
    assert!((0.2..0.8).contains(&g), "x holds {g}");
    let (mut banded, share) = with_x_past(side, depth);
    check_forward_jacobian(
        "t_push, x let go in part",
        &banded,
        &share,
        Coordinates::Embedded,
    );
    for integrator in [
        Integrator::Rk4,
        Integrator::DampedRk4,
        Integrator::SemiImplicitEuler,
    ] {
        model.integrator = integrator;
        check_step_jacobian(&model, &point, integrator, 0.002);
        banded.integrator = integrator;
        check_step_jacobian(&banded, &share, integrator, 0.002);
    }
}

#[test]
fn step_jacobians_of_every_integrator_match_central_differences() {
    let (mut model, point) = mocap_point();
    // Damping on the free joint, so that damped_euler's implicit damping is exercised.
    for j in &mut model.tree.joints {
        j.damping = 0.3;
    }
    let h = 0.002;
    for integrator in Integrator::ALL {
        model.integrator = integrator;
        check_step_jacobian(&model, &point, integrator, h);
    }
}

#[test]
fn damped_euler_step_jacobian_with_contact_implicit_matches_central_differences() {
    // The finger pressing the T's stem: a pair in reach, so damped_euler solves its step for
    // the end velocity with the contact implicit, and its Jacobian comes from Newton's
    // iterations on dual numbers. Taken with a stiff friction damper (v_s = 1 mm/s), where the
    // implicit step differs most from the explicit one (by more than the Jacobian's scale).
    check_contact_implicit_step(Integrator::DampedEuler, Integrator::SemiImplicitEuler);
}

#[test]
fn damped_rk4_step_jacobian_with_contact_implicit_matches_central_differences() {
    // The same pressing finger: each of damped RK4's four stages solves damped Euler's velocity
    // with the contact implicit (Newton's iterations on dual numbers), and the step's Jacobian
    // runs through all four. It differs from classic RK4's where the friction is a stiff damper.
    check_contact_implicit_step(Integrator::DampedRk4, Integrator::Rk4);
}

/// One step of `implicit` (contact implicit in velocity) with T-push's finger pressing the stem
/// and a stiff friction damper (v_s = 1 mm/s): it differs from `explicit`'s step by more than
/// 1e-3 in a velocity, and its exact Jacobian matches central differences.
fn check_contact_implicit_step(implicit: Integrator, explicit: Integrator) {
    let (mut model, mut point) = t_push_point(Dissipation::Paper);
    point.params.stiction_velocity = 1e-3;
    model.contact = point.params;
    model.integrator = implicit;
    let state = State::new(point.q.clone(), point.v.clone());
    let h = 0.002;
    let [damped, other] = [implicit, explicit].map(|i| {
        model
            .step_with(i, &state, &point.u, &point.params, h)
            .unwrap()
    });
    let apart = (0..damped.v.len())
        .map(|k| (damped.v[k] - other.v[k]).abs())
        .fold(0.0, f64::max);
    assert!(
        apart > 1e-3,
        "{}: the contact-implicit step must differ: {apart}",
        implicit.name()
    );
    check_step_jacobian(&model, &point, implicit, h);
}

/// The exact Jacobian of one step of `integrator` against central differences, in embedded and
/// tangent coordinates.
fn check_step_jacobian(model: &Model, point: &Point, integrator: Integrator, h: f64) {
    check_step_jacobian_rel(model, point, integrator, h, 1e-6);
}

/// [`check_step_jacobian`] with central differences of relative step `rel` (as
/// [`check_forward_jacobian_step`]'s).
fn check_step_jacobian_rel(model: &Model, point: &Point, integrator: Integrator, h: f64, rel: f64) {
    for coords in [Coordinates::Embedded, Coordinates::Tangent] {
        let (next, jac) = step_jacobian(model, integrator, point, h, coords).unwrap();
        let z = z0(model, point, coords);
        let n_state_inputs = z.len() - 7;
        let f = |z: &[f64]| -> Vec<f64> {
            let (q, v, u, p) = unpack(model, point, coords, z);
            let s = model
                .step_with(integrator, &State::new(q, v), &u, &p, h)
                .unwrap();
            let mut out = match coords {
                Coordinates::Embedded => s.q,
                Coordinates::Tangent => model.tree.difference_q(&next.q, &s.q),
            };
            out.extend(s.v);
            out
        };
        let fd = fd_jacobian(&f, &z, rel, &floors(&z, n_state_inputs));
        let label = format!("{} step ({coords:?})", integrator.name());
        // The implicit steps converge their Newton iterations to 1e-12 (relative), which the
        // differences see as 1e-12/1e-6: 1e-5 leaves room for it.
        assert_close(
            &label,
            &jac.full,
            &fd,
            &floors(&z, n_state_inputs),
            2e-5,
            &names(model, point, coords),
        );
    }
}

/// `∂v̇/∂z` as a function of `z`, for finite differences of the Jacobian.
struct JacobianOfForward<'a> {
    model: &'a Model,
    point: &'a Point,
    coords: Coordinates,
}

impl JacobianOfForward<'_> {
    fn at(&self, z: &[f64]) -> DMatrix<f64> {
        let (q, v, u, p) = unpack(self.model, self.point, self.coords, z);
        // The Jacobian at a shifted point: for tangent coordinates, at the moved configuration
        // in its own chart, which agrees with the chart at the point to first order in δ only;
        // so tangent Hessians are checked through embedded ones below.
        forward_jacobian(
            self.model,
            &Point {
                q,
                v,
                u,
                params: p,
                act: Vec::new(),
            },
            Coordinates::Embedded,
        )
        .unwrap()
        .full
    }
}

#[test]
fn forward_hessians_match_differences_of_the_exact_jacobian() {
    for d in [Dissipation::Paper, Dissipation::Smooth] {
        let (model, point) = t_push_point(d);
        let fh = forward_hessians(&model, &point, Coordinates::Embedded).unwrap();
        let (value, hess, layout) = (fh.value, fh.hessians, fh.layout);
        assert_eq!(value.len(), model.tree.nv);
        assert_eq!(hess.len(), model.tree.nv);
        let z = z0(&model, &point, Coordinates::Embedded);
        let n = layout.len();
        assert_eq!(n, z.len());
        let jf = JacobianOfForward {
            model: &model,
            point: &point,
            coords: Coordinates::Embedded,
        };
        let fl = floors(&z, n - 7);
        // Column k of the Hessian of output i is d/dz_k of row i of the Jacobian.
        let mut fd = vec![DMatrix::zeros(n, n); model.tree.nv];
        for k in 0..n {
            let hk = 1e-5 * z[k].abs().max(fl[k]);
            let (mut a, mut b) = (z.clone(), z.clone());
            a[k] += hk;
            b[k] -= hk;
            let (ja, jb) = (jf.at(&a), jf.at(&b));
            for (i, h) in fd.iter_mut().enumerate() {
                for j in 0..n {
                    h[(j, k)] = (ja[(i, j)] - jb[(i, j)]) / (2.0 * hk);
                }
            }
        }
        let nm = names(&model, &point, Coordinates::Embedded);
        for i in 0..model.tree.nv {
            let sym = (&hess[i] - hess[i].transpose()).amax();
            assert!(
                sym <= 1e-12 * hess[i].amax(),
                "Hessian {i} not symmetric by {sym}"
            );
            // Scale rows and columns by the inputs' sizes: both indices are inputs.
            let scaled = |m: &DMatrix<f64>| DMatrix::from_fn(n, n, |r, c| m[(r, c)] * fl[r]);
            assert_close(
                &format!("t_push ({}) Hessian of v̇[{i}]", d.name()),
                &scaled(&hess[i]),
                &scaled(&fd[i]),
                &fl,
                1e-4,
                &nm,
            );
        }
    }
}

#[test]
fn tangent_hessians_are_embedded_hessians_through_the_exponential_chart() {
    // In tangent coordinates the Hessian is that of f(q ⊕ δ) at δ = 0: check it against central
    // differences of the exact tangent gradient taken in the fixed chart at the point.
    let (model, point) = mocap_point();
    let fh = forward_hessians(&model, &point, Coordinates::Tangent).unwrap();
    let (hess, layout) = (fh.hessians, fh.layout);
    let n = layout.len();
    let z = z0(&model, &point, Coordinates::Tangent);
    // v̇ as a function of z in the fixed chart, and its exact Jacobian there by dual numbers.
    struct Fixed<'a>(&'a Model, &'a Point);
    impl VectorFunction for Fixed<'_> {
        fn eval<T: Scalar>(&self, z: &[T]) -> Result<Vec<T>, DynamicsError> {
            let (m, p) = (self.0, self.1);
            let (nv, nu) = (m.tree.nv, p.u.len());
            let q0: Vec<T> = p.q.iter().map(|&x| T::from(x)).collect();
            let q = m.tree.integrate_q(&q0, &z[..nv], T::one());
            let prm = params_from(&z[2 * nv + nu..], &p.params);
            Ok(
                m.forward(&q, &z[nv..2 * nv], &z[2 * nv..2 * nv + nu], &prm)?
                    .vdot
                    .iter()
                    .copied()
                    .collect(),
            )
        }
    }
    let fixed = Fixed(&model, &point);
    let fl = floors(&z, n - 7);
    let nm = names(&model, &point, Coordinates::Tangent);
    for i in [0, 2, 4] {
        let mut fd = DMatrix::zeros(n, n);
        for k in 0..n {
            let hk = 1e-5 * z[k].abs().max(fl[k]);
            let (mut a, mut b) = (z.clone(), z.clone());
            a[k] += hk;
            b[k] -= hk;
            let (ja, jb) = (
                jacobian(&fixed, &a).unwrap().1,
                jacobian(&fixed, &b).unwrap().1,
            );
            for j in 0..n {
                fd[(j, k)] = (ja[(i, j)] - jb[(i, j)]) / (2.0 * hk);
            }
        }
        let scaled = |m: &DMatrix<f64>| DMatrix::from_fn(n, n, |r, c| m[(r, c)] * fl[r]);
        assert_close(
            &format!("mocap_push tangent Hessian of v̇[{i}]"),
            &scaled(&hess[i]),
            &scaled(&fd),
            &fl,
            1e-4,
            &nm,
        );
    }
}

#[test]
fn distance_hessians_match_differences_of_the_exact_gradient() {
    for (name, pair, coords) in [
        ("box_stack", 3, Coordinates::Tangent),
        ("sphere_pair", 0, Coordinates::Embedded),
        ("mocap_push", 1, Coordinates::Tangent),
    ] {
        let model = load(name);
        let mut point = Point::start(&model);
        if name == "box_stack" {
            point.q[2] -= 0.0008; // bottom box into the floor, tilted
            point.q[9] -= 0.001;
            let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.02, -0.01, 0.05));
            point.q[10..14].copy_from_slice(&[r.w, r.i, r.j, r.k]);
        }
        if name == "mocap_push" {
            point = mocap_point().1;
        }
        let (d, g, hess) = distance_hessian(&model, pair, &point, coords).unwrap();
        let nq = if coords == Coordinates::Embedded {
            model.tree.nq
        } else {
            model.tree.nv
        };
        assert_eq!((g.len(), hess.shape()), (nq + 2, (nq + 2, nq + 2)));
        // D as a function of x = [q|δ, ε1, ε2] with everything else at the point.
        let dist = |x: &[f64]| -> f64 {
            let mut z = z0(&model, &point, coords);
            z[..nq].copy_from_slice(&x[..nq]);
            let rp = z.len() - 7;
            z[rp] = x[nq];
            z[rp + 1] = x[nq + 1];
            let (q, v, u, p) = unpack(&model, &point, coords, &z);
            let (_, mocap) = model.split_inputs(&u).unwrap();
            let kin = model.tree.kinematics_with(&q, &v, mocap);
            let pr = &model.pairs[pair];
            let (a, b) = (
                model.colliders[pr.a].as_ref().unwrap(),
                model.colliders[pr.b].as_ref().unwrap(),
            );
            scm::collision::SeparationDistribution::new(
                &scm::collision::separation_field(
                    a,
                    &kin.frames[pr.a],
                    b,
                    &kin.frames[pr.b],
                    pr.eps1_sides(p.eps1),
                ),
                p.eps2,
            )
            .distance
        };
        let mut x: Vec<f64> = z0(&model, &point, coords)[..nq].to_vec();
        x.extend([point.params.eps1, point.params.eps2]);
        assert!(
            (dist(&x) - d).abs() <= 1e-15 * d.abs().max(1e-3),
            "{name}: D {d} vs {}",
            dist(&x)
        );
        assert!(d < 0.0, "{name}: the pair is in contact (D = {d})");
        let fl: Vec<f64> = (0..nq + 2)
            .map(|k| if k < nq { 1e-3 } else { x[k].abs() })
            .collect();
        let nm: Vec<String> = (0..nq)
            .map(|i| format!("q{i}"))
            .chain(["eps1".into(), "eps2".into()])
            .collect();
        let fd_g = fd_jacobian(&|x: &[f64]| vec![dist(x)], &x, 1e-6, &fl);
        assert_close(
            &format!("{name} distance gradient"),
            &DMatrix::from_row_slice(1, nq + 2, g.as_slice()),
            &fd_g,
            &fl,
            1e-5,
            &nm,
        );
        // Hessian: differences of the exact gradient.
        let grad_at = |x: &[f64]| -> DVector<f64> {
            let mut z = z0(&model, &point, coords);
            z[..nq].copy_from_slice(&x[..nq]);
            let (q, v, u, mut p) = unpack(&model, &point, coords, &z);
            p.eps1 = x[nq];
            p.eps2 = x[nq + 1];
            distance_hessian(
                &model,
                pair,
                &Point {
                    q,
                    v,
                    u,
                    params: p,
                    act: Vec::new(),
                },
                Coordinates::Embedded,
            )
            .unwrap()
            .1
        };
        if coords == Coordinates::Embedded {
            let mut fd = DMatrix::zeros(nq + 2, nq + 2);
            for k in 0..nq + 2 {
                let hk = 1e-5 * x[k].abs().max(fl[k]);
                let (mut a, mut b) = (x.clone(), x.clone());
                a[k] += hk;
                b[k] -= hk;
                let diff = (grad_at(&a) - grad_at(&b)) / (2.0 * hk);
                fd.set_column(k, &diff);
            }
            let scaled =
                |m: &DMatrix<f64>| DMatrix::from_fn(nq + 2, nq + 2, |r, c| m[(r, c)] * fl[r]);
            assert_close(
                &format!("{name} distance Hessian"),
                &scaled(&hess),
                &scaled(&fd),
                &fl,
                1e-4,
                &nm,
            );
        } else {
            // Tangent: second differences of D itself in the fixed chart.
            let mut fd = DMatrix::zeros(nq + 2, nq + 2);
            for k in 0..nq + 2 {
                for j in 0..nq + 2 {
                    let (hk, hj) = (1e-4 * x[k].abs().max(fl[k]), 1e-4 * x[j].abs().max(fl[j]));
                    let at = |sk: f64, sj: f64| {
                        let mut y = x.clone();
                        y[k] += sk * hk;
                        y[j] += sj * hj;
                        dist(&y)
                    };
                    fd[(k, j)] = (at(1.0, 1.0) - at(1.0, -1.0) - at(-1.0, 1.0) + at(-1.0, -1.0))
                        / (4.0 * hk * hj);
                }
            }
            let scaled =
                |m: &DMatrix<f64>| DMatrix::from_fn(nq + 2, nq + 2, |r, c| m[(r, c)] * fl[r]);
            assert_close(
                &format!("{name} tangent distance Hessian"),
                &scaled(&hess),
                &scaled(&fd),
                &fl,
                1e-3,
                &nm,
            );
        }
    }
}

#[test]
fn smooth_dissipation_gives_continuous_second_derivatives() {
    // A 1 kg sphere (sampled at 1 cm, a point at its pole) on a vertical slide pressed 1 mm
    // into the floor; its normal velocity crosses
    // 0 (s = v_n / v_d = 0), where the paper's d(s) has a jump in d'' and the smooth one not.
    let text = r#"<mujoco model="slide"><custom><numeric name="scm_stiffness" data="1e4"/><numeric name="scm_spacing" data="0.01"/>DISSIPATION</custom>
  <worldbody><geom type="plane" size="1 1 0.1"/>
    <body name="b" pos="0 0 0.049"><joint name="z" type="slide" axis="0 0 1"/><geom type="sphere" size="0.05" mass="1"/></body>
  </worldbody></mujoco>"#;
    let mut jumps = Vec::new();
    for d in [Dissipation::Paper, Dissipation::Smooth] {
        // Selected by the scene's scm_dissipation (the paper's is the default).
        let setting = if d == Dissipation::Smooth {
            r#"<text name="scm_dissipation" data="smooth"/>"#
        } else {
            ""
        };
        let model = crate::dynamics_tree::model_of(&text.replace("DISSIPATION", setting));
        assert_eq!(model.contact.dissipation, d);
        let at = |v: f64| {
            let p = Point {
                q: vec![0.0],
                v: vec![v],
                u: vec![],
                act: vec![],
                params: model.contact,
            };
            forward_hessians(&model, &p, Coordinates::Embedded)
                .unwrap()
                .hessians[0][(1, 1)]
        };
        let (below, above) = (at(-1e-9), at(1e-9));
        jumps.push((below - above).abs());
    }
    // The paper's d'' jumps from 0 to 1/2 at s = 0, so ∂²v̇/∂v² jumps by c / (2 m v_d²), with
    // c = k s⁺(1 mm) ≈ 10 N: about 500 (m s⁻¹)⁻¹. The smooth one's d'' = 3s/2 - 3s²/4 is
    // 1.5e-8 at s = 1e-8.
    println!(
        "jump of ∂²v̇/∂v² across v = 0: paper {}, smooth {}",
        jumps[0], jumps[1]
    );
    assert!(jumps[0] > 100.0, "the paper's d(s) should show its C¹ kink");
    assert!(jumps[1] < 1e-6 * jumps[0], "the smooth d(s) must be C²");
}

#[test]
fn forward_jacobians_with_gravity_compensation_match_central_differences() {
    // An arm whose links carry partial gravity compensation (a force at each centre of mass,
    // whose torque depends on the configuration), and a compensated free body, all moving.
    let xml = r#"<mujoco>
  <worldbody>
    <body name="upper" pos="0 0 1" gravcomp="0.8">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
      <body name="lower" pos="0.3 0 0.1" gravcomp="0.5">
        <joint name="elbow" type="ball"/>
        <geom type="box" size="0.1 0.02 0.03" pos="0.12 0.02 0"/>
      </body>
    </body>
    <body name="balloon" pos="3 0 1" gravcomp="1.2">
      <freejoint/>
      <geom type="box" size="0.2 0.15 0.1" pos="0.005 0.003 0"/>
    </body>
  </worldbody>
</mujoco>"#;
    // The free body's angular acceleration does not depend on its orientation (every force
    // acts at its centre of mass), but the compensation's torque about the body origin and
    // gravity's cancel in rounding: a large body with a small offset keeps that noise small,
    // and steps of 1e-4 (1e-7 rad in tangent coordinates) keep central differences from
    // amplifying it (accelerations here reach 65 rad/s², so a 1e-9 step sees 1e-5 of noise).
    let model = scm::scene::load_str(xml, std::path::Path::new("gravcomp.xml"))
        .unwrap()
        .model;
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.4));
    let rb = UnitQuaternion::from_scaled_axis(Vector3::new(-0.5, 0.1, 0.7));
    p.q = vec![
        0.4, r.w, r.i, r.j, r.k, 3.0, 0.1, 1.2, rb.w, rb.i, rb.j, rb.k,
    ];
    p.v = vec![0.3, -0.5, 0.2, 0.7, 0.1, 0.15, -0.2, 0.4, 0.9, -0.3];
    // The compensation acts: the forward dynamics differ from those without it.
    let mut plain = model.clone();
    for b in &mut plain.tree.bodies {
        b.gravcomp = 0.0;
    }
    let with = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    let without = plain.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    assert!((with - without).amax() > 1.0);
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        check_forward_jacobian_step(&format!("plain {coords:?}"), &plain, &p, coords, 1e-4);
        check_forward_jacobian_step(&format!("gravcomp {coords:?}"), &model, &p, coords, 1e-4);
    }
}

#[test]
fn forward_jacobians_with_welds_and_connects_match_central_differences() {
    // A free box welded to a hinged arm (body semantics, held pose from qpos0), a second free
    // body welded to the world by relpose and torquescale 0.5, a weld and a connect between
    // sites: all away from their held poses and moving, so that every spring, damper and
    // rotational term acts.
    let xml = r#"<mujoco>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
      <site name="tip" pos="0.3 0 0.1" euler="10 20 0"/>
    </body>
    <body name="box" pos="0.35 0 1.1" euler="0 0 20">
      <freejoint/>
      <geom type="box" size="0.06 0.04 0.03" pos="0.02 0 0"/>
      <site name="corner" pos="0.06 0.04 0" euler="0 30 0"/>
    </body>
    <body name="puck" pos="1 0 1">
      <freejoint/>
      <geom type="box" size="0.05 0.03 0.02" pos="0 0.01 0"/>
    </body>
  </worldbody>
  <equality>
    <weld body1="arm" body2="box" solref="0.05 0.5"/>
    <weld body1="puck" relpose="1 0 1.1 1 0.2 0 0" torquescale="0.5" solref="0.1 0.3"/>
    <weld site1="tip" site2="corner" solref="0.2 0.4"/>
    <connect site1="corner" site2="tip" solref="0.1 0.8"/>
  </equality>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("welds.xml"))
        .unwrap()
        .model;
    assert_eq!(model.connects.len(), 4);
    assert_eq!(
        model
            .connects
            .iter()
            .filter(|c| c.orientation.is_some())
            .count(),
        3
    );
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.6));
    let rb = UnitQuaternion::from_scaled_axis(Vector3::new(-0.5, 0.1, 0.7));
    p.q = vec![
        0.4, 0.4, 0.05, 1.0, r.w, r.i, r.j, r.k, 1.1, -0.1, 0.9, rb.w, rb.i, rb.j, rb.k,
    ];
    p.v = vec![
        1.3, 0.4, -0.7, 0.5, 2.1, -1.6, 0.9, -0.3, 0.2, 0.6, 0.8, -1.2, 0.4,
    ];
    let mut free = model.clone();
    free.connects.clear();
    let with = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    let without = free.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    assert!((with - without).amax() > 1.0, "the welds act");
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        // Under the file's Euler the welds have MuJoCo's statics and its impedance as an added
        // inertia (check_forward_jacobian_values on why the values then round apart); the box
        // held by three of them is stiff enough that differences need steps of 1e-3 (of the
        // coordinate or its floor): at 3e-4 their rounding is 3e-5 of the entries.
        let label = format!("welds {coords:?}");
        check_forward_jacobian_values(&label, &model, &p, coords, 1e-3, 1e-11);
    }
}

#[test]
fn forward_jacobians_with_wrapping_tendons_match_central_differences() {
    // The wrapping fixture (a rope over a fixed sphere, a belt round a cylinder on a sprung
    // carriage, a sling round a sphere held by a side site inside it) moved and moving, every
    // tendon wrapped: the tangent points follow the sites and the geoms, and the tendons pull
    // the geoms' bodies at them.
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/tendon_wrap.xml");
    let model = scm::scene::load(&path).unwrap().model;
    let mut p = Point::start(&model);
    p.q = vec![0.35, 0.025, -0.02, 0.04, -0.05];
    p.v = vec![-1.2, 0.3, -0.4, 0.6, -0.5];
    let kin = model.tree.kinematics(&p.q, &p.v);
    for t in &model.spatial_tendons {
        let (l, _) = t.length_and_rate(&kin.frames);
        let mut straight = t.clone();
        straight.segments.iter_mut().for_each(|s| s.wrap = None);
        let (ls, _) = straight.length_and_rate(&kin.frames);
        assert!(
            l > ls + 1e-3,
            "tendon {} wraps: {l} vs {ls} straight",
            t.name
        );
    }
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        check_forward_jacobian_step(&format!("wraps {coords:?}"), &model, &p, coords, 1e-5);
    }
}

#[test]
fn forward_jacobians_with_fluid_forces_match_central_differences() {
    // MuJoCo's inertia-box fluid model (viscous and quadratic drag) on a hinged arm and a free
    // body whose inertia comes from two geoms (principal axes from the eigenvectors), moving in
    // every direction so that every |v|v term is away from zero.
    let xml = r#"<mujoco>
  <option density="1000" viscosity="0.5"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
    </body>
    <body name="fish" pos="3 0 1">
      <freejoint/>
      <geom type="box" size="0.2 0.05 0.03"/>
      <geom type="sphere" size="0.06" pos="0.2 0.03 0.01"/>
    </body>
  </worldbody>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("fluid.xml"))
        .unwrap()
        .model;
    assert_eq!(model.fluid.as_ref().unwrap().bodies.len(), 2);
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.6));
    p.q = vec![0.4, 3.0, 0.1, 1.2, r.w, r.i, r.j, r.k];
    p.v = vec![1.3, 0.4, -0.7, 0.5, 2.1, -1.6, 0.9];
    let mut still = model.clone();
    still.fluid = None;
    let with = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    let without = still.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    assert!((with - without).amax() > 1.0, "the fluid acts");
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        check_forward_jacobian_step(&format!("fluid {coords:?}"), &model, &p, coords, 1e-4);
    }
}

#[test]
fn forward_jacobians_with_the_ellipsoid_fluid_model_match_central_differences() {
    // MuJoCo's ellipsoid model (added mass, Magnus and Kutta lift, drag) on the same two bodies,
    // every geom an ellipsoid of its type, moving in every direction.
    let xml = r#"<mujoco>
  <option density="1000" viscosity="0.5"/>
  <default><geom fluidshape="ellipsoid" fluidcoef="0.5 0.25 1.5 2 1"/></default>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
    </body>
    <body name="fish" pos="3 0 1">
      <freejoint/>
      <geom type="box" size="0.2 0.05 0.03"/>
      <geom type="ellipsoid" size="0.06 0.03 0.02" pos="0.2 0.03 0.01"/>
    </body>
  </worldbody>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("fluid.xml"))
        .unwrap()
        .model;
    let fluid = model.fluid.as_ref().unwrap();
    assert_eq!((fluid.bodies.len(), fluid.ellipsoids.len()), (0, 3));
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.6));
    p.q = vec![0.4, 3.0, 0.1, 1.2, r.w, r.i, r.j, r.k];
    p.v = vec![1.3, 0.4, -0.7, 0.5, 2.1, -1.6, 0.9];
    let mut still = model.clone();
    still.fluid = None;
    let with = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    let without = still.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    assert!((with - without).amax() > 1.0, "the fluid acts");
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        check_forward_jacobian_step(
            &format!("ellipsoid fluid {coords:?}"),
            &model,
            &p,
            coords,
            1e-4,
        );
    }
}

#[test]
fn forward_jacobians_with_general_actuators_match_central_differences() {
    // An affine gain and bias on a geared hinge (the force depends on the control, the
    // position and the velocity together), a servo written as a <general>, and a motor whose
    // force range clamps (its derivatives beyond the range are zero, exactly and in the
    // differences).
    let xml = r#"<mujoco>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" contype="0" conaffinity="0"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025" contype="0" conaffinity="0"/>
        <body name="tip" pos="0.25 0 0">
          <joint name="reach" type="slide" axis="1 0 0"/>
          <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general joint="shoulder" gainprm="50" biastype="affine" biasprm="0 -50 -5" forcerange="-30 30"/>
    <general joint="elbow" gear="1.5" gaintype="affine" gainprm="2 0.5 0.1" biastype="affine" biasprm="0.1 -1 -0.2"/>
    <motor joint="reach" forcerange="-0.5 0.5"/>
  </actuator>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("general.xml"))
        .unwrap()
        .model;
    let mut p = Point::start(&model);
    p.q = vec![0.3, -0.4, 0.01];
    p.v = vec![0.5, -0.7, 0.2];
    p.u = vec![0.2, -0.6, 2.0];
    // Every actuator acts, and the motor's force is clamped.
    let tau = model.actuator_forces(&p.q, &p.v, &p.u);
    assert!(tau.iter().all(|t| t.abs() > 1e-3), "{tau}");
    assert_eq!(tau[2], 0.5);
    check_forward_jacobian("general actuators", &model, &p, Coordinates::Embedded);
}

#[test]
fn forward_jacobians_with_joint_actuator_force_ranges_match_central_differences() {
    // Two actuators on one hinge (one through a tendon) whose sum a joint `actuatorfrcrange`
    // clamps, and a geared motor on a slider within its joint's range: the clamped total's
    // derivatives are zero, exactly and in the differences; the other passes through.
    let xml = r#"<mujoco>
  <compiler autolimits="true"/>
  <worldbody>
    <body name="cart" pos="0 0 1">
      <joint name="s" type="slide" axis="1 0 0" actuatorfrcrange="-2 2"/>
      <geom type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0"/>
      <body name="arm">
        <joint name="h" axis="0 1 0" actuatorfrcrange="-0.05 0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="h" coef="2"/></fixed></tendon>
  <actuator>
    <motor joint="s" gear="3"/>
    <position joint="h" kp="4"/>
    <motor tendon="t"/>
  </actuator>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("frcrange.xml"))
        .unwrap()
        .model;
    let mut p = Point::start(&model);
    p.q = vec![0.02, 0.3];
    p.v = vec![0.1, -0.2];
    p.u = vec![0.4, 0.5, 0.3];
    let tau = model.actuator_forces(&p.q, &p.v, &p.u);
    assert!((tau[0] - 1.2).abs() < 1e-15, "{tau}");
    assert_eq!(tau[1], 0.1, "the hinge's total (0.8 + 0.6) is clamped");
    check_forward_jacobian(
        "joint actuator force ranges",
        &model,
        &p,
        Coordinates::Embedded,
    );
}

#[test]
fn forward_jacobians_with_adhesion_match_central_differences() {
    // An adhesive box (departure 7: 1 N within 2 mm, with a 1 mm margin) hanging tilted from a
    // ceiling, one edge pressed 0.3 mm past the margin and the other 4 mm out: points pressed,
    // pulling in the gap and past it all count, sliding and turning.
    let xml = r#"<mujoco>
  <worldbody>
    <geom name="ceiling" type="plane" size="1 1 0.1" pos="0 0 0.3" zaxis="0 0 -1"/>
    <body name="box" pos="0 0 0.25">
      <freejoint/>
      <geom type="box" size="0.05 0.04 0.05" mass="0.1" adhesion="1" gap="0.002" margin="0.001"/>
    </body>
  </worldbody>
</mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("adhesion.xml"))
        .unwrap()
        .model;
    assert_eq!((model.pairs[0].adhesion, model.pairs[0].gap), (1.0, 0.002));
    let mut p = Point::start(&model);
    // Tilted 0.043 rad about y: the top face's edges 0.05 m from the axis rise and sink by
    // 2.15 mm, from 0.3 mm past the margin's rest to 4 mm away.
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.043, 0.0));
    p.q = vec![0.0, 0.0, 0.3 - 0.05 - 0.001 - 0.0018, r.w, r.i, r.j, r.k];
    p.v = vec![0.02, -0.01, 0.005, 0.1, -0.2, 0.05];
    let f = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap();
    let pc = f.contacts[0].as_ref().expect("in reach");
    assert!(pc.on_a.force.norm() > 0.1, "{:?}", pc.on_a.force);
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        check_forward_jacobian_step(&format!("adhesion {coords:?}"), &model, &p, coords, 1e-6);
    }
}

/// The coupled fixture (tests/fixtures/coupled.xml, RK4: every constraint with MuJoCo's
/// impedance as inertia added along its rows) moved past both tendons' upper limits, away from
/// its equalities' held values, and moving deeper past the limits.
fn coupled_point() -> (Model, Point) {
    let model = crate::coupled_constraints::coupled();
    let mut p = Point::start(&model);
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.05, -0.03, 0.08));
    p.q = vec![
        0.4, -0.2, 0.01, 0.1, 0.2, 2.01, -0.01, 1.02, r.w, r.i, r.j, r.k,
    ];
    p.v = vec![0.3, -0.1, 0.2, -0.4, 0.5, 0.1, -0.2, 0.3, 0.4, -0.6, 0.2];
    p.u = vec![0.7];
    (model, p)
}

#[test]
fn jacobians_with_mujocos_impedance_on_coupled_constraints_match_central_differences() {
    // Every row acts: both tendons push with an added inertia, and the equalities (a joint
    // equality across branches, a connect's three rows and a weld's six) carry theirs.
    let (model, p) = coupled_point();
    let kin = model.tree.kinematics(&p.q, &p.v);
    let fixed = model.tendons[0].limit.unwrap();
    let (l, ldot) = (
        model.tendons[0].length(&p.q),
        model.tendons[0].velocity(&p.v),
    );
    assert!(
        l > fixed.hi + 1e-3 && fixed.added_inertia(l, ldot) > 0.0,
        "{l} {ldot}"
    );
    let spatial = model.spatial_tendons[0].law.limit.unwrap();
    let (l, ldot) = model.spatial_tendons[0].length_and_rate(&kin.frames);
    assert!(
        l > spatial.hi + 1e-3 && spatial.added_inertia(l, ldot) > 0.0,
        "{l} {ldot}"
    );
    assert!(model.equalities[0].impedance > 0.0);
    assert!(model.connects.iter().all(|c| c.impedance > 0.0));
    // The added inertia changes the accelerations (against the same gains without it).
    let mut light = model.clone();
    light.equalities[0].impedance = 0.0;
    light.connects.iter_mut().for_each(|c| c.impedance = 0.0);
    let with = model.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    let without = light.forward(&p.q, &p.v, &p.u, &p.params).unwrap().vdot;
    assert!((with - without).amax() > 1.0, "the rows' inertia acts");
    for coords in [Coordinates::Tangent, Coordinates::Embedded] {
        // The weld's free body: accelerations of 600 m/s² from springs 20 times MuJoCo's
        // reference, of which the added inertia cancels most, and the weld's error a difference
        // of positions 2 m from the origin: the values carry rounding of about 1e-12 of
        // themselves, so the differences take steps of 1e-4 (of the coordinate or its floor).
        let label = format!("coupled {coords:?}");
        check_forward_jacobian_values(&label, &model, &p, coords, 1e-4, 1e-11);
    }
    let mut model = model;
    for integrator in [
        Integrator::Rk4,
        Integrator::DampedRk4,
        Integrator::DampedEuler,
        Integrator::SemiImplicitEuler,
        Integrator::ImplicitEuler,
    ] {
        model.integrator = integrator;
        check_step_jacobian_rel(&model, &p, integrator, 0.002, 1e-4);
    }
}

#[test]
fn jacobians_where_a_tendon_limit_lets_go_in_part_match_central_differences() {
    // The fixed tendon at rest a depth past its upper limit, the motor pulling it back into
    // its range: just past the limit its push is small and the pull takes it off (the limit
    // lets go), deep past it the limit holds; between lies a depth where it holds a share
    // (found by bisection), the band where the share's own derivatives enter.
    // Without the weld, whose stiff rows on the free body round at 1e-12 of its accelerations
    // (differences through the band need smaller steps than those allow).
    let (mut model, mut p) = coupled_point();
    model.connects.retain(|c| c.orientation.is_none());
    p.v = vec![0.0; model.tree.nv];
    p.u = vec![-3.0];
    let l = model.tendons[0].length(&p.q);
    let slot = model.tree.joints.len();
    let past = |depth: f64| {
        let mut m = model.clone();
        let limit = m.tendons[0].limit.as_mut().unwrap();
        limit.hi = l - depth;
        m
    };
    let holds = |depth: f64| {
        let m = past(depth);
        let f = m.forward(&p.q, &p.v, &p.u, &p.params).unwrap();
        f.holds.map_or(1.0, |h| h[slot])
    };
    let (mut shallow, mut deep) = (1.2e-3, 0.5);
    assert!(holds(shallow) < 1e-9, "{}", holds(shallow));
    assert_eq!(holds(deep), 1.0);
    let mut depth = shallow;
    for _ in 0..200 {
        depth = 0.5 * (shallow + deep);
        let g = holds(depth);
        if (0.2..0.8).contains(&g) {
            break;
        }
        if g < 0.2 {
            shallow = depth;
        } else {
            deep = depth;
        }
    }
    let g = holds(depth);
    assert!((0.2..0.8).contains(&g), "the tendon's limit holds {g}");
    let mut banded = past(depth);
    // On the band the accelerations curve sharply (the share goes from 0 to 1 over 1 % of the
    // onset's force): the differences converge to the exact Jacobian as h², but only at steps
    // near 1e-7 rad of the arms' angles, where the velocities' columns already see their
    // rounding (measured: d v̇₀/d q₀ exact -2362.7688, differences -2358.44 at a step of
    // 1e-5 rad, -2362.7266 at 1e-6, -2362.7683 at 1e-7).
    let coords = Coordinates::Embedded;
    let jac = forward_jacobian(&banded, &p, coords).unwrap();
    let f = |z: &[f64]| -> Vec<f64> {
        let (q, v, u, prm) = unpack(&banded, &p, coords, z);
        let a = banded.forward(&q, &v, &u, &prm).unwrap().vdot;
        a.iter().copied().collect()
    };
    let label = "coupled, the tendon let go in part";
    assert_differences_converge(label, &banded, &p, coords, &jac.full, &f);
    // The shares of the step's start are taken in f64 and on dual numbers alike.
    for integrator in [Integrator::DampedRk4, Integrator::DampedEuler] {
        banded.integrator = integrator;
        let (_, jac) = step_jacobian(&banded, integrator, &p, 0.002, coords).unwrap();
        let f = |z: &[f64]| -> Vec<f64> {
            let (q, v, u, prm) = unpack(&banded, &p, coords, z);
            let s = (banded.step_with(integrator, &State::new(q, v), &u, &prm, 0.002)).unwrap();
            s.q.into_iter().chain(s.v).collect()
        };
        let label = format!("{label}, {} step", integrator.name());
        assert_differences_converge(&label, &banded, &p, coords, &jac.full, &f);
    }
}

/// Asserts that the central differences of `f` at the point converge to `exact`: each entry
/// is compared with the nearest of the differences at steps from 1e-4 to 1e-8 of its
/// coordinate (or its floor), as [`assert_close`] compares. For functions that curve sharply
/// where a single step is either too long for their curvature or too short for their rounding.
fn assert_differences_converge(
    label: &str,
    model: &Model,
    point: &Point,
    coords: Coordinates,
    exact: &DMatrix<f64>,
    f: &dyn Fn(&[f64]) -> Vec<f64>,
) {
    let z = z0(model, point, coords);
    let scales = floors(&z, z.len() - 7);
    let steps = [1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8];
    let fds: Vec<DMatrix<f64>> = (steps.iter())
        .map(|&rel| fd_jacobian(f, &z, rel, &scales))
        .collect();
    let nearest = DMatrix::from_fn(exact.nrows(), exact.ncols(), |i, k| {
        let e = exact[(i, k)];
        (fds.iter().map(|fd| fd[(i, k)]))
            .min_by(|a, b| (a - e).abs().total_cmp(&(b - e).abs()))
            .unwrap()
    });
    let names = names(model, point, coords);
    assert_close(label, exact, &nearest, &scales, 1e-5, &names);
}
