//! The simulation's variables: read and written by slot (what the FMU's value references
//! name) and, for Rust callers and the command line, by name. One code path for both, so the
//! command line refuses what a host would be refused and reads what a host would read.

use super::*;
use crate::fmi::contract::{Causality, VarType};

/// A value for [`Simulation::set`]: FMU variables are Real, except `solver.integrator`.
#[derive(Clone, Debug, PartialEq)]
pub enum Value<'a> {
    /// A Real variable's value.
    Real(f64),
    /// A String variable's value.
    Text(&'a str),
}

/// The small facade a Rust caller (and the command line) uses: names instead of value
/// references, no FMI state machine.
impl Simulation {
    /// The variable named `name` (its FMU name, e.g. `ball.pos.z`, `scm.eps1`) and its slot.
    pub fn variable(&self, name: &str) -> Result<&(Variable, Slot), String> {
        self.rows
            .iter()
            .find(|(v, _)| v.name == name)
            .ok_or_else(|| {
                let stem = name.split('.').next();
                let close: Vec<&str> = self
                    .rows
                    .iter()
                    .map(|(v, _)| v.name.as_str())
                    .filter(|n| n.split('.').next() == stem)
                    .collect();
                if close.is_empty() {
                    format!(
                        "no variable '{name}' (the FMU's modelDescription.xml lists every name)"
                    )
                } else {
                    format!(
                        "no variable '{name}' (variables of that name: {})",
                        close.join(", ")
                    )
                }
            })
    }

    /// The current value of a Real variable by name.
    pub fn get(&mut self, name: &str) -> ModelResult<f64> {
        let slot = self.variable(name)?.1;
        self.read(slot)
    }

    /// Sets a variable by name, with an FMU host's rules: before [`Simulation::initialize`]
    /// or the first step, start values of the states, parameters, solver settings and inputs;
    /// after it, inputs (a mocap pose is then the target the next step reaches) and tunable
    /// parameters. The same checks apply: a non-finite value, a zero step, an unknown
    /// integrator or an output is refused with the reason, and nothing changes.
    pub fn set(&mut self, name: &str, value: Value) -> ModelResult<()> {
        let row = self.variable(name)?.clone();
        let before_start = !self.data.started;
        match value {
            Value::Real(x) => self.write(&row, x, before_start),
            Value::Text(s) => self.write_text(&row, s, before_start),
        }
    }

    /// Sets a contact parameter (tunable at any time: between steps too). A parameter that no
    /// pair uses, because every pair has its own value from the scene file (its geoms'
    /// friction, or its stiffness and dissipation velocity from `solref` and `solimp`), is
    /// refused with why, so that a setting never does nothing silently (setting it to the value
    /// it has, as a host that writes every start value does, changes nothing and is accepted).
    pub fn set_param(&mut self, p: Param, value: f64) -> ModelResult<()> {
        let name = p.describe().0;
        Self::check_finite(&format!("scm.{name}"), value)?;
        let pairs = &self.model.pairs;
        let unchanged = p.get(&self.data.current.params) == value;
        if !unchanged && !pairs.is_empty() && pairs.iter().all(|pair| pair.owns(p)) {
            let source = if p == Param::Friction {
                "the friction its geoms or <pair> give"
            } else {
                "the value its geoms' or <pair>'s solref and solimp give"
            };
            return Err(format!(
                "scm.{name} = {value:?} refused: no contact pair uses it, every pair has its own, {source} (see `scm check`); to give every pair one value that scm.{name} then tunes, set scm_{name} in the scene (<custom><numeric name=\"scm_{name}\" data=\"...\"/>)"
            ));
        }
        // Each pair's stiction velocity is at least its floor (`Pair::stiction_floor`): a value
        // under every pair's changes nothing, unless a joint's or tendon's dry friction reads it
        // too, or a pair's floor follows `scm.friction` (which a host may set after this).
        let m = &self.model;
        let dry_friction = m.tree.joints.iter().any(|j| j.frictionloss > 0.0)
            || m.tendons.iter().any(|t| t.frictionloss > 0.0)
            || m.spatial_tendons.iter().any(|t| t.law.frictionloss > 0.0);
        if p == Param::StictionVelocity && !unchanged && !pairs.is_empty() && !dry_friction {
            let least = pairs
                .iter()
                .map(|pair| pair.friction.map_or(0.0, |mu| pair.stiction_floor * mu))
                .fold(f64::INFINITY, f64::min);
            if value < least {
                return Err(format!(
                    "scm.stiction_velocity = {value:?} refused: every contact pair's stiction velocity is held at {least:.4e} m/s or more (its stiction floor, a multiple of h mu g that keeps an explicit integrator stable at the scene's step; see `scm check`), so it would change nothing; set a larger value, or <custom><numeric name=\"scm_stiction_floor\" data=\"0\"/> in the scene to remove the floor"
                ));
            }
        }
        if !p.accepts(value) {
            return Err(format!(
                "scm.{} = {value:?} refused: it must be {}",
                p.describe().0,
                if p == Param::Friction {
                    "non-negative"
                } else {
                    "positive"
                }
            ));
        }
        *p.slot(&mut self.data.current.params) = value;
        if let Some(text) = self.smoothing_warning(p, value) {
            self.data.messages.push(LogMessage {
                category: LogCategory::StatusWarning,
                text,
            });
        }
        Ok(())
    }

    /// The names of the Real outputs, in the order of [`Simulation::outputs`].
    pub fn output_names(&self) -> Vec<&str> {
        self.output_rows().map(|(v, _)| v.name.as_str()).collect()
    }

    /// The Real outputs at the current state (contact forces, distances, limit forces,
    /// accelerations, ...), in the order of [`Simulation::output_names`].
    pub fn outputs(&mut self) -> ModelResult<Vec<f64>> {
        let all: Vec<usize> = (0..self.output_rows().count()).collect();
        self.outputs_of(&all)
    }

    /// The Real outputs numbered `which` (indices into [`Simulation::output_names`]), in that
    /// order. Only what is read is computed: a contact force costs the pairs in reach (the
    /// others are proven out of reach and push with zero), a smooth distance costs every pair
    /// evaluated in full, about as much as the step itself on a robot's self-collision pairs.
    pub fn outputs_of(&mut self, which: &[usize]) -> ModelResult<Vec<f64>> {
        let slots: Vec<Slot> = self.output_rows().map(|(_, s)| *s).collect();
        which
            .iter()
            .map(|&i| {
                let slot = *slots.get(i).ok_or_else(|| {
                    format!("output {i} out of range (there are {})", slots.len())
                })?;
                self.read(slot)
            })
            .collect()
    }

    fn output_rows(&self) -> impl Iterator<Item = &(Variable, Slot)> {
        self.rows.iter().filter(|(v, _)| {
            v.causality == Causality::Output && matches!(v.var_type, VarType::Real { .. })
        })
    }

    /// Ends the setting of start values: quaternions set by the caller are normalized (a zero
    /// one is refused). Stepping without it is allowed; the FMU calls it at
    /// `fmi2ExitInitializationMode`.
    pub fn initialize(&mut self) -> ModelResult<()> {
        let quaternions: Vec<usize> = self.quaternions();
        // Checked before any is changed, so a refusal leaves every quaternion as set.
        if let Some((_, name)) = named_quaternions(&self.model.tree)
            .into_iter()
            .find(|(i, _)| !has_direction(&self.data.current.state.q[*i..*i + 4]))
        {
            return Err(format!(
                "{name}.quat is zero: set a non-zero orientation quaternion"
            ));
        }
        for i in quaternions {
            normalize_quaternion(&mut self.data.current.state.q[i..i + 4]);
        }
        self.data.messages.push(LogMessage {
            category: LogCategory::Events,
            text: format!(
                "initialized {} at t = {} s",
                self.model.name, self.data.current.time
            ),
        });
        self.data.started = true;
        Ok(())
    }
}

/// Reading and writing by slot: what both the facade above and the FMU's value references use.
impl Simulation {
    /// The value a Real slot holds at the current state.
    pub(crate) fn read(&mut self, slot: Slot) -> ModelResult<f64> {
        Ok(match slot {
            Slot::Time => self.data.current.time,
            Slot::Q(i) => self.data.current.state.q[i],
            Slot::V(i) => self.data.current.state.v[i],
            Slot::Ctrl(i) => self.data.current.ctrl[i],
            Slot::Act(k) => self.data.current.state.act[k],
            Slot::ActDot(k) => self.activation_rates()[k],
            Slot::Mocap(m, k) => self.data.current.mocap_target[7 * m + k],
            Slot::Param(p) => p.get(&self.data.current.params),
            Slot::PairForce(p, k) => self.applied_contacts()[p].map_or(0.0, |c| c.on_a.force[k]),
            Slot::PairTorque(p, k) => self.applied_contacts()[p].map_or(0.0, |c| c.on_a.torque[k]),
            Slot::PairDistance(p) => self.contacts()[p].distance,
            Slot::LimitForce(j) => {
                let jt = &self.model.tree.joints[j];
                let s = &self.data.current.state;
                jt.limit
                    .as_ref()
                    .map_or(0.0, |l| l.force(s.q[jt.qadr], s.v[jt.dadr]))
            }
            Slot::TendonLimitForce(t) => {
                let tendon = &self.model.tendons[t];
                let s = &self.data.current.state;
                tendon
                    .limit
                    .as_ref()
                    .map_or(0.0, |l| l.force(tendon.length(&s.q), tendon.velocity(&s.v)))
            }
            Slot::SpatialTendonLimitForce(t) => {
                let tendon = &self.model.spatial_tendons[t];
                let s = &self.data.current.state;
                let kin = (self.model.tree).kinematics_with(&s.q, &s.v, &self.data.current.mocap);
                let (l, ldot) = tendon.length_and_rate(&kin.frames);
                tendon
                    .law
                    .limit
                    .as_ref()
                    .map_or(0.0, |lim| lim.force(l, ldot))
            }
            Slot::PairPoint(p, k, i) => self.contact_points()[p].get(k).map_or(f64::NAN, |c| c[i]),
            Slot::SolverStep => self.model.timestep,
            Slot::SolverTolerance => self.model.tolerance,
            Slot::PruneTolerance => self.model.prune_tolerance().unwrap_or(f64::NAN),
            Slot::SolverIntegrator => return Err("solver.integrator is a String variable".into()),
            Slot::QDot(i) => self
                .model
                .tree
                .qdot(&self.data.current.state.q, &self.data.current.state.v)[i],
            Slot::VDot(i) => self.accelerations()?[i],
        })
    }

    /// Gives the model's point clouds the pruning tolerance `tolerance` where it is another,
    /// and forgets what was carried or kept for the old one (`Data::forget_model`).
    pub(super) fn set_prune_tolerance(&mut self, tolerance: f64) {
        if self.model.prune_tolerance() != Some(tolerance) {
            self.model.set_prune_tolerance(tolerance);
            self.data.forget_model();
        }
    }

    /// Writes a Real row; `before_init`: start values, fixed parameters and solver settings
    /// may be set (before the FMU's initialization, or through the facade).
    pub(crate) fn write(
        &mut self,
        (var, slot): &(Variable, Slot),
        value: f64,
        before_init: bool,
    ) -> ModelResult<()> {
        Self::check_finite(&var.name, value)?;
        match *slot {
            // In Model Exchange the states may also be set by value reference after
            // initialization, as `fmi2SetContinuousStates` sets them: hosts that evaluate the
            // right-hand side at states of their own choosing (CasADi's `DaeBuilder` calls
            // `fmi2SetReal` on the states in Event Mode) rely on it, and Modelica tools' FMUs
            // accept it. A Co-Simulation instance owns its state between steps.
            Slot::Q(i) if before_init || self.model_exchange => {
                self.data.current.state.q[i] = value
            }
            Slot::V(i) if before_init || self.model_exchange => {
                self.data.current.state.v[i] = value
            }
            Slot::Act(k) if before_init || self.model_exchange => {
                self.data.current.state.act[k] = value
            }
            Slot::Ctrl(i) => self.data.current.ctrl[i] = value,
            Slot::Mocap(m, k) => {
                // Before initialization the pose is set at once (at rest). Later, in
                // Co-Simulation it is the target the next communication step moves to; in
                // Model Exchange the pose at the current time (its velocity is estimated at the
                // host's completed integrator steps, see `Simulation::sample_mocap`).
                self.data.current.mocap_target[7 * m + k] = value;
                let o = crate::dynamics::MOCAP_INPUTS * m;
                if self.model_exchange && !before_init {
                    self.data.current.mocap[o + k] = value;
                } else if before_init {
                    self.data.current.mocap[o + k] = value;
                    self.data.current.mocap[o + 7..o + 13].fill(0.0);
                }
            }
            // Tunable at any time; `fmi2Reset` restores the scene's value.
            Slot::Param(p) => return self.set_param(p, value),
            Slot::SolverStep | Slot::SolverTolerance if before_init => {
                if value.is_nan() || value <= 0.0 {
                    return Err(format!(
                        "{} = {value:?} refused: it must be positive",
                        var.name
                    ));
                }
                if *slot == Slot::SolverStep {
                    self.model.timestep = value;
                } else {
                    self.model.tolerance = value;
                }
            }
            Slot::SolverIntegrator => {
                return Err(format!("{} is a String variable", var.name));
            }
            Slot::PruneTolerance if before_init => {
                if !crate::scalar::prune_tolerance_ok(value) {
                    return Err(format!(
                        "{} = {value:?} refused: it must be above 0 and at most {:e} (the relative weight below which a softmax term or point force is skipped)",
                        var.name,
                        crate::scalar::PRUNE_TOLERANCE_MAX
                    ));
                }
                self.set_prune_tolerance(value);
            }
            _ => {
                return Err(format!(
                    "{} (value reference {}) cannot be set{}",
                    var.name,
                    var.value_reference,
                    if before_init {
                        ""
                    } else {
                        " after initialization"
                    }
                ))
            }
        }
        Ok(())
    }

    /// Writes a String row (`solver.integrator`, before initialization only).
    pub(crate) fn write_text(
        &mut self,
        (var, slot): &(Variable, Slot),
        value: &str,
        before_init: bool,
    ) -> ModelResult<()> {
        match slot {
            Slot::SolverIntegrator if before_init => {
                let integrator =
                    crate::integrate::Integrator::from_name(value).ok_or_else(|| {
                        format!(
                            "solver.integrator = \"{value}\" refused: known integrators are {}",
                            crate::integrate::Integrator::ALL
                                .map(|i| i.name())
                                .join(", ")
                        )
                    })?;
                self.model.set_integrator(integrator);
                Ok(())
            }
            Slot::SolverIntegrator => {
                Err("solver.integrator cannot be set after initialization".into())
            }
            _ => Err(format!(
                "{} (value reference {}) is not a String variable",
                var.name, var.value_reference
            )),
        }
    }
}
