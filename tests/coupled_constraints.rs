//! MuJoCo's impedance as inertia added along constraint rows that cross the tree's branches
//! (tendon limits, equalities): the factor with the rows against the dense matrix, on values
//! and derivatives; the forward dynamics' exact derivatives against central differences and
//! `ID(FD(τ)) = τ` with the rows acting and a tendon limit letting go; and MuJoCo's pace and
//! statics under the explicit integrators.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;
use scm::dynamics::{CoupledFactor, Row, Tree, TreeMatrix};

/// A tree of two branches (a free body with a hinged link; a body on a slide and a hinge: nine
/// coordinates) at a configuration away from the reference,
/// and its mass matrix, dense and sparse.
fn tree_and_mass() -> (Tree, DMatrix<f64>, TreeMatrix<f64>) {
    let xml = r#"<mujoco><worldbody>
      <body pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.2 0.3" mass="2"/>
        <body pos="0.3 0 0"><joint type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05" mass="0.5"/></body></body>
      <body pos="1 0 1"><joint type="slide" axis="1 0 0"/><joint type="hinge" axis="0 0 1"/>
        <geom type="sphere" size="0.1" mass="1"/></body>
    </worldbody></mujoco>"#;
    let model = scm::scene::load_str(xml, std::path::Path::new("two.xml"))
        .unwrap()
        .model;
    let tree = model.tree.clone();
    let mut q = tree.q0();
    q[7] = 0.4;
    q[9] = -0.7;
    let kin = tree.kinematics(&q, &vec![0.0; tree.nv]);
    (
        tree.clone(),
        tree.mass_matrix(&kin),
        tree.mass_matrix_sparse(&kin),
    )
}

#[test]
fn the_rows_inertia_is_added_as_woodbury_says_on_values_and_derivatives() {
    let (tree, dense, sparse) = tree_and_mass();
    let n = tree.nv;
    // Three rows across both branches, one of zero inertia (left out).
    let rows: Vec<Row<f64>> = [(0.7, 3.0), (-1.3, 0.5), (0.2, 0.0)]
        .iter()
        .enumerate()
        .map(|(i, &(s, a))| Row {
            jacobian: DVector::from_fn(n, |j, _| ((i + 2 * j) as f64 * s).sin()),
            inertia: a,
        })
        .collect();
    let rhs = DVector::from_fn(n, |j, _| (j as f64 * 0.37).cos());
    let mut full = dense.clone();
    for r in &rows {
        full += &r.jacobian * r.jacobian.transpose() * r.inertia;
    }
    let want = full.clone().lu().solve(&rhs).unwrap();
    let factor = CoupledFactor::new(tree.factor(sparse.clone()).unwrap(), &rows);
    let got = factor.solve(&rhs);
    assert!(
        (&got - &want).norm() < 1e-10 * want.norm(),
        "{got} vs {want}"
    );
    // Without rows, the tree's solve.
    let plain = CoupledFactor::new(tree.factor(sparse.clone()).unwrap(), &[]);
    let m_inv_b = dense.clone().lu().solve(&rhs).unwrap();
    assert!((plain.solve(&rhs) - &m_inv_b).norm() < 1e-10 * m_inv_b.norm());
    // On dual numbers, the derivative along the first row's inertia:
    // d/da (M + Jᵀ A J)⁻¹ b = -(M + Jᵀ A J)⁻¹ J₀ᵀ J₀ x.
    let lift = |m: &TreeMatrix<f64>| {
        let d = m.to_dense().map(Dual64::from);
        tree.sparse(&d)
    };
    let dual_rows: Vec<Row<Dual64>> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| Row {
            jacobian: r.jacobian.map(Dual64::from),
            inertia: Dual64::new(r.inertia, if i == 0 { 1.0 } else { 0.0 }),
        })
        .collect();
    let factor = CoupledFactor::new(tree.factor(lift(&sparse)).unwrap(), &dual_rows);
    let got = factor.solve(&rhs.map(Dual64::from));
    let j0 = &rows[0].jacobian;
    let slope = -full.lu().solve(&(j0 * j0.dot(&want))).unwrap();
    for k in 0..n {
        assert!((got[k].re - want[k]).abs() < 1e-10 * want.norm());
        assert!((got[k].eps - slope[k]).abs() < 1e-9 * slope.norm().max(1.0));
    }
}

/// The coupled fixture's model (tests/fixtures/coupled.xml).
pub fn coupled() -> scm::model::Model {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/coupled.xml");
    scm::scene::load(&path).unwrap().model
}

#[test]
fn inverse_of_forward_dynamics_is_the_identity_where_a_tendon_limit_holds_or_lets_go() {
    // The coupled fixture at rest past both tendons' upper limits (the fixed one by 5 mrad),
    // with the equalities away from their held values; generalized forces on the first arm
    // from pushing the tendons deeper (their limits hold) to pulling them out hard (the fixed
    // tendon's lets go). ID(FD(τ)) = τ with the rows' inertia and the shares the limits hold.
    let mut model = coupled();
    let mut q = model.tree.q0();
    q[..5].copy_from_slice(&[0.4, -0.2, 0.01, 0.1, 0.2]);
    let v = vec![0.0; model.tree.nv];
    let l = model.tendons[0].length(&q);
    model.tendons[0].limit.as_mut().unwrap().hi = l - 0.005;
    let slot = model.tree.joints.len();
    let (mut held, mut let_go) = (0, 0);
    for push in [-200.0, -20.0, -2.0, 0.0, 2.0, 20.0, 200.0] {
        let mut tau = vec![0.0; model.tree.nv];
        tau[0] = push;
        match crate::common::forward_then_inverse(&model, &q, &v, &tau) {
            Some(h) if h[slot] < 1.0 => let_go += 1,
            _ => held += 1,
        }
    }
    assert!(held > 0 && let_go > 0, "held {held}, let go {let_go}");
}

#[test]
fn the_equalities_added_inertia_counts_in_the_energy_that_their_motion_conserves() {
    // The coupled fixture's arms released under gravity, without the tendons' limits and
    // without damping anywhere, for 2 s of RK4 at 0.25 ms, each equality alone (the joint
    // equality, the connect, the weld) and all three together: the total counts the kinetic
    // energy of the inertia added along the equality's rows and its spring at the gains that
    // act, and stays within 1e-9 of the swing's energy (measured: 2e-11 J to 5e-10 J of 23.5 J). The added inertia resists each row's
    // whole acceleration, its turning `J̇ v` included (`Coupled::add_turning_force`). Without
    // that term the joint equality alone drifted by 0.027 J of 23.5 J, and with the connect it
    // pumped energy into the third body, whose joints both hold (6.6 J into a 19.6 J swing in
    // 1 s on the same file written with undamped `solref`, measured; MuJoCo's stays within
    // 0.5 J).
    use scm::integrate::{AdvanceOptions, Integrator, State};
    let undamped = || {
        let mut m = coupled();
        for j in &mut m.tree.joints {
            j.damping = 0.0;
        }
        m.tendons[0].limit = None;
        m.spatial_tendons[0].law.limit = None;
        m.equalities.iter_mut().for_each(|e| e.damping = 0.0);
        m.connects.iter_mut().for_each(|c| {
            c.damping = 0.0;
            c.orientation.iter_mut().for_each(|o| o.damping = 0.0);
        });
        m.integrator = Integrator::Rk4;
        m.timestep = 2.5e-4;
        m
    };
    let cases = [
        ("joint equality", 0usize),
        ("connect", 1),
        ("weld", 2),
        ("all three", 3),
    ];
    for (name, which) in cases {
        let mut m = undamped();
        if which == 1 || which == 2 {
            m.equalities.clear();
        }
        m.connects.retain(|c| match which {
            1 => c.orientation.is_none(),
            2 => c.orientation.is_some(),
            3 => true,
            _ => false,
        });
        let mut state = State {
            q: m.tree.q0(),
            v: vec![0.0; m.tree.nv],
            act: vec![],
        };
        let u = vec![0.0; m.nu()];
        let opts = AdvanceOptions {
            energy_guard: false,
            ..Default::default()
        };
        let e0 = m.energy(&state.q, &state.v);
        let (mut worst, mut added) = (0.0f64, 0.0f64);
        let mut without = m.clone();
        without
            .equalities
            .iter_mut()
            .for_each(|e| e.impedance = 0.0);
        without.connects.iter_mut().for_each(|c| {
            c.impedance = 0.0;
            c.orientation.iter_mut().for_each(|o| o.impedance = 0.0);
        });
        for k in 0..40 {
            let t = 0.05 * k as f64;
            state = (m.advance(&state, &u, &m.contact, t, 0.05, &opts))
                .unwrap()
                .state;
            let e = m.energy(&state.q, &state.v);
            worst = worst.max((e.total() - e0.total()).abs());
            added = added.max(e.kinetic - without.energy(&state.q, &state.v).kinetic);
        }
        let swing = e0.gravity.abs();
        println!("{name}: drift {worst:.3e} J of {swing:.3e} J; added kinetic up to {added:.3e} J");
        assert!(added > 0.0, "{name}: the rows move");
        assert!(worst < 1e-9 * swing, "{name}: {worst} vs {swing}");
    }
}

#[test]
fn the_rows_turning_is_the_rate_of_their_rates_along_the_motion() {
    // At a state of the coupled fixture away from the reference, every joint moving: each
    // equality row's `J̇ v` (the polynomial's curvature for the joint equality; the points' and
    // the bodies' velocity-product accelerations for the connect and the weld) against central
    // differences of `J v` along `q(t) = q ⊕ t v` at fixed `v`.
    let model = coupled();
    let tree = &model.tree;
    let mut q = tree.q0();
    for (k, x) in q.iter_mut().enumerate().take(5) {
        *x += 0.3 + 0.2 * k as f64;
    }
    let v: Vec<f64> = (0..tree.nv)
        .map(|k| (1.7 * k as f64 + 0.4).sin() * 2.0)
        .collect();
    let at = |t: f64| tree.integrate_q(&q, &v, t);
    let e = 1e-6;
    for eq in &model.equalities {
        let rate = |t: f64| {
            eq.row(&at(t), tree.nv)
                .dot(&nalgebra::DVector::from_column_slice(&v))
        };
        let fd = (rate(e) - rate(-e)) / (2.0 * e);
        let got = eq.turning(&q, &v);
        assert!(got.abs() > 0.1, "{got}: the row turns");
        assert!(
            (got - fd).abs() < 1e-6 * fd.abs().max(1.0),
            "{} {got} vs {fd}",
            eq.name
        );
    }
    let kin = tree.kinematics(&q, &v);
    let bias = tree.bias_accelerations(&kin);
    for k in &model.connects {
        let rates = |t: f64| k.row_rates(&tree.kinematics(&at(t), &v).frames);
        let (up, down) = (rates(e), rates(-e));
        let got = k.row_turnings(&kin.frames, &bias);
        let rows = if k.orientation.is_some() { 6 } else { 3 };
        for r in 0..rows {
            let fd = (up[r] - down[r]) / (2.0 * e);
            assert!(
                (got[r] - fd).abs() < 1e-6 * fd.abs().max(1.0),
                "{} row {r}: {} vs {fd}",
                k.name,
                got[r]
            );
        }
        assert!(got.iter().any(|x| x.abs() > 0.1), "{}: {got:?}", k.name);
    }
}
