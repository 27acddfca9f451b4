//! `master reproduce --out DIR`: every number and figure of docs/reproduction.md, written — the paper's
//! Table 2 and Figs. 4–6 side by side with ours and with ours under each hypothesis that could
//! explain the distance (a linearisation, another E, the platform locked, added or absent; a
//! ramped or momentum-consistent start; the platform's weight shift left out).
//!
//! Writes `table2.csv` (every modal case), `responses.csv` (peaks and the fast part of every
//! response case), `static_inertial.csv` (the static response to the inertial reactions),
//! `spectra.csv` (amplitude spectra of Y), `numbers.md` (the tables of docs/reproduction.md),
//! and the figures `fig4_B.svg`, `fig5_C.svg`, `spectrum.svg`. Runs are the monolithic model's
//! (IJCSA follows it: see the tests), 100 s at the scenes' step; `--quick` runs 10 s and a
//! reduced grid of modal cases (the test suite's check).
//! The reproduction is the library's ([`studies::reproduce`]).

use std::io::Write;
use std::path::{Path, PathBuf};

use studies::reproduce::{self, Scenes};

use crate::progress::Shown;

use super::output::Outputs;
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Directory for the tables and figures.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// The paper's pose B …
    #[arg(long, default_value = "scenes/lt50m_B.toml")]
    pub(crate) scene_b: PathBuf,
    /// … and pose C.
    #[arg(long, default_value = "scenes/lt50m_C.toml")]
    pub(crate) scene_c: PathBuf,
    /// 10 s runs and a reduced grid of modal cases (a check that everything runs).
    #[arg(long)]
    pub(crate) quick: bool,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let (b, c) = (load_scene(&args.scene_b)?, load_scene(&args.scene_c)?);
    let mut outputs = Outputs::new([args.scene_b.clone(), args.scene_c.clone()]);
    let names = [
        "table2.csv",
        "responses.csv",
        "static_inertial.csv",
        "spectra.csv",
        "numbers.md",
        "fig4_B.svg",
        "fig5_C.svg",
        "spectrum.svg",
    ];
    let mut ids = Vec::new();
    for n in names {
        let ext = Path::new(n).extension().and_then(|e| e.to_str());
        ids.push(outputs.declare("--out", &args.out.join(n), ext)?);
    }
    outputs.open()?;
    let scenes = Scenes { b: &b, b_file: &args.scene_b, c: &c, c_file: &args.scene_c };
    let r = reproduce::run(scenes, args.quick, &caps().run, &Shown { lines: true, bars: false })?;
    let md = r.numbers_md();
    let contents = [
        r.table2_csv(),
        r.responses_csv(),
        r.static_inertial_csv(),
        r.spectra_csv(),
        md.clone(),
        r.fig4()?,
        r.fig5()?,
        r.spectrum()?,
    ];
    for (id, content) in ids.into_iter().zip(contents) {
        outputs.write(id, |w| w.write_all(content.as_bytes()))?;
    }
    outputs.commit()?;
    let mut out = std::io::stdout().lock();
    write!(out, "{md}")?;
    writeln!(out, "\nTables and figures in {}.", args.out.display())?;
    Ok(())
}
