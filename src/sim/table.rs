//! The variable table: every FMU variable of a model (name, causality, unit, description) and
//! the slot of the simulation it reads or writes; the model's description built from it.

use super::derivative_rows::push_derivative_rows;
use super::{names, structure};
use crate::contact::Param;
use crate::dynamics::JointKind;
use crate::fmi::contract::{
    Capabilities, Causality, DefaultExperiment, Initial, ModelInfo, VarType, Variability, Variable,
};
use crate::model::Model;
use crate::scalar::PRUNE_TOLERANCE_MAX;

/// What a row of the variable table reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Slot {
    /// Simulation time.
    Time,
    /// A position coordinate `q[i]`.
    Q(usize),
    /// A velocity coordinate `v[i]`.
    V(usize),
    /// An actuator control.
    Ctrl(usize),
    /// Activation `k` of the actuators with activation dynamics (a state).
    Act(usize),
    /// Time derivative of activation `k` (a Model Exchange state derivative).
    ActDot(usize),
    /// Input pose of mocap body `m` (index into `Tree::mocap`): `k` = 0..3 position x, y, z (m,
    /// world frame), 3..7 quaternion w, x, y, z.
    Mocap(usize, usize),
    /// A contact parameter.
    Param(Param),
    /// Force on the pair's first body, world axis.
    PairForce(usize, usize),
    /// Torque on the pair's first body about its origin, world axis.
    PairTorque(usize, usize),
    /// Smooth separation distance of a pair.
    PairDistance(usize),
    /// Generalized force of joint `j`'s limit (N or N·m).
    LimitForce(usize),
    /// Force of fixed tendon `t`'s limit along the tendon.
    TendonLimitForce(usize),
    /// Force of spatial tendon `t`'s limit along the tendon (N).
    SpatialTendonLimitForce(usize),
    /// Soft top-K contact point `k` of a pair, world axis (scenes with `scm_contact_points`).
    PairPoint(usize, usize, usize),
    /// Internal step.
    SolverStep,
    /// Local error tolerance.
    SolverTolerance,
    /// Integrator name (String).
    SolverIntegrator,
    /// The point clouds' pruning tolerance (`scm.prune_tolerance`, fixed).
    PruneTolerance,
    /// Time derivative of the position coordinate `q[i]` (a Model Exchange state derivative).
    QDot(usize),
    /// Time derivative of the velocity coordinate `v[i]`: an acceleration (a Model Exchange
    /// state derivative, and an output, so that Co-Simulation has direct feedthrough from the
    /// controls).
    VDot(usize),
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Builds the variable table of a model: one row per FMU variable, value references in table
/// order. This table is the single source of truth for `modelDescription.xml`, get/set and
/// directional derivatives.
pub fn variable_table(model: &Model) -> Vec<(Variable, Slot)> {
    let mut rows: Vec<(Variable, Slot)> = Vec::new();
    let (q0, v0) = (&model.q0, &model.v0);
    let mut push =
        |name: String, causality, variability, initial, var_type, description: String, slot| {
            let value_reference = rows.len() as u32;
            rows.push((
                Variable {
                    name,
                    value_reference,
                    causality,
                    variability,
                    initial,
                    var_type,
                    description,
                },
                slot,
            ));
        };
    let real = |start: Option<f64>, unit: &'static str| VarType::Real {
        start,
        unit: Some(unit),
        derivative: None,
    };
    push(
        "time".into(),
        Causality::Independent,
        Variability::Continuous,
        None,
        VarType::Real {
            start: None,
            unit: Some("s"),
            derivative: None,
        },
        "Simulation time".into(),
        Slot::Time,
    );
    for j in &model.tree.joints {
        let body = &model.tree.bodies[j.body].name;
        let jn = names::identifier(&j.name);
        let state = |push: &mut dyn FnMut(
            String,
            Causality,
            Variability,
            Option<Initial>,
            VarType,
            String,
            Slot,
        ),
                     name: String,
                     start: f64,
                     unit: &'static str,
                     desc: String,
                     slot: Slot| {
            push(
                name,
                Causality::Output,
                Variability::Continuous,
                Some(Initial::Exact),
                real(Some(start), unit),
                desc,
                slot,
            );
        };
        match j.kind {
            JointKind::Slide | JointKind::Hinge => {
                let (u, uv, what) = if j.kind == JointKind::Slide {
                    ("m", "m/s", "displacement")
                } else {
                    ("rad", "rad/s", "angle")
                };
                state(
                    &mut push,
                    format!("{jn}.q"),
                    q0[j.qadr],
                    u,
                    format!(
                        "{} {what} of joint {} (body {body})",
                        if j.kind == JointKind::Slide {
                            "Slide"
                        } else {
                            "Hinge"
                        },
                        j.name
                    ),
                    Slot::Q(j.qadr),
                );
                state(
                    &mut push,
                    format!("{jn}.v"),
                    v0[j.dadr],
                    uv,
                    format!("Velocity of joint {}", j.name),
                    Slot::V(j.dadr),
                );
            }
            JointKind::Free | JointKind::Ball => {
                let qa = if j.kind == JointKind::Free {
                    j.qadr + 3
                } else {
                    j.qadr
                };
                if j.kind == JointKind::Free {
                    for (k, a) in AXES.iter().enumerate() {
                        state(
                            &mut push,
                            format!("{jn}.pos.{a}"),
                            q0[j.qadr + k],
                            "m",
                            format!("Position of body {body} (world frame)"),
                            Slot::Q(j.qadr + k),
                        );
                    }
                }
                for (k, a) in ["w", "x", "y", "z"].iter().enumerate() {
                    state(
                        &mut push,
                        format!("{jn}.quat.{a}"),
                        q0[qa + k],
                        "1",
                        format!(
                            "Orientation quaternion of body {body} (normalized at initialization)"
                        ),
                        Slot::Q(qa + k),
                    );
                }
                let da = if j.kind == JointKind::Free {
                    for (k, a) in AXES.iter().enumerate() {
                        state(
                            &mut push,
                            format!("{jn}.linvel.{a}"),
                            v0[j.dadr + k],
                            "m/s",
                            format!("Velocity of the origin of body {body} (world frame)"),
                            Slot::V(j.dadr + k),
                        );
                    }
                    j.dadr + 3
                } else {
                    j.dadr
                };
                for (k, a) in AXES.iter().enumerate() {
                    state(
                        &mut push,
                        format!("{jn}.angvel.{a}"),
                        v0[da + k],
                        "rad/s",
                        format!("Angular velocity of body {body} (body frame)"),
                        Slot::V(da + k),
                    );
                }
            }
        }
    }
    for (j, jt) in model.tree.joints.iter().enumerate() {
        let Some(limit) = &jt.limit else { continue };
        let unit = if jt.kind == JointKind::Slide {
            "N"
        } else {
            "N.m"
        };
        push(
            format!("{}.limit.force", names::identifier(&jt.name)),
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Calculated),
            real(None, unit),
            format!(
                "Force of joint {}'s limit [{}, {}] along the joint (positive towards larger values): a smooth one-sided spring and damper, zero inside the range{}",
                jt.name,
                limit.lo,
                limit.hi,
                if limit.impedance > 0.0 {
                    "; the spring and damper's push only: the limit also adds an inertia where it pushes (MuJoCo's impedance) and lets go where the whole would pull"
                } else {
                    ""
                }
            ),
            Slot::LimitForce(j),
        );
    }
    for (t, tendon) in model.tendons.iter().enumerate() {
        let Some(limit) = &tendon.limit else { continue };
        push(
            format!("tendon.{}.limit.force", names::identifier(&tendon.name)),
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Calculated),
            // No unit: a tendon's length mixes its joints' (m and rad) through its coefficients.
            VarType::Real {
                start: None,
                unit: None,
                derivative: None,
            },
            format!(
                "Force of fixed tendon {}'s limit [{}, {}] along the tendon (positive towards longer): a smooth one-sided spring and damper, zero inside the range",
                tendon.name, limit.lo, limit.hi
            ),
            Slot::TendonLimitForce(t),
        );
    }
    for (t, tendon) in model.spatial_tendons.iter().enumerate() {
        let Some(limit) = &tendon.law.limit else {
            continue;
        };
        push(
            format!("tendon.{}.limit.force", names::identifier(&tendon.name)),
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Calculated),
            real(None, "N"),
            format!(
                "Force of spatial tendon {}'s limit [{}, {}] m along the tendon (positive towards longer): a smooth one-sided spring and damper, zero inside the range",
                tendon.name, limit.lo, limit.hi
            ),
            Slot::SpatialTendonLimitForce(t),
        );
    }
    for (i, a) in model.actuators.iter().enumerate() {
        let target = model.actuator_target(a);
        push(
            format!("{}.ctrl", names::identifier(&a.name)),
            Causality::Input,
            Variability::Continuous,
            None,
            VarType::Real {
                start: Some(model.ctrl0[i]),
                unit: None,
                derivative: None,
            },
            format!("Control of actuator {} on {target}", a.name),
            Slot::Ctrl(i),
        );
    }
    for (k, a) in (model.actuators.iter())
        .filter(|a| a.activation.is_some())
        .enumerate()
    {
        push(
            format!("{}.act", names::identifier(&a.name)),
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Exact),
            VarType::Real {
                start: Some(model.act0[k]),
                unit: None,
                derivative: None,
            },
            match a.activation.map(|d| d.law) {
                Some(crate::model::ActivationLaw::PidIntegral { ki, .. }) => format!(
                    "Error integral of PID actuator {} (its force adds {ki} times its next value)",
                    a.name
                ),
                _ => format!(
                    "Activation of actuator {} (its force law reads it in place of its control)",
                    a.name
                ),
            },
            Slot::Act(k),
        );
    }
    let mocap0 = model.tree.mocap0();
    for (m, &b) in model.tree.mocap.iter().enumerate() {
        let name = &model.tree.bodies[b].name;
        let id = names::identifier(name);
        let start = |k: usize| mocap0[crate::dynamics::MOCAP_INPUTS * m + k];
        for (k, a) in AXES.iter().enumerate() {
            push(format!("{id}.pos.{a}"), Causality::Input, Variability::Continuous, None, real(Some(start(k)), "m"), format!("Position of mocap body {name} (world frame), reached at the end of the next communication step"), Slot::Mocap(m, k));
        }
        for (k, a) in ["w", "x", "y", "z"].iter().enumerate() {
            push(format!("{id}.quat.{a}"), Causality::Input, Variability::Continuous, None, real(Some(start(3 + k)), "1"), format!("Orientation quaternion of mocap body {name} (normalized on use), reached at the end of the next communication step"), Slot::Mocap(m, 3 + k));
        }
    }
    for (p, pair) in model.pairs.iter().enumerate() {
        let (na, nb) = (
            &model.tree.bodies[pair.a].name,
            &model.tree.bodies[pair.b].name,
        );
        let (ia, ib) = (names::identifier(na), names::identifier(nb));
        for (k, a) in AXES.iter().enumerate() {
            push(
                format!("contact.{ia}.{ib}.force.{a}"),
                Causality::Output,
                Variability::Continuous,
                Some(Initial::Calculated),
                real(None, "N"),
                format!(
                    "Contact force on {na} from {nb} (world frame; zero where the pair is proven out of reach, as the dynamics apply it); {nb} receives the opposite"
                ),
                Slot::PairForce(p, k),
            );
        }
        for (k, a) in AXES.iter().enumerate() {
            push(
                format!("contact.{ia}.{ib}.torque.{a}"),
                Causality::Output,
                Variability::Continuous,
                Some(Initial::Calculated),
                real(None, "N.m"),
                format!("Contact torque on {na} about its origin (world frame)"),
                Slot::PairTorque(p, k),
            );
        }
        push(
            format!("contact.{ia}.{ib}.distance"),
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Calculated),
            real(None, "m"),
            format!("Smooth separation distance between {na} and {nb} (negative: penetration; the first distance read at a state evaluates every pair in full)"),
            Slot::PairDistance(p),
        );
        for k in 0..model.contact_points {
            for (i, a) in AXES.iter().enumerate() {
                push(
                    format!("contact.{ia}.{ib}.point{}.{a}", k + 1),
                    Causality::Output,
                    Variability::Continuous,
                    Some(Initial::Calculated),
                    real(None, "m"),
                    format!(
                        "Soft top-K contact point {} of {na} and {nb} (world frame)",
                        k + 1
                    ),
                    Slot::PairPoint(p, k, i),
                );
            }
        }
    }
    for prm in Param::ALL {
        let (name, unit, desc) = prm.describe();
        push(
            format!("scm.{name}"),
            Causality::Parameter,
            Variability::Tunable,
            Some(Initial::Exact),
            real(Some(prm.get(&model.contact)), unit),
            desc.into(),
            Slot::Param(prm),
        );
    }
    push(
        "solver.integrator".into(),
        Causality::Parameter,
        Variability::Fixed,
        Some(Initial::Exact),
        VarType::String {
            start: Some(model.integrator.name().into()),
        },
        format!(
            "Integrator of the internal steps: one of {}",
            crate::integrate::Integrator::ALL
                .map(|i| i.name())
                .join(", ")
        ),
        Slot::SolverIntegrator,
    );
    push("solver.step".into(), Causality::Parameter, Variability::Fixed, Some(Initial::Exact), real(Some(model.timestep), "s"), "Internal step: a communication step is split into equal internal steps no longer than this".into(), Slot::SolverStep);
    push(
        "solver.tolerance".into(),
        Causality::Parameter,
        Variability::Fixed,
        Some(Initial::Exact),
        real(Some(model.tolerance), "1"),
        "Local error tolerance of the adaptive integrator".into(),
        Slot::SolverTolerance,
    );
    // Only where a point cloud reads it: a parameter a host sets acts, or is not there.
    if let Some(tolerance) = model.prune_tolerance() {
        push(
            "scm.prune_tolerance".into(),
            Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
            real(Some(tolerance), "1"),
            format!("Pruning tolerance: softmax terms and point forces below this weight relative to the largest are skipped, from above 0 to {PRUNE_TOLERANCE_MAX:e} (the scene's scm_prune_tolerance; 1e-15 by default); larger is faster and less exact"),
            Slot::PruneTolerance,
        );
    }
    // Distinct MJCF names give distinct FMU names, except where two kinds of element share
    // variable names (a free joint and a mocap body of one name): resolved, never refused.
    let mut all: Vec<String> = rows.iter().map(|(v, _)| v.name.clone()).collect();
    for (k, old) in names::make_unique(&mut all) {
        rows[k].0.description = format!(
            "{} (named {old} in the scene; renamed to be unique)",
            rows[k].0.description
        );
        rows[k].0.name = std::mem::take(&mut all[k]);
    }
    push_derivative_rows(&mut rows);
    rows
}

/// 64-bit FNV-1a (the GUID uses two lanes of it); see [`crate::fmi::serial::fnv1a`].
pub use crate::fmi::serial::fnv1a;

/// The FMU's GUID: a hash of the scene text and this crate's version, so an FMU refuses a
/// binary or a saved state from another scene or version.
pub fn guid(scene_text: &str) -> String {
    let mut bytes = scene_text.as_bytes().to_vec();
    bytes.extend_from_slice(env!("CARGO_PKG_VERSION").as_bytes());
    let (a, b) = (fnv1a(&bytes, 0), fnv1a(&bytes, 0x9e37_79b9_7f4a_7c15));
    format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        a >> 32,
        (a >> 16) & 0xffff,
        a & 0xffff,
        b >> 48,
        b & 0xffff_ffff_ffff
    )
}

/// The `ModelInfo` of a scene: Co-Simulation and Model Exchange, FMU state get/set and
/// serialization, and exact directional derivatives, all implemented by [`Simulation`](super::Simulation);
/// `<ModelStructure>` from [`structure::model_structure`].
pub fn model_info(model: &Model, scene_text: &str, rows: &[(Variable, Slot)]) -> ModelInfo {
    ModelInfo {
        model_name: model.name.clone(),
        guid: guid(scene_text),
        description: format!(
            "Soft-minimum contact model: scene {} ({} bodies, {} joints, {} contact pairs)",
            model.name,
            model.tree.bodies.len() - 1,
            model.tree.joints.len(),
            model.pairs.len()
        ),
        generation_tool: format!("scm {}", env!("CARGO_PKG_VERSION")),
        variables: rows.iter().map(|(v, _)| v.clone()).collect(),
        structure: structure::model_structure(model, rows),
        number_of_event_indicators: 0,
        model_exchange: true,
        capabilities: Capabilities {
            can_get_and_set_fmu_state: true,
            can_serialize_fmu_state: true,
            provides_directional_derivative: true,
        },
        default_experiment: DefaultExperiment {
            start_time: Some(0.0),
            stop_time: Some(2.0),
            tolerance: None,
            step_size: Some(model.timestep.max(0.01)),
        },
    }
}
