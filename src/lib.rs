//! Soft-minimum contact model (SCM) as an FMI 2.0 unit.
//!
//! The crate reads as the method: [`geometry`] (oriented point clouds and the soft signed
//! distance function) → [`collision`] (separation field and distribution) → [`contact`]
//! (point–plane, point–SSDF and SSDF–SSDF forces) → [`dynamics`] (kinematic trees, forward and
//! inverse dynamics) → [`model`] (the whole scene's dynamics) → [`integrate`] (time stepping,
//! the methods named in [`integrator`]), with exact first and second derivatives of all of it in
//! [`derivatives`] (on the engines of [`autodiff`]; [`linalg`]'s block inverses serve the
//! mass matrix and the implicit steps). That is the engine; above it, in layers
//! that import only downwards (checked by `tests/layers.rs`): [`scene`] (MJCF in, a [`Model`]
//! out), [`sim`] (a running simulation and its variable table), [`fmi`] (the FMI 2.0 C ABI) and
//! [`pack`] (the `.fmu` archive). The math never sees a file, a pointer or XML.
//!
//! # Features
//! - `fmu` (default): the FMI 2.0 functions (`fmi2Instantiate`, …) exported by the cdylib,
//!   which make `libscm.so` an FMU binary.
//! - `cli` (default): the `scm` command line.
//!
//! With `default-features = false` the crate is a plain Rust library: load a scene with
//! [`scene::load_str`] or [`scene::load`], step its [`Model`] or a [`sim::Simulation`], with no
//! C symbol exported (checked in CI by `scripts/lint.sh`).
//!
//! [`Model`]: model::Model
#![warn(missing_docs)]

pub mod autodiff;
pub mod collision;
pub mod contact;
pub mod derivatives;
pub mod dynamics;
pub mod fmi;
pub mod geometry;
pub mod integrate;
pub mod integrator;
pub mod linalg;
pub mod model;
pub mod pack;
pub mod scalar;
pub mod scene;
pub mod sim;

// The FMI 2.0 C ABI of the FMU binary: every `fmi2*` function, for scenes simulated by
// `sim::Simulation` (feature `fmu`, on by default; without it the crate is a plain library).
#[cfg(feature = "fmu")]
fmi2_exports!(crate::sim::Simulation);
