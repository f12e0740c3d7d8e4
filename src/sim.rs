//! A running simulation of a model: state, parameters, the variable table of the FMU and the
//! co-simulation step. This is the model side of the FMI contract ([`FmiModel`]); it holds no
//! pointer and knows nothing of C.

use crate::contact::{ContactParams, PairContact};
use crate::dynamics::JointKind;
use crate::fmi::contract::{
    Capabilities, Causality, DefaultExperiment, FmiModel, Initial, LogCategory, LogMessage,
    ModelInfo, ModelResult, Phase, StepError, VarType, Variability, Variable,
};
use crate::integrate::{Integrator, State};
use crate::model::Model;
use crate::scene::{self, Scene};
use std::path::Path;

pub mod jacobian;
pub mod names;
mod state_bytes;
pub mod structure;

pub use crate::contact::Param;
pub use crate::scene::SCENE_FILE;

/// What a row of the variable table reads or writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Slot {
    /// Simulation time.
    Time,
    /// A position coordinate `q[i]`.
    Q(usize),
    /// A velocity coordinate `v[i]`.
    V(usize),
    /// An actuator control.
    Ctrl(usize),
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
    /// Soft top-K contact point `k` of a pair, world axis (scenes with `scm_contact_points`).
    PairPoint(usize, usize, usize),
    /// Internal step.
    SolverStep,
    /// Local error tolerance.
    SolverTolerance,
    /// Integrator name (String).
    SolverIntegrator,
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
                "Force of joint {}'s limit [{}, {}] along the joint (positive towards larger values): a smooth one-sided spring and damper, zero inside the range",
                jt.name, limit.lo, limit.hi
            ),
            Slot::LimitForce(j),
        );
    }
    for (i, a) in model.actuators.iter().enumerate() {
        let jn = &model.tree.joints[a.joint].name;
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
            format!("Control of actuator {} on joint {jn}", a.name),
            Slot::Ctrl(i),
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
                    "Contact force on {na} from {nb} (world frame); {nb} receives the opposite"
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
            format!("Smooth separation distance between {na} and {nb} (negative: penetration)"),
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
    push("solver.step".into(), Causality::Parameter, Variability::Fixed, Some(Initial::Exact), real(Some(model.step), "s"), "Internal step: a communication step is split into equal internal steps no longer than this".into(), Slot::SolverStep);
    push(
        "solver.tolerance".into(),
        Causality::Parameter,
        Variability::Fixed,
        Some(Initial::Exact),
        real(Some(model.tolerance), "1"),
        "Local error tolerance of the adaptive integrator".into(),
        Slot::SolverTolerance,
    );
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

/// Appends the state derivatives `der(<state>)` of every position and velocity coordinate, in
/// coordinate order (`q` then `v`, which is the order of the continuous states). Position
/// derivatives are local; velocity derivatives (accelerations) are outputs.
fn push_derivative_rows(rows: &mut Vec<(Variable, Slot)>) {
    let mut states: Vec<(Slot, u32, String, Option<&'static str>)> = rows
        .iter()
        .filter(|(_, s)| matches!(s, Slot::Q(_) | Slot::V(_)))
        .map(|(v, s)| {
            (
                *s,
                v.value_reference,
                v.name.clone(),
                match v.var_type {
                    VarType::Real { unit, .. } => unit,
                    _ => None,
                },
            )
        })
        .collect();
    states.sort_by_key(|(s, ..)| match *s {
        Slot::Q(i) => i,
        Slot::V(i) => usize::MAX / 2 + i,
        _ => usize::MAX,
    });
    for (slot, state_vr, name, unit) in states {
        let (unit, slot, causality, what) = match (slot, unit) {
            (Slot::Q(i), Some("m")) => ("m/s", Slot::QDot(i), Causality::Local, "Time derivative"),
            (Slot::Q(i), Some("rad")) => {
                ("rad/s", Slot::QDot(i), Causality::Local, "Time derivative")
            }
            (Slot::Q(i), _) => ("1/s", Slot::QDot(i), Causality::Local, "Time derivative"),
            (Slot::V(i), Some("m/s")) => (
                "m/s2",
                Slot::VDot(i),
                Causality::Output,
                "Acceleration (time derivative)",
            ),
            (Slot::V(i), _) => (
                "rad/s2",
                Slot::VDot(i),
                Causality::Output,
                "Acceleration (time derivative)",
            ),
            _ => continue,
        };
        let value_reference = rows.len() as u32;
        let description =
            format!("{what} time derivative of {name} (Model Exchange state derivative)");
        let var_type = VarType::Real {
            start: None,
            unit: Some(unit),
            derivative: Some(state_vr),
        };
        rows.push((
            Variable {
                name: format!("der({name})"),
                value_reference,
                causality,
                variability: Variability::Continuous,
                initial: None,
                var_type,
                description,
            },
            slot,
        ));
    }
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
/// serialization, and exact directional derivatives, all implemented by [`Simulation`];
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
            step_size: Some(model.step.max(0.01)),
        },
    }
}

/// The time-varying part of a simulation: what `fmi2GetFMUstate` saves.
#[derive(Clone, Debug, PartialEq)]
pub struct SimState {
    /// Simulation time (s).
    pub time: f64,
    /// Positions and velocities.
    pub state: State<f64>,
    /// Actuator controls.
    pub ctrl: Vec<f64>,
    /// Contact parameters (tunable).
    pub params: ContactParams<f64>,
    /// Mocap bodies at `time`: `MOCAP_INPUTS` numbers each (pose, and the velocity of the last
    /// communication step), the mocap part of the model's inputs `u`.
    pub mocap: Vec<f64>,
    /// Mocap inputs as set by the host (7 per body: position, quaternion): the pose each mocap
    /// body reaches at the end of the next communication step.
    pub mocap_target: Vec<f64>,
    /// Model Exchange only: the mocap poses (7 per body) at the host's last completed
    /// integrator step and its time, from which the mocap velocities are estimated.
    pub mocap_sampled: Option<(f64, Vec<f64>)>,
}

/// What `fmi2GetFMUstate` saves: the time-varying state and the solver settings (which the
/// host may set before initialization), so that restoring it reproduces a rollout bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct FmuState {
    /// Time, positions, velocities, controls and contact parameters.
    pub sim: SimState,
    /// Integrator of the internal steps.
    pub integrator: Integrator,
    /// Internal step (s).
    pub step: f64,
    /// Local error tolerance.
    pub tolerance: f64,
    /// What the integrator carries between communication steps (the implicit method's Newton
    /// Jacobian): part of the state, since the next step's last bits depend on it.
    pub solver_cache: crate::integrate::SolverCache,
}

/// A quaternion whose norm differs from 1 by more than this after a step of the host's solver
/// (Model Exchange) is projected back onto the unit sphere at an event (see
/// [`Simulation::quaternion_drift`]).
pub const QUATERNION_DRIFT_TOLERANCE: f64 = 1e-6;

/// Soft top-K contact points per pair, with the positions (`q`, then the mocap poses) and ε1, ε2
/// they belong to.
type PointsCache = (Vec<f64>, f64, f64, Vec<Vec<nalgebra::Vector3<f64>>>);

/// A simulation of a scene: the model, its current state and what the FMU exposes of it.
///
/// # Example
///
/// A 0.1 kg sphere dropped onto a floor comes to rest on it, carried by the contact force:
///
/// ```
/// use std::path::Path;
/// use scm::sim::Simulation;
///
/// let xml = r#"<mujoco>
///   <option timestep="0.001"/>
///   <worldbody>
///     <geom name="floor" type="plane" size="1 1 0.1"/>
///     <body name="ball" pos="0 0 0.2">
///       <freejoint/><geom type="sphere" size="0.05" mass="0.1"/>
///     </body>
///   </worldbody>
/// </mujoco>"#;
/// let scene = scm::scene::load_str(xml, Path::new("drop.xml"))?;
/// let mut sim = Simulation::new(scene, xml);
/// sim.advance(1.0)?;
/// let z = sim.current.state.q[2];
/// assert!((z - 0.05).abs() < 2e-3, "resting height {z}");
/// // The floor (first body of the pair) carries the ball's weight.
/// let on_floor = sim.contacts()[0].on_a.force.z;
/// assert!((on_floor + 0.1 * 9.81).abs() < 1e-3, "floor force {on_floor}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Simulation {
    /// The model.
    pub model: Model,
    rows: Vec<(Variable, Slot)>,
    info: ModelInfo,
    /// Current state.
    pub current: SimState,
    start: SimState,
    /// Contact outputs at the current state, computed on demand.
    outputs: Option<Vec<PairContact<f64>>>,
    /// Soft top-K contact points per pair and the positions and ε1, ε2 they were computed at.
    points: Option<PointsCache>,
    /// What the integrator carries between communication steps (a Newton Jacobian).
    cache: crate::integrate::SolverCache,
    messages: Vec<LogMessage>,
    /// Accelerations `v̇` and the (time, state, controls, parameters) they were computed at.
    accelerations: Option<(SimState, Vec<f64>)>,
    /// Solver settings of the scene (restored by `fmi2Reset`).
    start_solver: (Integrator, f64, f64),
    /// Whether the host sees `logContact` messages (so diagnostics are only formatted then).
    log_contact: bool,
    /// Whether the host instantiated Model Exchange (mocap inputs then act at once).
    model_exchange: bool,
}

impl Simulation {
    /// A simulation of a loaded scene, at its initial state.
    pub fn new(scene: Scene, scene_text: &str) -> Simulation {
        let model = scene.model;
        let rows = variable_table(&model);
        let info = model_info(&model, scene_text, &rows);
        let mocap = model.tree.mocap0();
        let mocap_target = mocap
            .chunks(crate::dynamics::MOCAP_INPUTS)
            .flat_map(|m| m[..7].to_vec())
            .collect();
        let start = SimState {
            time: 0.0,
            state: State {
                q: model.q0.clone(),
                v: model.v0.clone(),
            },
            ctrl: model.ctrl0.clone(),
            params: model.contact,
            mocap,
            mocap_target,
            mocap_sampled: None,
        };
        let messages = scene
            .warnings
            .into_iter()
            .map(|text| LogMessage {
                category: LogCategory::StatusWarning,
                text,
            })
            .collect();
        let start_solver = (model.integrator, model.step, model.tolerance);
        let mut sim = Simulation {
            model,
            rows,
            info,
            current: start.clone(),
            start,
            outputs: None,
            points: None,
            cache: Default::default(),
            messages,
            accelerations: None,
            start_solver,
            log_contact: false,
            model_exchange: false,
        };
        for p in [Param::Eps1, Param::Eps2, Param::Eps3] {
            if let Some(text) = sim.smoothing_warning(p, p.get(&sim.current.params)) {
                sim.messages.push(LogMessage {
                    category: LogCategory::StatusWarning,
                    text,
                });
            }
        }
        sim
    }

    /// A warning when a smoothing length (`√ε1`, `ε2`, `ε3`) is as large as the smallest body
    /// in contact: the model is then no longer contact (ε1 smooths the SSDF over the whole
    /// body, ε2 averages the separation distribution instead of taking its minimum, ε3 pushes
    /// at any distance), though it stays finite. `None` for other parameters or smaller values.
    fn smoothing_warning(&self, p: Param, value: f64) -> Option<String> {
        let (length, what) = match p {
            Param::Eps1 => (value.sqrt(), "its square root smooths each SSDF over the whole body"),
            Param::Eps2 => (value, "the separation distribution becomes an average over the bodies instead of a soft minimum"),
            Param::Eps3 => (value, "the softplus pushes at any distance within the bodies' reach"),
            _ => return None,
        };
        let smallest = self
            .model
            .colliders
            .iter()
            .flatten()
            .filter_map(|c| match c {
                crate::collision::Collider::Aopc(s) if !s.is_empty() => Some(s.bvh().diameter),
                _ => None,
            });
        let smallest = smallest.fold(f64::INFINITY, f64::min);
        (length >= smallest).then(|| {
            let (name, unit, _) = p.describe();
            format!("scm.{name} = {value:e} {unit} is as large as the smallest colliding body ({smallest:.3e} m across): {what}; the result is finite but no longer contact")
        })
    }

    /// Loads a scene file and starts a simulation of it.
    pub fn from_file(path: &Path) -> Result<Simulation, scene::SceneError> {
        let text = scene::read_text(path)?;
        Ok(Simulation::new(scene::load_str(&text, path)?, &text))
    }

    /// The variable table.
    pub fn rows(&self) -> &[(Variable, Slot)] {
        &self.rows
    }

    fn row(&self, vr: u32) -> ModelResult<&(Variable, Slot)> {
        self.rows
            .get(vr as usize)
            .ok_or_else(|| format!("unknown value reference {vr}"))
    }

    /// The model's inputs `u` at the current time (see [`Model::nu`]): actuator controls, then
    /// each mocap body's pose and velocity. This is what [`Model::forward`] and
    /// [`Model::step`] take.
    pub fn inputs(&self) -> Vec<f64> {
        [self.current.ctrl.as_slice(), self.current.mocap.as_slice()].concat()
    }

    /// Contact of every pair at the current state.
    pub fn contacts(&mut self) -> &[PairContact<f64>] {
        if self.outputs.is_none() {
            let kin = self.model.tree.kinematics_with(
                &self.current.state.q,
                &self.current.state.v,
                &self.current.mocap,
            );
            self.outputs = Some(self.model.contacts(&kin, &self.current.params).1);
        }
        self.outputs.as_deref().unwrap_or(&[])
    }

    /// Soft top-K contact points of every pair at the current positions (world frame), cached
    /// until the positions or ε1, ε2 change.
    pub fn contact_points(&mut self) -> &[Vec<nalgebra::Vector3<f64>>] {
        let (q, e1, e2) = (
            &self.current.state.q,
            self.current.params.eps1,
            self.current.params.eps2,
        );
        let fresh = matches!(&self.points, Some((pq, p1, p2, _)) if *pq == [q.as_slice(), &self.current.mocap].concat() && *p1 == e1 && *p2 == e2);
        if !fresh {
            let kin =
                self.model
                    .tree
                    .kinematics_with(q, &self.current.state.v, &self.current.mocap);
            let pts = self
                .model
                .pairs
                .iter()
                .map(
                    |pair| match (&self.model.colliders[pair.a], &self.model.colliders[pair.b]) {
                        (Some(a), Some(b)) => crate::collision::contact_points(
                            a,
                            &kin.frames[pair.a],
                            b,
                            &kin.frames[pair.b],
                            e1,
                            e2,
                            self.model.contact_points,
                        ),
                        _ => Vec::new(),
                    },
                )
                .collect();
            self.points = Some(([q.as_slice(), &self.current.mocap].concat(), e1, e2, pts));
        }
        self.points.as_ref().map(|p| p.3.as_slice()).unwrap_or(&[])
    }

    /// Advances by `h` (s), landing exactly on `time + h`: in equal internal steps no longer than
    /// `solver.step`, or adaptive ones for `dopri5` (see [`Model::advance`]).
    ///
    /// Mocap bodies move from their pose at `time` to the pose last set through their inputs
    /// (`B.pos`, `B.quat`), reached exactly at `time + h`, with constant linear and angular
    /// velocity (position: linear interpolation; orientation: the constant-rate rotation
    /// `q ⊗ exp(t ω/2)`, ω = log(q⁻¹ ⊗ q_target)/h): the velocity the contact model sees is the
    /// input's rate over the communication step, and it is kept as the mocap body's velocity for
    /// the outputs at `time + h`.
    ///
    /// On failure (a non-finite state, an energy blow-up, a dynamics error) the simulation keeps
    /// everything from before the call and the error says what went wrong and when.
    pub fn advance(&mut self, h: f64) -> Result<(), StepError> {
        if !h.is_finite() || h <= 0.0 {
            return Err(StepError::Error(format!(
                "a step of {h} s refused: it must be positive and finite"
            )));
        }
        let mocap = self.mocap_path(h)?;
        let mut u = self.current.ctrl.clone();
        u.extend_from_slice(&mocap);
        let t0 = self.current.time;
        let done = self
            .model
            .advance_cached(
                &self.current.state,
                &u,
                &self.current.params,
                t0,
                h,
                &crate::integrate::AdvanceOptions::default(),
                &mut self.cache,
            )
            .map_err(|e| {
                StepError::Discard(format!(
                    "{e}; the state is kept at t = {t0} s: retry with a smaller step{}",
                    if self.model.integrator.is_explicit() {
                        ", or the implicit integrator implicit_euler"
                    } else {
                        ""
                    }
                ))
            })?;
        self.current.state = done.state;
        // Land the mocap bodies exactly on their targets, keeping the step's velocity.
        self.current.mocap = mocap;
        for (m, target) in self.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let q = crate::dynamics::quat_from(&target[3..7]);
            self.current.mocap[o..o + 7]
                .copy_from_slice(&[target[0], target[1], target[2], q.w, q.i, q.j, q.k]);
        }
        self.current.time += h;
        self.outputs = None;
        Ok(())
    }

    /// Model Exchange: at a completed integrator step of the host, the mocap bodies' velocities
    /// become the rate of their poses (the inputs) over the host's last step (position: the
    /// difference over the step; orientation: `log(q_prev⁻¹ ⊗ q)/Δt`, body frame), held until
    /// the next completed step. In Co-Simulation the rate is known ahead (the step's target), so
    /// this does nothing there.
    fn sample_mocap(&mut self) {
        if !self.model_exchange || self.model.tree.mocap.is_empty() {
            return;
        }
        let t = self.current.time;
        let poses: Vec<f64> = self
            .current
            .mocap
            .chunks(crate::dynamics::MOCAP_INPUTS)
            .flat_map(|m| m[..7].to_vec())
            .collect();
        if let Some((t0, prev)) = &self.current.mocap_sampled {
            let dt = t - t0;
            if dt > 0.0 {
                for (m, (now, before)) in poses.chunks(7).zip(prev.chunks(7)).enumerate() {
                    let o = crate::dynamics::MOCAP_INPUTS * m;
                    let q0 = crate::dynamics::quat_from(&before[3..7]);
                    let q1 = crate::dynamics::quat_from(&now[3..7]);
                    let w = crate::dynamics::quat_log(&(q0.conjugate() * q1)) / dt;
                    for k in 0..3 {
                        self.current.mocap[o + 7 + k] = (now[k] - before[k]) / dt;
                        self.current.mocap[o + 10 + k] = w[k];
                    }
                }
                self.outputs = None;
            }
        }
        self.current.mocap_sampled = Some((t, poses));
    }

    /// The mocap part of the inputs for a communication step of `h` (s): the current poses with
    /// the velocities that reach the targets at its end.
    fn mocap_path(&self, h: f64) -> Result<Vec<f64>, StepError> {
        let mut out = self.current.mocap.clone();
        for (m, target) in self.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let name = &self.model.tree.bodies[self.model.tree.mocap[m]].name;
            if target[3..7].iter().all(|&x| x == 0.0) {
                return Err(StepError::Error(format!(
                    "{name}.quat is zero: set a non-zero orientation quaternion"
                )));
            }
            let q0 = crate::dynamics::quat_from(&out[o + 3..o + 7]);
            let q1 = crate::dynamics::quat_from(&target[3..7]);
            let w = crate::dynamics::quat_log(&(q0.conjugate() * q1)) / h;
            for k in 0..3 {
                out[o + 7 + k] = (target[k] - out[o + k]) / h;
                out[o + 10 + k] = w[k];
            }
        }
        Ok(out)
    }

    fn check_finite(name: &str, value: f64) -> ModelResult<()> {
        if value.is_finite() {
            Ok(())
        } else {
            Err(format!(
                "{name} = {value:?} refused: the value must be finite"
            ))
        }
    }
}

/// Name of the first non-finite coordinate of a state, if any (see
/// [`Model::first_non_finite`]).
pub fn first_non_finite(model: &Model, s: &State<f64>) -> Option<String> {
    model.first_non_finite(s)
}

/// Model Exchange, directional derivatives and diagnostics.
impl Simulation {
    /// Accelerations `v̇` at the current state, controls and parameters (computed once per
    /// distinct state: the cache is keyed by the state itself, so no code path can leave it
    /// stale).
    pub fn accelerations(&mut self) -> ModelResult<&[f64]> {
        let fresh = matches!(&self.accelerations, Some((at, _)) if at.state == self.current.state && at.ctrl == self.current.ctrl && at.mocap == self.current.mocap && at.params == self.current.params);
        if !fresh {
            let c = &self.current;
            let f = self
                .model
                .forward(&c.state.q, &c.state.v, &self.inputs(), &c.params)
                .map_err(|e| format!("forward dynamics at t = {} s: {e}", c.time))?;
            self.accelerations = Some((self.current.clone(), f.vdot.iter().copied().collect()));
        }
        Ok(self
            .accelerations
            .as_ref()
            .map(|(_, a)| a.as_slice())
            .unwrap_or_default())
    }

    /// Start index in `q` of every quaternion (free and ball joints).
    fn quaternions(&self) -> Vec<usize> {
        self.model
            .tree
            .joints
            .iter()
            .filter_map(|j| match j.kind {
                JointKind::Free => Some(j.qadr + 3),
                JointKind::Ball => Some(j.qadr),
                _ => None,
            })
            .collect()
    }

    /// Largest `| |quaternion| - 1 |` of the current state.
    ///
    /// In Model Exchange the host's solver owns the state, and the quaternions are part of it.
    /// The model is well defined off the unit sphere (kinematics normalizes the quaternion, and
    /// `q̇ = ½ q ⊗ (0, ω)` is tangent to the sphere, so the exact flow keeps the norm), but a
    /// numerical solver drifts slowly. After each completed integrator step the model asks for
    /// an event when the drift exceeds [`QUATERNION_DRIFT_TOLERANCE`], and at the event
    /// ([`FmiModel::event_update`]) it normalizes the quaternions and reports that the states
    /// changed, so the host re-reads them and restarts its solver from the unit sphere.
    pub fn quaternion_drift(&self) -> f64 {
        self.quaternions()
            .iter()
            .map(|&i| {
                (self.current.state.q[i..i + 4]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt()
                    - 1.0)
                    .abs()
            })
            .fold(0.0, f64::max)
    }

    /// Continuous states `x = [q; v]` (Model Exchange).
    pub fn continuous_states(&self) -> Vec<f64> {
        self.current
            .state
            .q
            .iter()
            .chain(&self.current.state.v)
            .copied()
            .collect()
    }

    /// Queues one `logContact` message per pair with its smooth distance, force and torque at
    /// the current state (only when the host has the category on).
    fn log_contacts(&mut self) {
        if !self.log_contact {
            return;
        }
        let t = self.current.time;
        let names: Vec<(String, String)> = self
            .model
            .pairs
            .iter()
            .map(|p| {
                (
                    self.model.tree.bodies[p.a].name.clone(),
                    self.model.tree.bodies[p.b].name.clone(),
                )
            })
            .collect();
        let contacts = self.contacts().to_vec();
        for ((a, b), c) in names.iter().zip(contacts) {
            let (f, m) = (c.on_a.force, c.on_a.torque);
            let text = format!(
                "t = {t} s: contact {a}-{b}: distance D = {:.6e} m, force on {a} = ({:.6e}, {:.6e}, {:.6e}) N, torque on {a} = ({:.6e}, {:.6e}, {:.6e}) N.m",
                c.distance, f.x, f.y, f.z, m.x, m.y, m.z
            );
            self.messages.push(LogMessage {
                category: LogCategory::Contact,
                text,
            });
        }
    }
}

impl FmiModel for Simulation {
    type State = FmuState;

    fn instantiate(resources: &Path) -> ModelResult<Self> {
        let path = resources.join(SCENE_FILE);
        Simulation::from_file(&path).map_err(|e| e.to_string())
    }

    fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// The start time only: the plumbing owns `stopTime` (it refuses a step past it before
    /// calling [`FmiModel::do_step`], and saves it with the FMU state).
    fn setup_experiment(
        &mut self,
        start_time: f64,
        _stop_time: Option<f64>,
        _tolerance: Option<f64>,
    ) -> ModelResult<()> {
        Self::check_finite("startTime", start_time)?;
        // Only the current time: `fmi2Reset` goes back to the instantiated state (t = 0).
        self.current.time = start_time;
        Ok(())
    }

    fn enter_initialization(&mut self) -> ModelResult<()> {
        Ok(())
    }

    fn exit_initialization(&mut self) -> ModelResult<()> {
        // Normalize the quaternions the host set; a zero quaternion is an error.
        for j in &self.model.tree.joints {
            let qa = match j.kind {
                JointKind::Free => j.qadr + 3,
                JointKind::Ball => j.qadr,
                _ => continue,
            };
            let q = &mut self.current.state.q[qa..qa + 4];
            // Scale by the largest component first, so huge components do not overflow.
            let m = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if m.is_nan() || m <= 0.0 {
                return Err(format!(
                    "{}.quat is zero: set a non-zero orientation quaternion",
                    j.name
                ));
            }
            q.iter_mut().for_each(|x| *x /= m);
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            q.iter_mut().for_each(|x| *x /= n);
        }
        self.outputs = None;
        self.messages.push(LogMessage {
            category: LogCategory::Events,
            text: format!(
                "initialized {} at t = {} s",
                self.model.name, self.current.time
            ),
        });
        if self.model_exchange {
            // Mocap velocities are rates between completed integrator steps from here on.
            self.sample_mocap();
        }
        Ok(())
    }

    fn interface_chosen(&mut self, model_exchange: bool) {
        self.model_exchange = model_exchange;
    }

    fn reset(&mut self) -> ModelResult<()> {
        self.current = self.start.clone();
        (self.model.integrator, self.model.step, self.model.tolerance) = self.start_solver;
        self.cache = Default::default();
        self.outputs = None;
        self.messages.push(LogMessage {
            category: LogCategory::Events,
            text: "reset to the start values".into(),
        });
        Ok(())
    }

    fn time(&self) -> f64 {
        self.current.time
    }

    fn get_real(&mut self, vr: u32) -> ModelResult<f64> {
        let slot = self.row(vr)?.1;
        Ok(match slot {
            Slot::Time => self.current.time,
            Slot::Q(i) => self.current.state.q[i],
            Slot::V(i) => self.current.state.v[i],
            Slot::Ctrl(i) => self.current.ctrl[i],
            Slot::Mocap(m, k) => self.current.mocap_target[7 * m + k],
            Slot::Param(p) => p.get(&self.current.params),
            Slot::PairForce(p, k) => self.contacts()[p].on_a.force[k],
            Slot::PairTorque(p, k) => self.contacts()[p].on_a.torque[k],
            Slot::PairDistance(p) => self.contacts()[p].distance,
            Slot::LimitForce(j) => {
                let jt = &self.model.tree.joints[j];
                let s = &self.current.state;
                jt.limit
                    .as_ref()
                    .map_or(0.0, |l| l.force(s.q[jt.qadr], s.v[jt.dadr]))
            }
            Slot::PairPoint(p, k, i) => self.contact_points()[p].get(k).map_or(f64::NAN, |c| c[i]),
            Slot::SolverStep => self.model.step,
            Slot::SolverTolerance => self.model.tolerance,
            Slot::SolverIntegrator => {
                return Err(format!(
                    "solver.integrator (value reference {vr}) is a String variable"
                ))
            }
            Slot::QDot(i) => self
                .model
                .tree
                .qdot(&self.current.state.q, &self.current.state.v)[i],
            Slot::VDot(i) => self.accelerations()?[i],
        })
    }

    fn set_real(&mut self, vr: u32, value: f64, phase: Phase) -> ModelResult<()> {
        let (var, slot) = self.row(vr)?.clone();
        Self::check_finite(&var.name, value)?;
        let before_init = phase != Phase::Simulation;
        match slot {
            Slot::Q(i) | Slot::V(i) if before_init => {
                if matches!(slot, Slot::Q(_)) {
                    self.current.state.q[i] = value;
                } else {
                    self.current.state.v[i] = value;
                }
            }
            Slot::Ctrl(i) => self.current.ctrl[i] = value,
            Slot::Mocap(m, k) => {
                // Before initialization the pose is set at once (at rest). Later, in
                // Co-Simulation it is the target the next communication step moves to; in
                // Model Exchange the pose at the current time (its velocity is estimated at the
                // host's completed integrator steps, see `Simulation::sample_mocap`).
                self.current.mocap_target[7 * m + k] = value;
                if self.model_exchange && !before_init {
                    self.current.mocap[crate::dynamics::MOCAP_INPUTS * m + k] = value;
                } else if before_init {
                    let o = crate::dynamics::MOCAP_INPUTS * m;
                    self.current.mocap[o + k] = value;
                    self.current.mocap[o + 7..o + 13].fill(0.0);
                }
            }
            Slot::Param(p) => {
                if !p.accepts(value) {
                    return Err(format!(
                        "{} = {value:?} refused: it must be {}",
                        var.name,
                        if p == Param::Friction {
                            "non-negative"
                        } else {
                            "positive"
                        }
                    ));
                }
                // Tunable at any time; `fmi2Reset` restores the scene's value.
                *p.slot(&mut self.current.params) = value;
                if let Some(text) = self.smoothing_warning(p, value) {
                    self.messages.push(LogMessage {
                        category: LogCategory::StatusWarning,
                        text,
                    });
                }
            }
            Slot::SolverStep | Slot::SolverTolerance if before_init => {
                if value.is_nan() || value <= 0.0 {
                    return Err(format!(
                        "{} = {value:?} refused: it must be positive",
                        var.name
                    ));
                }
                if slot == Slot::SolverStep {
                    self.model.step = value;
                } else {
                    self.model.tolerance = value;
                }
            }
            _ => {
                return Err(format!(
                    "{} (value reference {vr}) cannot be set {}",
                    var.name,
                    if before_init {
                        ""
                    } else {
                        "after initialization"
                    }
                )
                .trim_end()
                .to_string())
            }
        }
        self.outputs = None;
        Ok(())
    }

    fn get_string(&mut self, vr: u32) -> ModelResult<String> {
        match self.row(vr)?.1 {
            Slot::SolverIntegrator => Ok(self.model.integrator.name().into()),
            _ => Err(format!("value reference {vr} is not a String variable")),
        }
    }

    fn set_string(&mut self, vr: u32, value: &str, phase: Phase) -> ModelResult<()> {
        match self.row(vr)?.1 {
            Slot::SolverIntegrator if phase != Phase::Simulation => {
                self.model.integrator =
                    crate::integrate::Integrator::from_name(value).ok_or_else(|| {
                        format!(
                            "solver.integrator = \"{value}\" refused: known integrators are {}",
                            crate::integrate::Integrator::ALL
                                .map(|i| i.name())
                                .join(", ")
                        )
                    })?;
                Ok(())
            }
            Slot::SolverIntegrator => {
                Err("solver.integrator cannot be set after initialization".into())
            }
            _ => Err(format!("value reference {vr} is not a String variable")),
        }
    }

    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError> {
        if !step.is_finite() || step <= 0.0 {
            return Err(StepError::Error(format!(
                "communicationStepSize = {step} refused: it must be positive and finite"
            )));
        }
        let before = self.current.time;
        self.current.time = current_time;
        if let Err(e) = self.advance(step) {
            self.current.time = before;
            return Err(e);
        }
        self.current.time = current_time + step;
        self.log_contacts();
        Ok(())
    }

    fn take_messages(&mut self) -> Vec<LogMessage> {
        std::mem::take(&mut self.messages)
    }

    fn get_state(&self) -> ModelResult<FmuState> {
        Ok(FmuState {
            sim: self.current.clone(),
            integrator: self.model.integrator,
            step: self.model.step,
            tolerance: self.model.tolerance,
            solver_cache: self.cache.clone(),
        })
    }

    fn set_state(&mut self, state: &FmuState) -> ModelResult<()> {
        let s = &state.sim;
        if (s.state.q.len(), s.state.v.len(), s.ctrl.len())
            != (
                self.model.tree.nq,
                self.model.tree.nv,
                self.model.actuators.len(),
            )
        {
            return Err("the FMU state belongs to another scene (its sizes differ)".into());
        }
        self.current = state.sim.clone();
        (self.model.integrator, self.model.step, self.model.tolerance) =
            (state.integrator, state.step, state.tolerance);
        self.cache = state.solver_cache.clone();
        self.outputs = None;
        Ok(())
    }

    fn serialize_state(&self, state: &FmuState) -> ModelResult<Vec<u8>> {
        Ok(state_bytes::encode(state))
    }

    fn deserialize_state(&self, bytes: &[u8]) -> ModelResult<FmuState> {
        state_bytes::decode(&self.model, bytes)
    }

    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
    ) -> ModelResult<Vec<f64>> {
        let mut u = Vec::with_capacity(unknowns.len());
        for &vr in unknowns {
            let (var, slot) = self.row(vr)?;
            if structure::knowns_of(&self.model, *slot).is_none() {
                return Err(format!("{} (value reference {vr}) is not an unknown: the unknowns are the outputs and the state derivatives", var.name));
            }
            u.push(*slot);
        }
        let mut k = Vec::with_capacity(knowns.len());
        for &vr in knowns {
            let (var, slot) = self.row(vr)?;
            if !matches!(
                slot,
                Slot::Q(_)
                    | Slot::V(_)
                    | Slot::Ctrl(_)
                    | Slot::Mocap(..)
                    | Slot::Param(_)
                    | Slot::Time
            ) {
                return Err(format!("{} (value reference {vr}) is not a known: the knowns are the states, the inputs and the contact parameters", var.name));
            }
            k.push(*slot);
        }
        if let Some(i) = dv_known.iter().position(|d| !d.is_finite()) {
            return Err(format!("dvKnown[{i}] = {} is not finite", dv_known[i]));
        }
        jacobian::directional_derivative(
            &self.model,
            &self.current,
            &u,
            &k,
            dv_known,
            self.model_exchange,
        )
    }

    fn number_of_states(&self) -> usize {
        self.model.tree.nq + self.model.tree.nv
    }

    fn set_time(&mut self, time: f64) -> ModelResult<()> {
        // Nothing depends on time explicitly: no cache to drop.
        self.current.time = time;
        Ok(())
    }

    fn get_continuous_states(&mut self) -> ModelResult<Vec<f64>> {
        Ok(self.continuous_states())
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> ModelResult<()> {
        let nq = self.model.tree.nq;
        for (j, qa) in self.model.tree.joints.iter().filter_map(|j| match j.kind {
            JointKind::Free => Some((j, j.qadr + 3)),
            JointKind::Ball => Some((j, j.qadr)),
            _ => None,
        }) {
            if x[qa..qa + 4].iter().all(|&c| c == 0.0) {
                return Err(format!("the quaternion of joint {} (x[{qa}..{}]) is zero: it has no orientation; the states are unchanged", j.name, qa + 4));
            }
        }
        self.current.state.q.copy_from_slice(&x[..nq]);
        self.current.state.v.copy_from_slice(&x[nq..]);
        self.outputs = None;
        Ok(())
    }

    fn get_derivatives(&mut self) -> ModelResult<Vec<f64>> {
        let mut dx = self
            .model
            .tree
            .qdot(&self.current.state.q, &self.current.state.v);
        dx.extend_from_slice(self.accelerations()?);
        if let Some(i) = dx.iter().position(|d| !d.is_finite()) {
            return Err(format!(
                "the derivative of state {i} is {} at t = {} s",
                dx[i], self.current.time
            ));
        }
        Ok(dx)
    }

    fn completed_integrator_step(&mut self) -> ModelResult<bool> {
        self.sample_mocap();
        self.log_contacts();
        Ok(self.quaternion_drift() > QUATERNION_DRIFT_TOLERANCE)
    }

    fn event_update(&mut self) -> ModelResult<bool> {
        // Project the quaternions that left the unit sphere; one already unit (to rounding)
        // keeps its bits, so an event without drift changes no state.
        let mut changed = false;
        for i in self.quaternions() {
            let q = &mut self.current.state.q[i..i + 4];
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if (n - 1.0).abs() > 4.0 * f64::EPSILON {
                q.iter_mut().for_each(|x| *x /= n);
                changed = true;
            }
        }
        if changed {
            self.outputs = None;
        }
        Ok(changed)
    }

    fn logging_changed(&mut self, category: LogCategory, on: bool) {
        if category == LogCategory::Contact {
            self.log_contact = on;
        }
    }
}
