//! The FMI contract of a simulation: how each `fmi2*` call reads, writes and steps it.

use super::*;
use crate::dynamics::JointKind;
use crate::fmi::contract::{
    FmiModel, LogCategory, LogMessage, ModelInfo, ModelResult, Phase, StepError,
};
use std::path::Path;

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
        self.data.current.time = start_time;
        Ok(())
    }

    fn enter_initialization(&mut self) -> ModelResult<()> {
        Ok(())
    }

    fn exit_initialization(&mut self) -> ModelResult<()> {
        self.initialize()?;
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
        self.data.current = self.start.clone();
        let (integrator, step, tolerance, prune) = self.start_solver;
        // The integrator brings its own limit law (`Model::set_integrator`).
        self.model.set_integrator(integrator);
        (self.model.timestep, self.model.tolerance) = (step, tolerance);
        if let Some(prune) = prune {
            self.set_prune_tolerance(prune);
        }
        self.data.solver = Default::default();
        self.data.started = false;
        self.data.messages.push(LogMessage {
            category: LogCategory::Events,
            text: "reset to the start values".into(),
        });
        Ok(())
    }

    fn time(&self) -> f64 {
        self.data.current.time
    }

    fn get_real(&mut self, vr: u32) -> ModelResult<f64> {
        let slot = self.row(vr)?.1;
        self.read(slot)
    }

    fn set_real(&mut self, vr: u32, value: f64, phase: Phase) -> ModelResult<()> {
        let row = self.row(vr)?.clone();
        self.write(&row, value, phase != Phase::Simulation)
    }

    fn get_string(&mut self, vr: u32) -> ModelResult<String> {
        match self.row(vr)?.1 {
            Slot::SolverIntegrator => Ok(self.model.integrator.name().into()),
            _ => Err(format!("value reference {vr} is not a String variable")),
        }
    }

    fn set_string(&mut self, vr: u32, value: &str, phase: Phase) -> ModelResult<()> {
        let row = self.row(vr)?.clone();
        self.write_text(&row, value, phase != Phase::Simulation)
    }

    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError> {
        // The step starts at the host's communication point (the time the FMU reports is the
        // host's, not the sum of its own steps) and lands on `current_time + step`; `advance_from`
        // checks the step and sets the time once, on success.
        self.advance_from(current_time, step)?;
        self.log_contacts();
        Ok(())
    }

    fn take_messages(&mut self) -> Vec<LogMessage> {
        std::mem::take(&mut self.data.messages)
    }

    fn get_state(&self) -> ModelResult<FmuState> {
        Ok(FmuState {
            sim: self.data.current.clone(),
            integrator: self.model.integrator,
            timestep: self.model.timestep,
            tolerance: self.model.tolerance,
            solver_cache: self.data.solver.clone(),
        })
    }

    fn set_state(&mut self, state: &FmuState) -> ModelResult<()> {
        let s = &state.sim;
        if (
            s.state.q.len(),
            s.state.v.len(),
            s.state.act.len(),
            s.ctrl.len(),
        ) != (
            self.model.tree.nq,
            self.model.tree.nv,
            self.model.na(),
            self.model.actuators.len(),
        ) {
            return Err("the FMU state belongs to another scene (its sizes differ)".into());
        }
        self.data.current = state.sim.clone();
        self.model.set_integrator(state.integrator);
        (self.model.timestep, self.model.tolerance) = (state.timestep, state.tolerance);
        self.data.solver = state.solver_cache.clone();
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
                    | Slot::Act(_)
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
            &self.data.current,
            &u,
            &k,
            dv_known,
            self.model_exchange,
        )
    }

    fn number_of_states(&self) -> usize {
        self.model.tree.nq + self.model.tree.nv + self.model.na()
    }

    fn set_time(&mut self, time: f64) -> ModelResult<()> {
        // Nothing depends on time explicitly: no cache to drop.
        self.data.current.time = time;
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
        let nv = self.model.tree.nv;
        let s = &mut self.data.current.state;
        s.q.copy_from_slice(&x[..nq]);
        s.v.copy_from_slice(&x[nq..nq + nv]);
        s.act.copy_from_slice(&x[nq + nv..]);
        Ok(())
    }

    fn get_derivatives(&mut self) -> ModelResult<Vec<f64>> {
        let mut dx = self
            .model
            .tree
            .qdot(&self.data.current.state.q, &self.data.current.state.v);
        dx.extend_from_slice(self.accelerations()?);
        dx.extend(self.activation_rates());
        if let Some(i) = dx.iter().position(|d| !d.is_finite()) {
            return Err(format!(
                "the derivative of state {i} is {} at t = {} s",
                dx[i], self.data.current.time
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
        // A zero quaternion (set a component at a time by value reference) has no direction:
        // it is left as set, said in the log, and the forward dynamics refuses it until the
        // host sets an orientation.
        let mut changed = false;
        let mut zero = Vec::new();
        for (i, name) in named_quaternions(&self.model.tree) {
            let q = &mut self.data.current.state.q[i..i + 4];
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if (n - 1.0).abs() > 4.0 * f64::EPSILON {
                if normalize_quaternion(q) {
                    changed = true;
                } else {
                    zero.push(name.to_string());
                }
            }
        }
        for name in zero {
            self.data.messages.push(LogMessage {
                category: LogCategory::StatusWarning,
                text: format!("{name}.quat is zero at the event: left as set; set a non-zero orientation quaternion before the next step"),
            });
        }
        Ok(changed)
    }

    fn logging_changed(&mut self, category: LogCategory, on: bool) {
        if category == LogCategory::Contact {
            self.data.log_contact = on;
        }
    }
}
