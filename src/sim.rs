//! A running simulation of a model: state, parameters, the variable table of the FMU and the
//! co-simulation step. This is the model side of the FMI contract
//! ([`FmiModel`](crate::fmi::contract::FmiModel), implemented in `sim/fmu.rs`); it holds no
//! pointer and knows nothing of C.

use crate::contact::ContactParams;
use crate::dynamics::{JointKind, Tree};
use crate::fmi::contract::{LogCategory, LogMessage, ModelInfo, ModelResult, StepError, Variable};
use crate::integrate::{Integrator, State};
use crate::model::Model;
use crate::scene::{self, Scene};
use std::path::Path;

mod access;
mod data;
mod derivative_rows;
mod fmu;
pub mod jacobian;
pub mod names;
mod outputs;
mod smoothing;
mod state_bytes;
pub mod structure;
mod table;

pub use crate::contact::Param;
pub use crate::scene::SCENE_FILE;

pub use access::Value;
pub use data::Data;
pub use table::{guid, model_info, variable_table, Slot};

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

impl SimState {
    /// The inputs the actuators' force laws read now ([`Model::driven_inputs`]): the controls,
    /// an activation in its actuator's place.
    pub(crate) fn driven(&self, model: &Model) -> Vec<f64> {
        model.driven_inputs(&self.ctrl, &self.state.act, &self.state.q, None)
    }
}

/// What `fmi2GetFMUstate` saves: the time-varying state and the solver settings (which the
/// host may set before initialization), so that restoring it reproduces a rollout bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct FmuState {
    /// Time, positions, velocities, controls and contact parameters.
    pub sim: SimState,
    /// Integrator of the internal steps.
    pub integrator: Integrator,
    /// Internal time step (s).
    pub timestep: f64,
    /// Local error tolerance.
    pub tolerance: f64,
    /// What the integrator carries between communication steps (the implicit methods' Newton
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
/// The model is the engine's [`Model`] (its option settings, integrator and step, may be set
/// before the start, as MuJoCo's `mjModel.opt`); everything that changes is its [`Data`]
/// (MuJoCo's `mjData`): the current [`SimState`], what the integrator carries, the outputs'
/// memos. The
/// FMU and the command line use the same small facade: variables by name
/// ([`Simulation::set`], [`Simulation::get`], [`Simulation::set_param`]),
/// [`Simulation::advance`] and [`Simulation::outputs`].
///
/// # Example
///
/// A 0.1 kg sphere dropped onto a floor comes to rest on it, carried by the contact force:
///
/// ```
/// use std::path::Path;
/// use scm::contact::Param;
/// use scm::sim::{Simulation, Value};
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
/// let mut sim = Simulation::new(scm::scene::load_str(xml, Path::new("drop.xml"))?, xml);
/// sim.set("ball.pos.z", Value::Real(0.1))?; // a start value, by its FMU name
/// sim.set_param(Param::Eps2, 5e-4)?; // a contact parameter (tunable at any time)
/// sim.advance(1.0)?;
/// let z = sim.get("ball.pos.z")?; // and every output: sim.output_names(), sim.outputs()
/// assert!((z - 0.05).abs() < 2e-3, "resting height {z}");
/// // The outputs by name: the floor (first body of the pair) carries the ball's weight.
/// let names = sim.output_names();
/// let fz = names.iter().position(|n| *n == "contact.world.ball.force.z").unwrap();
/// let on_floor = sim.outputs()?[fz];
/// assert!((on_floor + 0.1 * 9.81).abs() < 1e-3, "floor force {on_floor}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Simulation {
    /// The model.
    pub model: Model,
    rows: Vec<(Variable, Slot)>,
    info: ModelInfo,
    /// The scene's start state, restored by `fmi2Reset`.
    start: SimState,
    /// Solver settings of the scene (restored by `fmi2Reset`): integrator, step, tolerance and
    /// the clouds' pruning tolerance.
    start_solver: (Integrator, f64, f64, Option<f64>),
    /// Whether the host instantiated Model Exchange (mocap inputs then act at once).
    model_exchange: bool,
    /// Everything that changes while it runs: the current state, what the integrator carries,
    /// the outputs' memos and the queued messages ([`Data`]).
    pub data: Data,
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
                act: model.act0.clone(),
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
        let prune = model.prune_tolerance();
        let start_solver = (model.integrator, model.timestep, model.tolerance, prune);
        let mut sim = Simulation {
            model,
            rows,
            info,
            data: Data::at(start.clone(), messages),
            start,
            start_solver,
            model_exchange: false,
        };
        for p in [Param::Eps1, Param::Eps2, Param::Eps3] {
            if let Some(text) = sim.smoothing_warning(p, p.get(&sim.data.current.params)) {
                sim.data.messages.push(LogMessage {
                    category: LogCategory::StatusWarning,
                    text,
                });
            }
        }
        sim
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
        [
            self.data.current.ctrl.as_slice(),
            self.data.current.mocap.as_slice(),
        ]
        .concat()
    }

    /// Soft top-K contact points of every pair at the current positions (world frame), cached
    /// until the positions or ε1, ε2 change.
    pub fn contact_points(&mut self) -> &[Vec<nalgebra::Vector3<f64>>] {
        let (q, e1, e2) = (
            &self.data.current.state.q,
            self.data.current.params.eps1,
            self.data.current.params.eps2,
        );
        let fresh = matches!(&self.data.points, Some((pq, p1, p2, _)) if *pq == [q.as_slice(), &self.data.current.mocap].concat() && *p1 == e1 && *p2 == e2);
        if !fresh {
            let kin = self.model.tree.kinematics_with(
                q,
                &self.data.current.state.v,
                &self.data.current.mocap,
            );
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
                            pair.eps1_sides(e1),
                            e2,
                            self.model.contact_points,
                        ),
                        _ => Vec::new(),
                    },
                )
                .collect();
            self.data.points = Some((
                [q.as_slice(), &self.data.current.mocap].concat(),
                e1,
                e2,
                pts,
            ));
        }
        self.data
            .points
            .as_ref()
            .map(|p| p.3.as_slice())
            .unwrap_or(&[])
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
    /// its state, time and inputs from before the call and the error says what went wrong and
    /// when; its solver cache may have changed ([`Model::advance_cached`]), which no later
    /// step's validity depends on.
    pub fn advance(&mut self, h: f64) -> Result<(), StepError> {
        self.advance_from(self.data.current.time, h)
    }

    /// [`Simulation::advance`] from time `t0` (a host's communication point, which may differ
    /// from the sum of the steps taken by rounding): on success the time is `t0 + h`, set here
    /// and nowhere else in a step; on failure nothing changes but the solver cache.
    pub(crate) fn advance_from(&mut self, t0: f64, h: f64) -> Result<(), StepError> {
        if !h.is_finite() || h <= 0.0 {
            return Err(StepError::Error(format!(
                "a step of {h} s refused: it must be positive and finite"
            )));
        }
        let mocap = self.mocap_path(h)?;
        let mut u = self.data.current.ctrl.clone();
        u.extend_from_slice(&mocap);
        let done = self
            .model
            .advance_cached(
                &self.data.current.state,
                &u,
                &self.data.current.params,
                t0,
                h,
                &crate::integrate::AdvanceOptions::default(),
                &mut self.data.solver,
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
        self.data.current.state = done.state;
        // Land the mocap bodies exactly on their targets, keeping the step's velocity.
        self.data.current.mocap = mocap;
        for (m, target) in self.data.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let q = unit_target(&target[3..7]);
            self.data.current.mocap[o..o + 7]
                .copy_from_slice(&[target[0], target[1], target[2], q.w, q.i, q.j, q.k]);
        }
        self.data.current.time = t0 + h;
        self.data.started = true;
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
        let t = self.data.current.time;
        let poses: Vec<f64> = self
            .data
            .current
            .mocap
            .chunks(crate::dynamics::MOCAP_INPUTS)
            .flat_map(|m| m[..7].to_vec())
            .collect();
        if let Some((t0, prev)) = &self.data.current.mocap_sampled {
            let dt = t - t0;
            if dt > 0.0 {
                for (m, (now, before)) in poses.chunks(7).zip(prev.chunks(7)).enumerate() {
                    let o = crate::dynamics::MOCAP_INPUTS * m;
                    let q0 = crate::dynamics::quat_from(&before[3..7]);
                    let q1 = crate::dynamics::quat_from(&now[3..7]);
                    let w = crate::dynamics::quat_log(&(q0.conjugate() * q1)) / dt;
                    for k in 0..3 {
                        self.data.current.mocap[o + 7 + k] = (now[k] - before[k]) / dt;
                        self.data.current.mocap[o + 10 + k] = w[k];
                    }
                }
            }
        }
        self.data.current.mocap_sampled = Some((t, poses));
    }

    /// The mocap part of the inputs for a communication step of `h` (s): the current poses with
    /// the velocities that reach the targets at its end.
    fn mocap_path(&self, h: f64) -> Result<Vec<f64>, StepError> {
        let mut out = self.data.current.mocap.clone();
        for (m, target) in self.data.current.mocap_target.chunks(7).enumerate() {
            let o = crate::dynamics::MOCAP_INPUTS * m;
            let name = &self.model.tree.bodies[self.model.tree.mocap[m]].name;
            if target[3..7].iter().all(|&x| x == 0.0) {
                return Err(StepError::Error(format!(
                    "{name}.quat is zero: set a non-zero orientation quaternion"
                )));
            }
            let q0 = crate::dynamics::quat_from(&out[o + 3..o + 7]);
            let q1 = unit_target(&target[3..7]);
            let w = crate::dynamics::quat_log(&(q0.conjugate() * q1)) / h;
            for k in 0..3 {
                out[o + 7 + k] = (target[k] - out[o + k]) / h;
                out[o + 10 + k] = w[k];
            }
            // A step so short that the move overflows (h near the smallest double).
            if out[o + 7..o + 13].iter().any(|v| !v.is_finite()) {
                return Err(StepError::Discard(format!(
                    "{name}: reaching its target pose in a step of {h:e} s takes an infinite speed: take a longer step, or a nearer target"
                )));
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

/// A mocap target orientation (non-zero, as [`Simulation::mocap_path`] checks) as a unit
/// quaternion, scaled by its largest component first so that neither huge nor tiny
/// components overflow or vanish in the norm.
fn unit_target(q: &[f64]) -> nalgebra::Quaternion<f64> {
    let largest = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let scaled: Vec<f64> = q.iter().map(|x| x / largest).collect();
    crate::dynamics::quat_from(&scaled)
}

/// Model Exchange, directional derivatives and diagnostics.
impl Simulation {
    /// Accelerations `v̇` at the current state, controls and parameters (computed once per
    /// distinct state: the cache is keyed by the state itself, so no code path can leave it
    /// stale).
    pub fn accelerations(&mut self) -> ModelResult<&[f64]> {
        let fresh = matches!(&self.data.accelerations, Some((at, _)) if at.state == self.data.current.state && at.ctrl == self.data.current.ctrl && at.mocap == self.data.current.mocap && at.params == self.data.current.params);
        if !fresh {
            let c = &self.data.current;
            let f = self
                .model
                .forward(
                    &c.state.q,
                    &c.state.v,
                    &self
                        .model
                        .driven_inputs(&self.inputs(), &c.state.act, &c.state.q, None),
                    &c.params,
                )
                .map_err(|e| format!("forward dynamics at t = {} s: {e}", c.time))?;
            self.data.accelerations =
                Some((self.data.current.clone(), f.vdot.iter().copied().collect()));
        }
        Ok(self
            .data
            .accelerations
            .as_ref()
            .map(|(_, a)| a.as_slice())
            .unwrap_or_default())
    }

    /// Start index in `q` of every quaternion (free and ball joints).
    fn quaternions(&self) -> Vec<usize> {
        named_quaternions(&self.model.tree)
            .into_iter()
            .map(|(i, _)| i)
            .collect()
    }

    /// Largest `| |quaternion| - 1 |` of the current state.
    ///
    /// In Model Exchange the host's solver owns the state, and the quaternions are part of it.
    /// The model is well defined off the unit sphere (kinematics normalizes the quaternion, and
    /// `q̇ = ½ q ⊗ (0, ω)` is tangent to the sphere, so the exact flow keeps the norm), but a
    /// numerical solver drifts slowly. After each completed integrator step the model asks for
    /// an event when the drift exceeds [`QUATERNION_DRIFT_TOLERANCE`], and at the event
    /// ([`FmiModel::event_update`](crate::fmi::contract::FmiModel::event_update)) it normalizes the quaternions and reports that the states
    /// changed, so the host re-reads them and restarts its solver from the unit sphere.
    pub fn quaternion_drift(&self) -> f64 {
        self.quaternions()
            .iter()
            .map(|&i| {
                (self.data.current.state.q[i..i + 4]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt()
                    - 1.0)
                    .abs()
            })
            .fold(0.0, f64::max)
    }

    /// Continuous states `x = [q; v; act]` (Model Exchange).
    pub fn continuous_states(&self) -> Vec<f64> {
        let s = &self.data.current.state;
        s.q.iter().chain(&s.v).chain(&s.act).copied().collect()
    }

    /// The activations' rates `ȧ` at the current activations, controls and configuration.
    pub fn activation_rates(&self) -> Vec<f64> {
        let c = &self.data.current;
        self.model
            .activation_rates(&c.state.act, &c.ctrl, &c.state.q)
    }

    /// Queues one `logContact` message per pair with its smooth distance, force and torque at
    /// the current state (only when the host has the category on).
    fn log_contacts(&mut self) {
        if !self.data.log_contact {
            return;
        }
        let t = self.data.current.time;
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
            self.data.messages.push(LogMessage {
                category: LogCategory::Contact,
                text,
            });
        }
    }
}

/// Start index in `q` and joint name of every quaternion (free and ball joints).
fn named_quaternions(tree: &Tree) -> Vec<(usize, &str)> {
    tree.joints
        .iter()
        .filter_map(|j| match j.kind {
            JointKind::Free => Some((j.qadr + 3, j.name.as_str())),
            JointKind::Ball => Some((j.qadr, j.name.as_str())),
            _ => None,
        })
        .collect()
}

/// Scales a quaternion to unit length in place, by its largest component first so that huge
/// components do not overflow and tiny ones do not underflow. A zero (or non-finite) quaternion
/// has no direction: it is left as it is and `false` returned.
fn normalize_quaternion(q: &mut [f64]) -> bool {
    if !has_direction(q) {
        return false;
    }
    let m = largest(q);
    q.iter_mut().for_each(|x| *x /= m);
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.iter_mut().for_each(|x| *x /= n);
    true
}

/// The largest magnitude of a quaternion's components (NaN components ignored).
fn largest(q: &[f64]) -> f64 {
    q.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Whether [`normalize_quaternion`] can scale `q` to unit length (its largest component is
/// finite and not zero).
fn has_direction(q: &[f64]) -> bool {
    let m = largest(q);
    m.is_finite() && m > 0.0
}
