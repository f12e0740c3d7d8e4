//! Soft-minimum contact model (SCM) as an FMI 2.0 unit.
pub mod fmi;
