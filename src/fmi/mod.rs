//! FMI 2.0 plumbing: the same for every model; a model implements [`contract::FmiModel`].
pub mod contract;
