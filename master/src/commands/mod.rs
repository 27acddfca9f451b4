//! One module per subcommand. Each has an `Args` struct (clap) and `run(&Args)`.

pub mod modes;
pub mod package;
pub mod replay;
pub mod statics;
pub mod stewart;

/// Errors reach the user as one readable message.
pub type CmdResult = Result<(), Box<dyn std::error::Error>>;
