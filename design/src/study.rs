//! What `master design` computes from a design model: the LQG controller and its predicted
//! figures (the bound), the penalties that keep strokes and forces inside the scene's limits,
//! the uncompensated prediction, the bound against the fixes' rate and delay, and with each
//! instrument made better.
//!
//! What the bound bounds: the LQG controller minimizes the time average of
//! `|feed error|² + ℓ²|feed rotation|² + w_s²Σ strokes² + w_f²Σ forces² + w_u²|command|²` on the
//! design model with the instruments given. Any linear time-invariant controller (of any order,
//! using the same readings and fixes at the same times) with no larger mean squares of the
//! feed's rotation, the strokes, the forces and the command has a feed error RMS no lower than
//! the LQG's: were it lower, its cost would be below the minimum.

use feedcore::scene::{LqgDesign, ValidScene};
use nalgebra::DMatrix;

use crate::h2::ClosedLoop;
use crate::lqg::{Synthesis, SynthesisError, synthesize};
use crate::plant::{CoupledPlant, Instruments, PlantError, build};
use crate::sampled;

/// A Gaussian's excursions stay below this many standard deviations but for 7e-6 of the time:
/// the predicted strokes' and forces' RMS times it must stay inside the limits.
pub const PEAK_FACTOR: f64 = 4.5;

/// Predicted RMS figures of a closed loop (or of the uncompensated model).
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// The feed's position error (norm), m.
    pub feed_m: f64,
    /// Per component (x, y, z), m.
    pub feed_components_m: [f64; 3],
    /// The feed axis's tilt, rad.
    pub tilt_rad: f64,
    /// Each leg's stroke from rest, m; each actuator force's change, N.
    pub strokes_m: [f64; 6],
    pub forces_n: [f64; 6],
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Plant(#[from] PlantError),
    #[error(transparent)]
    Synthesis(#[from] SynthesisError),
    #[error("the closed loop's covariance: {0}")]
    Covariance(#[from] sampled::LyapunovError),
    #[error("{0}")]
    Limits(String),
}

fn six(v: &[f64]) -> [f64; 6] {
    std::array::from_fn(|i| v[i].sqrt())
}

/// The LQG of `design` with `ins`, and its predicted figures.
pub fn evaluate(
    scene: &ValidScene,
    design: &LqgDesign,
    ins: &Instruments,
) -> Result<(CoupledPlant, Synthesis, Figures), StudyError> {
    let cp = build(scene, design, ins)?;
    let syn = synthesize(&cp.plant)?;
    let cl = ClosedLoop::new(&cp.plant, &syn)?;
    let feed = cl.component_mean_squares(&cp.feed.0, &cp.feed.1);
    let figures = Figures {
        feed_m: feed.iter().sum::<f64>().sqrt(),
        feed_components_m: [feed[0].sqrt(), feed[1].sqrt(), feed[2].sqrt()],
        tilt_rad: cl.mean_square(&cp.tilt.0, &cp.tilt.1).sqrt(),
        strokes_m: six(&cl.component_mean_squares(&cp.strokes.0, &cp.strokes.1)),
        forces_n: six(&cl.component_mean_squares(&cp.forces.0, &cp.forces.1)),
    };
    Ok((cp, syn, figures))
}

/// The design model's prediction without compensation (the platform held at rest): the
/// fluctuating part only (the model has no mean wind).
pub fn uncompensated(cp: &CoupledPlant) -> Result<Figures, StudyError> {
    let p = &cp.plant;
    let nc = p.continuous_states();
    let (phi, _) = sampled::hold(&p.a, &DMatrix::zeros(nc, 1), p.period);
    let cov = sampled::lyapunov(&phi, &sampled::noise(&p.a, &p.w, p.period))?;
    let ms = |h: &DMatrix<f64>| -> Vec<f64> {
        let c = h * &cov * h.transpose();
        (0..c.nrows()).map(|i| c[(i, i)]).collect()
    };
    let feed = ms(&cp.feed.0);
    Ok(Figures {
        feed_m: feed.iter().sum::<f64>().sqrt(),
        feed_components_m: [feed[0].sqrt(), feed[1].sqrt(), feed[2].sqrt()],
        tilt_rad: ms(&cp.tilt.0).iter().sum::<f64>().sqrt(),
        strokes_m: [0.0; 6],
        forces_n: six(&ms(&cp.forces.0)),
    })
}

/// The scene's limits as the design keeps them: each leg's half stroke (m) and each actuator's
/// margin from its force at rest to the force limit (N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub stroke_m: Option<[f64; 6]>,
    pub force_margin_n: Option<[f64; 6]>,
}

impl Limits {
    /// The worst share of a limit the predicted peaks (RMS × [`PEAK_FACTOR`]) take.
    pub fn usage(&self, f: &Figures) -> f64 {
        let mut worst: f64 = 0.0;
        if let Some(s) = self.stroke_m {
            for i in 0..6 {
                worst = worst.max(PEAK_FACTOR * f.strokes_m[i] / s[i]);
            }
        }
        if let Some(m) = self.force_margin_n {
            for i in 0..6 {
                worst = worst.max(PEAK_FACTOR * f.forces_n[i] / m[i]);
            }
        }
        worst
    }
}

/// Most tenfold raises of the stroke and force penalties.
const RAISES: usize = 8;

/// The design with its stroke and force penalties raised tenfold until the predicted peaks stay
/// inside the limits (from the penalties it has: small ones, so that the limits decide).
pub fn keep_within(
    scene: &ValidScene,
    design: &LqgDesign,
    ins: &Instruments,
    limits: &Limits,
) -> Result<(LqgDesign, CoupledPlant, Synthesis, Figures), StudyError> {
    let mut d = design.clone();
    for _ in 0..=RAISES {
        let (cp, syn, fig) = evaluate(scene, &d, ins)?;
        if limits.usage(&fig) <= 1.0 {
            return Ok((d, cp, syn, fig));
        }
        d.stroke_weight *= 10.0;
        d.force_weight_m_per_n *= 10.0;
    }
    Err(StudyError::Limits(format!(
        "no penalty up to stroke weight {:e} and force weight {:e} m/N keeps the predicted strokes and forces \
         within the limits (×{PEAK_FACTOR} their RMS)",
        d.stroke_weight / 10.0,
        d.force_weight_m_per_n / 10.0
    )))
}

/// One cell of the bound against the fixes' rate and delay.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub rate_hz: f64,
    pub delay_s: f64,
    /// The bound's feed RMS (m), or why there is none.
    pub feed_m: Result<f64, String>,
}

/// The instruments with fixes at `rate_hz` (a whole fraction of the unit's rate) and `delay_s`.
pub fn with_fixes(ins: &Instruments, rate_hz: f64, delay_s: f64) -> Result<Instruments, String> {
    let every = 1.0 / (rate_hz * ins.period);
    if !((every - every.round()).abs() <= 1e-9 * every && every.round() >= 1.0) {
        return Err(format!("{rate_hz} Hz is not the unit's rate ({} Hz) divided by a whole number", 1.0 / ins.period));
    }
    Ok(Instruments {
        fix_every: every.round() as usize,
        delay_steps: crate::plant::delay_steps(delay_s, ins.period),
        ..*ins
    })
}

/// The bound (feed RMS) of each rate and delay.
pub fn sweep(
    scene: &ValidScene,
    design: &LqgDesign,
    ins: &Instruments,
    rates_hz: &[f64],
    delays_s: &[f64],
) -> Vec<Cell> {
    let mut cells = Vec::new();
    for &rate_hz in rates_hz {
        for &delay_s in delays_s {
            let feed_m = with_fixes(ins, rate_hz, delay_s)
                .and_then(|i| evaluate(scene, design, &i).map(|(_, _, f)| f.feed_m).map_err(|e| e.to_string()));
            cells.push(Cell { rate_hz, delay_s, feed_m });
        }
    }
    cells
}

/// What each instrument made better gives: (what, the bound's feed RMS in m).
pub fn improvements(scene: &ValidScene, design: &LqgDesign, ins: &Instruments) -> Vec<(String, Result<f64, String>)> {
    let mut out = Vec::new();
    let mut try_one = |what: String, d: &LqgDesign, i: &Instruments| {
        out.push((what, evaluate(scene, d, i).map(|(_, _, f)| f.feed_m).map_err(|e| e.to_string())));
    };
    try_one(
        "the inertial unit's noise and bias walks ×0.1".into(),
        design,
        &Instruments {
            accel_noise_density: ins.accel_noise_density * 0.1,
            gyro_noise_density: ins.gyro_noise_density * 0.1,
            accel_bias_walk: ins.accel_bias_walk * 0.1,
            gyro_bias_walk: ins.gyro_bias_walk * 0.1,
            ..*ins
        },
    );
    try_one(
        "the fixes' noise ×0.1".into(),
        design,
        &Instruments { fix_noise_m: ins.fix_noise_m * 0.1, fix_noise_rad: ins.fix_noise_rad * 0.1, ..*ins },
    );
    try_one("the fixes without delay".into(), design, &Instruments { delay_steps: 0, ..*ins });
    try_one("a fix at every reading".into(), design, &Instruments { fix_every: 1, ..*ins });
    try_one("the servo ×2 as fast".into(), design, &Instruments { servo_hz: ins.servo_hz * 2.0, ..*ins });
    let mut exact = design.clone();
    (exact.model_error_force_n, exact.model_error_moment_nm) = (0.0, 0.0);
    try_one("an exact linear model (no model error)".into(), &exact, ins);
    out
}
