//! The coupled model linearized at rest, for the second level's design (`[control.lqg]`).
//!
//! From the models this crate couples, at the static equilibrium of the scene's pose with the
//! platform at rest:
//!
//! * the cable–cabin modes with the platform locked (the cable crate's sparse modal solver):
//!   the lowest `modes`, of which every one up to `keep_below_hz` and above it those whose cabin
//!   share of the kinetic energy reaches `min_cabin_share` are kept (a mode the cabin hardly takes
//!   part in is neither driven by the wind or the platform nor seen by the instruments; above the
//!   band it acts statically), their Rayleigh damping ratios
//!   `α/(2ω) + βω/2` exactly; and what the modes left out give the cabin statically (the net's
//!   compliance at the cabin less the kept modes' `Σ φφᵀ/ω²`) as pseudo-modes at 20 Hz;
//! * the platform's wrench on the cabin, the legs' lengths and the actuator forces against its
//!   relative pose and acceleration, and the forces against the cabin's acceleration and
//!   rotation: central differences of the Stewart model's Newton–Euler solution (linear in the
//!   accelerations, so that their differences are exact to round-off);
//! * the wind: the drag linearized about the mean speed, and the fitted Kaimal filter (without
//!   `[wind]`, a filter whose load is nil).
//!
//! The locked payload of the modes and the platform model's own reaction to the cabin's
//! acceleration are one physics (tests check them against each other), so the relative motion
//! adds only what it changes.

use cable::model::{CableCabin, Payload};
use design::kaimal;
use feedcore::scene::{LEGS, LqgDesign, ValidScene};
use feedcore::{Quat, Vec3};
use nalgebra::Matrix6;
use stewart::compensation::commanded_point;
use stewart::{CabinMotion, Stewart};

/// What to keep of the modes, and the cost's weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// The lowest modes computed.
    pub modes: usize,
    /// Every mode up to this frequency is kept (Hz); above it, those with a cabin share of
    /// their kinetic energy of at least `min_cabin_share`.
    pub keep_below_hz: f64,
    pub min_cabin_share: f64,
    /// Poles of the wind's filter.
    pub wind_sections: usize,
    /// The fixes' delay the controller assumes, s.
    pub delay_s: f64,
    /// The linear model's error as a white wrench's densities (N/√Hz, N·m/√Hz); see [`model_error`].
    pub model_error: (f64, f64),
    pub tilt_weight_m: f64,
    pub stroke_weight: f64,
    pub force_weight_m_per_n: f64,
    pub command_weight: f64,
}

/// The design model with what was found on the way.
#[derive(Clone, Debug)]
pub struct Linearization {
    pub design: LqgDesign,
    /// Every mode computed: frequency (Hz), cabin share, kept.
    pub modes: Vec<(f64, f64, bool)>,
    pub wind_fit: kaimal::Fit,
    /// The actuator forces at rest, N.
    pub static_forces: [f64; LEGS],
    /// The leg lengths at rest, m.
    pub static_legs: [f64; LEGS],
    /// The platform's wrench per unit cabin acceleration from the Stewart model (minus its added
    /// mass) and the locked payload's spatial mass from the cable model, about the cabin centre.
    pub added_mass: Matrix6<f64>,
    pub locked_payload: Matrix6<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum LinearError {
    #[error("{0}")]
    Scene(String),
    #[error(transparent)]
    Model(#[from] cable::model::ModelError),
    #[error(transparent)]
    Stewart(#[from] stewart::StewartError),
    #[error("the wind's filter: {0}")]
    Wind(#[from] kaimal::FitError),
}

/// The pseudo-modes that carry the left-out modes' static compliance: far above the band the
/// design cares for (3 Hz) and below the readings' Nyquist frequency, damped near critically.
const PSEUDO_MODE_HZ: f64 = 20.0;
const PSEUDO_MODE_DAMPING: f64 = 0.7;

/// Steps of the central differences: pose (m, rad), acceleration (m/s², rad/s²).
const POSE_STEP: f64 = 1e-6;
const ACCELERATION_STEP: f64 = 1e-3;

/// The scene's design model.
pub fn linearize(scene: &ValidScene, o: &Options) -> Result<Linearization, LinearError> {
    let model = CableCabin::build(scene, o.modes)?;
    let found = model.modes.as_ref().ok_or_else(|| LinearError::Scene("no modes were computed".into()))?;
    let sys = model.system(Payload::Locked);
    let eq = &model.equilibrium;
    let rot = eq.orientation.to_rotation_matrix().into_inner();
    let locked_body = sys.body.transformed(&rot, &eq.position);
    let cabin_mass = locked_body.spatial_matrix_about(&eq.position);
    let (alpha, beta) = (model.damping.alpha, model.damping.beta);
    let mut modes = Vec::new();
    let (mut modes_hz, mut damping_ratios, mut cabin_shapes) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..o.modes.min(found.frequencies_hz.len()) {
        let f = found.frequencies_hz[k];
        let shape = found.cabin_part(k);
        let share = shape.dot(&(cabin_mass * shape));
        let keep = f > 0.0 && (f <= o.keep_below_hz || share >= o.min_cabin_share);
        modes.push((f, share, keep));
        if keep {
            let w = std::f64::consts::TAU * f;
            modes_hz.push(f);
            damping_ratios.push(alpha / (2.0 * w) + beta * w / 2.0);
            cabin_shapes.push(shape.as_slice().to_vec());
        }
    }
    // the modes left out, as the cabin's static compliance they carry: pseudo-modes above the
    // band (residual flexibility), so that the moments the platform puts on the cabin move it by
    // what the whole net gives (a tenth of the cabin's tilt at 2 Hz lies in the modes left out)
    let compliance = {
        let tangent = cable::modes::tangent(&sys, &model.equilibrium_config());
        let factor =
            tangent.stiffness.factorize(false).map_err(|e| LinearError::Scene(format!("the static stiffness: {e}")))?;
        let n = sys.dim();
        let c0 = sys.cabin_offset();
        let mut g = Matrix6::zeros();
        for j in 0..6 {
            let mut b = vec![0.0; n];
            b[c0 + j] = 1.0;
            factor.solve_in_place(&mut b);
            for i in 0..6 {
                g[(i, j)] = b[c0 + i];
            }
        }
        g
    };
    let mut kept_compliance = Matrix6::zeros();
    for (f, shape) in modes_hz.iter().zip(&cabin_shapes) {
        let phi = nalgebra::Vector6::from_column_slice(shape);
        kept_compliance += phi * phi.transpose() / (std::f64::consts::TAU * f).powi(2);
    }
    let residual = compliance - kept_compliance;
    let residual = (residual + residual.transpose()) * 0.5;
    let eig = residual.symmetric_eigen();
    let w = std::f64::consts::TAU * PSEUDO_MODE_HZ;
    let largest = eig.eigenvalues.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for (k, lambda) in eig.eigenvalues.iter().enumerate() {
        if *lambda > 1e-6 * largest && *lambda > 0.0 {
            let shape = eig.eigenvectors.column(k) * (lambda.sqrt() * w);
            modes_hz.push(PSEUDO_MODE_HZ);
            damping_ratios.push(PSEUDO_MODE_DAMPING);
            cabin_shapes.push(shape.as_slice().to_vec());
        }
    }
    if modes_hz.is_empty() {
        return Err(LinearError::Scene(format!(
            "no mode of the lowest {} has a cabin share of {} or more",
            o.modes, o.min_cabin_share
        )));
    }
    // the platform at rest in the cabin at rest
    let stewart = Stewart::from_scene(scene)?;
    let comp = stewart.compensation().ok_or_else(|| LinearError::Scene("no compensation".into()))?;
    let (p0, q0) = (scene.target_position(), scene.target_orientation());
    let rest = comp.rest().position;
    let r0 = [rest.x, rest.y, rest.z, 0.0, 0.0, 0.0];
    let evaluate = |cabin: &CabinMotion, r: &[f64; 6], acc: &[f64; 6]| {
        stewart.evaluate_at(cabin, &commanded_point(r, &[0.0; 6], acc), 0.0)
    };
    let still = CabinMotion::at_rest(p0, q0);
    let at_rest = evaluate(&still, &r0, &[0.0; 6])?;
    // columns by central differences of (wrench, legs, forces)
    let outputs = |cabin: &CabinMotion, r: &[f64; 6], acc: &[f64; 6]| -> Result<[f64; 18], LinearError> {
        let e = evaluate(cabin, r, acc)?;
        let w = e.wrench.to_vector();
        let mut out = [0.0; 18];
        out[..6].copy_from_slice(w.as_slice());
        out[6..12].copy_from_slice(&e.leg_lengths);
        out[12..].copy_from_slice(&e.actuator_forces);
        Ok(out)
    };
    let column = |plus: [f64; 18], minus: [f64; 18], step: f64| -> [f64; 18] {
        std::array::from_fn(|i| (plus[i] - minus[i]) / (2.0 * step))
    };
    let mut by_pose = Vec::new();
    let mut by_acceleration = Vec::new();
    for j in 0..6 {
        let (mut up, mut down) = (r0, r0);
        up[j] += POSE_STEP;
        down[j] -= POSE_STEP;
        by_pose.push(column(outputs(&still, &up, &[0.0; 6])?, outputs(&still, &down, &[0.0; 6])?, POSE_STEP));
        let (mut up, mut down) = ([0.0; 6], [0.0; 6]);
        up[j] = ACCELERATION_STEP;
        down[j] = -ACCELERATION_STEP;
        by_acceleration.push(column(outputs(&still, &r0, &up)?, outputs(&still, &r0, &down)?, ACCELERATION_STEP));
    }
    let mut by_cabin_acceleration = Vec::new();
    let mut by_cabin_rotation = Vec::new();
    for j in 0..6 {
        let moved = |s: f64| {
            let mut c = still;
            if j < 3 {
                c.acceleration[j] = s;
            } else {
                c.angular_acceleration[j - 3] = s;
            }
            c
        };
        by_cabin_acceleration.push(column(
            outputs(&moved(ACCELERATION_STEP), &r0, &[0.0; 6])?,
            outputs(&moved(-ACCELERATION_STEP), &r0, &[0.0; 6])?,
            ACCELERATION_STEP,
        ));
        if j < 3 {
            let turned = |s: f64| {
                let mut c = still;
                let mut axis = Vec3::zeros();
                axis[j] = s;
                c.orientation = Quat::from_scaled_axis(axis) * q0;
                c
            };
            by_cabin_rotation.push(column(
                outputs(&turned(POSE_STEP), &r0, &[0.0; 6])?,
                outputs(&turned(-POSE_STEP), &r0, &[0.0; 6])?,
                POSE_STEP,
            ));
        }
    }
    // rows `from..from + 6` of the columns, as a matrix given by rows
    let block = |cols: &[[f64; 18]], from: usize| -> Vec<Vec<f64>> {
        (0..6).map(|i| cols.iter().map(|c| c[from + i]).collect()).collect()
    };
    let added_mass = Matrix6::from_fn(|i, j| by_cabin_acceleration[j][i]);
    // without [wind], a still-air filter whose load is nil
    let (fit, direction, force) = match scene.wind.as_ref() {
        Some(wind) => {
            let a = wind.direction_deg.to_radians();
            let force = wind.air_density_kg_m3 * wind.drag_area_m2 * wind.mean_speed_m_s;
            (kaimal::fit(wind, o.wind_sections)?, [a.cos(), a.sin(), 0.0], force)
        }
        None => (
            kaimal::Fit {
                gain: 1.0,
                high_pass_hz: None,
                poles_hz: vec![1.0],
                zeros_hz: Vec::new(),
                worst_db: 0.0,
                variance_error: 0.0,
            },
            [1.0, 0.0, 0.0],
            0.0,
        ),
    };
    let feed_arm = q0 * (rest + comp.feed_point());
    let design = LqgDesign {
        delay_s: o.delay_s,
        modes_hz,
        damping_ratios,
        cabin_shapes,
        reaction_pose: block(&by_pose, 0),
        reaction_acceleration: block(&by_acceleration, 0),
        leg_jacobian: block(&by_pose, 6),
        force_pose: block(&by_pose, 12),
        force_acceleration: block(&by_acceleration, 12),
        force_cabin_acceleration: block(&by_cabin_acceleration, 12),
        force_cabin_rotation: block(&by_cabin_rotation, 12),
        feed_arm_m: feed_arm.into(),
        wind_direction: direction,
        wind_force_n_per_m_s: force,
        wind_gain: fit.gain,
        wind_high_pass_hz: fit.high_pass_hz,
        wind_poles_hz: fit.poles_hz.clone(),
        wind_zeros_hz: fit.zeros_hz.clone(),
        model_error_force_n: o.model_error.0,
        model_error_moment_nm: o.model_error.1,
        tilt_weight_m: o.tilt_weight_m,
        stroke_weight: o.stroke_weight,
        force_weight_m_per_n: o.force_weight_m_per_n,
        command_weight: o.command_weight,
    };
    let locked_payload = model.net.payload.transformed(&rot, &eq.position).spatial_matrix_about(&eq.position);
    Ok(Linearization {
        design,
        modes,
        wind_fit: fit,
        static_forces: at_rest.actuator_forces,
        static_legs: at_rest.leg_lengths,
        added_mass,
        locked_payload,
    })
}

/// The linear model's error against the nonlinear model under the scene's wind, and the white
/// wrench that stands for it in the design model.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelError {
    /// RMS over the measured window of the nonlinear model's cabin motion (displacement norm, m;
    /// rotation norm, rad) and of its difference from the linear model's.
    pub response: (f64, f64),
    pub residual: (f64, f64),
    /// The cabin's radius of gyration (locked payload included), m: the moment's density is the
    /// force's times it.
    pub gyration_m: f64,
    /// Densities of the white wrench (force N/√Hz per component, moment N·m/√Hz) under which the
    /// linear model's own motion has the residual's mean square `|δp|² + ρ²|δθ|²`.
    pub force_density: f64,
    pub moment_density: f64,
}

/// Both models driven by the same wind force (its mean and turbulence, the record of the scene's
/// seed) from the static equilibrium for `t_end` s at step `h`, the platform held still (the
/// sensor off): the residual of the cabin's pose after `settle` s, and the density of a white
/// wrench that gives the linear model the residual's mean square. The wrench is an acceleration
/// of the cabin alike in every direction (force `m a`, moment `I α` with `α = a/ρ`: force
/// density d, moment density ρd, ρ the radius of gyration), the mean square measured in the same
/// metric, `|δp|² + ρ²|δθ|²`.
pub fn model_error(
    scene: &ValidScene,
    design: &LqgDesign,
    t_end: f64,
    settle: f64,
    h: f64,
) -> Result<ModelError, LinearError> {
    use nalgebra::{DMatrix, DVector};
    let wind = scene.wind.as_ref().ok_or_else(|| LinearError::Scene("the scene has no [wind]".into()))?;
    let off = scene
        .edited(|s| {
            if let Some(c) = s.control.as_mut() {
                c.switch_off();
            }
        })
        .map_err(|e| LinearError::Scene(e.to_string()))?;
    let ins = design::plant::Instruments::of(scene).map_err(|e| LinearError::Scene(e.to_string()))?;
    let mut exact = design.clone();
    (exact.model_error_force_n, exact.model_error_moment_nm) = (0.0, 0.0);
    let plant = design::plant::build(scene, &exact, &ins).map_err(|e| LinearError::Scene(e.to_string()))?;
    let (ad, bd) = design::sampled::hold(&plant.plant.a, &plant.wrench_input, h);
    let load = feedcore::wind::WindLoad::new(wind);
    let mut nonlinear = crate::Monolithic::new(&off).map_err(|e| LinearError::Scene(e.to_string()))?;
    let (p0, q0) = (scene.target_position(), scene.target_orientation());
    // the radius of gyration of the cabin with its locked payload
    let model = CableCabin::build(scene, 0)?;
    let sys = model.system(Payload::Locked);
    let rot = q0.to_rotation_matrix().into_inner();
    let body = sys.body.transformed(&rot, &model.equilibrium.position);
    let gyration = (body.inertia_com.trace() / (3.0 * body.mass)).sqrt();
    let mut x = DVector::zeros(plant.plant.continuous_states());
    let steps = (t_end / h).round() as usize;
    let (mut resp, mut res, mut count) = ((0.0, 0.0), (0.0, 0.0), 0usize);
    for k in 0..steps {
        let t = k as f64 * h;
        // the force at the step's middle, held over it (the nonlinear model takes it at the step's end)
        let f = load.force(t + 0.5 * h);
        x = &ad * &x + &bd * DVector::from_vec(vec![f.x, f.y, f.z, 0.0, 0.0, 0.0]);
        nonlinear.step(h).map_err(|e| LinearError::Scene(e.to_string()))?;
        if t + h <= settle {
            continue;
        }
        let s = nonlinear.sample();
        let d = s.cabin.position - p0;
        let r = (s.cabin.orientation * q0.inverse()).scaled_axis();
        let lin = &plant.cabin.0 * &x;
        let (ld, lr) = (Vec3::new(lin[0], lin[1], lin[2]), Vec3::new(lin[3], lin[4], lin[5]));
        resp = (resp.0 + d.norm_squared(), resp.1 + r.norm_squared());
        res = (res.0 + (d - ld).norm_squared(), res.1 + (r - lr).norm_squared());
        count += 1;
    }
    if count == 0 {
        return Err(LinearError::Scene(format!("a comparison of {t_end} s leaves nothing after {settle} s")));
    }
    let n = count as f64;
    let (response, residual) = (((resp.0 / n).sqrt(), (resp.1 / n).sqrt()), ((res.0 / n).sqrt(), (res.1 / n).sqrt()));
    // the linear model's mean square in that metric under unit force density (moment ρ)
    let nc = plant.plant.continuous_states();
    let mut w = DMatrix::zeros(6, 6);
    for i in 0..3 {
        w[(i, i)] = 0.5;
        w[(i + 3, i + 3)] = 0.5 * gyration * gyration;
    }
    let intensity = &plant.wrench_input * w * plant.wrench_input.transpose();
    let (phi, _) = design::sampled::hold(&plant.plant.a, &DMatrix::zeros(nc, 1), h);
    let q = design::sampled::noise(&plant.plant.a, &intensity, h);
    let p = design::sampled::lyapunov(&phi, &q).map_err(|e| LinearError::Scene(e.to_string()))?;
    let c = &plant.cabin.0 * p * plant.cabin.0.transpose();
    let unit = c[(0, 0)] + c[(1, 1)] + c[(2, 2)] + gyration * gyration * (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]);
    let target = residual.0.powi(2) + gyration * gyration * residual.1.powi(2);
    let density = (target / unit).sqrt();
    Ok(ModelError {
        response,
        residual,
        gyration_m: gyration,
        force_density: density,
        moment_density: density * gyration,
    })
}

/// `H(j2πf) = C (j2πf I − A)⁻¹ B` of a continuous system, as (real, imaginary) parts.
pub fn frequency_response(
    a: &nalgebra::DMatrix<f64>,
    b: &nalgebra::DMatrix<f64>,
    c: &nalgebra::DMatrix<f64>,
    f: f64,
) -> nalgebra::DMatrix<nalgebra::Complex<f64>> {
    use nalgebra::{Complex, DMatrix};
    let n = a.nrows();
    let w = Complex::new(0.0, std::f64::consts::TAU * f);
    let m = DMatrix::from_fn(n, n, |i, j| if i == j { w } else { Complex::new(0.0, 0.0) })
        - a.map(|x| Complex::new(x, 0.0));
    let x = m.lu().solve(&b.map(|x| Complex::new(x, 0.0))).unwrap_or_else(|| DMatrix::zeros(n, b.ncols()));
    c.map(|x| Complex::new(x, 0.0)) * x
}

/// The complex amplitudes `z_k` of `y(t) ≈ c₀ + c₁t + Σ Re(z_k e^{j2πf_k t}) + Σ e^{−σ_i t}
/// (a_i cos 2πg_i t + b_i sin 2πg_i t)` fitted by least squares to samples (t, y): the sinusoids
/// at `freqs` and the free ringing of the modes `ringing` = (g_i Hz, σ_i 1/s) a start leaves.
pub fn sinusoids(times: &[f64], values: &[f64], freqs: &[f64], ringing: &[(f64, f64)]) -> Vec<nalgebra::Complex<f64>> {
    use nalgebra::{DMatrix, DVector};
    let k = 2 + 2 * freqs.len() + 2 * ringing.len();
    let t0 = times.first().copied().unwrap_or(0.0);
    let row = |t: f64| {
        let mut r = vec![1.0, t - t0];
        for f in freqs {
            let (s, c) = (std::f64::consts::TAU * f * t).sin_cos();
            r.push(c);
            r.push(-s);
        }
        for (g, sigma) in ringing {
            let (s, c) = (std::f64::consts::TAU * g * t).sin_cos();
            let e = (-sigma * (t - t0)).exp();
            r.push(e * c);
            r.push(e * s);
        }
        r
    };
    let (mut ata, mut atb) = (DMatrix::<f64>::zeros(k, k), DVector::<f64>::zeros(k));
    for (t, y) in times.iter().zip(values) {
        let r = DVector::from_vec(row(*t));
        ata += &r * r.transpose();
        atb += &r * *y;
    }
    let x = ata.lu().solve(&atb).unwrap_or_else(|| DVector::zeros(k));
    (0..freqs.len()).map(|i| nalgebra::Complex::new(x[2 + 2 * i], x[3 + 2 * i])).collect()
}
