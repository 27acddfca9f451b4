//! The cable–cabin system in motion: configuration, the residual of the equations of motion
//! and its exact tangent, in the structure of [`ChainMatrix`].
//!
//! Coordinates: the free (interior) nodes of every cable, and the cabin's centre point `r` with
//! orientation `R` (unit quaternion, body to world). The end node of each cable is eliminated
//! into the cabin: it sits on its attachment point `r + R a_i` and its lumped mass (half an
//! element) rides on the cabin as a point mass — the spherical joint of the paper, solved
//! exactly. Velocities: node velocities, the centre point's velocity `v` and the world-frame
//! angular velocity `ω`; rotation increments are world-frame rotation vectors (`R' = exp(θ) R`).
//!
//! The residual is `M(q) v̇ + g(q, v) − f(q, v, t)`: lumped node masses and the cabin's rigid-body
//! inertia about its centre point (its centre of mass need not be there), gyroscopic terms,
//! element forces, gravity, Rayleigh damping, and the external wrench on the cabin.

use feedcore::rigid::{BodyTerms, MassProperties, skew};
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Matrix3x6, Matrix6, Vector6};

use crate::chain_matrix::{ChainMatrix, add3, get3};
use crate::element::Bar;
use crate::net::CableNet;
use crate::statics::Equilibrium;

/// Whether the cabin moves or is held at its pose (a cable between two fixed points).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    Free,
    Fixed,
}

/// Positions: free nodes (world) and the cabin pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    pub nodes: Vec<Vec3>,
    pub position: Vec3,
    pub orientation: Quat,
}

impl Config {
    /// Moves by a velocity-level increment `du` (nodes, cabin translation, world rotation vector)
    /// applied to `base`: `x = x₀ + du`, `R = exp(du_θ) R₀`. Writes into `self` (no allocation).
    pub fn set_displaced(&mut self, base: &Config, du: &[f64]) {
        for (k, (x, x0)) in self.nodes.iter_mut().zip(&base.nodes).enumerate() {
            *x = x0 + get3(du, k);
        }
        let c0 = 3 * base.nodes.len();
        self.position = base.position + Vec3::new(du[c0], du[c0 + 1], du[c0 + 2]);
        self.orientation = feedcore::rigid::exp_so3(&Vec3::new(du[c0 + 3], du[c0 + 4], du[c0 + 5])) * base.orientation;
    }
}

/// Coefficients of the matrix to assemble: `m·M + c·C + k·K·T`, where `T` maps increments of
/// the rotation coordinates to world-frame rotations (identity for a plain tangent).
#[derive(Clone, Copy, Debug)]
pub struct Coefficients {
    pub mass: f64,
    pub damping: f64,
    pub stiffness: f64,
    pub rotation_tangent: Mat3,
    /// Give slack elements their taut axial stiffness (Newton iteration matrices only): Newton
    /// then cannot jump across the tension-only kink from the slack side and cycle. The
    /// residual, and every true tangent, keep the exact zero.
    pub slack_as_taut: bool,
}

impl Coefficients {
    pub const MASS: Coefficients = Coefficients {
        mass: 1.0,
        damping: 0.0,
        stiffness: 0.0,
        rotation_tangent: Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        slack_as_taut: false,
    };
    pub const STIFFNESS: Coefficients = Coefficients {
        mass: 0.0,
        damping: 0.0,
        stiffness: 1.0,
        rotation_tangent: Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        slack_as_taut: false,
    };
    pub const DAMPING: Coefficients = Coefficients {
        mass: 0.0,
        damping: 1.0,
        stiffness: 0.0,
        rotation_tangent: Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        slack_as_taut: false,
    };
}

/// The cable–cabin system with fixed unstretched lengths.
#[derive(Clone, Debug)]
pub struct System {
    pub net: CableNet,
    pub lengths: Vec<f64>,
    /// Unstretched element length per cable.
    pub element_length: Vec<f64>,
    /// Lumped mass of each free node, per cable.
    pub node_mass: Vec<f64>,
    /// The rigid body the cabin is: the cabin, the cables' end nodes, and the Stewart platform
    /// when it is locked; body frame, relative to the cabin centre point.
    pub body: MassProperties,
    pub support: Support,
    /// Constant damping matrix (Rayleigh), if any.
    pub damping: Option<ChainMatrix>,
}

/// Elastic and gravitational potential energy, and kinetic energy.
#[derive(Clone, Copy, Debug)]
pub struct Energy {
    pub kinetic: f64,
    pub strain: f64,
    pub gravity: f64,
}

impl Energy {
    pub fn total(&self) -> f64 {
        self.kinetic + self.strain + self.gravity
    }
}

impl System {
    /// A system with the given lengths. `locked_payload`: the net's payload (the Stewart platform
    /// at its starting pose) rides on the cabin as a rigid mass; otherwise it is left to an
    /// external wrench.
    pub fn new(net: CableNet, lengths: Vec<f64>, locked_payload: bool, support: Support) -> System {
        let n = net.spec.elements as f64;
        let element_length: Vec<f64> = lengths.iter().map(|l| l / n).collect();
        let node_mass: Vec<f64> = element_length.iter().map(|le| net.spec.mass_per_length * le).collect();
        let mut body = if locked_payload { net.suspended() } else { net.cabin };
        for (a, l) in net.attachments.iter().zip(&lengths) {
            body = body.combined(&MassProperties::point(net.end_node_mass(*l), *a));
        }
        System { net, lengths, element_length, node_mass, body, support, damping: None }
    }

    pub fn cables(&self) -> usize {
        self.net.cable_count()
    }

    /// Free nodes per cable.
    pub fn free_nodes(&self) -> usize {
        self.net.spec.elements - 1
    }

    /// Number of velocity-level unknowns: 3 per free node, 6 for the cabin.
    pub fn dim(&self) -> usize {
        3 * self.cables() * self.free_nodes() + 6
    }

    pub fn cabin_offset(&self) -> usize {
        3 * self.cables() * self.free_nodes()
    }

    pub fn new_matrix(&self) -> ChainMatrix {
        ChainMatrix::zeros(self.cables(), self.free_nodes())
    }

    /// The configuration of a static equilibrium found by form finding (same net).
    pub fn config_from(&self, eq: &Equilibrium) -> Config {
        let nodes = eq.cables.iter().flat_map(|c| c.shape.nodes[1..c.shape.nodes.len() - 1].iter().copied()).collect();
        Config { nodes, position: eq.position, orientation: eq.orientation }
    }

    /// Attachment point of cable `i` in the world, and its arm from the cabin centre point.
    pub fn attachment(&self, cfg: &Config, i: usize) -> (Vec3, Vec3) {
        let d = cfg.orientation * self.net.attachments[i];
        (cfg.position + d, d)
    }

    /// Axial forces of the element next to the anchor and next to the cabin, per cable.
    pub fn end_tensions(&self, cfg: &Config, out: &mut [(f64, f64)]) {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        for (i, o) in out.iter_mut().enumerate() {
            let l0 = self.element_length[i];
            let (attach, _) = self.attachment(cfg, i);
            let first_end = if m > 0 { cfg.nodes[i * m] } else { attach };
            let last_start = if m > 0 { cfg.nodes[i * m + m - 1] } else { self.net.anchors[i] };
            *o = (
                Bar::new(&(first_end - self.net.anchors[i]), ea, l0).force,
                Bar::new(&(attach - last_start), ea, l0).force,
            );
        }
    }

    /// Change of the end tensions (anchor end, cabin end) per cable for a change `du` of the
    /// configuration (node displacements, cabin displacement and world-frame rotation;
    /// tension-only: a slack element stays at zero).
    pub fn end_tension_sensitivity(&self, cfg: &Config, du: &[f64]) -> Vec<(f64, f64)> {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        let c0 = self.cabin_offset();
        let (dr, dth) = (get3(du, c0 / 3), get3(du, c0 / 3 + 1));
        (0..self.cables())
            .map(|i| {
                let l0 = self.element_length[i];
                let (attach, d) = self.attachment(cfg, i);
                let d_attach = dr + dth.cross(&d);
                let (first_end, d_first) = if m > 0 { (cfg.nodes[i * m], get3(du, i * m)) } else { (attach, d_attach) };
                let (last_start, d_last) = if m > 0 {
                    (cfg.nodes[i * m + m - 1], get3(du, i * m + m - 1))
                } else {
                    (self.net.anchors[i], Vec3::zeros())
                };
                let rate = |delta: Vec3, d_delta: Vec3| {
                    let bar = Bar::new(&delta, ea, l0);
                    if bar.is_slack() { 0.0 } else { ea / l0 * bar.dir.dot(&d_delta) }
                };
                (rate(first_end - self.net.anchors[i], d_first), rate(attach - last_start, d_attach - d_last))
            })
            .collect()
    }

    /// Residual `M v̇ + g − f` (written to `residual`) and, if `matrix` is given, the matrix
    /// `coef.mass·M + coef.damping·∂r/∂v + coef.stiffness·(∂r/∂q)·T` written into it.
    /// `wrench`: external force and moment (about the cabin centre point) on the cabin, world.
    #[allow(clippy::too_many_arguments)]
    pub fn assemble(
        &self,
        cfg: &Config,
        vel: &[f64],
        acc: &[f64],
        wrench: &Vector6<f64>,
        residual: &mut [f64],
        mut matrix: Option<(&mut ChainMatrix, Coefficients)>,
    ) {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        let c0 = self.cabin_offset();
        let g = self.net.spec.gravity;
        residual.iter_mut().for_each(|r| *r = 0.0);
        if let Some((mat, _)) = matrix.as_mut() {
            mat.set_zero();
        }
        let rot = cfg.orientation.to_rotation_matrix().into_inner();
        let mut cabin_res = Vector6::<f64>::zeros();
        let mut cabin_k = Matrix6::<f64>::zeros(); // ∂r_cabin/∂q_cabin (before T)

        for i in 0..self.cables() {
            let l0 = self.element_length[i];
            let mn = self.node_mass[i];
            let d = rot * self.net.attachments[i];
            let attach = cfg.position + d;
            // B maps a cabin increment (δr, δθ) to the attachment point's displacement.
            let mut b = Matrix3x6::<f64>::zeros();
            b.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
            b.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&d)));
            let point = |e: usize| -> Vec3 {
                if e == 0 {
                    self.net.anchors[i]
                } else if e == m + 1 {
                    attach
                } else {
                    cfg.nodes[i * m + e - 1]
                }
            };
            // free nodes: inertia and gravity
            for j in 0..m {
                let k = i * m + j;
                add3(residual, k, &(get3(acc, k) * mn - g * mn));
                if let Some((mat, coef)) = matrix.as_mut() {
                    mat.diag[k] += Mat3::identity() * (coef.mass * mn);
                }
            }
            // elements e = 0 … m, from point e to point e + 1
            for e in 0..=m {
                let bar = Bar::new(&(point(e + 1) - point(e)), ea, l0);
                let pull = bar.dir * bar.force; // force on the first point; minus on the second
                if e > 0 {
                    add3(residual, i * m + e - 1, &(-pull));
                }
                let ke = match &matrix {
                    Some((_, c)) if c.slack_as_taut && bar.is_slack() => bar.dir * bar.dir.transpose() * (ea / l0),
                    _ => bar.stiffness(ea, l0),
                };
                if e < m {
                    add3(residual, i * m + e, &pull);
                } else {
                    // the second point is the attachment: generalized force on the cabin
                    let r = Vector6::new(pull.x, pull.y, pull.z, 0.0, 0.0, 0.0);
                    let mom = d.cross(&pull);
                    cabin_res += r + Vector6::new(0.0, 0.0, 0.0, mom.x, mom.y, mom.z);
                }
                if let Some((mat, coef)) = matrix.as_mut() {
                    let kk = ke * coef.stiffness;
                    if e > 0 {
                        mat.diag[i * m + e - 1] += kk;
                    }
                    if e < m {
                        mat.diag[i * m + e] += kk;
                        if e > 0 {
                            mat.upper[i * (m - 1) + e - 1] -= kk;
                        }
                    } else {
                        // cabin coupling: r_cabin += Bᵀ(pull), pull depends on attach − point(m)
                        let kb = ke * b; // 3×6
                        cabin_k += b.transpose() * kb;
                        // the arm rotates: ∂(d × F)/∂θ = [F]×[d]×
                        let geo = skew(&pull) * skew(&d);
                        let mut block = cabin_k.fixed_view_mut::<3, 3>(3, 3);
                        block += geo;
                        if m > 0 {
                            let mut nc = -kb;
                            let rotation_cols = nc.fixed_view::<3, 3>(0, 3) * coef.rotation_tangent;
                            nc.fixed_view_mut::<3, 3>(0, 3).copy_from(&rotation_cols);
                            mat.node_cabin[i] += nc * coef.stiffness;
                            mat.cabin_node[i] -= b.transpose() * kk;
                        }
                    }
                }
            }
        }

        // the rigid cabin about its centre point
        let world = self.body.transformed(&rot, &cfg.position);
        let v3 = |v: &[f64], k: usize| Vec3::new(v[c0 + k], v[c0 + k + 1], v[c0 + k + 2]);
        let body = BodyTerms::new(&world, &cfg.position, &v3(vel, 3), &v3(acc, 0), &v3(acc, 3), &g);
        cabin_res += body.residual - wrench;
        if let Some((mat, coef)) = matrix.as_mut() {
            let mut kt = cabin_k + body.stiffness;
            for r in 0..6 {
                let row = kt.fixed_view::<1, 3>(r, 3) * coef.rotation_tangent;
                kt.fixed_view_mut::<1, 3>(r, 3).copy_from(&row);
            }
            mat.cabin += body.mass * coef.mass + body.gyroscopic * coef.damping + kt * coef.stiffness;
        }
        for k in 0..6 {
            residual[c0 + k] += cabin_res[k];
        }
        // Rayleigh damping: r += C v
        if let Some(cd) = &self.damping {
            cd.mul_add(vel, residual);
            if let Some((mat, coef)) = matrix.as_mut() {
                mat.add_scaled(coef.damping, cd);
            }
        }
        if self.support == Support::Fixed {
            for k in 0..6 {
                residual[c0 + k] = 0.0;
            }
        }
    }

    /// Kinetic, strain and gravitational energy. The gravitational energy is measured from the
    /// configuration `reference` (e.g. the equilibrium), which keeps small vibration energies
    /// free of round-off from large heights.
    pub fn energy(&self, cfg: &Config, vel: &[f64], reference: &Config) -> Energy {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        let g = self.net.spec.gravity;
        let c0 = self.cabin_offset();
        let rot = cfg.orientation.to_rotation_matrix().into_inner();
        let (mut kinetic, mut strain, mut gravity) = (0.0, 0.0, 0.0);
        for i in 0..self.cables() {
            let l0 = self.element_length[i];
            let mut prev = self.net.anchors[i];
            for j in 0..m {
                let k = i * m + j;
                kinetic += 0.5 * self.node_mass[i] * get3(vel, k).norm_squared();
                gravity -= self.node_mass[i] * g.dot(&(cfg.nodes[k] - reference.nodes[k]));
                strain += Bar::new(&(cfg.nodes[k] - prev), ea, l0).energy(ea, l0);
                prev = cfg.nodes[k];
            }
            let (attach, _) = self.attachment(cfg, i);
            strain += Bar::new(&(attach - prev), ea, l0).energy(ea, l0);
        }
        let world = self.body.transformed(&rot, &cfg.position);
        let v6 = Vector6::from_column_slice(&vel[c0..c0 + 6]);
        kinetic += 0.5 * v6.dot(&(world.spatial_matrix_about(&cfg.position) * v6));
        let com_shift = (cfg.position - reference.position)
            + (rot - reference.orientation.to_rotation_matrix().into_inner()) * self.body.com;
        gravity -= world.mass * g.dot(&com_shift);
        Energy { kinetic, strain, gravity }
    }
}
