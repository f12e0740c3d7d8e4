//! Exact directional derivatives of the FMU's unknowns (`fmi2GetDirectionalDerivative`), by one
//! forward-mode pass of the model's own (scalar-generic) math on dual numbers.
//!
//! The knowns are the states (`q`, `v`, activations), the inputs (controls) and the tunable contact
//! parameters; the pass seeds each with its component of the direction `dv_known`, so the dual
//! part of every unknown is `J[unknown, knowns] · dv_known` exactly (no step size, no
//! truncation error). Unknowns: the states themselves, their derivatives (`q̇`, and the
//! accelerations `v̇` from forward dynamics) and the contact outputs.

use num_dual::Dual64;

use super::{Param, SimState, Slot};
use crate::contact::{ContactParams, PairContact};
use crate::model::Model;
use crate::scalar::c;

/// A state, controls and parameters lifted to dual numbers, seeded with a direction.
struct Seeded {
    q: Vec<Dual64>,
    v: Vec<Dual64>,
    /// Activations.
    act: Vec<Dual64>,
    /// The model's inputs `u`: actuator controls, then the mocap bodies' poses and velocities.
    u: Vec<Dual64>,
    prm: ContactParams<Dual64>,
}

fn seed(
    model: &Model,
    state: &SimState,
    knowns: &[Slot],
    dv: &[f64],
    model_exchange: bool,
) -> Result<Seeded, String> {
    let lift = |x: &[f64]| x.iter().map(|&x| c::<Dual64>(x)).collect::<Vec<_>>();
    let mut s = Seeded {
        q: lift(&state.state.q),
        v: lift(&state.state.v),
        act: lift(&state.state.act),
        u: lift(&[state.ctrl.as_slice(), &state.mocap].concat()),
        prm: state.params.lift(),
    };
    for (&slot, &d) in knowns.iter().zip(dv) {
        // A known listed twice gets the sum of its directions (the derivative is linear in them).
        let x = match slot {
            Slot::Q(i) => &mut s.q[i],
            Slot::V(i) => &mut s.v[i],
            Slot::Act(k) => &mut s.act[k],
            Slot::Ctrl(i) => &mut s.u[i],
            Slot::Param(p) => match p {
                Param::Eps1 => &mut s.prm.eps1,
                Param::Eps2 => &mut s.prm.eps2,
                Param::Eps3 => &mut s.prm.eps3,
                Param::Stiffness => &mut s.prm.stiffness,
                Param::DissipationVelocity => &mut s.prm.dissipation_velocity,
                Param::StictionVelocity => &mut s.prm.stiction_velocity,
                Param::Friction => &mut s.prm.friction,
            },
            // In Model Exchange a mocap input is its body's pose now.
            Slot::Mocap(m, k) if model_exchange => {
                &mut s.u[model.actuators.len() + crate::dynamics::MOCAP_INPUTS * m + k]
            }
            // Nothing depends on time (the dynamics is autonomous), and in Co-Simulation a
            // mocap input is the pose its body reaches at the end of the next communication
            // step: nothing depends on it at the current time.
            Slot::Time | Slot::Mocap(..) => continue,
            _ => return Err(format!("{slot:?} is not a known")),
        };
        x.eps += d;
    }
    Ok(s)
}

/// `J[unknowns, knowns] · dv` at `state` (controls and parameters included in it). `knowns`
/// must be states, controls, parameters or time; `unknowns` states, state derivatives or contact
/// outputs (the caller maps value references to slots and names them in errors).
///
/// `model_exchange`: whether a mocap input acts at once (Model Exchange) or at the end of the
/// next communication step (Co-Simulation: no instantaneous effect).
pub fn directional_derivative(
    model: &Model,
    state: &SimState,
    unknowns: &[Slot],
    knowns: &[Slot],
    dv: &[f64],
    model_exchange: bool,
) -> Result<Vec<f64>, String> {
    let s = seed(model, state, knowns, dv, model_exchange)?;
    let needs_vdot = unknowns.iter().any(|u| matches!(u, Slot::VDot(_)));
    // The force laws read the activations where they have them.
    let driven = model.driven_inputs(&s.u, &s.act, &s.q, None);
    let needs_contacts = unknowns.iter().any(|u| {
        matches!(
            u,
            Slot::PairForce(..) | Slot::PairTorque(..) | Slot::PairDistance(_)
        )
    });
    let kin = || {
        model
            .tree
            .kinematics_with(&s.q, &s.v, &s.u[model.actuators.len()..])
    };
    let pulls = model.pulls(&driven);
    // As the outputs read them (`src/sim/outputs.rs`): the applied contacts, a pair out of
    // reach with zero wrenches (and derivatives) and, only when its distance is asked, that
    // distance from a full evaluation.
    let complete = |applied: Vec<Option<PairContact<Dual64>>>| {
        let skipped_distance = unknowns
            .iter()
            .any(|u| matches!(u, Slot::PairDistance(p) if applied[*p].is_none()));
        if skipped_distance {
            model.complete_contacts(&kin(), &s.prm, &pulls, &applied)
        } else {
            applied
                .into_iter()
                .map(|c| c.unwrap_or_else(PairContact::none))
                .collect()
        }
    };
    let (vdot, contacts) = if needs_vdot {
        let f = model
            .forward(&s.q, &s.v, &driven, &s.prm)
            .map_err(|e| e.to_string())?;
        (Some(f.vdot), Some(complete(f.contacts)))
    } else if needs_contacts {
        (
            None,
            Some(complete(model.contact_forces(&kin(), &s.prm, &pulls).1)),
        )
    } else {
        (None, None)
    };
    let qdot = unknowns
        .iter()
        .any(|u| matches!(u, Slot::QDot(_)))
        .then(|| model.tree.qdot(&s.q, &s.v));
    let points = unknowns
        .iter()
        .any(|u| matches!(u, Slot::PairPoint(..)))
        .then(|| {
            let kin = kin();
            model
                .pairs
                .iter()
                .map(
                    |pair| match (&model.colliders[pair.a], &model.colliders[pair.b]) {
                        (Some(a), Some(b)) => crate::collision::contact_points(
                            a,
                            &kin.frames[pair.a],
                            b,
                            &kin.frames[pair.b],
                            pair.eps1_sides(s.prm.eps1),
                            s.prm.eps2,
                            model.contact_points,
                        ),
                        _ => Vec::new(),
                    },
                )
                .collect::<Vec<_>>()
        });
    let missing = || "internal error: a needed evaluation was skipped".to_string();
    unknowns
        .iter()
        .map(|&u| {
            let d: Dual64 = match u {
                Slot::Q(i) => s.q[i],
                Slot::V(i) => s.v[i],
                Slot::Act(k) => s.act[k],
                Slot::ActDot(k) => {
                    model.activation_rates(&s.act, &s.u[..model.actuators.len()], &s.q)[k]
                }
                Slot::QDot(i) => qdot.as_ref().ok_or_else(missing)?[i],
                Slot::VDot(i) => vdot.as_ref().ok_or_else(missing)?[i],
                Slot::PairForce(p, k) => contacts.as_ref().ok_or_else(missing)?[p].on_a.force[k],
                Slot::PairTorque(p, k) => contacts.as_ref().ok_or_else(missing)?[p].on_a.torque[k],
                Slot::PairDistance(p) => contacts.as_ref().ok_or_else(missing)?[p].distance,
                Slot::LimitForce(j) => {
                    let jt = &model.tree.joints[j];
                    jt.limit
                        .as_ref()
                        .map_or(Dual64::from(0.0), |l| l.force(s.q[jt.qadr], s.v[jt.dadr]))
                }
                Slot::TendonLimitForce(t) => {
                    let tendon = &model.tendons[t];
                    tendon.limit.as_ref().map_or(Dual64::from(0.0), |l| {
                        l.force(tendon.length(&s.q), tendon.velocity(&s.v))
                    })
                }
                Slot::SpatialTendonLimitForce(t) => {
                    let tendon = &model.spatial_tendons[t];
                    let kin =
                        (model.tree).kinematics_with(&s.q, &s.v, &s.u[model.actuators.len()..]);
                    let (l, ldot) = tendon.length_and_rate(&kin.frames);
                    (tendon.law.limit.as_ref()).map_or(Dual64::from(0.0), |lim| lim.force(l, ldot))
                }
                Slot::PairPoint(p, k, i) => points.as_ref().ok_or_else(missing)?[p]
                    .get(k)
                    .map_or(Dual64::from(0.0), |c| c[i]),
                _ => return Err(format!("{u:?} is not an unknown")),
            };
            // Out of contact the distance is +inf with a NaN dual part: report 0 (it does not
            // change with anything).
            Ok(if d.re.is_finite() { d.eps } else { 0.0 })
        })
        .collect()
}
