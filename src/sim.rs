//! A running simulation of a model: state, parameters, the variable table of the FMU and the
//! co-simulation step. This is the model side of the FMI contract ([`FmiModel`]); it holds no
//! pointer and knows nothing of C.

use crate::contact::{ContactParams, PairContact};
use crate::dynamics::JointKind;
use crate::fmi::contract::{
    Causality, DefaultExperiment, FmiModel, Initial, LogCategory, LogMessage, ModelInfo, ModelResult, ModelStructure, Phase, StepError, VarType, Variability, Variable,
};
use crate::integrate::State;
use crate::model::Model;
use crate::scene::{self, Scene};
use std::path::Path;

/// Name of the scene file inside an FMU's `resources/` folder.
pub const SCENE_FILE: &str = "scene.xml";

/// A tunable contact parameter (`scm.<name>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// ε1 (m²).
    Eps1,
    /// ε2 (m).
    Eps2,
    /// ε3 (m).
    Eps3,
    /// k (N/m).
    Stiffness,
    /// v_d (m/s).
    DissipationVelocity,
    /// v_s (m/s).
    StictionVelocity,
    /// μ (1).
    Friction,
}

impl Param {
    /// Every parameter, in table order.
    pub const ALL: [Param; 7] = [Param::Eps1, Param::Eps2, Param::Eps3, Param::Stiffness, Param::DissipationVelocity, Param::StictionVelocity, Param::Friction];

    /// `(name, unit, description)`.
    pub fn describe(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Param::Eps1 => ("eps1", "m2", "SSDF softmax temperature over squared distances (smaller: sharper surfaces)"),
            Param::Eps2 => ("eps2", "m", "separation-distribution softmax temperature (smaller: force concentrates on the deepest points)"),
            Param::Eps3 => ("eps3", "m", "softplus smoothing of the penetration (force at zero penetration is k*eps3*ln 2)"),
            Param::Stiffness => ("stiffness", "N/m", "contact stiffness k"),
            Param::DissipationVelocity => ("dissipation_velocity", "m/s", "approach speed at which damping cancels the spring (v_d)"),
            Param::StictionVelocity => ("stiction_velocity", "m/s", "sliding speed below which friction fades (v_s); also smooths joint frictionloss"),
            Param::Friction => ("friction", "1", "friction coefficient mu"),
        }
    }

    /// The parameter's slot.
    pub fn get<T: Copy>(self, p: &ContactParams<T>) -> T {
        match self {
            Param::Eps1 => p.eps1,
            Param::Eps2 => p.eps2,
            Param::Eps3 => p.eps3,
            Param::Stiffness => p.stiffness,
            Param::DissipationVelocity => p.dissipation_velocity,
            Param::StictionVelocity => p.stiction_velocity,
            Param::Friction => p.friction,
        }
    }

    fn slot<T>(self, p: &mut ContactParams<T>) -> &mut T {
        match self {
            Param::Eps1 => &mut p.eps1,
            Param::Eps2 => &mut p.eps2,
            Param::Eps3 => &mut p.eps3,
            Param::Stiffness => &mut p.stiffness,
            Param::DissipationVelocity => &mut p.dissipation_velocity,
            Param::StictionVelocity => &mut p.stiction_velocity,
            Param::Friction => &mut p.friction,
        }
    }

    /// Whether `value` is allowed (finite; positive, or non-negative for friction).
    pub fn accepts(self, value: f64) -> bool {
        value.is_finite() && if self == Param::Friction { value >= 0.0 } else { value > 0.0 }
    }
}

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
    /// Internal step.
    SolverStep,
    /// Local error tolerance.
    SolverTolerance,
    /// Integrator name (String).
    SolverIntegrator,
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Builds the variable table of a model: one row per FMU variable, value references in table
/// order. This table is the single source of truth for `modelDescription.xml`, get/set and
/// directional derivatives.
pub fn variable_table(model: &Model) -> Vec<(Variable, Slot)> {
    let mut rows: Vec<(Variable, Slot)> = Vec::new();
    let q0 = model.tree.q0();
    let mut push = |name: String, causality, variability, initial, var_type, description: String, slot| {
        let value_reference = rows.len() as u32;
        rows.push((Variable { name, value_reference, causality, variability, initial, var_type, description }, slot));
    };
    let real = |start: Option<f64>, unit: &'static str| VarType::Real { start, unit: Some(unit), derivative: None };
    push("time".into(), Causality::Independent, Variability::Continuous, None, VarType::Real { start: None, unit: Some("s"), derivative: None }, "Simulation time".into(), Slot::Time);
    for j in &model.tree.joints {
        let body = &model.tree.bodies[j.body].name;
        let state = |push: &mut dyn FnMut(String, Causality, Variability, Option<Initial>, VarType, String, Slot), name: String, start: f64, unit: &'static str, desc: String, slot: Slot| {
            push(name, Causality::Output, Variability::Continuous, Some(Initial::Exact), real(Some(start), unit), desc, slot);
        };
        match j.kind {
            JointKind::Slide | JointKind::Hinge => {
                let (u, uv, what) = if j.kind == JointKind::Slide { ("m", "m/s", "displacement") } else { ("rad", "rad/s", "angle") };
                state(&mut push, format!("{}.q", j.name), q0[j.qadr], u, format!("{} {what} of joint {} (body {body})", if j.kind == JointKind::Slide { "Slide" } else { "Hinge" }, j.name), Slot::Q(j.qadr));
                state(&mut push, format!("{}.v", j.name), 0.0, uv, format!("Velocity of joint {}", j.name), Slot::V(j.dadr));
            }
            JointKind::Free | JointKind::Ball => {
                let qa = if j.kind == JointKind::Free { j.qadr + 3 } else { j.qadr };
                if j.kind == JointKind::Free {
                    for (k, a) in AXES.iter().enumerate() {
                        state(&mut push, format!("{}.pos.{a}", j.name), q0[j.qadr + k], "m", format!("Position of body {body} (world frame)"), Slot::Q(j.qadr + k));
                    }
                }
                for (k, a) in ["w", "x", "y", "z"].iter().enumerate() {
                    state(&mut push, format!("{}.quat.{a}", j.name), q0[qa + k], "1", format!("Orientation quaternion of body {body} (normalized at initialization)"), Slot::Q(qa + k));
                }
                let da = if j.kind == JointKind::Free {
                    for (k, a) in AXES.iter().enumerate() {
                        state(&mut push, format!("{}.linvel.{a}", j.name), 0.0, "m/s", format!("Velocity of the origin of body {body} (world frame)"), Slot::V(j.dadr + k));
                    }
                    j.dadr + 3
                } else {
                    j.dadr
                };
                for (k, a) in AXES.iter().enumerate() {
                    state(&mut push, format!("{}.angvel.{a}", j.name), 0.0, "rad/s", format!("Angular velocity of body {body} (body frame)"), Slot::V(da + k));
                }
            }
        }
    }
    for (i, a) in model.actuators.iter().enumerate() {
        let jn = &model.tree.joints[a.joint].name;
        push(format!("{}.ctrl", a.name), Causality::Input, Variability::Continuous, None, VarType::Real { start: Some(0.0), unit: None, derivative: None }, format!("Control of actuator {} on joint {jn}", a.name), Slot::Ctrl(i));
    }
    let mocap0 = model.tree.mocap0();
    for (m, &b) in model.tree.mocap.iter().enumerate() {
        let name = &model.tree.bodies[b].name;
        let start = |k: usize| mocap0[crate::dynamics::MOCAP_INPUTS * m + k];
        for (k, a) in AXES.iter().enumerate() {
            push(format!("{name}.pos.{a}"), Causality::Input, Variability::Continuous, None, real(Some(start(k)), "m"), format!("Position of mocap body {name} (world frame), reached at the end of the next communication step"), Slot::Mocap(m, k));
        }
        for (k, a) in ["w", "x", "y", "z"].iter().enumerate() {
            push(format!("{name}.quat.{a}"), Causality::Input, Variability::Continuous, None, real(Some(start(3 + k)), "1"), format!("Orientation quaternion of mocap body {name} (normalized on use), reached at the end of the next communication step"), Slot::Mocap(m, 3 + k));
        }
    }
    for (p, pair) in model.pairs.iter().enumerate() {
        let (na, nb) = (&model.tree.bodies[pair.a].name, &model.tree.bodies[pair.b].name);
        for (k, a) in AXES.iter().enumerate() {
            push(format!("contact.{na}.{nb}.force.{a}"), Causality::Output, Variability::Continuous, Some(Initial::Calculated), real(None, "N"), format!("Contact force on {na} from {nb} (world frame); {nb} receives the opposite"), Slot::PairForce(p, k));
        }
        for (k, a) in AXES.iter().enumerate() {
            push(format!("contact.{na}.{nb}.torque.{a}"), Causality::Output, Variability::Continuous, Some(Initial::Calculated), real(None, "N.m"), format!("Contact torque on {na} about its origin (world frame)"), Slot::PairTorque(p, k));
        }
        push(format!("contact.{na}.{nb}.distance"), Causality::Output, Variability::Continuous, Some(Initial::Calculated), real(None, "m"), format!("Smooth separation distance between {na} and {nb} (negative: penetration)"), Slot::PairDistance(p));
    }
    for prm in Param::ALL {
        let (name, unit, desc) = prm.describe();
        push(format!("scm.{name}"), Causality::Parameter, Variability::Tunable, Some(Initial::Exact), real(Some(prm.get(&model.contact)), unit), desc.into(), Slot::Param(prm));
    }
    push("solver.integrator".into(), Causality::Parameter, Variability::Fixed, Some(Initial::Exact), VarType::String { start: Some(model.integrator.name().into()) }, format!("Integrator of the internal steps: one of {}", crate::integrate::Integrator::ALL.map(|i| i.name()).join(", ")), Slot::SolverIntegrator);
    push("solver.step".into(), Causality::Parameter, Variability::Fixed, Some(Initial::Exact), real(Some(model.step), "s"), "Internal step: a communication step is split into equal internal steps no longer than this".into(), Slot::SolverStep);
    push("solver.tolerance".into(), Causality::Parameter, Variability::Fixed, Some(Initial::Exact), real(Some(model.tolerance), "1"), "Local error tolerance of the adaptive integrator".into(), Slot::SolverTolerance);
    rows
}

/// A 128-bit FNV-1a hash (two 64-bit lanes), for the GUID and state checksums. Hand-written:
/// eight lines, and it must stay byte-for-byte stable across versions of any library.
pub fn fnv1a(bytes: &[u8], seed: u64) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The FMU's GUID: a hash of the scene text and this crate's version, so an FMU refuses a
/// binary or a saved state from another scene or version.
pub fn guid(scene_text: &str) -> String {
    let mut bytes = scene_text.as_bytes().to_vec();
    bytes.extend_from_slice(env!("CARGO_PKG_VERSION").as_bytes());
    let (a, b) = (fnv1a(&bytes, 0), fnv1a(&bytes, 0x9e37_79b9_7f4a_7c15));
    format!("{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}", a >> 32, (a >> 16) & 0xffff, a & 0xffff, b >> 48, b & 0xffff_ffff_ffff)
}

/// The `ModelInfo` of a scene.
pub fn model_info(model: &Model, scene_text: &str, rows: &[(Variable, Slot)]) -> ModelInfo {
    let outputs = rows.iter().filter(|(v, _)| v.causality == Causality::Output).map(|(v, _)| (v.value_reference, Some(vec![]))).collect::<Vec<_>>();
    // Initial unknowns: calculated outputs depend on the exact-initial states and parameters.
    let knowns: Vec<u32> = rows.iter().filter(|(v, s)| v.initial == Some(Initial::Exact) && matches!(s, Slot::Q(_) | Slot::V(_) | Slot::Param(_))).map(|(v, _)| v.value_reference).collect();
    let initial_unknowns = rows.iter().filter(|(v, _)| v.causality == Causality::Output && v.initial == Some(Initial::Calculated)).map(|(v, _)| (v.value_reference, Some(knowns.clone()))).collect();
    ModelInfo {
        model_name: model.name.clone(),
        guid: guid(scene_text),
        description: format!("Soft-minimum contact model: scene {} ({} bodies, {} joints, {} contact pairs)", model.name, model.tree.bodies.len() - 1, model.tree.joints.len(), model.pairs.len()),
        generation_tool: format!("scm {}", env!("CARGO_PKG_VERSION")),
        variables: rows.iter().map(|(v, _)| v.clone()).collect(),
        structure: ModelStructure { outputs, derivatives: vec![], initial_unknowns },
        number_of_event_indicators: 0,
        model_exchange: false,
        default_experiment: DefaultExperiment { start_time: Some(0.0), stop_time: Some(2.0), tolerance: None, step_size: Some(model.step.max(0.01)) },
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
}

/// A simulation of a scene.
pub struct Simulation {
    /// The model.
    pub model: Model,
    rows: Vec<(Variable, Slot)>,
    info: ModelInfo,
    /// Current state.
    pub current: SimState,
    start: SimState,
    stop_time: Option<f64>,
    /// Contact outputs at the current state, computed on demand.
    outputs: Option<Vec<PairContact<f64>>>,
    /// What the integrator carries between communication steps (a Newton Jacobian).
    cache: crate::integrate::SolverCache,
    messages: Vec<LogMessage>,
}

impl Simulation {
    /// A simulation of a loaded scene, at its initial state.
    pub fn new(scene: Scene, scene_text: &str) -> Simulation {
        let model = scene.model;
        let rows = variable_table(&model);
        let info = model_info(&model, scene_text, &rows);
        let mocap = model.tree.mocap0();
        let mocap_target = mocap.chunks(crate::dynamics::MOCAP_INPUTS).flat_map(|m| m[..7].to_vec()).collect();
        let start = SimState { time: 0.0, state: State { q: model.tree.q0(), v: vec![0.0; model.tree.nv] }, ctrl: vec![0.0; model.actuators.len()], params: model.contact, mocap, mocap_target };
        let messages = scene.warnings.into_iter().map(|text| LogMessage { category: LogCategory::StatusWarning, text }).collect();
        Simulation { model, rows, info, current: start.clone(), start, stop_time: None, outputs: None, cache: Default::default(), messages }
    }

    /// Loads a scene file and starts a simulation of it.
    pub fn from_file(path: &Path) -> Result<Simulation, scene::SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| scene::SceneError { file: path.display().to_string(), line: 0, element: "mujoco".into(), message: format!("cannot read the scene: {e}") })?;
        Ok(Simulation::new(scene::load_str(&text, path)?, &text))
    }

    /// The variable table.
    pub fn rows(&self) -> &[(Variable, Slot)] {
        &self.rows
    }

    fn row(&self, vr: u32) -> ModelResult<&(Variable, Slot)> {
        self.rows.get(vr as usize).ok_or_else(|| format!("unknown value reference {vr}"))
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
            let kin = self.model.tree.kinematics_with(&self.current.state.q, &self.current.state.v, &self.current.mocap);
            self.outputs = Some(self.model.contacts(&kin, &self.current.params).1);
        }
        self.outputs.as_deref().unwrap_or(&[])
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
            return Err(StepError::Error(format!("a step of {h} s refused: it must be positive and finite")));
        }
        let mocap = self.mocap_path(h)?;
        let mut u = self.current.ctrl.clone();
        u.extend_from_slice(&mocap);
        let t0 = self.current.time;
        let done = self.model.advance_cached(&self.current.state, &u, &self.current.params, t0, h, &crate::integrate::AdvanceOptions::default(), &mut self.cache).map_err(|e| {
            StepError::Discard(format!("{e}; the state is kept at t = {t0} s: retry with a smaller step{}", if self.model.integrator.is_explicit() { ", or the implicit integrator implicit_euler" } else { "" }))
        })?;
        self.current.state = done.state;
        // Land the mocap bodies exactly on their targets, keeping the step's velocity.
        self.current.mocap = mocap;
        for (m, target) in self.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let q = crate::dynamics::quat_from(&target[3..7]);
            self.current.mocap[o..o + 7].copy_from_slice(&[target[0], target[1], target[2], q.w, q.i, q.j, q.k]);
        }
        self.current.time += h;
        self.outputs = None;
        Ok(())
    }

    /// The mocap part of the inputs for a communication step of `h` (s): the current poses with
    /// the velocities that reach the targets at its end.
    fn mocap_path(&self, h: f64) -> Result<Vec<f64>, StepError> {
        let mut out = self.current.mocap.clone();
        for (m, target) in self.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let name = &self.model.tree.bodies[self.model.tree.mocap[m]].name;
            if target[3..7].iter().all(|&x| x == 0.0) {
                return Err(StepError::Error(format!("{name}.quat is zero: set a non-zero orientation quaternion")));
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
            Err(format!("{name} = {value} refused: the value must be finite"))
        }
    }
}

/// Name of the first non-finite coordinate of a state, if any (see
/// [`Model::first_non_finite`]).
pub fn first_non_finite(model: &Model, s: &State<f64>) -> Option<String> {
    model.first_non_finite(s)
}

impl FmiModel for Simulation {
    type State = SimState;

    fn instantiate(resources: &Path) -> ModelResult<Self> {
        let path = resources.join(SCENE_FILE);
        Simulation::from_file(&path).map_err(|e| e.to_string())
    }

    fn info(&self) -> &ModelInfo {
        &self.info
    }

    fn setup_experiment(&mut self, start_time: f64, stop_time: Option<f64>, _tolerance: Option<f64>) -> ModelResult<()> {
        Self::check_finite("startTime", start_time)?;
        if let Some(stop) = stop_time {
            if !(stop >= start_time) {
                return Err(format!("stopTime = {stop} refused: it must be finite and not before startTime = {start_time}"));
            }
        }
        self.current.time = start_time;
        self.start.time = start_time;
        self.stop_time = stop_time;
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
            if !(m > 0.0) {
                return Err(format!("{}.quat is zero: set a non-zero orientation quaternion", j.name));
            }
            q.iter_mut().for_each(|x| *x /= m);
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            q.iter_mut().for_each(|x| *x /= n);
        }
        self.outputs = None;
        self.messages.push(LogMessage { category: LogCategory::Events, text: format!("initialized {} at t = {} s", self.model.name, self.current.time) });
        Ok(())
    }

    fn reset(&mut self) -> ModelResult<()> {
        self.current = self.start.clone();
        self.outputs = None;
        self.messages.push(LogMessage { category: LogCategory::Events, text: "reset to the start values".into() });
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
            Slot::SolverStep => self.model.step,
            Slot::SolverTolerance => self.model.tolerance,
            Slot::SolverIntegrator => return Err(format!("solver.integrator (value reference {vr}) is a String variable")),
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
                self.start.state = self.current.state.clone();
            }
            Slot::Ctrl(i) => self.current.ctrl[i] = value,
            Slot::Mocap(m, k) => {
                // Before initialization the pose is set at once (at rest); later it is the
                // target the next communication step moves to.
                self.current.mocap_target[7 * m + k] = value;
                if before_init {
                    let o = crate::dynamics::MOCAP_INPUTS * m;
                    self.current.mocap[o + k] = value;
                    self.current.mocap[o + 7..o + 13].fill(0.0);
                    self.start.mocap = self.current.mocap.clone();
                    self.start.mocap_target = self.current.mocap_target.clone();
                }
            }
            Slot::Param(p) => {
                if !p.accepts(value) {
                    return Err(format!("{} = {value} refused: it must be {}", var.name, if p == Param::Friction { "non-negative" } else { "positive" }));
                }
                *p.slot(&mut self.current.params) = value;
                if before_init {
                    self.start.params = self.current.params;
                }
            }
            Slot::SolverStep | Slot::SolverTolerance if before_init => {
                if !(value > 0.0) {
                    return Err(format!("{} = {value} refused: it must be positive", var.name));
                }
                if slot == Slot::SolverStep {
                    self.model.step = value;
                } else {
                    self.model.tolerance = value;
                }
            }
            _ => return Err(format!("{} (value reference {vr}) cannot be set {}", var.name, if before_init { "" } else { "after initialization" }).trim_end().to_string()),
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
                self.model.integrator = crate::integrate::Integrator::from_name(value)
                    .ok_or_else(|| format!("solver.integrator = \"{value}\" refused: known integrators are {}", crate::integrate::Integrator::ALL.map(|i| i.name()).join(", ")))?;
                Ok(())
            }
            Slot::SolverIntegrator => Err("solver.integrator cannot be set after initialization".into()),
            _ => Err(format!("value reference {vr} is not a String variable")),
        }
    }

    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError> {
        if !(step > 0.0) || !step.is_finite() {
            return Err(StepError::Error(format!("communicationStepSize = {step} refused: it must be positive and finite")));
        }
        if let Some(stop) = self.stop_time {
            if current_time + step > stop * (1.0 + 1e-12) + 1e-12 {
                return Err(StepError::Error(format!("a step from t = {current_time} s by {step} s would pass the stop time {stop} s")));
            }
        }
        self.current.time = current_time;
        self.advance(step)?;
        self.current.time = current_time + step;
        Ok(())
    }

    fn take_messages(&mut self) -> Vec<LogMessage> {
        std::mem::take(&mut self.messages)
    }

    fn get_state(&self) -> ModelResult<SimState> {
        Ok(self.current.clone())
    }

    fn set_state(&mut self, state: &SimState) -> ModelResult<()> {
        self.current = state.clone();
        self.outputs = None;
        Ok(())
    }
}
