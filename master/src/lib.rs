//! Library side of the `master` tool: everything the subcommands share, usable from tests.
//!
//! * [`plot`]: SVG figures (time histories like the paper's Figs. 4–5, log–log work–precision);
//! * [`progress`]: a progress bar for long runs on a terminal;
//! * [`table`]: plain-text tables.

pub mod monolithic;
pub mod plot;
pub mod progress;
pub mod table;
