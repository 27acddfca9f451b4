//! `master stress`: the long and the hard runs — 1000 s simulated, ten times stiffer cables, 50
//! elements per cable, the nearly slack cable at B, abrupt against smooth start, the platform held
//! still — each with what bounds it: drift, constraint residual, the response's growth, the
//! agreement of IJCSA with the monolithic model. (The cable-only and free-body stress tests are
//! in the test suite.)
//! The cases are the library's ([`studies::stress`]).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use studies::stress::{self, Scenes};

use crate::progress::Shown;

use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene C (the centre of the workspace) …
    #[arg(long, default_value = "scenes/lt50m_C.toml")]
    pub(crate) scene_c: PathBuf,
    /// … and scene B (the edge, with the nearly slack cable).
    #[arg(long, default_value = "scenes/lt50m_B.toml")]
    pub(crate) scene_b: PathBuf,
    /// Durations divided by 50 (a check that every case runs, for the test suite).
    #[arg(long)]
    pub(crate) quick: bool,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let (c, b) = (load_scene(&args.scene_c)?, load_scene(&args.scene_b)?);
    let scenes = Scenes { c: &c, c_file: &args.scene_c, b: &b, b_file: &args.scene_b };
    let shown = Shown { lines: true, bars: std::io::stderr().is_terminal() };
    let cases = stress::run(scenes, args.quick, &caps().run, &shown);
    write!(std::io::stdout().lock(), "{}", cases.table().render())?;
    let failures = cases.failures();
    if failures > 0 {
        anyhow::bail!("{failures} stress case(s) failed");
    }
    Ok(())
}
