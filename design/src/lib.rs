//! The second level's model-based design.
//!
//! * [`riccati`]: the discrete-time algebraic Riccati equation (doubling), checked by residual;
//! * [`sampled`]: a continuous system sampled with its input held (Van Loan), the Lyapunov equation;
//! * [`lqg`]: sampled-data LQG synthesis with a periodic Kalman filter, and the controller;
//! * [`kaimal`]: a rational model of the wind's Kaimal spectrum (the turbulence as filtered white noise);
//! * [`plant`]: the linear design model of the coupled system from a scene's `[control.lqg]` and instruments;
//! * [`h2`]: the closed loop's stationary covariance and any output's mean square.
//! * [`study`]: the bound, the penalties that keep the limits, the bound against the fixes' rate and delay;
//! * [`simulate`]: a seeded run of the linear closed loop, what predictions are checked against.

pub mod h2;
pub mod kaimal;
pub mod lqg;
pub mod plant;
pub mod riccati;
pub mod sampled;
pub mod simulate;
pub mod study;
