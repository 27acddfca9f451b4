//! FMI 2.0 Co-Simulation for this workspace, in plain Rust.
//!
//! * [`export`]: a model implements [`export::Model`]; `fmi2::export_fmu!(Model)` in a cdylib
//!   crate exports the 34 `fmi2*` C functions with the standard's state machine, checks and
//!   FMU-state handling.
//! * [`description`]: the variable table and its validation; [`xml`] writes
//!   `modelDescription.xml` from it, so the XML and the code cannot disagree.
//! * [`package`]: writes `.fmu` archives.
//! * [`import`]: loads any FMI 2.0 Co-Simulation FMU and calls it through a safe API.
//! * [`ffi`]: the C types of the standard; [`uri`]: resource-location URIs;
//!   [`state_bytes`]: helpers for models to save and restore their state bit for bit.

pub mod description;
pub mod export;
pub mod ffi;
pub mod import;
pub mod package;
pub mod resources;
pub mod state_bytes;
pub mod uri;
pub mod xml;

pub use description::{
    Capabilities, Causality, DefaultExperiment, Initial, ModelDescription, ModelInfo, Unit, Value, VarType,
    Variability, Variable,
};
pub use export::{Model, Resource};
