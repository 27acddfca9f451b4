//! The integrated state and the scratch of a step.

/// Everything the integrator carries from step to step (what a rollback restores, together
/// with whatever the model keeps of its own, such as a factorization).
#[derive(Debug, PartialEq)]
pub struct State<C> {
    pub time: f64,
    pub config: C,
    pub velocity: Vec<f64>,
    /// True acceleration v̇.
    pub acceleration: Vec<f64>,
    /// The generalized-α pseudo-acceleration `a`.
    pub pseudo_acceleration: Vec<f64>,
    /// Lagrange multipliers (empty without constraints).
    pub multipliers: Vec<f64>,
    /// The acceleration one step back, and that step's size (0 before the first step): the
    /// predictor extrapolates from them.
    pub previous_acceleration: Vec<f64>,
    pub previous_step: f64,
}

impl<C> State<C> {
    /// A state whose pseudo-acceleration equals its acceleration (a consistent start).
    pub fn new(time: f64, config: C, velocity: Vec<f64>, acceleration: Vec<f64>, multipliers: Vec<f64>) -> Self {
        assert_eq!(velocity.len(), acceleration.len(), "velocity and acceleration differ in length");
        State {
            time,
            config,
            velocity,
            pseudo_acceleration: acceleration.clone(),
            previous_acceleration: acceleration.clone(),
            acceleration,
            multipliers,
            previous_step: 0.0,
        }
    }

    /// Number of motion unknowns.
    pub fn dim(&self) -> usize {
        self.velocity.len()
    }
}

impl<C: Clone> Clone for State<C> {
    fn clone(&self) -> Self {
        State {
            time: self.time,
            config: self.config.clone(),
            velocity: self.velocity.clone(),
            acceleration: self.acceleration.clone(),
            pseudo_acceleration: self.pseudo_acceleration.clone(),
            multipliers: self.multipliers.clone(),
            previous_acceleration: self.previous_acceleration.clone(),
            previous_step: self.previous_step,
        }
    }

    /// Copies `source` into the existing storage (no allocation when the sizes agree).
    fn clone_from(&mut self, source: &Self) {
        self.time = source.time;
        self.config.clone_from(&source.config);
        self.velocity.clone_from(&source.velocity);
        self.acceleration.clone_from(&source.acceleration);
        self.pseudo_acceleration.clone_from(&source.pseudo_acceleration);
        self.multipliers.clone_from(&source.multipliers);
        self.previous_acceleration.clone_from(&source.previous_acceleration);
        self.previous_step = source.previous_step;
    }
}

/// Scratch of a step, allocated once for a state's sizes and reused.
#[derive(Clone, Debug)]
pub struct Workspace<C> {
    pub(crate) trial: C,
    pub(crate) increment: Vec<f64>,
    pub(crate) velocity: Vec<f64>,
    pub(crate) acceleration: Vec<f64>,
    pub(crate) multipliers: Vec<f64>,
    pub(crate) residual: Vec<f64>,
    pub(crate) delta: Vec<f64>,
}

impl<C: Clone> Workspace<C> {
    pub fn new(state: &State<C>) -> Self {
        let (n, m) = (state.velocity.len(), state.multipliers.len());
        Workspace {
            trial: state.config.clone(),
            increment: vec![0.0; n],
            velocity: vec![0.0; n],
            acceleration: vec![0.0; n],
            multipliers: vec![0.0; m],
            residual: vec![0.0; n + m],
            delta: vec![0.0; n + m],
        }
    }
}

impl<C> Workspace<C> {
    /// The velocity-level increment of the last step taken (of its last half, if it was halved).
    pub fn increment(&self) -> &[f64] {
        &self.increment
    }
}
