//! What can go wrong in the Stewart model, with the leg (1-based) and the time it happened at.

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StewartError {
    /// The joint-centre distance of a leg lies outside what its two parts can span.
    #[error("Stewart leg {leg} at t = {time} s: joint distance {length:.6} m is {}", leg_bound(*length, *shortest, *longest))]
    LegLength { leg: usize, time: f64, length: f64, shortest: f64, longest: f64 },
    /// A leg lies along its first Hooke axis: the Hooke joint locks (gimbal lock).
    #[error(
        "Stewart leg {leg} at t = {time} s: the leg lies along its first Hooke axis (sine of the angle {sin_angle:.3e}); the Hooke joint is singular"
    )]
    HookeSingular { leg: usize, time: f64, sin_angle: f64 },
    /// The six legs cannot carry an arbitrary wrench on the platform (force Jacobian singular).
    #[error(
        "Stewart platform at t = {time} s: singular pose, the legs' force Jacobian has condition number {condition:.3e}; the legs cannot hold the platform"
    )]
    SingularPose { time: f64, condition: f64 },
    /// Forward kinematics did not converge.
    #[error(
        "Stewart forward kinematics: no convergence after {iterations} Newton iterations (leg length residual {residual:.3e} m)"
    )]
    ForwardKinematics { iterations: usize, residual: f64 },
    /// The feed's rotation from its start attitude reaches π, where its rate is not defined.
    #[error("the feed's rotation from its start attitude reaches π at t = {time} s")]
    FeedRotationAtPi { time: f64 },
    /// The scene's LQG controller could not be made.
    #[error("{0}")]
    Design(String),
    /// An input that is not a finite number (or a model set up with one).
    #[error("Stewart model: {what} = {value} is not valid")]
    Input { what: String, value: String },
}

fn leg_bound(length: f64, shortest: f64, longest: f64) -> String {
    if length < shortest {
        format!("shorter than the shortest possible leg {shortest} m (the longer part)")
    } else {
        format!("longer than the longest possible leg {longest} m (both parts end to end)")
    }
}
