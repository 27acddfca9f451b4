//! FMI 2.0 and 3.0, Co-Simulation and Model Exchange, for this workspace, in plain Rust.
//!
//! * [`description`]: what `modelDescription.xml` says, as data — one set of types that the
//!   exporter writes from and the importer reads into — and its validation for export.
//! * [`xml`]: `modelDescription.xml` generated from a description and parsed back into one.
//! * [`export`]: a model implements [`export::Model`]; `fmi::export_fmu!(Model)` in a cdylib
//!   crate exports the 34 `fmi2*` C functions with the standard's state machine, checks and
//!   FMU-state handling.
//! * [`package`]: writes `.fmu` archives.
//! * [`import`]: loads any FMI 2.0 or 3.0 FMU, Co-Simulation or Model Exchange, and calls it
//!   through a safe API.
//! * [`fmi3`]: the same models exported as FMI 3.0.
//! * [`resources`]: files a model reads through a String parameter, inside `resources/`.
//! * [`table`]: a model's Real variables declared once, as a table of blocks.
//! * [`ffi`]: the C types of the standard; [`uri`]: resource-location URIs.
//! * [`archive`]: single entries of a zip archive unpacked within a budget; [`digest`]: FNV-1a.

/// The README's examples, compiled by `cargo test` so that they follow the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExamples;

pub mod archive;
pub mod description;
pub mod digest;
pub mod export;
pub mod ffi;
pub mod fmi3;
pub mod import;
pub mod package;
pub mod resources;
pub mod table;
pub mod uri;
pub mod xml;

pub use description::{
    Causality, CoSimulationFlags, ContinuousState, DefaultExperiment, Initial, ModelDescription, ModelExchange,
    ModelInfo, Unit, Value, VarType, Variability, Variable,
};
pub use export::{Model, Resource};
