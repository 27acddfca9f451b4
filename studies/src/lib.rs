//! What can be asked of a scene or of a system of FMUs, as a library: typed settings in, typed
//! results out, nothing printed, and no file written but where a caller hands a writer or names a
//! place (a VTK series' folder). The `master` command line and the Python package `feedsim` are
//! two front ends over it.
//!
//! * [`cosim`]: the co-simulation crate, re-exported (systems, schemes, IQN, step control, SSP);
//! * [`monolithic`]: the paper's eq. (7) for the whole system, the accuracy reference;
//! * [`options`]: the methods and their options, with their ranges and defaults;
//! * [`limits`]: what a run may cost (steps, memory), checked before anything is built;
//! * [`simulate`]: one run of a method (monolithic, a co-simulation scheme, decoupled) as a trace;
//! * [`stepping`]: the step loop of every run (fixed or adaptive steps, caps, totals), and what a
//!   caller watches of it ([`stepping::Watch`]);
//! * [`system`]: the scene's `[system]` as a system description, and runs of any FMU system;
//! * [`feed`]: the feed's error in the world frame and the platform's limits (`[control]`);
//! * [`report`]: what statics, modes and a run report (the command line's `--json`);
//! * [`sweep`]: grids over the workspace and the parameters, their tables and maps;
//! * the studies, each with its settings, its results and their tables, CSV and figures:
//!   [`compare`] (each method against the monolithic model), [`bench`] (run time against
//!   error), [`stability`] (where each scheme is stable), [`compensation`] (the second level:
//!   feed error, sensor sweep, error budget), [`tune`] (the second level's filter chosen),
//!   [`stress`] (the long and hard runs), [`reproduce`] (the paper side by side, with the
//!   modal [`hypotheses`]), [`calibrate`] (scene keys fitted to measured natural frequencies),
//!   [`lqg`] (the second level's LQG design and the bound no linear controller beats);
//! * [`observe`]: what a caller sees of a study as it goes;
//! * [`net`]: the system in space at one instant (cable points and tensions, cabin, platform,
//!   feed), what runs hand to a [`net::NetSink`]; [`view3d`]: the net drawn in 3-D (statics,
//!   mode shapes); [`vtk`]: the net as VTK files and series for ParaView; [`tempfiles`]: where a
//!   result is written before it is moved into place;
//! * [`plot`]: SVG figures (time histories, work–precision, stability maps); [`table`]: plain-text
//!   tables;
//! * [`parallel`]: independent cases on every core, results in order; [`points`]: the points of
//!   a long study, each kept as it finishes by the caller's store, and taken from it on resume;
//! * [`cancel`]: a caller's request to stop between steps and points.

pub use cosim;
pub use monolithic;

pub mod bench;
pub mod calibrate;
pub mod cancel;
pub mod compare;
pub mod compensation;
pub mod feed;
pub mod hypotheses;
pub mod limits;
pub mod lqg;
pub mod net;
pub mod observe;
pub mod options;
pub mod parallel;
pub mod plot;
pub mod points;
pub mod report;
pub mod reproduce;
pub mod simulate;
pub mod stability;
pub mod stepping;
pub mod stress;
pub mod sweep;
pub mod system;
pub mod table;
pub mod tempfiles;
pub mod tune;
pub mod view3d;
pub mod vtk;
