//! The model's part of a serialized FMU state: plain little-endian numbers, no pointers.
//!
//! The plumbing wraps these bytes with a magic number, its layout version, the FMU's GUID and
//! a checksum ([`crate::fmi::serial`]), so a state of another scene, of another scm version,
//! or corrupt bytes are refused before they get here. This layout has its own version and
//! checks its sizes against the model, so it refuses a mismatched state on its own too.
//!
//! | bytes | what |
//! | --- | --- |
//! | 4 | layout version ([`STATE_VERSION`]) |
//! | 4 × 3 | `nq`, `nv`, number of controls |
//! | 8 | time (s) |
//! | 8 × (nq + nv + nctrl) | `q`, `v`, controls |
//! | 8 × 7 | the tunable contact parameters, in [`Param::ALL`] order |
//! | 8 × 2 | internal step (s), tolerance |
//! | 4 + n | integrator name: length, UTF-8 bytes |
//!
//! Every f64 is stored as its bits, so a state restored from bytes is bit-identical.

use super::{FmuState, Param, SimState};
use crate::fmi::serial::Reader;
use crate::integrate::{Integrator, State};
use crate::model::Model;

/// Version of the layout written by [`encode`].
pub const STATE_VERSION: u32 = 1;

/// Writes `state`.
pub fn encode(state: &FmuState) -> Vec<u8> {
    let s = &state.sim;
    let mut b = Vec::with_capacity(64 + 8 * (s.state.q.len() + s.state.v.len() + s.ctrl.len() + 10));
    b.extend_from_slice(&STATE_VERSION.to_le_bytes());
    for n in [s.state.q.len(), s.state.v.len(), s.ctrl.len()] {
        b.extend_from_slice(&(n as u32).to_le_bytes());
    }
    let params = Param::ALL.map(|p| p.get(&s.params));
    let values = std::iter::once(&s.time).chain(&s.state.q).chain(&s.state.v).chain(&s.ctrl).chain(params.iter()).chain([&state.step, &state.tolerance]);
    for x in values {
        b.extend_from_slice(&x.to_bits().to_le_bytes());
    }
    let name = state.integrator.name().as_bytes();
    b.extend_from_slice(&(name.len() as u32).to_le_bytes());
    b.extend_from_slice(name);
    b
}

/// Reads a state written by [`encode`] for `model`; refuses another layout version, sizes that
/// do not match the model, non-finite or out-of-range values, and trailing bytes.
pub fn decode(model: &Model, bytes: &[u8]) -> Result<FmuState, String> {
    let mut r = Reader::new(bytes);
    let version = r.u32("the model state version")?;
    if version != STATE_VERSION {
        return Err(format!("model state has layout version {version}; this FMU reads version {STATE_VERSION} only"));
    }
    let (nq, nv, nc) = (r.u32("nq")? as usize, r.u32("nv")? as usize, r.u32("the number of controls")? as usize);
    let expected = (model.tree.nq, model.tree.nv, model.actuators.len());
    if (nq, nv, nc) != expected {
        return Err(format!("model state has (nq, nv, controls) = {:?}, this scene has {expected:?}", (nq, nv, nc)));
    }
    let mut finite = |what: &str| -> Result<f64, String> {
        let x = r.f64(what)?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(format!("model state is corrupt: {what} is {x}"))
        }
    };
    let time = finite("the time")?;
    let q = (0..nq).map(|_| finite("a position")).collect::<Result<Vec<_>, _>>()?;
    let v = (0..nv).map(|_| finite("a velocity")).collect::<Result<Vec<_>, _>>()?;
    let ctrl = (0..nc).map(|_| finite("a control")).collect::<Result<Vec<_>, _>>()?;
    let mut params = model.contact;
    for p in Param::ALL {
        let x = finite(p.describe().0)?;
        if !p.accepts(x) {
            return Err(format!("model state is corrupt: scm.{} = {x} is out of range", p.describe().0));
        }
        *p.slot(&mut params) = x;
    }
    let step = finite("the internal step")?;
    let tolerance = finite("the tolerance")?;
    if step <= 0.0 || tolerance <= 0.0 {
        return Err(format!("model state is corrupt: solver.step = {step}, solver.tolerance = {tolerance} must be positive"));
    }
    let n = r.u32("the integrator name length")? as usize;
    let name = r.take(n, "the integrator name")?;
    let name = std::str::from_utf8(name).map_err(|_| "model state is corrupt: integrator name is not UTF-8".to_string())?;
    let integrator = Integrator::from_name(name).ok_or_else(|| format!("model state names an unknown integrator {name:?}"))?;
    if r.remaining() != 0 {
        return Err(format!("model state is corrupt: {} unexpected bytes at the end", r.remaining()));
    }
    Ok(FmuState { sim: SimState { time, state: State { q, v }, ctrl, params }, integrator, step, tolerance })
}
