//! `master modes` (not implemented yet).

use super::CmdResult;

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: &Args) -> CmdResult {
    Err("`master modes` is not implemented yet".into())
}
