//! FMI 2.0 plumbing: the same for every model; a model implements [`contract::FmiModel`].
//!
//! - [`contract`]: what a model implements (safe Rust, no C types).
//! - [`ffi`]: the FMI 2.0 C types and the host logger (unsafe, at the edge).
//! - [`state_machine`]: which `fmi2*` function is legal in which state, as data.
//! - [`uri`]: `fmuResourceLocation` to a path.
//! - [`instance`]: one instance in safe Rust; every `fmi2*` function as a method.
//! - [`exports`]: the C ABI: generic `extern "C"` functions and the [`fmi2_exports!`](crate::fmi2_exports) macro.
//! - [`model_description`]: `modelDescription.xml` from a [`contract::ModelInfo`].
//! - [`pack`]: the `.fmu` archive.
//! - [`serial`]: the byte format of a serialized FMU state (versioned, checksummed, GUID-bound).
pub mod contract;
pub mod exports;
pub mod ffi;
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
pub mod host_log;
pub mod instance;
pub mod model_description;
pub mod pack;
pub mod serial;
pub mod state_machine;
pub mod uri;

#[cfg(test)]
pub(crate) mod toy_model;
