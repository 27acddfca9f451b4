//! Library side of the `master` tool: everything the subcommands share, usable from tests.
//!
//! * [`cosim`]: the co-simulation crate, re-exported (systems, schemes, IQN, step control, SSP);
//! * [`monolithic`]: the paper's eq. (7) for the whole system, the accuracy reference;
//! * [`plot`]: SVG figures (time histories like the paper's Figs. 4–5, log–log work–precision);
//! * [`simulate`]: one run of a method (monolithic, a co-simulation scheme, decoupled) as a trace;
//! * [`system`]: the scene's `[system]` as a system description, and runs of any FMU system;
//! * [`progress`]: a progress bar for long runs on a terminal;
//! * [`table`]: plain-text tables.

pub use cosim;
pub mod monolithic;
pub mod plot;
pub mod progress;
pub mod simulate;
pub mod system;
pub mod table;
