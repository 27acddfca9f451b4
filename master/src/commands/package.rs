//! `master package`: build the Co-Simulation archives (`.fmu`) of every model the workspace
//! exports, FMI 2.0 in `<out>/` and FMI 3.0 in `<out>/fmi3/`, from the in-process model
//! descriptions and the built shared libraries (each exports both versions).

use std::path::{Path, PathBuf};

use fmi::export::Model;

use super::BoxResult as CmdResult;

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Directory for the `.fmu` files (created if missing).
    #[arg(long, default_value = "dist")]
    pub out: PathBuf,
    /// Directory holding the built `lib<crate>.so` files [default: the directory of this executable].
    #[arg(long)]
    pub lib_dir: Option<PathBuf>,
}

/// A model the workspace exports as an FMU.
pub(crate) struct Exportable {
    /// Cargo package of the cdylib (its library is `lib<package>.so`).
    pub package: &'static str,
    /// Writes `<out>/<modelIdentifier>.fmu` from the library; returns the archive path.
    pub write: fn(&Path, &Path) -> Result<PathBuf, fmi::package::PackageError>,
    /// The same as FMI 3.0.
    pub write3: fn(&Path, &Path) -> Result<PathBuf, fmi::package::PackageError>,
}

impl Exportable {
    pub(crate) const fn of<M: Model>(package: &'static str) -> Exportable {
        Exportable { package, write: fmi::package::package_model::<M>, write3: fmi::package::package_model3::<M> }
    }
}

/// The folder below `--out` of the FMI 3.0 archives.
pub(crate) const FMI3_DIR: &str = "fmi3";

/// Every FMU of the workspace: one line per model (its `Model` type and its cdylib package).
pub(crate) const EXPORTABLE: &[Exportable] = &[
    Exportable::of::<fmi_testmodel::Oscillator>("fmi_testmodel"),
    Exportable::of::<cable_fmu::CableFmu>("cable_fmu_cdylib"),
    Exportable::of::<stewart_fmu::StewartFmu>("stewart_fmu_cdylib"),
    // The zoo: small FMUs that know nothing of the LT50m system (testfmus/, docs/systems.md).
    Exportable::of::<zoo_fmus::dahlquist::DahlquistFmu>("zoo_dahlquist"),
    Exportable::of::<zoo_fmus::van_der_pol::VanDerPolFmu>("zoo_van_der_pol"),
    Exportable::of::<zoo_fmus::bouncing_ball::BouncingBallFmu>("zoo_bouncing_ball"),
    Exportable::of::<zoo_fmus::feedthrough::FeedthroughFmu>("zoo_feedthrough"),
    Exportable::of::<zoo_fmus::stair::StairFmu>("zoo_stair"),
    Exportable::of::<zoo_fmus::resource::ResourceFmu>("zoo_resource"),
];

pub(crate) fn run(args: &Args) -> CmdResult {
    let lib_dir = match &args.lib_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()?.parent().ok_or("the master executable has no parent directory")?.to_owned(),
    };
    for e in EXPORTABLE {
        let lib = lib_dir.join(format!("lib{}.so", e.package));
        if !lib.is_file() {
            return Err(format!(
                "{} not found: build it with `cargo build --release -p {}` (or point --lib-dir at it)",
                lib.display(),
                e.package
            )
            .into());
        }
        for fmu in [(e.write)(&args.out, &lib)?, (e.write3)(&args.out.join(FMI3_DIR), &lib)?] {
            let size = std::fs::metadata(&fmu)?.len();
            println!("{} ({:.1} MB, from {})", fmu.display(), size as f64 / 1e6, lib.display());
        }
    }
    Ok(())
}
