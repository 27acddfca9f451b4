//! `resource`: a signal read from a text file in the FMU's `resources/` directory (the String
//! parameter `file`, default `signal.txt`): `y(t)` interpolated linearly between the file's
//! points, `points` the number of points, `title` the file's title.
//!
//! The files are read from disk, never from a copy compiled into the binary, so the FMU works
//! only where the importer hands it the right resource location: without one, instantiation
//! fails and says so.

use std::path::Path;

use fmi::export::{Model, ModelError, Resource, StepOutcome};
use fmi::resources::{FileKind, FileParameter, SavedFile};
use fmi::{Causality, ModelDescription, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::{Table, TableError};

/// Value references, per type.
pub mod vr {
    /// Real.
    pub const Y: u32 = 0;
    /// Integer.
    pub const POINTS: u32 = 0;
    /// String.
    pub const FILE: u32 = 0;
    pub const TITLE: u32 = 1;
}

/// The file read when `file` is not set.
pub const DEFAULT_FILE: &str = "signal.txt";

fn parse(text: &str, _origin: &str) -> Result<Table, TableError> {
    Table::parse(text)
}

/// Tables: read from `resources/` only (no shipped copies), at most 64 KiB.
static TABLES: FileKind<Table, TableError> = FileKind::new(&[], 64 * 1024, parse);

pub struct ResourceFmu {
    table: FileParameter<Table, TableError>,
    /// The time of the outputs (the start time until the first step).
    time: f64,
}

/// A saved state: the file's name and the time.
#[derive(Serialize, Deserialize)]
pub struct SavedResource<'a> {
    #[serde(borrow)]
    file: SavedFile<'a>,
    time: f64,
}

impl Model for ResourceFmu {
    type State<'a> = SavedResource<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let output = |name: &str, vr: u32, t: VarType, v: Variability| {
            Variable::new(name, vr, t, Causality::Output, v).depends_on::<&str>(&[]).initially_depends_on(&["file"])
        };
        let variables = vec![
            output("y", vr::Y, VarType::Real, Variability::Continuous).describe("the signal, linear between points"),
            output("points", vr::POINTS, VarType::Integer, Variability::Discrete).describe("points in the file"),
            output("title", vr::TITLE, VarType::String, Variability::Discrete).describe("the file's title"),
            Variable::parameter("file", vr::FILE, DEFAULT_FILE, false)
                .describe("the signal's file (lines `time value`, `title = ...`), relative to resources/"),
        ];
        Ok(crate::description(
            "resource",
            "{a1f7d5b1-5956-41e8-941b-c97c90c99266}",
            "A signal read from a file in the FMU's resources/ directory",
            false,
            (4.0, 0.1),
            variables,
        ))
    }

    fn resources() -> Vec<Resource> {
        Resource::texts(&[
            ("signal.txt", include_str!("../resources/signal.txt")),
            ("ramp.txt", include_str!("../resources/ramp.txt")),
        ])
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(ResourceFmu { table: TABLES.open(resources, DEFAULT_FILE)?, time: 0.0 })
    }

    fn set_real(&mut self, vr: u32, _value: f64) -> Result<(), ModelError> {
        Err(format!("value reference {vr} is not settable").into())
    }

    fn get_real(&mut self, _vr: u32) -> Result<f64, ModelError> {
        Ok(self.table.value().value_at(self.time))
    }

    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        i32::try_from(self.table.value().times.len()).map_err(|_| "more points than an Integer counts".into())
    }

    /// `file`, the only settable String: read at once, so that a missing or malformed file is
    /// reported by fmi2SetString (and the parameter keeps its file).
    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        self.table.set(value)?;
        Ok(())
    }

    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        Ok(if vr == vr::FILE { self.table.name().to_owned() } else { self.table.value().title.clone() })
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.time = start_time;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        self.time = t + h;
        Ok(StepOutcome::Complete)
    }

    fn save(&mut self) -> Result<SavedResource<'_>, ModelError> {
        Ok(SavedResource { file: self.table.saved(), time: self.time })
    }

    fn restore(&mut self, saved: SavedResource<'_>) -> Result<(), ModelError> {
        self.table.restore(saved.file)?;
        self.time = saved.time;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resources() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("resources")
    }

    #[test]
    fn reads_its_file_from_the_resource_directory_only() {
        let mut m = ResourceFmu::instantiate(Some(&resources())).unwrap();
        assert_eq!(m.get_integer(vr::POINTS).unwrap(), 4);
        assert_eq!(m.get_string(vr::TITLE).unwrap(), "triangle from resources/signal.txt");
        m.exit_initialization(0.0).unwrap();
        m.do_step(0.0, 1.5).unwrap();
        assert_eq!(m.get_real(vr::Y).unwrap(), 0.5);
        m.set_string(vr::FILE, "ramp.txt").unwrap();
        assert_eq!(m.get_real(vr::Y).unwrap(), 1.75);
        let e = m.set_string(vr::FILE, "missing.txt").unwrap_err().to_string();
        assert!(e.contains("missing.txt"), "{e}");
        assert_eq!(m.get_string(vr::FILE).unwrap(), "ramp.txt", "unchanged by the error");
        let e = ResourceFmu::instantiate(None).err().expect("no location, no file").to_string();
        assert!(e.contains("no resource location"), "{e}");
    }
}
