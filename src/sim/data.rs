//! [`Data`]: everything of a running simulation that changes, in one place beside the
//! [`Model`](crate::model::Model) (MuJoCo's `mjData` beside its `mjModel`). Each field says
//! whether it can change what a step computes and whether it is part of the FMU state
//! (`fmi2GetFMUstate`, and the bytes of `src/sim/state_bytes.rs`).
//!
//! Outside it, by design: the model's solver settings (integrator, step, tolerance: part of
//! the FMU state, set through the model as MuJoCo's `mjModel.opt`); and each point cloud's
//! hierarchy, built once on first use (`OnceLock` in `src/geometry/aopc.rs`; changes nothing).
//! The hierarchy walks' scratch is carried with the pairs' data in [`SolverCache`], one per
//! pair thread (`Scratch`, `src/collision/scratch.rs`); nothing is kept in thread-locals.

use super::outputs::ContactOutputs;
use super::{PointsCache, SimState};
use crate::fmi::contract::LogMessage;
use crate::integrate::SolverCache;

/// Everything of a running [`Simulation`](super::Simulation) that changes (see the module).
#[derive(Clone, Debug)]
pub struct Data {
    /// The current state: time, positions, velocities, controls, contact parameters and the
    /// mocap bodies. Changes a result: it is what the next step starts from. FMU state: yes.
    pub current: SimState,
    /// What the integrator carries from one communication step to the next
    /// ([`SolverCache`]: Newton's warm Jacobian, the energy guard's ledger, the pairs' proofs
    /// and candidate memos, the walks' scratch, the kinematics memo). Changes a result: in the
    /// last bits (where Newton starts), in which pairs a proof switches off (below its bound), and in which steps
    /// the guard refuses. FMU state: yes; in memory (`fmi2GetFMUstate`) a whole copy (but the
    /// scratch, which starts empty), in the serialized bytes all but the memos and the scratch
    /// ([`SolverCache::parts`]).
    pub(crate) solver: SolverCache,
    /// The contact outputs and the state they were computed at, as far as they have been read,
    /// and the candidate planes their evaluations keep ([`ContactOutputs`]): they serve while
    /// the current state is that one (a memo). Changes a result: no. FMU state: no.
    pub(super) outputs: ContactOutputs,
    /// Soft top-K contact points per pair and the positions and ε1, ε2 they were computed at
    /// (a memo). Changes a result: no. FMU state: no.
    pub(super) points: Option<PointsCache>,
    /// The accelerations `v̇` and the state they were computed at (a memo). Changes a result:
    /// no. FMU state: no.
    pub(super) accelerations: Option<(SimState, Vec<f64>)>,
    /// Messages queued for the host's logger. Changes a result: no. FMU state: no.
    pub(super) messages: Vec<LogMessage>,
    /// Whether the host sees `logContact` messages (so diagnostics are formatted only then).
    /// Changes a result: no. FMU state: no.
    pub(super) log_contact: bool,
    /// Whether the simulation is initialized or has stepped: from then on
    /// [`Simulation::set`](super::Simulation::set) sets inputs and tunable parameters only,
    /// as after an FMU's initialization. Changes a result: no (it gates what a host may set).
    /// FMU state: no (the FMI plumbing keeps the instance's own state machine).
    pub(super) started: bool,
}

impl Data {
    /// The data of a simulation about to start at `start`, with `messages` queued.
    pub(super) fn at(start: SimState, messages: Vec<LogMessage>) -> Data {
        Data {
            current: start,
            solver: SolverCache::default(),
            outputs: ContactOutputs::default(),
            points: None,
            accelerations: None,
            messages,
            log_contact: false,
            started: false,
        }
    }

    /// Forgets what was carried or kept for the model as it was: the integrator's carry and
    /// the memos (after a change to the model itself, such as its pruning tolerance, that the
    /// state they are keyed by does not show).
    pub(super) fn forget_model(&mut self) {
        self.solver = SolverCache::default();
        self.outputs = ContactOutputs::default();
        self.points = None;
        self.accelerations = None;
    }
}
