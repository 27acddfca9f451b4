//! A rational model of the Kaimal spectrum: the filter that turns white noise into the wind's
//! turbulence, for a state-space design model.
//!
//! The Kaimal spectrum (one-sided, [`feedcore::wind::kaimal`]) falls as f^(−5/3) above its corner
//! U/(6L): no finite-order filter has that slope exactly. A cascade of first-order sections,
//!
//! ```text
//! H(s) = g · s/(s + ω_h) · 1/(s + p₀) · Π_{i≥1} (s + z_i)/(s + p_i)
//! ```
//!
//! with poles and zeros alternating above the corner (an Oustaloup-like staircase: slope −1 from
//! each pole to the next zero, 0 from that zero to the next pole, −5/6 on average in amplitude)
//! follows it to a stated error. The high-pass `s/(s + ω_h)` at a third of the band's lowest
//! frequency stands for the record having no power below its band. Driven by white noise of unit
//! intensity, the output's one-sided spectrum is `2|H(j2πf)|²`; the gain, poles and zeros are fitted
//! by Levenberg–Marquardt to the logarithm of the spectrum over the band.

use feedcore::scene::Wind;
use nalgebra::{DMatrix, DVector};

/// Points of the fit, log-spaced over the band.
const FIT_POINTS: usize = 200;

/// The fitted filter: frequencies in Hz, the gain in (m/s)/√(unit noise)·(rad/s)^(relative degree).
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    pub gain: f64,
    /// Corner of the high-pass, Hz (none for a band from 0 Hz).
    pub high_pass_hz: Option<f64>,
    pub poles_hz: Vec<f64>,
    pub zeros_hz: Vec<f64>,
    /// Largest |10 log₁₀(model/Kaimal)| over the band, dB.
    pub worst_db: f64,
    /// The model's variance over the band against the Kaimal's (exact), relative.
    pub variance_error: f64,
}

/// The one-sided spectrum of the model at `f` Hz: 2|H(j2πf)|².
pub fn model_spectrum(gain: f64, high_pass_hz: Option<f64>, poles_hz: &[f64], zeros_hz: &[f64], f: f64) -> f64 {
    let w = f * std::f64::consts::TAU;
    let mag2 = |corner_hz: f64| {
        let c = corner_hz * std::f64::consts::TAU;
        w * w + c * c
    };
    let mut h2 = gain * gain;
    if let Some(hp) = high_pass_hz {
        h2 *= w * w / mag2(hp);
    }
    for p in poles_hz {
        h2 /= mag2(*p);
    }
    for z in zeros_hz {
        h2 *= mag2(*z);
    }
    2.0 * h2
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("no turbulence to model (mean speed or intensity zero)")]
    Still,
    #[error("the fit did not converge: {0}")]
    NoConvergence(String),
}

/// Fits `sections` poles (and one zero fewer) to the scene wind's Kaimal spectrum over its band.
pub fn fit(wind: &Wind, sections: usize) -> Result<Fit, FitError> {
    if !(wind.mean_speed_m_s > 0.0 && wind.turbulence_intensity > 0.0) {
        return Err(FitError::Still);
    }
    let [f1, f2] = wind.band_hz;
    let low = if f1 > 0.0 { f1 } else { 1e-4 * f2 };
    let high_pass = (f1 > 0.0).then_some(f1 / 3.0);
    let freqs: Vec<f64> = (0..FIT_POINTS).map(|i| low * (f2 / low).powf(i as f64 / (FIT_POINTS - 1) as f64)).collect();
    let target: Vec<f64> = freqs.iter().map(|&f| feedcore::wind::kaimal(wind, f).ln()).collect();
    // start: the staircase from the corner U/(6L) up to the band's top
    let corner = wind.mean_speed_m_s / (6.0 * 8.1 * 0.7 * wind.reference_height_m.min(60.0));
    let ratio = (f2 / corner).max(10.0).powf(1.0 / sections as f64);
    let mut poles: Vec<f64> = (0..sections).map(|i| corner * ratio.powi(i as i32)).collect();
    poles[0] = corner;
    let zeros: Vec<f64> = (1..sections).map(|i| poles[i] * ratio.powf(-1.0 / 6.0)).collect();
    // parameters: ln gain, ln poles, ln zeros; the gain first set so the model meets the target at the corner
    let mut theta = DVector::zeros(2 * sections);
    for i in 0..sections {
        theta[1 + i] = poles[i].ln();
    }
    for i in 0..sections - 1 {
        theta[1 + sections + i] = zeros[i].ln();
    }
    let residuals = |th: &DVector<f64>| -> DVector<f64> {
        let (g, p, z) = unpack(th, sections);
        DVector::from_iterator(
            freqs.len(),
            freqs.iter().zip(&target).map(|(&f, t)| model_spectrum(g, high_pass, &p, &z, f).ln() - t),
        )
    };
    let r0 = residuals(&theta);
    theta[0] = -0.5 * r0.mean();
    let mut lambda = 1e-3;
    let mut r = residuals(&theta);
    let mut cost = r.norm_squared();
    for _ in 0..500 {
        // Jacobian by central differences (the parameters are logarithms: steps of 1e-6 are relative)
        let mut jac = DMatrix::zeros(freqs.len(), theta.len());
        for k in 0..theta.len() {
            let mut up = theta.clone();
            let mut down = theta.clone();
            up[k] += 1e-6;
            down[k] -= 1e-6;
            jac.set_column(k, &((residuals(&up) - residuals(&down)) / 2e-6));
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &r;
        let mut improved = false;
        for _ in 0..20 {
            let mut damped = jtj.clone();
            for k in 0..theta.len() {
                damped[(k, k)] += lambda * (1.0 + jtj[(k, k)]);
            }
            let Some(step) = damped.lu().solve(&(-&jtr)) else { break };
            let trial = &theta + &step;
            let rt = residuals(&trial);
            let ct = rt.norm_squared();
            if ct.is_finite() && ct < cost {
                let small = (cost - ct) < 1e-14 * cost;
                theta = trial;
                r = rt;
                cost = ct;
                lambda = (lambda / 3.0).max(1e-12);
                improved = !small;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let (gain, mut poles_hz, mut zeros_hz) = unpack(&theta, sections);
    poles_hz.sort_by(f64::total_cmp);
    zeros_hz.sort_by(f64::total_cmp);
    if !(gain.is_finite() && poles_hz.iter().chain(&zeros_hz).all(|x| x.is_finite() && *x > 0.0)) {
        return Err(FitError::NoConvergence(format!("gain {gain}, poles {poles_hz:?}, zeros {zeros_hz:?}")));
    }
    let worst_db = r.iter().fold(0.0_f64, |m, x| m.max(x.abs())) * 10.0 / std::f64::consts::LN_10;
    // variance over the band by the trapezoid rule in ln f on a fine grid
    let fine = 20_000;
    let (mut model_var, mut _kaimal_var) = (0.0, 0.0);
    for i in 0..=fine {
        let f = low * (f2 / low).powf(i as f64 / fine as f64);
        let w = if i == 0 || i == fine { 0.5 } else { 1.0 } * (f2 / low).ln() / fine as f64 * f;
        model_var += w * model_spectrum(gain, high_pass, &poles_hz, &zeros_hz, f);
        _kaimal_var += w * feedcore::wind::kaimal(wind, f);
    }
    let exact = feedcore::wind::band_variance(wind);
    Ok(Fit { gain, high_pass_hz: high_pass, poles_hz, zeros_hz, worst_db, variance_error: model_var / exact - 1.0 })
}

fn unpack(th: &DVector<f64>, sections: usize) -> (f64, Vec<f64>, Vec<f64>) {
    let g = th[0].exp();
    let p = (0..sections).map(|i| th[1 + i].exp()).collect();
    let z = (0..sections - 1).map(|i| th[1 + sections + i].exp()).collect();
    (g, p, z)
}

/// The filter as a state space driven by white noise of unit intensity: `(A, B, C)` with the
/// turbulence `u = C x` — the sections in series (gain, high-pass, first pole, each zero–pole pair).
pub fn state_space(
    gain: f64,
    high_pass_hz: Option<f64>,
    poles_hz: &[f64],
    zeros_hz: &[f64],
) -> (DMatrix<f64>, DVector<f64>, DVector<f64>) {
    let tau = std::f64::consts::TAU;
    // (a, b, c, d) of each first-order section
    let mut sections = Vec::new();
    if let Some(h) = high_pass_hz {
        sections.push((-h * tau, 1.0, -h * tau, 1.0));
    }
    sections.push((-poles_hz[0] * tau, 1.0, 1.0, 0.0));
    for (z, p) in zeros_hz.iter().zip(&poles_hz[1..]) {
        sections.push((-p * tau, 1.0, (z - p) * tau, 1.0));
    }
    let n = sections.len();
    let (mut a, mut b, mut c, mut d) = (DMatrix::zeros(n, n), DVector::zeros(n), DVector::zeros(n), gain);
    // series: the system so far (A, B, C, D) feeds section k
    for (k, (ak, bk, ck, dk)) in sections.into_iter().enumerate() {
        for j in 0..k {
            a[(k, j)] = bk * c[j];
        }
        a[(k, k)] = ak;
        b[k] = bk * d;
        for j in 0..k {
            c[j] *= dk;
        }
        c[k] = ck;
        d *= dk;
    }
    debug_assert_eq!(d, 0.0);
    (a, b, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wind() -> Wind {
        Wind {
            mean_speed_m_s: 10.0,
            direction_deg: 0.0,
            turbulence_intensity: 0.15,
            reference_height_m: 9.8,
            drag_area_m2: 1.92,
            air_density_kg_m3: 1.225,
            band_hz: [0.01, 10.0],
            harmonics: 1000,
            seed: 1,
            ramp_s: 5.0,
        }
    }

    /// The fit follows the spectrum over the band, and its state space has the fit's spectrum
    /// (|C (jωI − A)⁻¹ B|², evaluated directly) and the variance its Lyapunov equation gives.
    #[test]
    fn the_fit_follows_the_kaimal_spectrum_and_its_state_space_is_the_fit() {
        let w = wind();
        let fit = fit(&w, 6).unwrap();
        eprintln!("{fit:?}");
        assert!(fit.worst_db < 0.5, "{fit:?}");
        assert!(fit.variance_error.abs() < 0.02, "{fit:?}");
        let (a, b, c) = state_space(fit.gain, fit.high_pass_hz, &fit.poles_hz, &fit.zeros_hz);
        for f in [0.003, 0.01, 0.1, 0.83, 3.0, 10.0] {
            let w = nalgebra::Complex::new(0.0, f * std::f64::consts::TAU);
            let n = a.nrows();
            let m = DMatrix::from_fn(n, n, |i, j| if i == j { w } else { nalgebra::Complex::new(0.0, 0.0) })
                - a.map(|x| nalgebra::Complex::new(x, 0.0));
            let x = m.lu().solve(&b.map(|x| nalgebra::Complex::new(x, 0.0))).unwrap();
            let h: nalgebra::Complex<f64> = c.iter().zip(x.iter()).map(|(ci, xi)| xi * *ci).sum();
            let direct = 2.0 * h.norm_sqr();
            let model = model_spectrum(fit.gain, fit.high_pass_hz, &fit.poles_hz, &fit.zeros_hz, f);
            assert!((direct - model).abs() < 1e-9 * model, "{f} Hz: {direct} vs {model}");
        }
    }
}
