//! `master stewart` (not implemented yet).

use super::CmdResult;

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: &Args) -> CmdResult {
    Err("`master stewart` is not implemented yet".into())
}
