//! A scene compiled as MuJoCo's compiler compiles it, before SCM builds its colliders: what
//! `scm compile` prints and the differential tests compare.

use super::*;

/// A scene compiled as MuJoCo's compiler would (bodies, inertias, joints, geoms, actuators),
/// before SCM builds its colliders: what the differential tests compare with MuJoCo's
/// `MjModel`, and what `scm compile` prints.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// Bodies and joints.
    pub tree: Tree,
    /// Geoms, in file order.
    pub geoms: Vec<Geom>,
    /// Actuators.
    pub actuators: Vec<Actuator>,
    /// `<option timestep>` (s).
    pub timestep: f64,
    /// `<option integrator>` as SCM maps it.
    pub integrator: Integrator,
    /// Each joint's limits (m or rad), if limited.
    pub limits: Vec<Option<(f64, f64)>>,
    /// Each joint's range of its total actuator force (`actuatorfrcrange`), if limited.
    pub actuator_ranges: Vec<Option<(f64, f64)>>,
    /// Fixed tendons.
    pub tendons: Vec<crate::dynamics::tendon::FixedTendon>,
    /// Spatial tendons.
    pub spatial_tendons: Vec<crate::dynamics::tendon::SpatialTendon>,
    /// The sites and slider-cranks that actuators drive.
    pub transmissions: actuator::Transmissions,
    /// Joint and tendon equalities.
    pub equalities: Vec<crate::dynamics::equality::ScalarEquality>,
    /// Connect and weld equalities.
    pub connects: Vec<crate::dynamics::equality::Connect>,
    /// The fluid forces, if the medium has a density or a viscosity.
    pub fluid: Option<crate::dynamics::fluid::Fluid>,
    /// What SCM refuses to simulate, with file and line.
    pub refused: Vec<SceneError>,
    /// Accepted and unused by SCM.
    pub unused: Vec<String>,
    /// Accepted but modelled differently from MuJoCo.
    pub warnings: Vec<String>,
    /// Each contact pair's bodies, margin and law from `solref` and `solimp` (none where the
    /// scene's `scm_stiffness` or `scm_dissipation_velocity` applies, or contact is off).
    pub pair_laws: Vec<CompiledPair>,
}

/// A contact pair of a [`Compiled`] model: its bodies' names, its margin (m) and its law.
#[derive(Clone, Debug)]
pub struct CompiledPair {
    /// The first body.
    pub body1: String,
    /// The second body.
    pub body2: String,
    /// Its margin (m; [`crate::model::Pair::margin`]).
    pub margin: f64,
    /// Its adhesion (N) and gap (m; [`crate::model::Pair::adhesion`], [`crate::model::Pair::gap`]).
    pub adhesion: (f64, f64),
    /// The least stiction velocity it takes (m/s; [`crate::model::Pair::stiction_floor`] times
    /// its friction; NaN where the scene's `scm_friction` gives it, 0 for none).
    pub stiction_floor: f64,
    /// Whether its finite dissipation force holds a separation
    /// ([`crate::model::Pair::hold_separation`]; false where the force is infinite).
    pub hold_separation: bool,
    /// Its stiffness and damping from `solref` and `solimp`.
    pub law: contact::PairLaw,
}

/// Compiles a scene file without building colliders and without refusing: see [`Compiled`].
pub fn compile(path: &Path) -> Result<Compiled, SceneError> {
    let text = read_text(path)?;
    let (b, _) = read(&text, path)?;
    b.compiled()
}
