//! Time stepping: one enumeration of integrators (docs/method.md), the same names in code, scenes
//! (`scm_integrator`), the command line (`scm simulate --integrator`) and the FMU
//! (`solver.integrator`); one step of any of them ([`Model::step_with`], generic over the scalar,
//! so its exact derivatives come from the same code), and [`Model::advance`], which covers a
//! communication step with internal steps that land exactly on its end, refusing a step that
//! diverges.
//!
//! Positions live on a manifold (quaternions for free and ball joints). The one-step methods
//! move them with [`Tree::integrate_q`](crate::dynamics::Tree::integrate_q) (the exponential map)
//! or, for the Runge–Kutta methods, combine `q̇ = ½ q ⊗ (0, ω)` stages additively and normalize
//! the quaternions at the end of the step.
//!
//! Mocap bodies move with the constant velocity their inputs carry (see
//! [`Model::inputs_after`]).
//!
//! Files: [`crate::integrator`] names the integrators; `step` holds one internal step of each
//! (generic over the scalar); `advance` covers a communication step and guards it against
//! non-finite states; `cache` holds what one call leaves for the next ([`SolverCache`]); `guard` keeps the energy balance that refuses growth no input explains.
//!
//! [`Model::step_with`]: crate::model::Model::step_with
//! [`Model::advance`]: crate::model::Model::advance
//! [`Model::inputs_after`]: crate::model::Model::inputs_after

mod advance;
mod cache;
mod guard;
mod implicit;
mod newton;
mod step;

pub use crate::integrator::{Integrator, State};
pub use advance::{AdvanceOptions, Advanced, StepFailure, DIVERGED};
pub use cache::{CacheMark, CacheParts, SolverCache};
pub use guard::{contact_energy, EnergyLedger};
pub use step::Dopri5Step;
