//! Flags several commands share, each group once: the scene read, the macro steps of a study,
//! worker threads, resuming from a journal, progress.

use std::path::PathBuf;

use super::scheme_args::positive;

/// The scene a command reads.
#[derive(clap::Args)]
pub(crate) struct SceneFile {
    /// Scene file (TOML), e.g. scenes/lt50m_C.toml.
    #[arg(long)]
    pub(crate) scene: PathBuf,
}

/// The macro steps a study runs at.
#[derive(clap::Args)]
pub(crate) struct Steps {
    /// Macro steps (s, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.04,0.02,0.01,0.005,0.0025")]
    pub(crate) dts: Vec<f64>,
}

/// How many threads a study runs on.
#[derive(clap::Args)]
pub(crate) struct Workers {
    /// Worker threads: the runs are independent (default: one per core; progress bars only
    /// with one).
    #[arg(long, value_parser = studies::options::jobs)]
    pub(crate) jobs: Option<usize>,
}

/// Continuing a study from its journal.
#[derive(clap::Args)]
pub(crate) struct Resume {
    /// Continue work that was interrupted, killed or failed: the points its journal in --out
    /// (`<table>.partial`, written as each point finishes) holds are not computed again.
    #[arg(long)]
    pub(crate) resume: bool,
}

/// Whether progress is shown.
#[derive(clap::Args)]
pub(crate) struct Quiet {
    /// No progress bars or progress lines (the bars are also off when stderr is not a terminal).
    #[arg(long)]
    pub(crate) quiet: bool,
}
