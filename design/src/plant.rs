//! The linear design model of the coupled system: a scene's `[control.lqg]` (the cable–cabin
//! modes, the platform's reaction, the wind's filter) with its instruments (the inertial unit,
//! the delayed fixes) and actuators (the command filter's stages as the servo), as a sampled-data
//! plant ([`crate::lqg::Plant`]) at the unit's rate.
//!
//! Continuous state `x_c = (q, q̇, servo, wind)`: the modal coordinates,
//! `q̈ = −Ω²q − 2ZΩq̇ + Φᵀ(W_wind + R_r r + R_a r̈)` (Φ the modes' cabin parts, 6 × N), the
//! platform's relative pose `r` following the command through n first-order stages
//! (`(τ d/dt + 1)ⁿ r = u`), the turbulence from white noise through the fitted Kaimal filter, its
//! drag `d ρC_dAU u_t` at the cabin centre, and a white wrench on the cabin for what the linear
//! model does not hold (its error against the nonlinear model, measured). Discrete state `x_d`: the cabin's velocity and
//! rotation at the last reading (the unit reports means over each interval), the unit's two
//! biases (random walks), and the cabin pose at the last `d` readings (the fixes' delay line).
//!
//! Readings, cabin frame (deviations from the static reading): specific force
//! `R₀ᵀ[(v_k − v_{k−1})/T − [g]×(θ_k + θ_{k−1})/2] + b_a`, angular rate `R₀ᵀ(θ_k − θ_{k−1})/T + b_g`;
//! a fix arriving now is the pose `d` readings ago. Outputs: the feed's position error
//! `δp − [a_f]×δθ + R₀δc − R₀[f]×δφ` and rotation `δθ + R₀δφ`, the legs' strokes, the actuator
//! forces, the command.

use feedcore::Vec3;
use feedcore::scene::{LqgDesign, ValidScene};
use nalgebra::{DMatrix, Matrix3};

use crate::kaimal;
use crate::lqg::{Measurement, Plant};

/// Smallest variances of a fix as the filter takes them: (1 µm)², (0.1 µrad)² (the fusion's).
const FIX_VARIANCE_FLOOR: (f64, f64) = (1e-12, 1e-14);

/// The design model of a scene with its output maps.
#[derive(Clone, Debug)]
pub struct CoupledPlant {
    pub plant: Plant,
    /// Readings between fixes (the measurement period).
    pub fix_every: usize,
    /// The fixes' delay in readings.
    pub delay_steps: usize,
    /// Output maps (H on x_c, D on u).
    pub feed: (DMatrix<f64>, DMatrix<f64>),
    pub feed_rotation: (DMatrix<f64>, DMatrix<f64>),
    /// The feed's tilt: the rotation's part across the feed's axis.
    pub tilt: (DMatrix<f64>, DMatrix<f64>),
    pub strokes: (DMatrix<f64>, DMatrix<f64>),
    pub forces: (DMatrix<f64>, DMatrix<f64>),
    /// The cabin's pose (displacement, rotation) and the platform's relative pose.
    pub cabin: (DMatrix<f64>, DMatrix<f64>),
    pub relative: (DMatrix<f64>, DMatrix<f64>),
    /// The turbulence (m/s).
    pub turbulence: (DMatrix<f64>, DMatrix<f64>),
    /// How a wrench on the cabin (force, moment about its centre point; world) enters ẋ_c.
    pub wrench_input: DMatrix<f64>,
}

/// What the design model's instruments are: the scene's, or changed for a study.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instruments {
    /// The controller's period (the unit's), s.
    pub period: f64,
    pub fix_every: usize,
    pub delay_steps: usize,
    pub accel_noise_density: f64,
    pub gyro_noise_density: f64,
    pub accel_bias_walk: f64,
    pub gyro_bias_walk: f64,
    /// Uniform noise half-widths of a fix: m, rad.
    pub fix_noise_m: f64,
    pub fix_noise_rad: f64,
    /// The servo: stage bandwidth (Hz) and count.
    pub servo_hz: f64,
    pub servo_stages: usize,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlantError {
    #[error("{0}")]
    Scene(String),
}

impl Instruments {
    /// The scene's instruments as the controller assumes them: its noise model is the fusion's
    /// (`[control.imu.filter]` over the instruments' figures), its delay `control.lqg.delay_s`
    /// (without `[control.lqg]`, the sensor's `delay_s`), its servo the command filter's stages.
    pub fn of(scene: &ValidScene) -> Result<Instruments, PlantError> {
        let control = scene.control.as_ref().ok_or_else(|| PlantError::Scene("the scene has no [control]".into()))?;
        let imu = control.imu.as_ref().ok_or_else(|| {
            PlantError::Scene("the design reads an inertial unit: the scene has no [control.imu]".into())
        })?;
        let model = control.fusion_model().ok_or_else(|| PlantError::Scene("no [control.imu]".into()))?;
        let period = 1.0 / imu.rate_hz;
        let fixes = control.sample_period().ok_or_else(|| {
            PlantError::Scene("the design needs the sampled sensor's fixes (sensor = \"sampled\")".into())
        })?;
        let ratio = fixes / period;
        if !((ratio - ratio.round()).abs() <= 1e-9 * ratio && ratio.round() >= 1.0) {
            return Err(PlantError::Scene(format!(
                "control.sample_rate_hz = {}: a fix must come every whole number of the unit's readings \
                 (control.imu.rate_hz = {}), not every {ratio}",
                1.0 / fixes,
                imu.rate_hz
            )));
        }
        let delay = control.lqg.as_ref().map_or(control.delay_s, |d| d.delay_s);
        Ok(Instruments {
            period,
            fix_every: ratio.round() as usize,
            delay_steps: delay_steps(delay, period),
            accel_noise_density: model.accel_noise_density,
            gyro_noise_density: model.gyro_noise_density,
            accel_bias_walk: model.accel_bias_walk,
            gyro_bias_walk: model.gyro_bias_walk,
            fix_noise_m: model.fix_noise_m,
            fix_noise_rad: model.fix_noise_rad,
            servo_hz: control.bandwidth_hz.unwrap_or(f64::NAN),
            servo_stages: control.filter_stages.unwrap_or(2) as usize,
        })
    }

    /// Refuses what no steady-state filter can use, naming the scene key.
    fn check(&self) -> Result<(), PlantError> {
        for (key, value) in [
            ("control.imu.accel_noise_density", self.accel_noise_density),
            ("control.imu.gyro_noise_density", self.gyro_noise_density),
            ("control.imu.accel_bias_walk", self.accel_bias_walk),
            ("control.imu.gyro_bias_walk", self.gyro_bias_walk),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(PlantError::Scene(format!(
                    "{key} = {value}: the LQG's Kalman filter needs noise on every reading and a walk on every bias (a perfect \
                     reading would be trusted without limit, a bias that never moves is never learnt by a steady filter); \
                     give the figure it should assume in [control.imu.filter]"
                )));
            }
        }
        if !(self.servo_hz > 0.0 && self.servo_hz.is_finite()) {
            return Err(PlantError::Scene(format!(
                "control.bandwidth_hz = {}: the servo needs a bandwidth",
                self.servo_hz
            )));
        }
        if !(2..=3).contains(&self.servo_stages) {
            return Err(PlantError::Scene(format!("control.filter_stages = {}: 2 or 3", self.servo_stages)));
        }
        if self.fix_every == 0 || !(self.period > 0.0 && self.period.is_finite()) {
            return Err(PlantError::Scene(format!(
                "a fix every {} readings of period {} s is not a measurement",
                self.fix_every, self.period
            )));
        }
        Ok(())
    }
}

/// A fix measured at a reading arrives at the first reading at or after its delay.
pub fn delay_steps(delay_s: f64, period: f64) -> usize {
    (delay_s / period - 1e-9).ceil().max(0.0) as usize
}

fn rows(m: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(m.len(), m.first().map_or(0, Vec::len), |i, j| m[i][j])
}

fn skew(v: &Vec3) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn put3(m: &mut DMatrix<f64>, r: usize, c: usize, block: &Matrix3<f64>) {
    m.view_mut((r, c), (3, 3)).copy_from(block);
}

/// The scene's design model with its own instruments.
pub fn of_scene(scene: &ValidScene) -> Result<CoupledPlant, PlantError> {
    let design = scene
        .control
        .as_ref()
        .and_then(|c| c.lqg_design())
        .ok_or_else(|| PlantError::Scene("[control] has no law = \"lqg\" with [control.lqg]".into()))?
        .1;
    build(scene, design, &Instruments::of(scene)?)
}

/// The design model of `design` (for `scene`'s gravity, pose and feed point) with `ins`.
pub fn build(scene: &ValidScene, design: &LqgDesign, ins: &Instruments) -> Result<CoupledPlant, PlantError> {
    ins.check()?;
    // without [control] the feed is the platform's centre, its axis the default
    let (feed_point, feed_axis) = scene
        .control
        .as_ref()
        .map_or(([0.0; 3], feedcore::scene::DEFAULT_FEED_AXIS), |c| (c.feed_point_m, c.feed_axis()));
    let t = ins.period;
    let n = design.modes_hz.len();
    let stages = ins.servo_stages;
    let tau = 1.0 / (std::f64::consts::TAU * ins.servo_hz);
    let (wa, wb, wc) =
        kaimal::state_space(design.wind_gain, design.wind_high_pass_hz, &design.wind_poles_hz, &design.wind_zeros_hz);
    let nw = wa.nrows();
    // offsets in x_c
    let (q, qd, servo, wind) = (0, n, 2 * n, 2 * n + 6 * stages);
    let nc = wind + nw;
    let m = 6;
    let phi = rows(&design.cabin_shapes).transpose(); // 6 × N
    let (react_r, react_a) = (rows(&design.reaction_pose), rows(&design.reaction_acceleration));
    // the servo: r, ṙ (, r̈) per component; r̈ = sr x_c + su u
    let mut a = DMatrix::zeros(nc, nc);
    let mut b = DMatrix::zeros(nc, m);
    let (mut sr, mut su) = (DMatrix::zeros(6, nc), DMatrix::zeros(6, m));
    for i in 0..6 {
        let (r, v) = (servo + i, servo + 6 + i);
        a[(r, v)] = 1.0;
        if stages == 2 {
            // τ² r̈ + 2τ ṙ + r = u
            sr[(i, r)] = -1.0 / (tau * tau);
            sr[(i, v)] = -2.0 / tau;
            su[(i, i)] = 1.0 / (tau * tau);
            for j in 0..nc {
                a[(v, j)] = sr[(i, j)];
            }
            b[(v, i)] = su[(i, i)];
        } else {
            // τ³ r⃛ + 3τ² r̈ + 3τ ṙ + r = u
            let acc = servo + 12 + i;
            a[(v, acc)] = 1.0;
            sr[(i, acc)] = 1.0;
            a[(acc, r)] = -1.0 / tau.powi(3);
            a[(acc, v)] = -3.0 / (tau * tau);
            a[(acc, acc)] = -3.0 / tau;
            b[(acc, i)] = 1.0 / tau.powi(3);
        }
    }
    // the wind's filter and its drag on the cabin
    a.view_mut((wind, wind), (nw, nw)).copy_from(&wa);
    let mut w = DMatrix::zeros(nc, nc);
    for i in 0..nw {
        for j in 0..nw {
            w[(wind + i, wind + j)] = wb[i] * wb[j];
        }
    }
    // the linear model's own error, a white wrench on the cabin (one-sided densities: intensity d²/2)
    let (fe, me) = (design.model_error_force_n.powi(2) / 2.0, design.model_error_moment_nm.powi(2) / 2.0);
    let error = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![fe, fe, fe, me, me, me]));
    let mut modal_noise = w.view_mut((qd, qd), (n, n));
    modal_noise += phi.transpose() * error * &phi;
    let direction = Vec3::from(design.wind_direction);
    let mut wind_wrench = DMatrix::zeros(6, nc);
    for k in 0..3 {
        for j in 0..nw {
            wind_wrench[(k, wind + j)] = direction[k] * design.wind_force_n_per_m_s * wc[j];
        }
    }
    // the modes: q̈ = −Ω²q − 2ZΩq̇ + Φᵀ(W_wind + R_r r + R_a r̈)
    let mut pose_of_r = DMatrix::zeros(6, nc);
    for i in 0..6 {
        pose_of_r[(i, servo + i)] = 1.0;
    }
    let wrench_x = &wind_wrench + &react_r * &pose_of_r + &react_a * &sr;
    let wrench_u = &react_a * &su;
    let modal_x = phi.transpose() * &wrench_x;
    let modal_u = phi.transpose() * &wrench_u;
    for k in 0..n {
        let om = std::f64::consts::TAU * design.modes_hz[k];
        a[(q + k, qd + k)] = 1.0;
        for j in 0..nc {
            a[(qd + k, j)] += modal_x[(k, j)];
        }
        a[(qd + k, q + k)] -= om * om;
        a[(qd + k, qd + k)] -= 2.0 * design.damping_ratios[k] * om;
        for j in 0..m {
            b[(qd + k, j)] = modal_u[(k, j)];
        }
    }
    // maps on x_c: the cabin's pose, velocity and acceleration
    let mut cabin_pose = DMatrix::zeros(6, nc);
    cabin_pose.view_mut((0, q), (6, n)).copy_from(&phi);
    let mut cabin_velocity = DMatrix::zeros(6, nc);
    cabin_velocity.view_mut((0, qd), (6, n)).copy_from(&phi);
    let cabin_acc_x = &phi * a.view((qd, 0), (n, nc));
    let cabin_acc_u = &phi * b.view((qd, 0), (n, m));
    // outputs
    let r0 = scene.target_orientation().to_rotation_matrix().into_inner();
    let f = Vec3::from(feed_point);
    let arm = Vec3::from(design.feed_arm_m);
    let mut feed_of_pose = DMatrix::zeros(3, 12); // (δp, δθ, δc, δφ)
    put3(&mut feed_of_pose, 0, 0, &Matrix3::identity());
    put3(&mut feed_of_pose, 0, 3, &(-skew(&arm)));
    put3(&mut feed_of_pose, 0, 6, &r0);
    put3(&mut feed_of_pose, 0, 9, &(-(r0 * skew(&f))));
    let mut rot_of_pose = DMatrix::zeros(3, 12);
    put3(&mut rot_of_pose, 0, 3, &Matrix3::identity());
    put3(&mut rot_of_pose, 0, 9, &r0);
    let mut both = DMatrix::zeros(12, nc);
    both.view_mut((0, 0), (6, nc)).copy_from(&cabin_pose);
    both.view_mut((6, 0), (6, nc)).copy_from(&pose_of_r);
    let feed_h = &feed_of_pose * &both;
    let rot_h = &rot_of_pose * &both;
    let axis = r0 * Vec3::from(feed_axis).normalize();
    let across = Matrix3::identity() - axis * axis.transpose();
    let tilt_h = DMatrix::from_fn(3, 3, |i, j| across[(i, j)]) * &rot_h;
    let stroke_h = rows(&design.leg_jacobian) * &pose_of_r;
    let (fr, fa, fc, ft) = (
        rows(&design.force_pose),
        rows(&design.force_acceleration),
        rows(&design.force_cabin_acceleration),
        rows(&design.force_cabin_rotation),
    );
    let force_h = &fr * &pose_of_r + &fa * &sr + &fc * &cabin_acc_x + &ft * cabin_pose.rows(3, 3);
    let force_d = &fa * &su + &fc * &cabin_acc_u;
    let zero = |rows: usize| DMatrix::zeros(rows, m);
    // the weight on (x_c, u)
    let mut stacked = DMatrix::zeros(3 + 3 + 6 + 6 + 6, nc + m);
    let mut place = |row: usize, h: &DMatrix<f64>, d: &DMatrix<f64>, s: f64| {
        stacked.view_mut((row, 0), (h.nrows(), nc)).copy_from(&(h * s));
        stacked.view_mut((row, nc), (d.nrows(), m)).copy_from(&(d * s));
    };
    place(0, &feed_h, &zero(3), 1.0);
    place(3, &rot_h, &zero(3), design.tilt_weight_m);
    place(6, &stroke_h, &zero(6), design.stroke_weight);
    place(12, &force_h, &force_d, design.force_weight_m_per_n);
    place(18, &DMatrix::zeros(6, nc), &DMatrix::identity(6, 6), design.command_weight);
    let weight = stacked.transpose() * &stacked;
    // the discrete part: last velocity and rotation (6), biases (6), the delay line (6 d)
    let d = ins.delay_steps;
    let nd = 12 + 6 * d;
    let mut fmat = DMatrix::zeros(nd, nc);
    fmat.view_mut((0, 0), (3, nc)).copy_from(&cabin_velocity.rows(0, 3));
    fmat.view_mut((3, 0), (3, nc)).copy_from(&cabin_pose.rows(3, 3));
    let mut e = DMatrix::zeros(nd, nd);
    for i in 6..12 {
        e[(i, i)] = 1.0;
    }
    if d > 0 {
        fmat.view_mut((12, 0), (6, nc)).copy_from(&cabin_pose);
        for s in 1..d {
            for i in 0..6 {
                e[(12 + 6 * s + i, 12 + 6 * (s - 1) + i)] = 1.0;
            }
        }
    }
    let mut v = DMatrix::zeros(nd, nd);
    for i in 0..3 {
        v[(6 + i, 6 + i)] = ins.accel_bias_walk.powi(2) * t;
        v[(9 + i, 9 + i)] = ins.gyro_bias_walk.powi(2) * t;
    }
    // the readings, on x = (x_c, x_d)
    let nx = nc + nd;
    let g = scene.gravity();
    let r0t = r0.transpose();
    let mut imu = DMatrix::zeros(6, nx);
    let vel = cabin_velocity.rows(0, 3).into_owned();
    let rot = cabin_pose.rows(3, 3).into_owned();
    let tilt_g = DMatrix::from_fn(3, 3, |i, j| (r0t * skew(&g))[(i, j)]);
    let r0t_d = DMatrix::from_fn(3, 3, |i, j| r0t[(i, j)]);
    imu.view_mut((0, 0), (3, nc)).copy_from(&(&r0t_d * &vel / t - &tilt_g * &rot * 0.5));
    imu.view_mut((0, nc), (3, 3)).copy_from(&(-&r0t_d / t));
    imu.view_mut((0, nc + 3), (3, 3)).copy_from(&(-&tilt_g * 0.5));
    imu.view_mut((0, nc + 6), (3, 3)).copy_from(&DMatrix::identity(3, 3));
    imu.view_mut((3, 0), (3, nc)).copy_from(&(&r0t_d * &rot / t));
    imu.view_mut((3, nc + 3), (3, 3)).copy_from(&(-&r0t_d / t));
    imu.view_mut((3, nc + 9), (3, 3)).copy_from(&DMatrix::identity(3, 3));
    let mut imu_r = DMatrix::zeros(6, 6);
    for i in 0..3 {
        imu_r[(i, i)] = ins.accel_noise_density.powi(2) / t;
        imu_r[(3 + i, 3 + i)] = ins.gyro_noise_density.powi(2) / t;
    }
    let mut fix = DMatrix::zeros(6, nx);
    if d > 0 {
        fix.view_mut((0, nc + 12 + 6 * (d - 1)), (6, 6)).copy_from(&DMatrix::identity(6, 6));
    } else {
        fix.view_mut((0, 0), (6, nc)).copy_from(&cabin_pose);
    }
    let fix_var = (
        (ins.fix_noise_m.powi(2) / 3.0).max(FIX_VARIANCE_FLOOR.0),
        (ins.fix_noise_rad.powi(2) / 3.0).max(FIX_VARIANCE_FLOOR.1),
    );
    let mut phases = Vec::with_capacity(ins.fix_every);
    for j in 0..ins.fix_every {
        if j == 0 {
            let mut c = DMatrix::zeros(12, nx);
            c.view_mut((0, 0), (6, nx)).copy_from(&imu);
            c.view_mut((6, 0), (6, nx)).copy_from(&fix);
            let mut r = DMatrix::zeros(12, 12);
            r.view_mut((0, 0), (6, 6)).copy_from(&imu_r);
            for i in 0..3 {
                r[(6 + i, 6 + i)] = fix_var.0;
                r[(9 + i, 9 + i)] = fix_var.1;
            }
            phases.push(Measurement { c, r });
        } else {
            phases.push(Measurement { c: imu.clone(), r: imu_r.clone() });
        }
    }
    let mut wrench_input = DMatrix::zeros(nc, 6);
    wrench_input.view_mut((qd, 0), (n, 6)).copy_from(&phi.transpose());
    let plant = Plant { period: t, a, b, w, f: fmat, e, v, phases, weight };
    let mut relative_h = DMatrix::zeros(6, nc);
    relative_h.view_mut((0, 0), (6, nc)).copy_from(&pose_of_r);
    let mut turbulence = DMatrix::zeros(1, nc);
    for j in 0..nw {
        turbulence[(0, wind + j)] = wc[j];
    }
    Ok(CoupledPlant {
        plant,
        fix_every: ins.fix_every,
        delay_steps: d,
        feed: (feed_h, zero(3)),
        feed_rotation: (rot_h, zero(3)),
        tilt: (tilt_h, zero(3)),
        strokes: (stroke_h, zero(6)),
        forces: (force_h, force_d),
        cabin: (cabin_pose, zero(6)),
        relative: (relative_h, zero(6)),
        turbulence: (turbulence, zero(1)),
        wrench_input,
    })
}
