//! Library side of the `master` tool: everything the subcommands share, usable from tests.
//!
//! * [`cosim`]: the co-simulation crate, re-exported (systems, schemes, IQN, step control, SSP);
//! * [`monolithic`]: the paper's eq. (7) for the whole system, the accuracy reference;
//! * [`limits`]: what a run may cost (steps, memory), checked before anything is built;
//! * [`plot`]: SVG figures (time histories like the paper's Figs. 4–5, log–log work–precision,
//!   stability maps);
//! * [`options`]: the scheme names and options, as the command line and the Python package take them;
//! * [`report`]: what `statics`, `modes` and `run` report (their `--json`), for the CLI and Python;
//! * [`simulate`]: one run of a method (monolithic, a co-simulation scheme, decoupled) as a trace;
//! * [`feed`]: the feed's error in the world frame and the platform's limits (`[control]`);
//! * [`stepping`]: the step loop of every run (fixed or adaptive steps, caps, totals);
//! * [`system`]: the scene's `[system]` as a system description, and runs of any FMU system;
//! * [`progress`]: a progress bar for long runs on a terminal;
//! * [`table`]: plain-text tables; [`tempfiles`]: where a result is written before it is moved
//!   into place;
//! * [`parallel`]: independent cases on every core, results in order;
//! * [`sweep`]: grids over the workspace and the parameters, their tables and maps;
//! * [`calibrate`]: scene keys fitted to measured natural frequencies (model updating);
//! * [`net`]: the system in space at one instant (cable points and tensions, cabin, platform,
//!   feed), what runs hand to a [`net::NetSink`]; [`view3d`]: the net drawn in 3-D (statics,
//!   mode shapes); [`vtk`]: the net as VTK files and series for ParaView;
//! * [`interrupt`]: Ctrl-C between steps and points; [`journal`]: the points a long command
//!   finished, kept through an interrupt or a kill for `--resume`.

pub use cosim;
pub mod calibrate;
pub use monolithic;
pub mod feed;
pub mod interrupt;
pub mod journal;
pub mod limits;
pub mod net;
pub mod options;
pub mod parallel;
pub mod plot;
pub mod progress;
pub mod report;
pub mod simulate;
pub mod stepping;
pub mod sweep;
pub mod system;
pub mod table;
pub mod tempfiles;
pub mod view3d;
pub mod vtk;
