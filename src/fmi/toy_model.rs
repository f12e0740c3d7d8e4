//! A toy model for the plumbing's tests: a unit mass on a spring, `ẍ = -k·x + u`.
//!
//! Value references: Real 0 `x` (state, output), 1 `v` (state, output), 2 `u` (input),
//! 3 `k` (tunable parameter), 4 `der(x)`, 5 `der(v)`, 6 `max_step` (a step longer than this is
//! discarded; setting `u` to -666 panics, to test the panic guard), Integer 10 `steps` (output), Boolean 0 `frozen` (parameter), String 0 `label`.

use std::path::Path;

use super::contract::*;

pub const GUID: &str = "{8c4e810f-3df3-4a00-8276-176fa3c9f000}";

#[derive(Clone, Debug, PartialEq)]
pub struct ToyState {
    pub t: f64,
    pub x: f64,
    pub v: f64,
    pub u: f64,
    pub k: f64,
    pub max_step: f64,
    pub steps: i32,
    pub frozen: bool,
    pub label: String,
}

impl ToyState {
    fn start() -> ToyState {
        ToyState {
            t: 0.0,
            x: 1.0,
            v: 0.0,
            u: 0.0,
            k: 4.0,
            max_step: 1.0,
            steps: 0,
            frozen: false,
            label: "toy".into(),
        }
    }
}

pub struct Toy {
    pub info: ModelInfo,
    pub s: ToyState,
    pub messages: Vec<LogMessage>,
}

#[allow(clippy::too_many_arguments)]
fn real(
    name: &str,
    vr: u32,
    causality: Causality,
    variability: Variability,
    initial: Option<Initial>,
    start: Option<f64>,
    unit: &'static str,
    derivative: Option<u32>,
) -> Variable {
    Variable {
        name: name.into(),
        value_reference: vr,
        causality,
        variability,
        initial,
        var_type: VarType::Real {
            start,
            unit: Some(unit),
            derivative,
        },
        description: format!("{name} of the toy"),
    }
}

pub fn toy_info() -> ModelInfo {
    use Causality::*;
    use Variability::*;
    let variables = vec![
        real(
            "x",
            0,
            Output,
            Continuous,
            Some(Initial::Exact),
            Some(1.0),
            "m",
            None,
        ),
        real(
            "v",
            1,
            Output,
            Continuous,
            Some(Initial::Exact),
            Some(0.0),
            "m/s",
            None,
        ),
        real("u", 2, Input, Continuous, None, Some(0.0), "N", None),
        real(
            "k",
            3,
            Parameter,
            Tunable,
            Some(Initial::Exact),
            Some(4.0),
            "N/m",
            None,
        ),
        real("der(x)", 4, Local, Continuous, None, None, "m/s", Some(0)),
        real("der(v)", 5, Local, Continuous, None, None, "m/s2", Some(1)),
        real("max_step", 6, Parameter, Fixed, None, Some(1.0), "s", None),
        Variable {
            name: "steps".into(),
            value_reference: 10,
            causality: Output,
            variability: Discrete,
            initial: None,
            var_type: VarType::Integer { start: None },
            description: String::new(),
        },
        Variable {
            name: "frozen".into(),
            value_reference: 0,
            causality: Parameter,
            variability: Fixed,
            initial: None,
            var_type: VarType::Boolean { start: Some(false) },
            description: "no motion".into(),
        },
        Variable {
            name: "label".into(),
            value_reference: 0,
            causality: Parameter,
            variability: Fixed,
            initial: None,
            var_type: VarType::String {
                start: Some("toy".into()),
            },
            description: "a <label> & \"quote\"".into(),
        },
    ];
    ModelInfo {
        model_name: "toy".into(),
        guid: GUID.into(),
        description: "mass on a spring".into(),
        generation_tool: "scm tests".into(),
        variables,
        structure: ModelStructure {
            outputs: vec![(0, Some(vec![0])), (1, Some(vec![1])), (10, Some(vec![]))],
            derivatives: vec![(4, Some(vec![1])), (5, Some(vec![0, 2, 3]))],
            initial_unknowns: vec![(4, Some(vec![1])), (5, None)],
        },
        number_of_event_indicators: 0,
        model_exchange: true,
        capabilities: Capabilities {
            can_get_and_set_fmu_state: true,
            can_serialize_fmu_state: true,
            provides_directional_derivative: true,
        },
        default_experiment: DefaultExperiment {
            start_time: Some(0.0),
            stop_time: Some(10.0),
            tolerance: None,
            step_size: Some(0.01),
        },
    }
}

impl Toy {
    fn acc(&self) -> f64 {
        -self.s.k * self.s.x + self.s.u
    }
    fn msg(&mut self, category: LogCategory, text: String) {
        self.messages.push(LogMessage { category, text });
    }
}

fn finite(vr: u32, value: f64) -> ModelResult<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(format!(
            "value {value} for value reference {vr} is not finite"
        ))
    }
}

impl FmiModel for Toy {
    type State = ToyState;

    fn instantiate(resources: &Path) -> ModelResult<Self> {
        if resources.ends_with("missing") {
            return Err(format!("no scene in {}", resources.display()));
        }
        Ok(Toy {
            info: toy_info(),
            s: ToyState::start(),
            messages: vec![],
        })
    }
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn setup_experiment(
        &mut self,
        start_time: f64,
        _stop: Option<f64>,
        _tol: Option<f64>,
    ) -> ModelResult<()> {
        self.s.t = start_time;
        Ok(())
    }
    fn enter_initialization(&mut self) -> ModelResult<()> {
        self.msg(LogCategory::Events, "toy: initializing".into());
        Ok(())
    }
    fn exit_initialization(&mut self) -> ModelResult<()> {
        Ok(())
    }
    fn reset(&mut self) -> ModelResult<()> {
        self.s = ToyState::start();
        Ok(())
    }
    fn time(&self) -> f64 {
        self.s.t
    }
    fn get_real(&mut self, vr: u32) -> ModelResult<f64> {
        Ok(match vr {
            0 => self.s.x,
            1 => self.s.v,
            2 => self.s.u,
            3 => self.s.k,
            4 => self.s.v,
            5 => self.acc(),
            6 => self.s.max_step,
            _ => return Err(format!("no Real variable with value reference {vr}")),
        })
    }
    fn set_real(&mut self, vr: u32, value: f64, phase: Phase) -> ModelResult<()> {
        let value = finite(vr, value)?;
        match (vr, phase) {
            (0, Phase::Instantiated | Phase::Initialization) => self.s.x = value,
            (1, Phase::Instantiated | Phase::Initialization) => self.s.v = value,
            (2, _) if value == -666.0 => panic!("toy panic on request"),
            (2, _) => self.s.u = value,
            (3, _) if value > 0.0 => self.s.k = value,
            (3, _) => return Err(format!("k must be > 0, got {value}")),
            (6, Phase::Instantiated | Phase::Initialization) => self.s.max_step = value,
            _ => return Err(format!("variable {vr} cannot be set in phase {phase:?}")),
        }
        Ok(())
    }
    fn get_integer(&mut self, vr: u32) -> ModelResult<i32> {
        if vr == 10 {
            Ok(self.s.steps)
        } else {
            Err(format!("no Integer variable with value reference {vr}"))
        }
    }
    fn get_boolean(&mut self, _vr: u32) -> ModelResult<bool> {
        Ok(self.s.frozen)
    }
    fn set_boolean(&mut self, _vr: u32, value: bool, phase: Phase) -> ModelResult<()> {
        if phase == Phase::Simulation {
            return Err("frozen is fixed".into());
        }
        self.s.frozen = value;
        Ok(())
    }
    fn get_string(&mut self, _vr: u32) -> ModelResult<String> {
        Ok(self.s.label.clone())
    }
    fn set_string(&mut self, _vr: u32, value: &str, _phase: Phase) -> ModelResult<()> {
        self.s.label = value.to_owned();
        Ok(())
    }
    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError> {
        if step > self.s.max_step {
            return Err(StepError::Discard(format!(
                "step {step} longer than max_step {}",
                self.s.max_step
            )));
        }
        if !self.s.frozen {
            // semi-implicit Euler
            self.s.v += step * self.acc();
            self.s.x += step * self.s.v;
        }
        self.s.steps += 1;
        self.s.t = current_time + step;
        self.msg(
            LogCategory::Contact,
            format!("toy: step to t = {}", self.s.t),
        );
        Ok(())
    }
    fn take_messages(&mut self) -> Vec<LogMessage> {
        std::mem::take(&mut self.messages)
    }
    fn get_state(&self) -> ModelResult<ToyState> {
        Ok(self.s.clone())
    }
    fn set_state(&mut self, state: &ToyState) -> ModelResult<()> {
        self.s = state.clone();
        Ok(())
    }
    fn serialize_state(&self, s: &ToyState) -> ModelResult<Vec<u8>> {
        let mut b = b"TOY1".to_vec();
        for f in [s.t, s.x, s.v, s.u, s.k, s.max_step] {
            b.extend_from_slice(&f.to_le_bytes());
        }
        b.extend_from_slice(&s.steps.to_le_bytes());
        b.push(s.frozen as u8);
        b.extend_from_slice(s.label.as_bytes());
        Ok(b)
    }
    fn deserialize_state(&self, b: &[u8]) -> ModelResult<ToyState> {
        if b.len() < 4 + 48 + 5 || &b[..4] != b"TOY1" {
            return Err("not a toy state".into());
        }
        let f =
            |i: usize| f64::from_le_bytes(b[4 + 8 * i..12 + 8 * i].try_into().unwrap_or([0; 8]));
        Ok(ToyState {
            t: f(0),
            x: f(1),
            v: f(2),
            u: f(3),
            k: f(4),
            max_step: f(5),
            steps: i32::from_le_bytes(b[52..56].try_into().unwrap_or([0; 4])),
            frozen: b[56] != 0,
            label: String::from_utf8(b[57..].to_vec()).map_err(|e| e.to_string())?,
        })
    }
    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv: &[f64],
    ) -> ModelResult<Vec<f64>> {
        let partial = |y: u32, x: u32| -> ModelResult<f64> {
            Ok(match (y, x) {
                (0, 0) | (1, 1) | (4, 1) => 1.0,
                (5, 0) => -self.s.k,
                (5, 2) => 1.0,
                (5, 3) => -self.s.x,
                (0 | 1 | 4 | 5, _) => 0.0,
                _ => return Err(format!("no derivative of {y}")),
            })
        };
        unknowns
            .iter()
            .map(|&y| {
                knowns
                    .iter()
                    .zip(dv)
                    .map(|(&x, d)| Ok(partial(y, x)? * d))
                    .sum()
            })
            .collect()
    }
    fn number_of_states(&self) -> usize {
        2
    }
    fn set_time(&mut self, time: f64) -> ModelResult<()> {
        self.s.t = time;
        Ok(())
    }
    fn get_continuous_states(&mut self) -> ModelResult<Vec<f64>> {
        Ok(vec![self.s.x, self.s.v])
    }
    fn set_continuous_states(&mut self, x: &[f64]) -> ModelResult<()> {
        self.s.x = x[0];
        self.s.v = x[1];
        Ok(())
    }
    fn get_derivatives(&mut self) -> ModelResult<Vec<f64>> {
        Ok(vec![self.s.v, self.acc()])
    }
}
