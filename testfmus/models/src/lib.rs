//! Small test models in plain Rust, in the spirit of the FMI project's Reference FMUs: each
//! knows its equations and nothing of FMI (`zoo_fmus` exports them as FMI 2.0 Co-Simulation
//! FMUs). Each model is an immutable description (parameters) whose methods advance a state it
//! is handed; the state types derive serde so that an exporter can save them as they are.
//!
//! | model | what | exact answer |
//! |---|---|---|
//! | [`Dahlquist`] | `ẋ = −k x + u` | `x(t+h)` in closed form for a held `u` |
//! | [`VanDerPol`] | `ẍ = μ (1 − x²) ẋ − x + u` | none (RK4 substeps) |
//! | [`BouncingBall`] | free fall with impacts located inside the step | ballistic arcs, impact times |
//! | [`Feedthrough`] | outputs equal inputs, every type | the inputs |
//! | [`Stair`] | a counter that steps every period and ends at a final count | `1 + ⌊t / period⌋` |
//! | [`Table`] | a signal read from a text file, interpolated linearly | the file's points |

mod bouncing_ball;
mod dahlquist;
mod feedthrough;
mod stair;
mod table;
mod van_der_pol;

pub use bouncing_ball::{Ball, BouncingBall};
pub use dahlquist::Dahlquist;
pub use feedthrough::Feedthrough;
pub use stair::{Stair, StairStep};
pub use table::{Table, TableError};
pub use van_der_pol::VanDerPol;
