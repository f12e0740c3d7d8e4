//! The state derivatives' rows of the variable table (`der(<state>)`) and the accelerations as
//! outputs of their own.

use super::names;
use super::table::Slot;
use crate::fmi::contract::{Causality, VarType, Variability, Variable};

/// Appends the state derivatives `der(<state>)` of every position and velocity coordinate, in
/// coordinate order (`q` then `v`, which is the order of the continuous states), all local;
/// then the accelerations as outputs of their own (`<joint>.a`, `<body>.linacc.*`,
/// `<body>.angacc.*`), the same values as the velocity derivatives. A state derivative that is
/// also an output is legal FMI, but hosts that list derivatives and outputs together (CasADi's
/// `DaeBuilder`, `['ode', 'y']`) then see one variable twice and refuse.
pub(super) fn push_derivative_rows(rows: &mut Vec<(Variable, Slot)>) {
    let mut states: Vec<(Slot, u32, String, Option<&'static str>)> = rows
        .iter()
        .filter(|(_, s)| matches!(s, Slot::Q(_) | Slot::V(_) | Slot::Act(_)))
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
        Slot::V(i) => usize::MAX / 4 + i,
        Slot::Act(i) => usize::MAX / 2 + i,
        _ => usize::MAX,
    });
    let mut accelerations = Vec::new();
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
                Causality::Local,
                "Acceleration, the time derivative",
            ),
            (Slot::V(i), _) => (
                "rad/s2",
                Slot::VDot(i),
                Causality::Local,
                "Acceleration, the time derivative",
            ),
            (Slot::Act(i), _) => (
                "1/s",
                Slot::ActDot(i),
                Causality::Local,
                "Rate, the time derivative",
            ),
            _ => continue,
        };
        let value_reference = rows.len() as u32;
        let description = format!("{what} of {name} (Model Exchange state derivative)");
        let var_type = VarType::Real {
            start: None,
            unit: Some(unit),
            derivative: Some(state_vr),
        };
        if let Slot::VDot(_) = slot {
            accelerations.push((slot, name.clone(), unit));
        }
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
    let first = rows.len();
    for (slot, state, unit) in accelerations {
        let value_reference = rows.len() as u32;
        rows.push((
            Variable {
                name: acceleration_name(&state),
                value_reference,
                causality: Causality::Output,
                variability: Variability::Continuous,
                initial: None,
                var_type: VarType::Real {
                    start: None,
                    unit: Some(unit),
                    derivative: None,
                },
                description: format!("Acceleration: the time derivative of {state} (der({state}))"),
            },
            slot,
        ));
    }
    // An acceleration's name may meet a name the scene already gave: renamed, as any other.
    let mut all: Vec<String> = rows.iter().map(|(v, _)| v.name.clone()).collect();
    for (k, old) in names::make_unique(&mut all) {
        if k >= first {
            rows[k].0.description = format!(
                "{} (named {old} at first; renamed to be unique)",
                rows[k].0.description
            );
            rows[k].0.name = std::mem::take(&mut all[k]);
        }
    }
}

/// The name of the acceleration output of a velocity state: `<joint>.v` → `<joint>.a`,
/// `<body>.linvel.x` → `<body>.linacc.x`, `<body>.angvel.x` → `<body>.angacc.x`.
fn acceleration_name(state: &str) -> String {
    if let Some(joint) = state.strip_suffix(".v") {
        return format!("{joint}.a");
    }
    for (vel, acc) in [(".linvel.", ".linacc."), (".angvel.", ".angacc.")] {
        if let Some(at) = state.rfind(vel) {
            return format!("{}{acc}{}", &state[..at], &state[at + vel.len()..]);
        }
    }
    format!("{state}.acc")
}
