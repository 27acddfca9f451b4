//! Library side of the `master` tool: everything the subcommands share, usable from tests.
//!
//! * [`cosim`]: FMUs coupled by a scheme (Jacobi, Gauss–Seidel, iterative, IJCSA);
//! * [`monolithic`]: the paper's eq. (7) for the whole system, the accuracy reference (its own
//!   crate, re-exported);
//! * [`plot`]: SVG figures (time histories like the paper's Figs. 4–5, log–log work–precision);
//! * [`simulate`]: one run of a method (monolithic, a co-simulation scheme, decoupled) as a trace;
//! * [`progress`]: a progress bar for long runs on a terminal;
//! * [`table`]: plain-text tables.

pub mod cosim;
pub use monolithic;
pub mod plot;
pub mod progress;
pub mod simulate;
pub mod table;
