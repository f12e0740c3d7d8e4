//! Tests of the state bytes' layout (`super`): the module's table against what `encode` writes.

use super::*;
use crate::contact::ContactParams;
use crate::integrate::{CacheParts, SolverCache};
use nalgebra::DMatrix;

/// The sizes of the state below, by the names the table's formulas use.
const SIZES: [(&str, usize); 9] = [
    ("nq", 7),
    ("nv", 6),
    ("nctrl", 2),
    ("na", 1),
    ("nm", 1),
    ("n", "implicit_euler".len()),
    ("r", 6),
    ("c", 6),
    ("pair", 2),
];

/// A state with every optional part present (mocap, sampled mocap poses, Jacobian, the
/// state it was left for with a velocity change, ledger, proofs on both sides of every
/// pair), numbers chosen only to have the sizes of [`SIZES`].
fn full_state() -> FmuState {
    let size = |name| SIZES.iter().find(|(n, _)| *n == name).unwrap().1;
    let (nq, nv) = (size("nq"), size("nv"));
    let state = State {
        q: vec![0.5; nq],
        v: vec![0.25; nv],
        act: vec![0.125; size("na")],
    };
    let side = ProofSide {
        rotation: Matrix3::identity(),
        translation: Vector3::new(1.0, 0.0, 0.0),
        t: 0.1,
        m1: 0.01,
        room: 0.001,
    };
    let ledger = EnergyLedger {
        at: state.clone(),
        params: ContactParams::default(),
        since: 0.0,
        reference: 1.0,
        work: 0.0,
        gross_work: 0.0,
        scale: 1.0,
        kinetic: 0.5,
        energy: 0.75,
        stored: Some(0.125),
    };
    FmuState {
        sim: SimState {
            time: 1.0,
            state: state.clone(),
            ctrl: vec![0.0; size("nctrl")],
            params: ContactParams::default(),
            mocap: vec![0.0; MOCAP_INPUTS * size("nm")],
            mocap_target: vec![0.0; 7 * size("nm")],
            mocap_sampled: Some((0.5, vec![0.0; 7 * size("nm")])),
        },
        integrator: Integrator::from_name("implicit_euler").unwrap(),
        timestep: 0.002,
        tolerance: 1e-6,
        solver_cache: SolverCache::from_parts(CacheParts {
            jacobian: Some(DMatrix::identity(size("r"), size("c"))),
            left: Some((state, 0.002)),
            ledger: Some(ledger),
            velocity_change: Some(vec![0.0; nv]),
            reach: vec![
                Some(ReachProof {
                    sides: [Some(side), Some(side)],
                });
                size("pair")
            ],
        }),
    }
}

/// The module doc's table: each row's section name and byte formula.
fn table() -> Vec<(String, String)> {
    include_str!("state_bytes.rs")
        .lines()
        .filter_map(|l| l.strip_prefix("//! | `"))
        .map(|row| {
            let cells: Vec<&str> = row.split(" | ").collect();
            (
                cells[0].trim_end_matches('`').to_string(),
                cells[1].to_string(),
            )
        })
        .collect()
}

/// The value of a formula of the table: numbers, the names of [`SIZES`], `+`, `×` and
/// juxtaposition for products, parentheses, `(+ …)` for an optional part (present in
/// [`full_state`]), and "per pair" for a product with the number of pairs.
fn evaluate(formula: &str) -> usize {
    let spaced = formula
        .replace("per pair", "pair ×")
        .replace('(', " ( ")
        .replace(')', " ) ")
        .replace('+', " + ");
    let tokens: Vec<&str> = spaced.split_whitespace().collect();
    let mut at = 0;
    let value = sum(&tokens, &mut at);
    assert_eq!(at, tokens.len(), "unread tokens in {formula:?}");
    value
}

fn sum(t: &[&str], at: &mut usize) -> usize {
    let mut value = product(t, at);
    loop {
        match (t.get(*at), t.get(*at + 1)) {
            (Some(&"+"), _) => {
                *at += 1;
                value += product(t, at);
            }
            (Some(&"("), Some(&"+")) => {
                *at += 2;
                value += sum(t, at);
                assert_eq!(t[*at], ")");
                *at += 1;
            }
            _ => return value,
        }
    }
}

fn product(t: &[&str], at: &mut usize) -> usize {
    let mut value = factor(t, at);
    loop {
        match (t.get(*at), t.get(*at + 1)) {
            (Some(&"×"), _) => {
                *at += 1;
                value *= factor(t, at);
            }
            (Some(&"("), Some(&"+")) | (None, _) | (Some(&"+" | &")"), _) => return value,
            _ => value *= factor(t, at),
        }
    }
}

fn factor(t: &[&str], at: &mut usize) -> usize {
    let token = t[*at];
    *at += 1;
    if token == "(" {
        let value = sum(t, at);
        assert_eq!(t[*at], ")");
        *at += 1;
        return value;
    }
    token.parse().unwrap_or_else(|_| {
        SIZES
            .iter()
            .find(|(n, _)| *n == token)
            .unwrap_or_else(|| panic!("unknown size {token:?}"))
            .1
    })
}

#[test]
fn the_table_describes_what_encode_writes() {
    let state = full_state();
    let written = write(&state);
    let rows = table();
    let names: Vec<&str> = written.sections.iter().map(|(n, _)| *n).collect();
    let listed: Vec<&str> = rows.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names, listed,
        "the sections in the order encode writes them"
    );
    let ends = written.sections[1..]
        .iter()
        .map(|(_, start)| *start)
        .chain([written.bytes.len()]);
    for (((name, start), end), (_, formula)) in written.sections.iter().zip(ends).zip(&rows) {
        assert_eq!(end - start, evaluate(formula), "section {name}: {formula}");
    }
}

#[test]
fn the_formulas_read_as_meant() {
    assert_eq!(evaluate("4 × 4"), 16);
    assert_eq!(evaluate("8 × (nq + nv + nctrl)"), 8 * 15);
    assert_eq!(evaluate("1 (+ 8 + 8 × 7 nm)"), 1 + 8 + 56);
    assert_eq!(
        evaluate("1 (+ 8 (nq + nv + na + 1) (+ 8 nv))"),
        1 + 8 * 15 + 48
    );
    assert_eq!(
        evaluate("4 + per pair (1 + 2 (1 + 8 × 15))"),
        4 + 2 * (1 + 2 * 121)
    );
}
