//! One module per subcommand. Each has an `Args` struct (clap) and `run(&Args)`.

pub mod bench;
pub mod compare;
pub mod modes;
pub mod package;
pub mod replay;
pub mod run;
pub mod scaling;
pub mod scheme_args;
pub mod stability;
pub mod statics;
pub mod stewart;
pub mod stress;
pub mod sweep;

/// Errors reach the user as one readable message.
pub type CmdResult = Result<(), Box<dyn std::error::Error>>;
