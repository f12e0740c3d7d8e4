//! Rigid-body dynamics on kinematic trees: the mass matrix and bias forces against a
//! hand-derived double pendulum, `ID(FD(τ)) = τ` and `M ≻ 0` on random states of every scene,
//! `½ vᵀ M v` against the bodies' kinetic energy, energy conservation by RK4 shrinking as h⁴,
//! momentum conservation through contact, and the loader's joint and body properties.

use crate::common::{scene, Lcg};
use nalgebra::{DVector, UnitQuaternion, Vector3};
use scm::contact::Wrench;
use scm::dynamics::{JointKind, MOCAP_INPUTS};
use scm::integrate::{AdvanceOptions, Integrator, State};
use scm::model::{EvalPoint, Model};
use scm::scene::load_str;
use std::path::Path;

pub fn model_of(text: &str) -> Model {
    load_str(text, Path::new("inline.xml"))
        .unwrap_or_else(|e| panic!("{e}"))
        .model
}

/// Every bundled scene.
pub fn bundled() -> Vec<(String, Model)> {
    let mut out = Vec::new();
    for name in [
        "sphere_drop",
        "sphere_pair",
        "t_push",
        "box_stack",
        "arm_push",
        "mocap_push",
        "adhesion_pick",
    ] {
        let path = scene(name);
        if path.exists() {
            out.push((name.to_string(), scm::scene::load(&path).unwrap().model));
        }
    }
    assert!(out.len() >= 5);
    out
}

/// A random configuration near the start (so that contacts may be active), random velocities,
/// random mocap poses near their start with random velocities.
pub fn random_point(model: &Model, rng: &mut Lcg, spread: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut q = model.tree.q0();
    for j in &model.tree.joints {
        let rot = |q: &mut [f64], rng: &mut Lcg| {
            let r = UnitQuaternion::new(rng.direction() * rng.range(0.0, 0.5))
                * UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    q[0], q[1], q[2], q[3],
                ));
            q.copy_from_slice(&[r.w, r.i, r.j, r.k]);
        };
        match j.kind {
            JointKind::Free => {
                for k in 0..3 {
                    q[j.qadr + k] += rng.range(-spread, spread);
                }
                rot(&mut q[j.qadr + 3..j.qadr + 7], rng);
            }
            JointKind::Ball => rot(&mut q[j.qadr..j.qadr + 4], rng),
            JointKind::Slide => q[j.qadr] += rng.range(-spread, spread),
            JointKind::Hinge => q[j.qadr] += rng.range(-0.5, 0.5),
        }
    }
    let v = (0..model.tree.nv).map(|_| rng.range(-0.5, 0.5)).collect();
    let mut u: Vec<f64> = model
        .actuators
        .iter()
        .map(|_| rng.range(-1.0, 1.0))
        .collect();
    let mocap = model.tree.mocap0();
    for m in mocap.chunks(MOCAP_INPUTS) {
        let r = UnitQuaternion::new(rng.direction() * 0.3)
            * UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(m[3], m[4], m[5], m[6]));
        u.extend_from_slice(&[
            m[0] + rng.range(-spread, spread),
            m[1] + rng.range(-spread, spread),
            m[2] + rng.range(-spread, spread),
            r.w,
            r.i,
            r.j,
            r.k,
        ]);
        u.extend((0..6).map(|_| rng.range(-0.3, 0.3)));
    }
    (q, v, u)
}

/// The double pendulum of the test below: two links swinging about y, hanging along -z.
const DOUBLE_PENDULUM: &str = r#"<mujoco model="double_pendulum">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="link1">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.3" mass="1.5" diaginertia="0.02 0.03 0.01"/>
      <body name="link2" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="0.7" diaginertia="0.005 0.008 0.004"/>
      </body>
    </body>
  </worldbody>
</mujoco>"#;

#[test]
fn mass_matrix_and_bias_match_the_hand_derived_double_pendulum() {
    let model = model_of(DOUBLE_PENDULUM);
    // Link 1: mass m1, centre at l1 from the shoulder, inertia I1 about y through its centre;
    // link 2 hangs from L1 with m2, l2, I2. Angles about +y: a point (0, 0, -r) goes to
    // r (-sin θ, 0, -cos θ). Lagrangian of the planar double pendulum:
    //   M11 = I1 + I2 + m1 l1² + m2 (L1² + l2² + 2 L1 l2 cos θ2)
    //   M12 = I2 + m2 (l2² + L1 l2 cos θ2),   M22 = I2 + m2 l2²
    //   c1 = -m2 L1 l2 sin θ2 (2 θ̇1 θ̇2 + θ̇2²) + g (m1 l1 + m2 L1) sin θ1 + g m2 l2 sin(θ1 + θ2)
    //   c2 =  m2 L1 l2 sin θ2 θ̇1² + g m2 l2 sin(θ1 + θ2)
    let (m1, l1, i1, m2, l2, i2, big_l1, g) = (1.5, 0.3, 0.03, 0.7, 0.2, 0.008, 0.5, 9.81);
    let mut rng = Lcg(3);
    for _ in 0..20 {
        let (t1, t2, w1, w2) = (
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-4.0, 4.0),
            rng.range(-4.0, 4.0),
        );
        let kin = model.tree.kinematics(&[t1, t2], &[w1, w2]);
        let m = model.tree.mass_matrix(&kin);
        let m11 = i1
            + i2
            + m1 * l1 * l1
            + m2 * (big_l1 * big_l1 + l2 * l2 + 2.0 * big_l1 * l2 * t2.cos());
        let m12 = i2 + m2 * (l2 * l2 + big_l1 * l2 * t2.cos());
        let m22 = i2 + m2 * l2 * l2;
        for (got, want) in [
            (m[(0, 0)], m11),
            (m[(0, 1)], m12),
            (m[(1, 0)], m12),
            (m[(1, 1)], m22),
        ] {
            assert!((got - want).abs() < 1e-12, "M: {got} vs {want}");
        }
        let bias = model.tree.rnea(&kin, &[0.0, 0.0], &[Wrench::zero(); 3]);
        let h = m2 * big_l1 * l2 * t2.sin();
        let c1 = -h * (2.0 * w1 * w2 + w2 * w2)
            + g * (m1 * l1 + m2 * big_l1) * t1.sin()
            + g * m2 * l2 * (t1 + t2).sin();
        let c2 = h * w1 * w1 + g * m2 * l2 * (t1 + t2).sin();
        assert!(
            (bias[0] - c1).abs() < 1e-11 && (bias[1] - c2).abs() < 1e-11,
            "c: {:?} vs {c1}, {c2}",
            bias.as_slice()
        );
    }
}

/// A chain with every joint kind in nested bodies: a ball-jointed body hanging from the world,
/// a hinge below it, a ball joint below that (offset and rotated frames), a slide at the end,
/// and a free-flying box. Inertias from geoms and from `<inertial>`; armature, damping,
/// stiffness and frictionloss where the test asks for them.
pub fn chain(extra_joint_attrs: &str) -> String {
    format!(
        r#"<mujoco model="chain">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="a" pos="0 0 1" euler="10 0 20">
      <joint name="ball_a" type="ball" pos="0 0 0.1" {extra_joint_attrs}/>
      <geom type="box" size="0.05 0.04 0.1" pos="0 0 -0.05" density="800" contype="0" conaffinity="0"/>
      <body name="b" pos="0.02 0 -0.2" quat="0.9 0.1 0.3 0">
        <joint name="hinge_b" type="hinge" axis="1 1 0" pos="0 0 0.02" {extra_joint_attrs}/>
        <inertial pos="0.01 0 -0.1" mass="0.8" fullinertia="0.01 0.012 0.004 0.001 0 0.0005"/>
        <body name="c" pos="0 0.03 -0.25" euler="0 30 0">
          <joint name="ball_c" type="ball" {extra_joint_attrs}/>
          <geom type="sphere" size="0.04" pos="0 0 -0.06" mass="0.5" contype="0" conaffinity="0"/>
          <geom type="box" size="0.02 0.06 0.01" pos="0.03 0 -0.02" mass="0.2" contype="0" conaffinity="0"/>
          <body name="d" pos="0 0 -0.1">
            <joint name="slide_d" type="slide" axis="0 0.6 -0.8" {extra_joint_attrs}/>
            <geom type="sphere" size="0.03" mass="0.3" contype="0" conaffinity="0"/>
          </body>
        </body>
      </body>
    </body>
    <body name="flyer" pos="1 0 2" quat="0.8 0.2 -0.4 0.4">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.02" mass="1.2" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>"#
    )
}

#[test]
fn inverse_of_forward_dynamics_is_the_identity_where_a_limit_holds_or_lets_go() {
    // The chain's hinge and slide past their upper limits, acting with MuJoCo's statics and
    // impedance (an added inertia, docs/mjcf.md "Joint limits"); generalized forces from
    // pushing them deeper (the limits hold) to pulling them out hard (the limits let go).
    use scm::dynamics::limit::{JointLimit, LimitLaw};
    let mut model = model_of(&chain(r#"armature="0.01""#));
    model.integrator = scm::integrate::Integrator::Rk4;
    let (q, _, _) = random_point(&model, &mut Lcg(5), 0.0);
    // At rest, so that the dampers do not let go by themselves.
    let v = vec![0.0; model.tree.nv];
    for j in model.tree.joints.iter_mut() {
        if matches!(j.kind, JointKind::Hinge | JointKind::Slide) {
            let hi = q[j.qadr] - 0.01;
            j.limit = Some(
                JointLimit::from_solref(hi - 1.0, hi, [0.02, 1.0], 0.05)
                    .stiffened(20.0)
                    .acting(LimitLaw::Impedance),
            );
        }
    }
    let limited: Vec<usize> = (model.tree.joints.iter())
        .filter(|j| j.limit.is_some())
        .map(|j| j.dadr)
        .collect();
    assert_eq!(limited.len(), 2);
    let (mut held, mut let_go) = (0, 0);
    for push in [-200.0, -50.0, -5.0, 0.0, 5.0, 50.0, 200.0] {
        let mut tau = vec![0.0; model.tree.nv];
        for &d in &limited {
            tau[d] = push;
        }
        match crate::common::forward_then_inverse(&model, &q, &v, &tau) {
            Some(h)
                if limited.iter().any(|&d| {
                    h[model.tree.joints.iter().position(|j| j.dadr == d).unwrap()] < 1.0
                }) =>
            {
                let_go += 1
            }
            _ => held += 1,
        }
    }
    assert!(held > 0 && let_go > 0, "held {held}, let go {let_go}");
}

#[test]
fn inverse_of_forward_dynamics_is_the_identity_on_every_scene() {
    let mut models = bundled();
    models.push((
        "chain".into(),
        model_of(&chain(
            r#"armature="0.01" damping="0.1" frictionloss="0.2""#,
        )),
    ));
    let mut rng = Lcg(11);
    for (name, model) in &models {
        for _ in 0..8 {
            let (q, v, u) = random_point(model, &mut rng, 0.01);
            let tau: Vec<f64> = (0..model.tree.nv).map(|_| rng.range(-5.0, 5.0)).collect();
            let (_, mocap) = model.split_inputs(&u).unwrap();
            let prm = model.contact;
            let at = EvalPoint {
                q: &q,
                v: &v,
                tau: &tau,
                mocap,
                pulls: &[],
            };
            let fd = model.forward_at(at, &prm, Default::default()).unwrap();
            let id = model.inverse(&q, &v, fd.vdot.as_slice(), mocap, &prm, &[]);
            // Scale: the largest generalized force involved (τ, contact, gravity through M v̇).
            let kin = model.tree.kinematics_with(&q, &v, mocap);
            let mvdot = model.tree.mass_matrix(&kin) * &fd.vdot;
            let scale = tau
                .iter()
                .chain(mvdot.iter())
                .fold(1.0f64, |m, x| m.max(x.abs()));
            for k in 0..model.tree.nv {
                assert!(
                    (id[k] - tau[k]).abs() <= 1e-10 * scale,
                    "{name}: dof {k}: ID(FD(τ)) = {} vs τ = {} (scale {scale})",
                    id[k],
                    tau[k]
                );
            }
            // The actuated form: ID(FD(u)) is the actuators' generalized force.
            let fd = model.forward(&q, &v, &u, &prm).unwrap();
            let pulls = model.pulls(&u);
            let id = model.inverse(&q, &v, fd.vdot.as_slice(), mocap, &prm, &pulls);
            let act = model.actuator_forces(&q, &v, &u[..model.actuators.len()]);
            assert!(
                (id - act).amax() <= 1e-10 * scale.max(1.0),
                "{name}: actuated form"
            );
        }
    }
}

#[test]
fn mass_matrix_is_symmetric_positive_definite_and_carries_the_kinetic_energy() {
    let mut models = bundled();
    models.push(("chain".into(), model_of(&chain(r#"armature="0.01""#))));
    let mut rng = Lcg(17);
    for (name, model) in &models {
        for _ in 0..8 {
            let (q, v, _) = random_point(model, &mut rng, 0.05);
            let m = model.tree.mass_matrix(&model.tree.kinematics(&q, &v));
            let asym = (&m - m.transpose()).amax();
            assert!(
                asym <= 1e-14 * m.amax(),
                "{name}: M not symmetric by {asym}"
            );
            let eig = m.clone().symmetric_eigenvalues();
            assert!(eig.min() > 0.0, "{name}: eigenvalues {eig}");
            // ½ vᵀ M v equals the kinetic energy of the bodies' motion (computed from their
            // frames, not from M), armature included.
            let v = DVector::from_vec(v.clone());
            let t_m = 0.5 * v.dot(&(&m * &v));
            let t = model.energy(&q, v.as_slice()).kinetic;
            assert!(
                (t_m - t).abs() <= 1e-12 * t.max(1e-12),
                "{name}: ½vᵀMv = {t_m} vs {t}"
            );
        }
    }
}

/// The mass matrix factored along the tree (`M = Lᵀ D L`, `dynamics/factor.rs`) solves as the
/// dense Cholesky factorization of the same matrix (plus the diagonal damped Euler adds), on
/// values and on dual numbers, for separate subtrees (free bodies, a slide) and for a branching
/// one (a free torso with a ball-jointed limb and a two-hinge limb, and a limb below the
/// ball). The two orders of elimination round differently: agreement to 1e-12 relative to the
/// solution's size, which a matrix this well conditioned (condition number below 1e4 here)
/// allows with room.
#[test]
fn the_mass_matrix_factored_along_the_tree_solves_as_the_dense_factor() {
    use num_dual::Dual64;
    let model = model_of(
        r#"<mujoco><option gravity="0 0 -9.81"/><worldbody>
      <body name="a" pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.05 0.02" mass="1"/></body>
      <body name="torso" pos="1 0 1"><freejoint/><geom type="capsule" size="0.03 0.1" mass="0.5"/>
        <body name="upper" pos="0.1 0 0"><joint name="shoulder" type="ball"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.3"/>
          <body name="lower" pos="0.3 0 0"><joint name="elbow" type="hinge" axis="0 1 0"/>
            <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/></body></body>
        <body name="thigh" pos="0 0 -0.1"><joint name="h1" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02" mass="0.3"/>
          <body name="shin" pos="0 0 -0.3"><joint name="h2" type="hinge" axis="1 0 0" armature="0.01"/>
            <geom type="sphere" size="0.05" mass="0.2"/></body></body></body>
      <body name="s" pos="2 0 1"><joint name="sl" type="slide" axis="1 0 0"/>
        <geom type="sphere" size="0.05" mass="0.4"/></body>
    </worldbody></mujoco>"#,
    );
    let nv = model.tree.nv;
    assert_eq!(nv, 6 + 6 + 3 + 1 + 1 + 1 + 1);
    let close = |a: &[f64], b: &[f64], what: &str| {
        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for k in 0..a.len() {
            assert!(
                (a[k] - b[k]).abs() <= 1e-12 * scale,
                "{what}[{k}]: {} vs {} (scale {scale})",
                a[k],
                b[k]
            );
        }
    };
    let mut rng = Lcg(23);
    for _ in 0..5 {
        let (q, v, _) = random_point(&model, &mut rng, 0.3);
        let mut m = model.tree.mass_matrix(&model.tree.kinematics(&q, &v));
        for k in 0..nv {
            m[(k, k)] += rng.range(0.0, 0.1); // damped Euler's h D
        }
        // The tree's sparsity: the legs do not couple with the arm, nor bodies with each other.
        let (arm, leg) = (12, 16);
        assert_eq!(m[(arm, leg)], 0.0);
        assert_eq!(m[(0, 6)], 0.0);
        let couples =
            |dofs: std::ops::Range<usize>| dofs.clone().any(|d| (6..12).any(|t| m[(d, t)] != 0.0));
        assert!(couples(arm..arm + 4) && couples(leg..leg + 2));
        let rhs = DVector::from_fn(nv, |_, _| rng.range(-1.0, 1.0));
        // Every nonzero entry is at the tree's sparsity (what the factor stores).
        assert_eq!(model.tree.sparse(&m).to_dense(), m);
        let tree = model
            .tree
            .factor(model.tree.sparse(&m))
            .unwrap()
            .solve(&rhs);
        let dense = m.clone().cholesky().unwrap().solve(&rhs);
        close(tree.as_slice(), dense.as_slice(), "x");
        // M x = rhs.
        close((&m * &tree).as_slice(), rhs.as_slice(), "M x");
        // Dual numbers: a direction in the matrix and the right-hand side.
        let dm = m.map(|x| Dual64::new(x, 0.1 * x));
        let drhs = rhs.map(|x| Dual64::new(x, 1.0 - x));
        let (a, b) = (
            model
                .tree
                .factor(model.tree.sparse(&dm))
                .unwrap()
                .solve(&drhs),
            dm.cholesky().unwrap().solve(&drhs),
        );
        let parts = |x: &DVector<Dual64>| -> (Vec<f64>, Vec<f64>) {
            (
                x.iter().map(|d| d.re).collect(),
                x.iter().map(|d| d.eps).collect(),
            )
        };
        let ((are, aeps), (bre, beps)) = (parts(&a), parts(&b));
        close(&are, &bre, "dual re");
        close(&aeps, &beps, "dual eps");
    }
    // A matrix that is not positive definite is refused, in a block of its own (the slide)
    // and inside the branching tree, as the dense factorization refuses it.
    let (q, v, _) = random_point(&model, &mut rng, 0.1);
    let m0 = model.tree.mass_matrix(&model.tree.kinematics(&q, &v));
    for k in [nv - 1, 13, 6] {
        let mut m = m0.clone();
        m[(k, k)] = -1.0;
        assert!(
            model.tree.factor(model.tree.sparse(&m)).is_none() && m.cholesky().is_none(),
            "{k}"
        );
    }
    let mut m = m0.clone();
    m[(nv - 1, nv - 1)] = f64::NAN;
    assert!(model.tree.factor(model.tree.sparse(&m)).is_none());
}

/// Energy error of RK4 on the chain (no contact, no input, no dissipation) after 1 s.
fn rk4_energy_error(model: &Model, h: f64) -> f64 {
    let mut m = model.clone();
    m.integrator = Integrator::Rk4;
    m.timestep = h;
    let mut rng = Lcg(5);
    let (q, v, u) = random_point(&m, &mut rng, 0.0);
    let v: Vec<f64> = v.iter().map(|x| 4.0 * x).collect(); // up to 2 rad/s, 2 m/s
    let state = State::new(q, v);
    let e0 = m.energy(&state.q, &state.v).total();
    let opts = AdvanceOptions {
        energy_guard: false,
        ..Default::default()
    };
    let end = m
        .advance(&state, &u, &m.contact, 0.0, 1.0, &opts)
        .unwrap()
        .state;
    m.energy(&end.q, &end.v).total() - e0
}

#[test]
fn rk4_conserves_energy_with_an_error_shrinking_as_h4() {
    // The chain tumbles at up to 2 rad/s with every joint kind; its energy error after 1 s,
    // measured: 3.4e-6 J (h = 5 ms), 3.0e-7 (2.5 ms), 2.2e-8 (1.25 ms), 1.4e-9 (0.625 ms),
    // 6e-11 (0.3125 ms, where rounding over 3200 steps starts to count). The fourth-order regime
    // (ratio 16 per halving) holds from 2.5 ms down.
    let model = model_of(&chain(""));
    let errors: Vec<(f64, f64)> = [0.0025, 0.00125, 0.000625]
        .iter()
        .map(|&h| (h, rk4_energy_error(&model, h)))
        .collect();
    println!("RK4 energy error after 1 s: {errors:?}");
    for w in errors.windows(2) {
        // Halving h divides a fourth-order error by 16; 12 to 20 leaves room for the
        // fifth-order terms still present (measured 13.8 and 15.0).
        let ratio = w[0].1 / w[1].1;
        assert!(
            (12.0..20.0).contains(&ratio),
            "error ratio {ratio} from h = {} to {}",
            w[0].0,
            w[1].0
        );
    }
    assert!(errors[2].1.abs() < 1e-8, "{errors:?}");
}

#[test]
fn contact_between_free_bodies_conserves_linear_momentum() {
    // Two free spheres without gravity, a glancing collision (friction and spin): the contact
    // forces are equal and opposite, so total momentum stays what it was, with every integrator
    // (each preserves linear invariants; implicit_euler to its Newton tolerance).
    let text = r#"<mujoco model="billiards">
  <option gravity="0 0 0" timestep="0.001"/>
  <custom>
    <numeric name="scm_stiffness" data="20000"/>
    <numeric name="scm_friction" data="0.8"/>
    <numeric name="scm_stiction_velocity" data="0.01"/>
    <numeric name="scm_spacing" data="0.02"/>
  </custom>
  <worldbody>
    <body name="a" pos="0 0 0"><freejoint/><geom type="sphere" size="0.05" mass="1"/></body>
    <body name="b" pos="0.2 0.04 0.01"><freejoint/><geom type="box" size="0.04 0.03 0.05" mass="2.5"/></body>
  </worldbody>
</mujoco>"#;
    for integrator in Integrator::ALL {
        let mut model = model_of(text);
        model.integrator = integrator;
        let mut state = State::new(model.tree.q0(), vec![0.0; 12]);
        state.v[0] = 1.0; // a moves towards b at 1 m/s
        state.v[4] = 2.0; // and spins
        state.v[6] = -0.2;
        let momentum = |s: &State<f64>| {
            Vector3::new(
                s.v[0] + 2.5 * s.v[6],
                s.v[1] + 2.5 * s.v[7],
                s.v[2] + 2.5 * s.v[8],
            )
        };
        let p0 = momentum(&state);
        let mut touched = false;
        for k in 0..40 {
            state = model
                .advance(
                    &state,
                    &[],
                    &model.contact,
                    k as f64 * 0.01,
                    0.01,
                    &AdvanceOptions::default(),
                )
                .unwrap()
                .state;
            touched |= (state.v[0] - 1.0).abs() > 0.1;
            let dp = (momentum(&state) - p0).norm();
            assert!(dp < 1e-9, "{}: momentum changed by {dp}", integrator.name());
        }
        assert!(touched, "{}: the bodies never collided", integrator.name());
        // They hit off-centre: the box was pushed sideways too.
        assert!(
            state.v[7].abs() > 1e-3,
            "{}: no sideways push",
            integrator.name()
        );
    }
}

#[test]
fn loader_reads_joint_and_body_properties() {
    let model = model_of(&chain(
        r#"armature="0.02" damping="0.3" stiffness="2" frictionloss="0.1""#,
    ));
    let t = &model.tree;
    assert_eq!((t.nq, t.nv), (4 + 1 + 4 + 1 + 7, 3 + 1 + 3 + 1 + 6));
    let ball = &t.joints[0];
    assert_eq!(
        (
            ball.kind,
            ball.armature,
            ball.damping,
            ball.stiffness,
            ball.frictionloss
        ),
        (JointKind::Ball, 0.02, 0.3, 2.0, 0.1)
    );
    assert!((ball.anchor - Vector3::new(0.0, 0.0, 0.1)).norm() < 1e-15);
    let hinge = &t.joints[1];
    assert!((hinge.axis - Vector3::new(1.0, 1.0, 0.0).normalize()).norm() < 1e-15);
    // Inertia from two geoms of body c: total mass and centre of mass.
    let c = &t.bodies[3].inertia;
    assert!((c.mass - 0.7).abs() < 1e-15);
    assert!(
        (c.com - Vector3::new(0.03 * 0.2 / 0.7, 0.0, (-0.06 * 0.5 - 0.02 * 0.2) / 0.7)).norm()
            < 1e-15
    );
    // Inertia of body a from its box geom and density 800.
    let a = &t.bodies[1].inertia;
    assert!((a.mass - 800.0 * 0.1 * 0.08 * 0.2).abs() < 1e-12);
    // Armature sits on the diagonal of M.
    let (q, v) = (t.q0(), vec![0.0; t.nv]);
    let with = t.mass_matrix(&t.kinematics(&q, &v));
    let without = model_of(&chain(r#"damping="0.3""#))
        .tree
        .mass_matrix(&t.kinematics(&q, &v));
    let d = &with - &without;
    for i in 0..t.nv {
        let expect = if i < 8 { 0.02 } else { 0.0 };
        assert!(
            (d[(i, i)] - expect).abs() < 1e-14,
            "armature on dof {i}: {}",
            d[(i, i)]
        );
    }
    // Ball stiffness pulls towards the reference orientation: the torque is -k θ.
    let mut q = q.clone();
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.2, -0.1, 0.3));
    q[0..4].copy_from_slice(&[r.w, r.i, r.j, r.k]);
    let tau = model.passive_forces(&q, &v, 0.01);
    for k in 0..3 {
        assert!(
            (tau[k] + 2.0 * r.scaled_axis()[k]).abs() < 1e-12,
            "ball spring dof {k}: {}",
            tau[k]
        );
    }
    // Frictionloss is smooth dry friction: -F v / sqrt(v_s² + v²), tending to -F sign(v).
    let mut v = v.clone();
    v[3] = 2.0;
    let tau = model.passive_forces(&model.tree.q0(), &v, 1e-3);
    let expect = -0.3 * 2.0 - 0.1 * 2.0 / (1e-6f64 + 4.0).sqrt();
    assert!((tau[3] - expect).abs() < 1e-12, "{} vs {expect}", tau[3]);
}

#[test]
fn actuators_apply_gear_gains_and_control_ranges() {
    let text = r#"<mujoco model="act">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="b"><joint name="s" type="slide" axis="1 0 0"/><joint name="h" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.1" mass="1"/></body>
  </worldbody>
  <actuator>
    <motor name="m" joint="s" gear="3" ctrlrange="-1 1"/>
    <position name="p" joint="h" gear="2" kp="10" kv="0.5"/>
    <velocity name="v" joint="s" kv="4"/>
  </actuator>
</mujoco>"#;
    let model = model_of(text);
    let (q, v) = ([0.1, 0.2], [0.3, -0.4]);
    let tau: DVector<f64> = model.actuator_forces(&q, &v, &[5.0, 0.7, 0.25]);
    // Motor: clamped to 1, force 1, generalized 3·1. Velocity actuator: 4 (0.25 - 0.3).
    assert!(
        (tau[0] - (3.0 + 4.0 * (0.25 - 0.3))).abs() < 1e-14,
        "{}",
        tau[0]
    );
    // Position: force 10 (0.7 - 2·0.2) - 0.5·2·(-0.4), generalized ×2.
    assert!(
        (tau[1] - 2.0 * (10.0 * (0.7 - 0.4) + 0.5 * 2.0 * 0.4)).abs() < 1e-14,
        "{}",
        tau[1]
    );
    // The derivative with respect to a clamped control is zero, inside the range it is the gear.
    use num_dual::Dual64;
    let d = |u0: f64| {
        model.actuator_forces(
            &q.map(Dual64::from),
            &v.map(Dual64::from),
            &[Dual64::new(u0, 1.0), Dual64::from(0.0), Dual64::from(0.0)],
        )[0]
        .eps
    };
    assert_eq!((d(5.0), d(0.5)), (0.0, 3.0));
    // A bad ctrlrange is refused.
    let e = load_str(
        &text.replace(r#"ctrlrange="-1 1""#, r#"ctrlrange="1 -1""#),
        Path::new("bad.xml"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("reversed"), "{e}");
}

#[test]
fn structural_errors_name_the_problem() {
    let base = chain("");
    for (from, to, words) in [
        (
            r#"<joint name="slide_d""#,
            r#"<freejoint/><joint name="slide_d""#,
            "free joint",
        ),
        (
            r#"<freejoint/>"#,
            r#"<freejoint/><joint type="ball"/>"#,
            "free joint",
        ),
        (
            r#"<joint name="ball_a" type="ball""#,
            r#"<joint name="ball_a" type="ball" stiffness="-1""#,
            "negative",
        ),
        (
            r#"<freejoint/>"#,
            r#"<joint type="free" stiffness="3"/>"#,
            "stiffness on a free joint",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let e = load_str(&base.replacen(from, to, 1), Path::new("bad.xml")).unwrap_err();
        assert!(e.to_string().contains(words), "'{words}' not in {e}");
    }
}

#[test]
fn mujoco_integrator_options_map_to_ours() {
    let scene = |option: &str, custom: &str| {
        format!(
            r#"<mujoco model="m"><option {option}/><custom>{custom}</custom><worldbody>
  <body name="b"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body></worldbody></mujoco>"#
        )
    };
    for (mj, ours) in [
        ("Euler", Integrator::DampedEuler),
        ("RK4", Integrator::DampedRk4),
        ("implicit", Integrator::ImplicitEuler),
        ("implicitfast", Integrator::ImplicitEuler),
    ] {
        assert_eq!(
            model_of(&scene(&format!(r#"integrator="{mj}""#), "")).integrator,
            ours,
            "{mj}"
        );
    }
    // scm_integrator wins over MuJoCo's option, and every name of ours is accepted.
    for i in Integrator::ALL {
        let m = model_of(&scene(
            r#"integrator="RK4""#,
            &format!(r#"<text name="scm_integrator" data="{}"/>"#, i.name()),
        ));
        assert_eq!(m.integrator, i);
        assert_eq!(Integrator::from_name(i.name()), Some(i));
    }
    let e = load_str(&scene(r#"integrator="leapfrog""#, ""), Path::new("bad.xml")).unwrap_err();
    assert!(e.to_string().contains("leapfrog"), "{e}");
}

#[test]
fn fluid_forces_only_dissipate_and_follow_the_box_formulas() {
    use scm::dynamics::fluid::FluidBody;
    // A box's equivalent inertia box is the box itself: sides 0.4, 0.1, 0.06.
    let xml = r#"<mujoco>
  <option density="1000" viscosity="0.2"/>
  <worldbody>
    <body name="box" pos="0 0 1"><freejoint/><geom type="box" size="0.2 0.05 0.03"/></body>
  </worldbody>
</mujoco>"#;
    let model = model_of(xml);
    let fluid = model.fluid.as_ref().unwrap();
    let fb: &FluidBody = &fluid.bodies[0];
    let mut sides: Vec<f64> = fb.sides.iter().copied().collect();
    sides.sort_by(f64::total_cmp);
    for (s, want) in sides.iter().zip([0.06, 0.1, 0.4]) {
        assert!((s - want).abs() < 1e-12, "{sides:?}");
    }
    // Sliding along its long axis at 2 m/s (no gravity in the force, only the fluid's): drag
    // -3π β d v - ½ ρ b_y b_z v², d the mean side.
    let kin = model
        .tree
        .kinematics(&model.q0, &[2.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let mut w = vec![Wrench::zero(); 2];
    fluid.add_wrenches(&kin.frames, &mut w);
    let d = (0.4 + 0.1 + 0.06) / 3.0;
    let want = -3.0 * std::f64::consts::PI * d * 0.2 * 2.0 - 0.5 * 1000.0 * 0.1 * 0.06 * 4.0;
    assert!(
        (w[1].force.x - want).abs() < 1e-12 * want.abs(),
        "{} vs {want}",
        w[1].force.x
    );
    assert!(w[1].force.y.abs() + w[1].force.z.abs() + w[1].torque.norm() < 1e-12);
    // Whatever the motion, the power of the fluid forces is negative.
    let mut rng = Lcg(7);
    for _ in 0..50 {
        let (q, v, _) = random_point(&model, &mut rng, 3.0);
        let kin = model.tree.kinematics(&q, &v);
        let p: f64 = fluid.power(&kin.frames);
        assert!(p < 0.0, "power {p} at v = {v:?}");
    }
}

/// The velocity that sets the hinged arm and the free box of the welds' and strings' tests
/// swinging.
const SWING: [f64; 7] = [3.0, 0.5, -0.4, 0.8, 2.0, -3.0, 1.5];

/// The energies of `m` every 0.05 s over 1 s of RK4 at 0.25 ms from `q0` and velocity `v`.
fn swing_energies(mut m: scm::model::Model, v: &[f64]) -> Vec<scm::model::Energy<f64>> {
    m.integrator = Integrator::Rk4;
    m.timestep = 2.5e-4;
    let mut state = State {
        q: m.tree.q0(),
        v: v.to_vec(),
        act: Vec::new(),
    };
    let u = vec![0.0; m.nu()];
    let opts = AdvanceOptions {
        energy_guard: false,
        ..Default::default()
    };
    let mut energies = vec![m.energy(&state.q, &state.v)];
    for k in 0..20 {
        let t = 0.05 * k as f64;
        state = m
            .advance(&state, &u, &m.contact, t, t + 0.05, &opts)
            .unwrap()
            .state;
        energies.push(m.energy(&state.q, &state.v));
    }
    energies
}

/// The largest spring energy of a run and the largest drift of its total energy.
fn swing_and_drift(run: &[scm::model::Energy<f64>]) -> (f64, f64) {
    let total: Vec<f64> = run.iter().map(|e| e.total()).collect();
    let swing = run.iter().map(|e| e.springs).fold(0.0, f64::max);
    let drift = total
        .iter()
        .map(|e| (e - total[0]).abs())
        .fold(0.0, f64::max);
    (swing, drift)
}

/// A spatial tendon's spring is conservative and its damper only dissipates: a hinged arm and
/// a free box tied by a string over a pulley (a segment within the box too), with a spring and
/// no damping, keep their total energy (the tendon's spring counted) to RK4's truncation error
/// while the string pulls them through large motions; with damping and dry friction the energy
/// only decreases. (A force with the wrong sign or scale against its length would not store
/// what it takes. One spring length, not a deadband: the deadband's kink in the force costs
/// RK4 its order, 1.2e-4 J of drift at this step and 1.3e-5 J at half of it, measured.)
#[test]
fn spatial_tendons_store_what_they_take_and_their_dampers_only_dissipate() {
    let xml = |extra: &str| {
        format!(
            r#"<mujoco>
  <option gravity="0 0 -3"><flag contact="disable"/></option>
  <worldbody>
    <site name="hook" pos="0.2 0 1.4"/>
    <site name="hook2" pos="0.6 0 1.5"/>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
      <site name="tip" pos="0.3 0 0.1"/>
    </body>
    <body name="box" pos="0.6 0.1 1.1" euler="0 0 20">
      <freejoint/>
      <geom type="box" size="0.06 0.04 0.03" pos="0.02 0 0"/>
      <site name="corner" pos="0.06 0.04 0.03"/>
      <site name="other" pos="-0.06 0.04 -0.03"/>
    </body>
  </worldbody>
  <tendon>
    <spatial stiffness="400" springlength="0.3" {extra}>
      <site site="tip"/>
      <site site="hook"/>
      <pulley divisor="2"/>
      <site site="hook2"/>
      <site site="corner"/>
      <site site="other"/>
    </spatial>
  </tendon>
</mujoco>"#
        )
    };
    let run = |extra: &str| {
        let m = load_str(&xml(extra), Path::new("string.xml"))
            .unwrap()
            .model;
        assert_eq!(m.spatial_tendons.len(), 1);
        swing_energies(m, &SWING)
    };
    let kept = run("");
    let (swing, drift) = swing_and_drift(&kept);
    println!("string without damping: spring energy up to {swing:.3e} J, drift {drift:.2e} J");
    assert!(swing > 0.1, "the string must work: {swing}");
    assert!(drift < 1e-6 * swing, "{drift} vs {swing}");
    let damped: Vec<f64> = run(r#"damping="5" frictionloss="0.5""#)
        .iter()
        .map(|e| e.total())
        .collect();
    assert!(damped.windows(2).all(|w| w[1] < w[0]), "{damped:?}");
    assert!(
        damped[0] - damped[20] > 0.2 * kept[0].kinetic,
        "the damper takes much of the motion: {damped:?}"
    );
}

/// Tendons wrapping geoms are conservative springs: the wrapping fixture without its dampers,
/// started moving, keeps its total energy (the tendons' springs counted) to RK4's truncation
/// error while the arm swings the rope round the sphere and the bob slides in its sling (the
/// inside wrap, up to grazing and off it): a force not along the length's gradient at the
/// tangent points, or a length that jumps, would not keep it. The belt round the cylinder is
/// left slack here: with MuJoCo's rule for a cylinder (the side of the shorter chord) its
/// length has kinks and jumps as the arm swings round, and MuJoCo's own RK4 loses energy
/// there too (measured: 1.2e-3 J at 0.25 ms, 7e-4 J at 0.125 ms).
#[test]
fn wrapping_tendons_store_what_they_take() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/tendon_wrap.xml");
    let xml = std::fs::read_to_string(&path).unwrap();
    let undamped = xml
        .replace(r#" damping="0.02""#, "")
        .replace(r#" damping="0.5""#, "")
        .replace(r#"stiffness="80""#, r#"stiffness="0""#);
    assert_ne!(undamped, xml);
    let m = load_str(&undamped, &path).unwrap().model;
    let energies = swing_energies(m, &[-4.0, 0.5, -0.3, 0.8, -0.6]);
    let (swing, drift) = swing_and_drift(&energies);
    println!("wrapping tendons: spring energy up to {swing:.3e} J, drift {drift:.2e} J");
    assert!(swing > 1.0, "the tendons must work: {swing}");
    assert!(drift < 1e-6 * swing, "{drift} vs {swing}");
}

/// Welds and connects are conservative springs plus dampers that only dissipate: without
/// damping (`solref="-k 0"`) RK4 keeps the total energy (the welds' springs counted) to its
/// truncation error while the bodies swing and tumble through large angles; with damping it
/// only decreases.
#[test]
fn welds_store_what_they_take_and_their_dampers_only_dissipate() {
    let xml = |solref: &str| {
        format!(
            r#"<mujoco>
  <option><flag contact="disable"/></option>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
      <site name="tip" pos="0.3 0 0.1"/>
    </body>
    <body name="box" pos="0.35 0 1.1" euler="0 0 20">
      <freejoint/>
      <geom type="box" size="0.06 0.04 0.03" pos="0.02 0 0"/>
      <site name="corner" pos="0.06 0.04 0" euler="0 30 0"/>
    </body>
  </worldbody>
  <equality>
    <weld body1="arm" body2="box" solref="{solref}"/>
    <weld site1="corner" site2="tip" solref="{solref}"/>
    <connect body1="box" anchor="0.1 0 0" solref="{solref}"/>
  </equality>
</mujoco>"#
        )
    };
    // The springs and dampers at their reference gains, without the inertia MuJoCo's
    // impedance adds along the welds' rows (src/model/coupled.rs): that inertia moves the
    // springs at MuJoCo's pace, and with the rows turning as the bodies turn it is not the
    // Hessian of a kinetic energy, so the total would be conserved only near the held poses;
    // and the raised springs (11 times) leave RK4 at 0.25 ms a truncation error of 1e-4 of
    // the swing over the second.
    let run = |solref: &str| {
        let mut m = load_str(&xml(solref), Path::new("welds.xml"))
            .unwrap()
            .model;
        let reference = scm::dynamics::limit::LimitLaw::Reference;
        for c in &mut m.connects {
            (c.stiffness, c.damping) = c.gains.acting(reference);
            c.impedance = 0.0;
            if let Some(o) = &mut c.orientation {
                (o.stiffness, o.damping) = o.gains.acting(reference);
                o.impedance = 0.0;
            }
        }
        swing_energies(m, &SWING)
    };
    let kept = run("-2000 0");
    let (swing, drift) = swing_and_drift(&kept);
    println!("welds without damping: spring energy up to {swing:.3e} J, drift {drift:.2e} J");
    assert!(swing > 0.1, "the welds must work: {swing}");
    assert!(drift < 1e-6 * swing, "{drift} vs {swing}");
    let damped: Vec<f64> = run("-2000 -3").iter().map(|e| e.total()).collect();
    assert!(damped.windows(2).all(|w| w[1] < w[0]), "{damped:?}");
    assert!(
        damped[0] - damped[20] > 0.5 * kept[0].kinetic,
        "the dampers take most of the motion: {damped:?}"
    );
}

/// `Tree::wrench_forces` is the part of the recursive Newton–Euler pass that external wrenches
/// give: `rnea(0, f) - rnea(0, 0) = -Σ Jᵀ f`, on a chain with a ball joint, a free body and a
/// body of several joints, moving, with wrenches on every body.
#[test]
fn wrench_forces_are_the_external_part_of_rnea() {
    let xml = r#"<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint type="ball"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="b" pos="0.3 0 0">
        <joint axis="0 1 0"/>
        <joint type="slide" axis="1 0 0"/>
        <geom type="box" size="0.05 0.04 0.03"/>
      </body>
    </body>
    <body name="c" pos="1 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>"#;
    let m = load_str(xml, Path::new("chain.xml")).unwrap().model;
    let mut q = m.tree.q0();
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
    q[..4].copy_from_slice(&[r.w, r.i, r.j, r.k]);
    q[4] = 0.4;
    q[5] = 0.05;
    let v: Vec<f64> = (0..m.tree.nv).map(|k| 0.3 - 0.1 * k as f64).collect();
    let kin = m.tree.kinematics(&q, &v);
    let wrenches: Vec<Wrench<f64>> = (0..m.tree.bodies.len())
        .map(|b| Wrench {
            force: Vector3::new(1.0, -2.0, 0.5) * b as f64,
            torque: Vector3::new(-0.3, 0.4, 1.1) * b as f64,
        })
        .collect();
    let zero = vec![0.0; m.tree.nv];
    let none = vec![Wrench::zero(); m.tree.bodies.len()];
    let want = m.tree.rnea(&kin, &zero, &none) - m.tree.rnea(&kin, &zero, &wrenches);
    let got = m.tree.wrench_forces(&kin, &wrenches);
    assert!((got - &want).amax() < 1e-12 * want.amax(), "{want}");
    assert!(want.amax() > 1.0);
}

/// A branching tree: a free torso, a ball-jointed limb below a hinge, a body of two joints, a
/// body welded below a hinge, a slide, a mocap body and the world.
const BRANCHING: &str = r#"<mujoco><worldbody>
      <body name="torso" pos="1 0 1"><freejoint/><geom type="capsule" size="0.03 0.1" mass="0.5"/>
        <body name="upper" pos="0.1 0.05 0"><joint type="hinge" axis="0 0 1"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.3"/>
          <body name="lower" pos="0.3 0 0.02"><joint type="ball" pos="0.01 0 0"/>
            <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
            <body name="welded" pos="0.2 0.01 0" euler="0.3 0 0.2">
              <geom type="box" size="0.02 0.03 0.01" mass="0.1"/></body></body></body>
        <body name="two" pos="0 0 -0.1"><joint type="hinge" axis="0 1 0" pos="0 0 0.02"/>
          <joint type="slide" axis="1 0 0.5"/>
          <geom type="sphere" size="0.05" mass="0.2"/></body></body>
      <body name="s" pos="2 0 1"><joint type="slide" axis="1 0 0"/>
        <geom type="sphere" size="0.05" mass="0.4"/></body>
      <body name="m" mocap="true" pos="0 2 0"><geom type="sphere" size="0.05"/></body>
    </worldbody></mujoco>"#;

/// A body's Jacobian columns (`Tree::body_jacobian`) give its frame velocity and the
/// generalized force of a wrench on it, on a branching tree (a free torso, a ball-jointed limb
/// below a hinge, a body of two joints, a body welded below a hinge), a slide, a mocap body and
/// the world; at a random configuration and velocity, to rounding.
#[test]
fn body_jacobians_carry_frame_velocities_and_wrenches() {
    let m = model_of(BRANCHING);
    let tree = &m.tree;
    let mut rng = Lcg(11);
    let (q, v, _) = random_point(&m, &mut rng, 0.2);
    let kin = tree.kinematics(&q, &v);
    let mut moving = 0;
    for b in 0..tree.bodies.len() {
        let cols = tree.body_jacobian(&kin, b);
        let (mut lin, mut ang) = (Vector3::zeros(), Vector3::zeros());
        for (d, l, a) in &cols {
            lin += l * v[*d];
            ang += a * v[*d];
        }
        let frame = &kin.frames[b];
        let scale = 1.0 + frame.linvel.norm() + frame.angvel.norm();
        assert!((lin - frame.linvel).norm() < 1e-13 * scale, "body {b}");
        assert!((ang - frame.angvel).norm() < 1e-13 * scale, "body {b}");
        // A wrench on this body alone, as generalized forces.
        let mut wrenches = vec![Wrench::zero(); tree.bodies.len()];
        wrenches[b] = Wrench {
            force: Vector3::new(1.0, -2.0, 0.5),
            torque: Vector3::new(-0.3, 0.4, 1.1),
        };
        let want = tree.wrench_forces(&kin, &wrenches);
        let mut got = DVector::zeros(tree.nv);
        for (d, l, a) in &cols {
            got[*d] += l.dot(&wrenches[b].force) + a.dot(&wrenches[b].torque);
        }
        assert!(
            (&got - &want).amax() < 1e-13 * (1.0 + want.amax()),
            "body {b}"
        );
        moving += usize::from(!cols.is_empty());
    }
    // The torso, upper, lower, welded, two and the slider move; the world and the mocap body
    // have no columns.
    assert_eq!(moving, 6);
    assert!(tree.body_jacobian(&kin, 0).is_empty());
}

/// A forward dynamics that does not list the pairs' contacts (`ForwardOptions::list_contacts`,
/// what a residual reads) gives the accelerations of one that does, to the bit, on every
/// bundled scene at random states near their start (pairs in reach among them); and
/// `Model::contacts_only` the contacts it lists, the pairs' kept proofs alike.
#[test]
fn accelerations_without_the_contact_list_are_the_same_bits() {
    use scm::collision::PairCarry;
    use scm::model::{ForwardOptions, Reuse};
    let mut rng = Lcg(29);
    let mut in_reach = 0;
    for (name, model) in bundled() {
        for _ in 0..3 {
            let (q, v, u) = random_point(&model, &mut rng, 0.01);
            let listed = model
                .forward_with(&q, &v, &u, &model.contact, ForwardOptions::default())
                .unwrap();
            let opts = ForwardOptions {
                list_contacts: false,
                ..ForwardOptions::default()
            };
            let bare = model
                .forward_with(&q, &v, &u, &model.contact, opts)
                .unwrap();
            let bits = |x: &DVector<f64>| x.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&listed.vdot), bits(&bare.vdot), "{name}");
            assert!(bare.contacts.is_empty());
            in_reach += listed.contacts.iter().flatten().count();
            // The contacts alone (what implicit Euler's guard reads at a call's start): the
            // list's contacts, and with the pairs' kept proofs the same proofs kept after.
            let alone = model
                .contacts_only(&q, &v, &u, &model.contact, ForwardOptions::default())
                .unwrap();
            assert_eq!(alone, listed.contacts, "{name}");
            let (mut by_forward, mut by_contacts) = (PairCarry::default(), PairCarry::default());
            for _ in 0..2 {
                let kept = |carry| ForwardOptions {
                    reuse: Reuse::All(carry),
                    ..ForwardOptions::default()
                };
                let f = model.forward_with(&q, &v, &u, &model.contact, kept(&mut by_forward));
                let c = model.contacts_only(&q, &v, &u, &model.contact, kept(&mut by_contacts));
                assert_eq!(c.unwrap(), f.unwrap().contacts, "{name}");
                assert_eq!(by_contacts.reach, by_forward.reach, "{name}");
            }
        }
    }
    assert!(in_reach > 0);
}

/// What damped Euler's Newton iterations take apart (`FrozenForward`): the bodies' frames at a
/// new velocity from the kinematics of another (`Tree::frames_at_velocity`) are those of the
/// full kinematics there, and RNEA finished from its forward pass (`Tree::rnea_forces`,
/// `Tree::rnea_with`) is `Tree::rnea`, to the bit, on the branching tree with its mocap body
/// moved and moving.
#[test]
fn frames_at_a_new_velocity_and_rnea_from_its_forward_pass_are_the_same_bits() {
    let m = model_of(BRANCHING);
    let tree = &m.tree;
    let mut rng = Lcg(17);
    let bits = |x: &[f64]| x.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
    let frame_bits = |f: &scm::collision::Frame<f64>| {
        let parts = [f.rotation.as_slice(), f.origin.as_slice()];
        let vel = [f.linvel.as_slice(), f.angvel.as_slice()];
        (parts.concat().iter().chain(&vel.concat()))
            .map(|a| a.to_bits())
            .collect::<Vec<_>>()
    };
    for _ in 0..5 {
        let (q, v, u) = random_point(&m, &mut rng, 0.2);
        let (_, mocap) = m.split_inputs(&u).unwrap();
        assert!(!mocap.is_empty());
        let kin = tree.kinematics_with(&q, &v, mocap);
        let v2: Vec<f64> = (0..tree.nv).map(|_| rng.range(-2.0, 2.0)).collect();
        let want = tree.kinematics_with(&q, &v2, mocap);
        let got = tree.frames_at_velocity(&kin, &v2, mocap);
        assert_eq!(got.len(), want.frames.len());
        let mut moving = 0;
        for (b, (g, w)) in got.iter().zip(&want.frames).enumerate() {
            assert_eq!(frame_bits(g), frame_bits(w), "body {b}");
            moving += usize::from(w.linvel.norm() > 0.0);
        }
        assert!(moving >= 7, "the bodies move, the mocap body too: {moving}");
        let wrenches: Vec<Wrench<f64>> = (0..tree.bodies.len())
            .map(|_| Wrench {
                force: rng.direction() * rng.range(0.0, 3.0),
                torque: rng.direction() * rng.range(0.0, 1.0),
            })
            .collect();
        for vdot in [vec![], v2.clone()] {
            let whole = tree.rnea(&kin, &vdot, &wrenches);
            let split = tree.rnea_with(&kin, tree.rnea_forces(&kin, &vdot), &wrenches);
            assert_eq!(bits(whole.as_slice()), bits(split.as_slice()));
            assert!(whole.amax() > 0.1);
        }
    }
}
