//! Soft-minimum contact model (SCM) as an FMI 2.0 unit.
//!
//! The crate reads as the method: [`geometry`] (oriented point clouds and the soft signed
//! distance function) → [`collision`] (separation field and distribution) → [`contact`]
//! (point–plane, point–SSDF and SSDF–SSDF forces) → [`dynamics`] (kinematic trees, forward and
//! inverse dynamics) → [`integrate`] (time stepping), with exact first and second derivatives of
//! all of it in [`derivatives`]. [`scene`] (MJCF loader) and [`fmi`] (the
//! FMI 2.0 C ABI) are the edges: the math never sees a file, a pointer or XML.
#![warn(missing_docs)]

pub mod collision;
pub mod contact;
pub mod derivatives;
pub mod dynamics;
pub mod fmi;
pub mod geometry;
pub mod integrate;
pub mod model;
pub mod pack;
pub mod scalar;
pub mod scene;
pub mod sim;

// The FMI 2.0 C ABI of the FMU binary: every `fmi2*` function, for scenes simulated by
// `sim::Simulation`.
fmi2_exports!(crate::sim::Simulation);
