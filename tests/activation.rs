//! Actuator activation dynamics: the laws stepped as MuJoCo steps them, the activations as FMU
//! states (derivatives, dependencies, directional derivatives against central differences,
//! saved and restored states), and a state of the wrong size refused.

use scm::fmi::contract::{FmiModel, Phase};
use scm::integrate::{Integrator, State};
use scm::model::ActivationLaw;
use scm::sim::Simulation;

/// Four activated actuators on a hinge and a slide: a filter, a clamped integrator with an
/// affine bias, a position servo's filterexact (`timeconst`), and an `actearly` filterexact
/// whose gain grows with the slide's length (so the acceleration's derivative with respect to
/// its activation depends on the state); beside them a motor without activation.
const SCENE: &str = r#"<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      <body name="slider" pos=".3 0 0">
        <joint name="s" type="slide" axis="1 0 0"/>
        <geom type="box" size=".05 .05 .05"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="filt" joint="h" dyntype="filter" dynprm="0.05" gainprm="2" ctrlrange="-1 1" ctrllimited="true"/>
    <general name="integ" joint="s" dyntype="integrator" gainprm="3" biastype="affine" biasprm="0 -3 -0.5" actlimited="true" actrange="-0.2 0.3" ctrlrange="-1 1" ctrllimited="true"/>
    <position name="pos" joint="h" kp="4" timeconst="0.03"/>
    <general name="early" joint="s" dyntype="filterexact" dynprm="0.02" actearly="true" gaintype="affine" gainprm="1.5 2 0"/>
    <motor name="plain" joint="h"/>
  </actuator>
</mujoco>"#;

fn sim() -> Simulation {
    let scene = scm::scene::load_str(SCENE, std::path::Path::new("activation.xml")).unwrap();
    Simulation::new(scene, SCENE)
}

fn vr(sim: &Simulation, name: &str) -> u32 {
    let v = sim.info().variables.iter().find(|v| v.name == name);
    v.unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

#[test]
fn the_laws_are_read_as_mujoco_reads_them_and_stepped_as_it_steps_them() {
    let s = sim();
    let m = &s.model;
    assert_eq!(m.na(), 4);
    let laws: Vec<ActivationLaw> = (m.actuators.iter())
        .filter_map(|a| a.activation.map(|d| d.law))
        .collect();
    assert_eq!(
        laws,
        [
            ActivationLaw::Filter { tau: 0.05 },
            ActivationLaw::Integrator,
            ActivationLaw::FilterExact { tau: 0.03 },
            ActivationLaw::FilterExact { tau: 0.02 },
        ]
    );
    // Rates: the controls clamped to their ranges first (2 -> 1, -3 -> -1).
    let act = [0.1, 0.25, -0.2, 0.4];
    let ctrl = [2.0, -3.0, 0.5, -1.0, 7.0];
    let q = m.q0.clone();
    let r = m.activation_rates(&act, &ctrl, &q);
    let expect = [
        (1.0 - 0.1) / 0.05,
        -1.0,
        (0.5 + 0.2) / 0.03,
        (-1.0 - 0.4) / 0.02,
    ];
    for (a, b) in r.iter().zip(expect) {
        assert!((a - b).abs() < 1e-12 * b.abs(), "{a} vs {b}");
    }
    // An Euler-family step: the filter by Euler's rule, the integrator clamped to its range
    // (0.25 - 0.01 stays inside; from 0.29 upwards it stops at 0.3), filterexact exactly.
    let h = 0.01;
    let next = m.next_activations(&act, &r, h);
    assert!((next[0] - (0.1 + h * expect[0])).abs() < 1e-15);
    assert!((next[1] - 0.24).abs() < 1e-15);
    for (k, (u, a, tau)) in [(2, (0.5, -0.2, 0.03)), (3, (-1.0, 0.4, 0.02))] {
        let exact = u + (a - u) * f64::exp(-h / tau);
        assert!((next[k] - exact).abs() < 1e-15, "{} vs {exact}", next[k]);
    }
    let up = m.next_activations(&[0.1, 0.29, 0.0, 0.0], &[0.0, 5.0, 0.0, 0.0], h);
    assert_eq!(up[1], 0.3);
    // The force laws read the activations (the motor its control); with actearly, the
    // activation after the step.
    let u = m.driven_inputs(&ctrl, &act, &q, Some(h));
    assert_eq!(&u[..3], &act[..3]);
    assert!((u[3] - next[3]).abs() < 1e-15);
    assert_eq!(u[4], 7.0);
    assert_eq!(m.driven_inputs(&ctrl, &act, &q, None)[3], act[3]);
}

#[test]
fn every_integrator_moves_the_activations_toward_their_controls() {
    // Held controls: a filter's activation approaches its control as 1 - e^{-t/τ}; the
    // integrator's rises at its control's rate until its range stops it.
    let mut s = sim();
    for integrator in Integrator::ALL {
        let m = &mut s.model;
        m.set_integrator(integrator);
        let ctrl = vec![0.8, 1.0, -0.5, 0.6, 0.0];
        let mut u = ctrl.clone();
        u.extend(m.tree.mocap0());
        let mut st = State {
            q: m.q0.clone(),
            v: m.v0.clone(),
            act: m.act0.clone(),
        };
        let h = 0.001;
        for _ in 0..100 {
            st = m.step(&st, &u, &m.contact, h).unwrap();
        }
        let t: f64 = 0.1;
        let filter = 0.8 * (1.0 - (-t / 0.05).exp());
        // Euler's rule on the filter is first order: within h/(2τ) of the exact curve.
        let tol = if integrator.order() > 1 { 1e-7 } else { 0.02 };
        assert!(
            (st.act[0] - filter).abs() < tol,
            "{integrator:?}: {} vs {filter}",
            st.act[0]
        );
        // filterexact is exact over an Euler-family step; RK4 applies its exact rule to the
        // stages' weighted rate, as MuJoCo's does (a lag of about h/(2τ) of the change).
        let exact = -0.5 * (1.0 - (-t / 0.03).exp());
        let tol = match integrator {
            Integrator::Rk4 | Integrator::DampedRk4 => 0.02,
            _ => tol,
        };
        assert!(
            (st.act[2] - exact).abs() < tol,
            "{integrator:?}: {}",
            st.act[2]
        );
        assert!(
            (st.act[1] - t).abs() < 1e-12,
            "{integrator:?}: {}",
            st.act[1]
        );
        for _ in 0..300 {
            st = m.step(&st, &u, &m.contact, h).unwrap();
        }
        assert_eq!(
            st.act[1], 0.3,
            "{integrator:?}: clamped at the top of actrange"
        );
    }
    // A state without the model's activations is refused, not read as a model without them.
    let m = &s.model;
    let bare = State::new(m.q0.clone(), m.v0.clone());
    let err = m.step(&bare, &m.u0(), &m.contact, 0.001).unwrap_err();
    assert!(err.to_string().contains("actuators have 4"), "{err}");
    // So are inputs of the wrong length, and a derivative point without the activations.
    let full = State {
        q: m.q0.clone(),
        v: m.v0.clone(),
        act: m.act0.clone(),
    };
    for integrator in Integrator::ALL {
        let err = (m.step_with(integrator, &full, &[0.1], &m.contact, 0.001)).unwrap_err();
        assert!(
            err.to_string().contains("1 inputs given"),
            "{integrator:?}: {err}"
        );
    }
    let mut point = scm::derivatives::Point::start(m);
    point.act.clear();
    let coords = scm::derivatives::Coordinates::Embedded;
    let err = scm::derivatives::forward_jacobian(m, &point, coords).unwrap_err();
    assert!(err.to_string().contains("actuators have 4"), "{err}");
}

#[test]
fn activation_derivatives_and_their_directional_derivatives_match_central_differences() {
    let mut s = sim();
    s.interface_chosen(true);
    for (name, x) in [
        ("filt.ctrl", 0.4),
        ("integ.ctrl", -0.7),
        ("pos.ctrl", 0.3),
        ("early.ctrl", -0.6),
        ("plain.ctrl", 0.2),
        ("filt.act", 0.2),
        ("integ.act", -0.1),
        ("pos.act", 0.5),
        ("early.act", 0.3),
        ("s.q", 0.05),
        ("h.v", 0.3),
    ] {
        s.set_real(vr(&s, name), x, Phase::Instantiated).unwrap();
    }
    s.enter_initialization().unwrap();
    s.exit_initialization().unwrap();
    // The continuous states end with the activations, their derivatives with the rates.
    let x = s.get_continuous_states().unwrap();
    assert_eq!(x.len(), s.number_of_states());
    assert_eq!(&x[x.len() - 4..], &[0.2, -0.1, 0.5, 0.3]);
    let dx = s.get_derivatives().unwrap();
    let rates = [
        (0.4 - 0.2) / 0.05,
        -0.7,
        (0.3 - 0.5) / 0.03,
        (-0.6 - 0.3) / 0.02,
    ];
    for (a, b) in dx[dx.len() - 4..].iter().zip(rates) {
        assert!((a - b).abs() < 1e-12 * b.abs(), "{a} vs {b}");
    }
    let unknowns: Vec<u32> = [
        "der(h.v)",
        "der(s.v)",
        "der(filt.act)",
        "der(pos.act)",
        "der(early.act)",
    ]
    .iter()
    .map(|n| vr(&s, n))
    .collect();
    let knowns = [
        "filt.act",
        "integ.act",
        "pos.act",
        "early.act",
        "filt.ctrl",
        "early.ctrl",
        "plain.ctrl",
        "s.q",
        "h.q",
    ];
    let values = |s: &mut Simulation| -> Vec<f64> {
        (unknowns.iter()).map(|&u| s.get_real(u).unwrap()).collect()
    };
    for known in knowns {
        let k = vr(&s, known);
        let exact = s.directional_derivative(&unknowns, &[k], &[1.0]).unwrap();
        let x0 = s.get_real(k).unwrap();
        let d = 1e-6;
        s.set_real(k, x0 + d, Phase::Simulation).unwrap();
        let up = values(&mut s);
        s.set_real(k, x0 - d, Phase::Simulation).unwrap();
        let down = values(&mut s);
        s.set_real(k, x0, Phase::Simulation).unwrap();
        for (i, e) in exact.iter().enumerate() {
            let fd = (up[i] - down[i]) / (2.0 * d);
            assert!(
                (e - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                "d {} / d {known}: exact {e}, central differences {fd}",
                s.info().variables[unknowns[i] as usize].name
            );
        }
        // The ModelStructure lists every dependency that is not zero.
        for (i, e) in exact.iter().enumerate() {
            let (_, deps) = (s.info().structure.derivatives.iter())
                .find(|(u, _)| *u == unknowns[i])
                .expect("a state derivative");
            if *e != 0.0 {
                assert!(
                    deps.as_ref().unwrap().contains(&k),
                    "{} depends on {known}",
                    s.info().variables[unknowns[i] as usize].name
                );
            }
        }
    }
    // The accelerations read the activations, not the controls, of activated actuators.
    let a = s
        .directional_derivative(&unknowns[..1], &[vr(&s, "filt.ctrl")], &[1.0])
        .unwrap();
    assert_eq!(a[0], 0.0);
}

#[test]
fn a_saved_state_keeps_the_activations_and_replays_bit_for_bit() {
    let mut s = sim();
    for (name, x) in [
        ("filt.ctrl", 0.9),
        ("integ.ctrl", 0.5),
        ("early.ctrl", -0.4),
    ] {
        s.set_real(vr(&s, name), x, Phase::Instantiated).unwrap();
    }
    s.enter_initialization().unwrap();
    s.exit_initialization().unwrap();
    s.do_step(0.0, 0.05).unwrap();
    let saved = s.get_state().unwrap();
    let bytes = s.serialize_state(&saved).unwrap();
    s.do_step(0.05, 0.05).unwrap();
    let end = s.data.current.clone();
    assert!(end.state.act[0] > 0.5 && end.state.act[1] > 0.0 && end.state.act[3] < -0.3);
    let restored = s.deserialize_state(&bytes).unwrap();
    assert_eq!(restored, saved);
    s.set_state(&restored).unwrap();
    assert_eq!(s.data.current.state.act, saved.sim.state.act);
    s.do_step(0.05, 0.05).unwrap();
    assert_eq!(s.data.current, end, "the restored run replays bit for bit");
    // A state with its activations cut off is refused with a reason.
    let cut = [&bytes[..bytes.len() - 1]].concat();
    assert!(s.deserialize_state(&cut).is_err());
}
