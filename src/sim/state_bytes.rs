//! The model's part of a serialized FMU state: plain little-endian numbers, no pointers.
//!
//! The plumbing wraps these bytes with a magic number, its layout version, the FMU's GUID and
//! a checksum ([`crate::fmi::serial`]), so a state of another scene, of another scm version,
//! or corrupt bytes are refused before they get here. This layout has its own version and
//! checks its sizes against the model, so it refuses a mismatched state on its own too.
//!
//! | section | bytes | what |
//! | --- | --- | --- |
//! | `version` | 4 | layout version ([`STATE_VERSION`]) |
//! | `sizes` | 4 × 4 | `nq`, `nv`, number of controls, number of mocap bodies `nm` |
//! | `time` | 8 | time (s) |
//! | `state` | 8 × (nq + nv + nctrl) | `q`, `v`, controls |
//! | `act` | 8 × na | since version 7, the actuators' activations (`na` the model's) |
//! | `mocap` | 8 × 13 nm | mocap bodies at `time`: pose and velocity ([`MOCAP_INPUTS`] each) |
//! | `mocap_target` | 8 × 7 nm | mocap inputs as set: the pose reached at the end of the next step |
//! | `params` | 8 × 7 | the tunable contact parameters, in [`Param::ALL`] order |
//! | `solver` | 8 × 2 | internal step (s), tolerance |
//! | `integrator` | 4 + n | integrator name: length, UTF-8 bytes |
//! | `mocap_sampled` | 1 (+ 8 + 8 × 7 nm) | Model Exchange: mocap poses at the last completed integrator step: 0, or 1, time, poses |
//! | `jacobian` | 1 (+ 8 + 8 + 8 r c) | the implicit method's cached Newton Jacobian: 0, or 1, rows, columns (u64), entries (column-major) |
//! | `left` | 1 (+ 8 (nq + nv + na + 1) (+ 8 nv)) | the state and internal step that Jacobian was left for: 0; or 1, `q`, `v`, `act` (since version 7), step; or 2, `q`, `v`, `act`, step, implicit Euler's last velocity change `V - v` |
//! | `ledger` | 1 (+ 8 (nq + nv + na + 7 + 6) (+ 8)) | the energy guard's ledger ([`EnergyLedger`]): 0; or 1, the state it was left at (`q`, `v`, `act` since version 7), its contact parameters ([`Param::ALL`] order), start time, reference energy, work, gross work, scale, kinetic energy at that state (since version 5; computed from `q`, `v` for 3 and 4); or 2 (since version 10), the same and the energy stored in contact at that state ([`EnergyLedger::stored`]) |
//! | `reach` | 4 + per pair (1 + 2 (1 + 8 × 15)) | since version 6, the kept out-of-reach proofs ([`ReachProof`]): their number (0, or one per pair), then per pair 0, or 1 and per side 0, or 1 (by planes) or 2 (by the floor alone, since version 8), rotation (column-major), translation, distance, relevance margin (0 for flag 2), room the margin is widened for (since version 9; 0 for flag 2, and for versions 6 to 8); each proven again when read |
//!
//! The sections are written in this order, and [`decode`] reads them in it; a test holds this
//! table against what [`encode`] writes, section by section and byte by byte.
//!
//! Every f64 is stored as its bits, so a state restored from bytes is bit-identical.

use super::{FmuState, Param, SimState};
use crate::collision::{reach_proof_holds, ProofSide, ReachProof};
use crate::dynamics::MOCAP_INPUTS;
use crate::fmi::serial::Reader;
use crate::integrate::{EnergyLedger, Integrator, State};
use crate::model::Model;
use nalgebra::{Matrix3, Vector3};

/// Version of the layout written by [`encode`]. Version 4 added the solver cache state's flag
/// 2 (implicit Euler's last velocity change), version 5 the energy ledger's kinetic energy,
/// version 6 the kept out-of-reach proofs, version 7 the activations, version 8 the kept
/// proofs by the floor alone (a side's flag 2), version 9 a kept proof's room (its relevance
/// margin widened point by point, [`ProofSide`]), version 10 the ledger's energy stored in
/// contact (the ledger's flag 2); [`decode`] also reads versions 3 (never a cache state flag
/// 2), 4 and 5 (no kept proofs), 6 (no activations: of a model without them), 7 and 8 (no room:
/// 0) and 9; before 10, never a ledger flag 2.
pub const STATE_VERSION: u32 = 10;

/// The bytes of a state as [`encode`] writes them, with where each section of the module's
/// table begins (what the layout test compares with the table).
#[derive(Default)]
struct Writer {
    bytes: Vec<u8>,
    sections: Vec<(&'static str, usize)>,
}

impl Writer {
    fn section(&mut self, name: &'static str) -> &mut Self {
        self.sections.push((name, self.bytes.len()));
        self
    }
    fn u32(&mut self, n: usize) -> &mut Self {
        self.bytes.extend_from_slice(&(n as u32).to_le_bytes());
        self
    }
    fn u64(&mut self, n: usize) -> &mut Self {
        self.bytes.extend_from_slice(&(n as u64).to_le_bytes());
        self
    }
    fn flag(&mut self, f: u8) -> &mut Self {
        self.bytes.push(f);
        self
    }
    /// Each value as its bits, so a state read back is the same to the bit.
    fn reals<'a>(&mut self, xs: impl IntoIterator<Item = &'a f64>) -> &mut Self {
        for x in xs {
            self.bytes.extend_from_slice(&x.to_bits().to_le_bytes());
        }
        self
    }
}

/// Writes `state`.
pub fn encode(state: &FmuState) -> Vec<u8> {
    write(state).bytes
}

fn write(state: &FmuState) -> Writer {
    let s = &state.sim;
    let mut w = Writer::default();
    w.section("version")
        .bytes
        .extend_from_slice(&STATE_VERSION.to_le_bytes());
    w.section("sizes")
        .u32(s.state.q.len())
        .u32(s.state.v.len())
        .u32(s.ctrl.len())
        .u32(s.mocap.len() / MOCAP_INPUTS);
    w.section("time").reals([&s.time]);
    w.section("state")
        .reals(s.state.q.iter().chain(&s.state.v).chain(&s.ctrl));
    w.section("act").reals(&s.state.act);
    w.section("mocap").reals(&s.mocap);
    w.section("mocap_target").reals(&s.mocap_target);
    w.section("params")
        .reals(&Param::ALL.map(|p| p.get(&s.params)));
    w.section("solver")
        .reals([&state.timestep, &state.tolerance]);
    let name = state.integrator.name().as_bytes();
    w.section("integrator")
        .u32(name.len())
        .bytes
        .extend_from_slice(name);
    w.section("mocap_sampled");
    match &s.mocap_sampled {
        None => w.flag(0),
        Some((t, poses)) => w.flag(1).reals(std::iter::once(t).chain(poses)),
    };
    let cache = state.solver_cache.parts();
    w.section("jacobian");
    match &cache.jacobian {
        None => w.flag(0),
        Some(j) => w.flag(1).u64(j.nrows()).u64(j.ncols()).reals(j.iter()),
    };
    w.section("left");
    match &cache.left {
        None => w.flag(0),
        Some((st, h)) => w
            .flag(if cache.velocity_change.is_some() {
                2
            } else {
                1
            })
            .reals(st.q.iter().chain(&st.v).chain(&st.act).chain([h]))
            .reals(cache.velocity_change.iter().flatten()),
    };
    w.section("ledger");
    match &cache.ledger {
        None => w.flag(0),
        Some(l) => w
            .flag(if l.stored.is_some() { 2 } else { 1 })
            .reals(l.at.q.iter().chain(&l.at.v).chain(&l.at.act))
            .reals(&Param::ALL.map(|p| p.get(&l.params)))
            .reals([
                &l.since,
                &l.reference,
                &l.work,
                &l.gross_work,
                &l.scale,
                &l.kinetic,
            ])
            .reals(&l.stored),
    };
    w.section("reach").u32(cache.reach.len());
    for kept in &cache.reach {
        let Some(k) = kept else {
            w.flag(0);
            continue;
        };
        w.flag(1);
        for side in &k.sides {
            match side {
                None => w.flag(0),
                Some(ks) => {
                    // A proof by the floor alone (an infinite margin) is flagged 2, its
                    // margin written as 0.
                    let (flag, m1) = if ks.m1 == f64::INFINITY {
                        (2, 0.0)
                    } else {
                        (1, ks.m1)
                    };
                    w.flag(flag).reals(
                        ks.rotation
                            .iter()
                            .chain(&ks.translation)
                            .chain([&ks.t, &m1, &ks.room]),
                    )
                }
            };
        }
    }
    w
}

/// Reads a state written by [`encode`] for `model`; refuses another layout version, sizes that
/// do not match the model, non-finite or out-of-range values, and trailing bytes.
pub fn decode(model: &Model, bytes: &[u8]) -> Result<FmuState, String> {
    let mut r = Reader::new(bytes);
    let version = r.u32("the model state version")?;
    if !(3..=STATE_VERSION).contains(&version) {
        return Err(format!(
            "model state has layout version {version}; this FMU reads versions 3 to {STATE_VERSION}"
        ));
    }
    let (nq, nv, nc, nm) = (
        r.u32("nq")? as usize,
        r.u32("nv")? as usize,
        r.u32("the number of controls")? as usize,
        r.u32("the number of mocap bodies")? as usize,
    );
    let expected = (
        model.tree.nq,
        model.tree.nv,
        model.actuators.len(),
        model.tree.mocap.len(),
    );
    if (nq, nv, nc, nm) != expected {
        return Err(format!(
            "model state has (nq, nv, controls, mocap bodies) = {:?}, this scene has {expected:?}",
            (nq, nv, nc, nm)
        ));
    }
    let time = finite(&mut r, "the time")?;
    let q = (0..nq)
        .map(|_| finite(&mut r, "a position"))
        .collect::<Result<Vec<_>, _>>()?;
    let v = (0..nv)
        .map(|_| finite(&mut r, "a velocity"))
        .collect::<Result<Vec<_>, _>>()?;
    // A zero quaternion is not refused here: before initialization a host may set one (a
    // component at a time), save the state and serialize it, and the bytes must round-trip;
    // `fmi2ExitInitializationMode` refuses it, and a step from it is refused as non-finite.
    let ctrl = (0..nc)
        .map(|_| finite(&mut r, "a control"))
        .collect::<Result<Vec<_>, _>>()?;
    // Activations since version 7; before, a model had none.
    let na = model.na();
    if version < 7 && na > 0 {
        return Err(format!("model state has layout version {version}, which keeps no activations: this scene has {na}"));
    }
    let activations = |r: &mut Reader, what| {
        (0..na)
            .map(|_| finite(r, what))
            .collect::<Result<Vec<_>, _>>()
    };
    let act = activations(&mut r, "an activation")?;
    let mocap = (0..nm * MOCAP_INPUTS)
        .map(|_| finite(&mut r, "a mocap pose or velocity"))
        .collect::<Result<Vec<_>, _>>()?;
    let mocap_target = (0..nm * 7)
        .map(|_| finite(&mut r, "a mocap input"))
        .collect::<Result<Vec<_>, _>>()?;
    let mut params = model.contact;
    for p in Param::ALL {
        let x = finite(&mut r, p.describe().0)?;
        if !p.accepts(x) {
            return Err(format!(
                "model state is corrupt: scm.{} = {x} is out of range",
                p.describe().0
            ));
        }
        *p.slot(&mut params) = x;
    }
    let step = finite(&mut r, "the internal step")?;
    let tolerance = finite(&mut r, "the tolerance")?;
    if step <= 0.0 || tolerance <= 0.0 {
        return Err(format!("model state is corrupt: solver.step = {step}, solver.tolerance = {tolerance} must be positive"));
    }
    let n = r.u32("the integrator name length")? as usize;
    let name = r.take(n, "the integrator name")?;
    let name = std::str::from_utf8(name)
        .map_err(|_| "model state is corrupt: integrator name is not UTF-8".to_string())?;
    let integrator = Integrator::from_name(name)
        .ok_or_else(|| format!("model state names an unknown integrator {name:?}"))?;
    let mocap_sampled = match r.take(1, "the sampled mocap flag")?[0] {
        0 => None,
        1 => {
            let t = finite(&mut r, "the time mocap poses were sampled at")?;
            Some((
                t,
                (0..nm * 7)
                    .map(|_| finite(&mut r, "a sampled mocap pose"))
                    .collect::<Result<Vec<_>, _>>()?,
            ))
        }
        f => return Err(format!("model state is corrupt: sampled mocap flag {f}")),
    };
    let jacobian = match r.take(1, "the solver cache flag")?[0] {
        0 => None,
        1 => {
            let (rows, cols) = (
                r.u64("the Jacobian's rows")?,
                r.u64("the Jacobian's columns")?,
            );
            // The Newton Jacobian is square in the velocity coordinates or the whole state.
            let n = nq + 2 * nv;
            if rows != cols || rows > n as u64 || rows == 0 {
                return Err(format!("model state is corrupt: a {rows} x {cols} Newton Jacobian for {nq} positions and {nv} velocities"));
            }
            let (rows, cols) = (rows as usize, cols as usize);
            let entries = (0..rows * cols)
                .map(|_| finite(&mut r, "a Newton Jacobian entry"))
                .collect::<Result<Vec<_>, _>>()?;
            Some(nalgebra::DMatrix::from_vec(rows, cols, entries))
        }
        f => return Err(format!("model state is corrupt: solver cache flag {f}")),
    };
    let mut velocity_change = None;
    let left = match r.take(1, "the solver cache state flag")?[0] {
        0 => None,
        f @ (1 | 2) if f == 1 || version >= 4 => {
            let q = (0..nq)
                .map(|_| finite(&mut r, "a cached position"))
                .collect::<Result<Vec<_>, _>>()?;
            let v = (0..nv)
                .map(|_| finite(&mut r, "a cached velocity"))
                .collect::<Result<Vec<_>, _>>()?;
            let act = activations(&mut r, "a cached activation")?;
            let h = finite(&mut r, "the cached internal step")?;
            if f == 2 {
                velocity_change = Some(
                    (0..nv)
                        .map(|_| finite(&mut r, "a cached velocity change"))
                        .collect::<Result<Vec<_>, _>>()?,
                );
            }
            Some((State { q, v, act }, h))
        }
        f => {
            return Err(format!(
                "model state is corrupt: solver cache state flag {f}"
            ))
        }
    };
    let ledger = match r.take(1, "the energy ledger flag")?[0] {
        0 => None,
        f @ (1 | 2) if f == 1 || version >= 10 => {
            let q = (0..nq)
                .map(|_| finite(&mut r, "the energy ledger's position"))
                .collect::<Result<Vec<_>, _>>()?;
            let v = (0..nv)
                .map(|_| finite(&mut r, "the energy ledger's velocity"))
                .collect::<Result<Vec<_>, _>>()?;
            let act = activations(&mut r, "the energy ledger's activation")?;
            let mut params = model.contact;
            for p in Param::ALL {
                let x = finite(&mut r, "the energy ledger's contact parameter")?;
                if !p.accepts(x) {
                    return Err(format!(
                        "model state is corrupt: the energy ledger's scm.{} = {x} is out of range",
                        p.describe().0
                    ));
                }
                *p.slot(&mut params) = x;
            }
            let mut next = |what| finite(&mut r, what);
            let (since, reference, work) = (
                next("the energy ledger's start time")?,
                next("the energy ledger's reference energy")?,
                next("the energy ledger's work")?,
            );
            let (gross_work, scale) = (
                next("the energy ledger's gross work")?,
                next("the energy ledger's scale")?,
            );
            // The mechanical energy at the ledger's state is not kept: the function the guard
            // computed it with gives the same bits. Nor, before version 5, the kinetic energy.
            let at = model.energy(&q, &v);
            let kinetic = if version >= 5 {
                next("the energy ledger's kinetic energy")?
            } else {
                at.kinetic
            };
            if gross_work < 0.0 || scale < 0.0 || work.abs() > gross_work * (1.0 + 1e-9) {
                return Err(format!("model state is corrupt: an energy ledger with work {work} J, gross work {gross_work} J and scale {scale} J"));
            }
            if !(0.0..=scale * (1.0 + 1e-9)).contains(&kinetic) {
                return Err(format!("model state is corrupt: an energy ledger with kinetic energy {kinetic} J outside [0, {scale}] J (its scale)"));
            }
            let stored = match f {
                2 => Some(next("the energy ledger's contact energy")?),
                _ => None,
            };
            if stored.is_some_and(|u| u < 0.0) {
                return Err(format!("model state is corrupt: an energy ledger with a negative contact energy ({} J)", stored.unwrap_or_default()));
            }
            Some(EnergyLedger {
                at: State { q, v, act },
                params,
                since,
                reference,
                work,
                gross_work,
                scale,
                kinetic,
                energy: at.total(),
                stored,
            })
        }
        f => return Err(format!("model state is corrupt: energy ledger flag {f}")),
    };
    let reach = if version >= 6 {
        reach_proofs(model, &mut r, version)?
    } else {
        vec![]
    };
    let solver_cache = crate::integrate::SolverCache::from_parts(crate::integrate::CacheParts {
        jacobian,
        left,
        ledger,
        velocity_change,
        reach,
    });
    if r.remaining() != 0 {
        return Err(format!(
            "model state is corrupt: {} unexpected bytes at the end",
            r.remaining()
        ));
    }
    Ok(FmuState {
        sim: SimState {
            time,
            state: State { q, v, act },
            ctrl,
            params,
            mocap,
            mocap_target,
            mocap_sampled,
        },
        integrator,
        timestep: step,
        tolerance,
        solver_cache,
    })
}

/// The kept out-of-reach proofs of a state (version 6 on; by the floor alone from 8): none, or
/// one entry per pair, each proven again at its own pose before it is accepted (a forged proof
/// would switch a contact off).
fn reach_proofs(
    model: &Model,
    r: &mut Reader,
    version: u32,
) -> Result<Vec<Option<ReachProof>>, String> {
    let n = r.u32("the number of kept out-of-reach proofs")? as usize;
    if n != 0 && n != model.pairs.len() {
        return Err(format!(
            "model state is corrupt: {n} kept out-of-reach proofs for {} pairs",
            model.pairs.len()
        ));
    }
    let mut out = Vec::with_capacity(n);
    for pair in model.pairs.iter().take(n) {
        match r.take(1, "a kept out-of-reach proof's flag")?[0] {
            0 => out.push(None),
            1 => {
                let mut sides = [None, None];
                for side in &mut sides {
                    match r.take(1, "a kept proof's side flag")?[0] {
                        0 => {}
                        f @ (1 | 2) if f == 1 || version >= 8 => {
                            let mut x = [0.0; 15];
                            let count = if version >= 9 { 15 } else { 14 };
                            for v in &mut x[..count] {
                                *v = finite(r, "a kept out-of-reach proof's value")?;
                            }
                            let rotation = Matrix3::from_column_slice(&x[..9]);
                            // The proof's bounds assume a rotation (unit axes, lengths kept)
                            // and a margin that is not negative. Its distance may be negative
                            // (a pair with a negative contact margin); the proof is made again
                            // at its own pose before it serves (`reach_proof_holds`).
                            let skew =
                                (rotation.transpose() * rotation - Matrix3::identity()).norm();
                            if !(skew <= 1e-9
                                && rotation.determinant() > 0.0
                                && x[13] >= 0.0
                                && x[14] >= 0.0
                                && (f == 1 || (x[13] == 0.0 && x[14] == 0.0)))
                            {
                                return Err(format!("model state is corrupt: a kept out-of-reach proof with a rotation {skew:e} from orthonormal, distance {} m, margin {} m², room {} m", x[12], x[13], x[14]));
                            }
                            *side = Some(ProofSide {
                                rotation,
                                translation: Vector3::new(x[9], x[10], x[11]),
                                t: x[12],
                                m1: if f == 2 { f64::INFINITY } else { x[13] },
                                room: x[14],
                            });
                        }
                        f => {
                            return Err(format!("model state is corrupt: kept proof side flag {f}"))
                        }
                    }
                }
                let kept = ReachProof { sides };
                let holds = match (&model.colliders[pair.a], &model.colliders[pair.b]) {
                    (Some(a), Some(b)) => reach_proof_holds(a, b, &kept),
                    _ => false,
                };
                if !holds {
                    return Err(format!("model state is corrupt: the kept out-of-reach proof of bodies '{}' and '{}' does not hold", model.tree.bodies[pair.a].name, model.tree.bodies[pair.b].name));
                }
                out.push(Some(kept));
            }
            f => {
                return Err(format!(
                    "model state is corrupt: kept out-of-reach proof flag {f}"
                ))
            }
        }
    }
    Ok(out)
}

/// The next f64 of `r`, refused unless finite.
fn finite(r: &mut Reader, what: &str) -> Result<f64, String> {
    let x = r.f64(what)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("model state is corrupt: {what} is {x}"))
    }
}

#[cfg(test)]
#[path = "state_bytes_tests.rs"]
mod tests;
