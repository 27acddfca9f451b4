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

use feedcore::rigid::{BodyTerms, MassProperties, skew, turning_arm_stiffness};
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Matrix3x6, Matrix6, Vector6};

use crate::chain_matrix::{ChainMatrix, LinkedChain, get3, vec3};
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
#[derive(Debug, PartialEq)]
pub struct Config {
    pub nodes: Vec<Vec3>,
    pub position: Vec3,
    pub orientation: Quat,
}

impl Clone for Config {
    fn clone(&self) -> Self {
        Config { nodes: self.nodes.clone(), position: self.position, orientation: self.orientation }
    }

    /// Copies into the existing node storage (no allocation).
    fn clone_from(&mut self, source: &Self) {
        self.nodes.clone_from(&source.nodes);
        self.position = source.position;
        self.orientation = source.orientation;
    }
}

impl Config {
    /// Moves by a velocity-level increment `du` (nodes, cabin translation, world rotation vector)
    /// applied to `base`: `x = x₀ + du`, `R = exp(du_θ) R₀`. Writes into `self` (no allocation).
    pub fn set_displaced(&mut self, base: &Config, du: &[f64]) {
        for ((x, x0), d) in self.nodes.iter_mut().zip(&base.nodes).zip(du.chunks_exact(3)) {
            *x = x0 + vec3(d);
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
    pub damping: Option<LinkedChain>,
    /// The scene's wind on the cabin, if any (shared: its harmonics are drawn once).
    pub wind: Option<std::sync::Arc<feedcore::wind::WindLoad>>,
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
        let node_mass: Vec<f64> = lengths.iter().map(|&l| net.spec.node_mass(l)).collect();
        let mut body = if locked_payload { net.suspended() } else { net.cabin };
        for (a, l) in net.attachments.iter().zip(&lengths) {
            body = body.combined(&MassProperties::point(net.spec.end_node_mass(*l), *a));
        }
        System { net, lengths, element_length, node_mass, body, support, damping: None, wind: None }
    }

    /// The loads the scene itself puts on the cabin at time `t` (its wind), added to the external
    /// wrench by every model at each step's end: force, moment about the centre point, world.
    pub fn scene_load(&self, t: f64) -> Vector6<f64> {
        match &self.wind {
            Some(w) => {
                let f = w.force(t);
                Vector6::new(f.x, f.y, f.z, 0.0, 0.0, 0.0)
            }
            None => Vector6::zeros(),
        }
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

    /// Points of the elements of every cable at `cfg`, appended to `out`: per cable, from its
    /// anchor through its free nodes to its attachment point (`elements + 1` points).
    pub fn cable_points(&self, cfg: &Config, out: &mut Vec<Vec3>) {
        let m = self.free_nodes();
        for i in 0..self.cables() {
            out.push(self.net.anchors[i]);
            out.extend_from_slice(&cfg.nodes[i * m..(i + 1) * m]);
            out.push(self.attachment(cfg, i).0);
        }
    }

    /// Axial force of every element at `cfg` (zero when slack), appended to `out`: per cable,
    /// from the anchor to the cabin (`elements` forces).
    pub fn element_forces(&self, cfg: &Config, out: &mut Vec<f64>) {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        for i in 0..self.cables() {
            let l0 = self.element_length[i];
            let mut from = self.net.anchors[i];
            for e in 0..=m {
                let to = if e < m { cfg.nodes[i * m + e] } else { self.attachment(cfg, i).0 };
                out.push(Bar::new(&(to - from), ea, l0).force);
                from = to;
            }
        }
    }

    /// A velocity-level vector `du` (a mode shape, a change of configuration) as the motion of
    /// the points of [`System::cable_points`], appended to `out`: zero at the anchors, the free
    /// nodes' entries, and at each attachment point the cabin's `δr + δθ × d` (d its arm).
    pub fn point_motion(&self, cfg: &Config, du: &[f64], out: &mut Vec<Vec3>) {
        let m = self.free_nodes();
        let c0 = self.cabin_offset();
        let (dr, dth) = (get3(du, c0 / 3), get3(du, c0 / 3 + 1));
        for i in 0..self.cables() {
            out.push(Vec3::zeros());
            out.extend((i * m..(i + 1) * m).map(|k| get3(du, k)));
            let (_, d) = self.attachment(cfg, i);
            out.push(dr + dth.cross(&d));
        }
    }

    /// Change of the end tensions (anchor end, cabin end) per cable for a change `du` of the
    /// configuration (node displacements, cabin displacement and world-frame rotation;
    /// tension-only: a slack element stays at zero).
    pub(crate) fn end_tension_sensitivity(&self, cfg: &Config, du: &[f64]) -> Vec<(f64, f64)> {
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
        matrix: Option<(&mut ChainMatrix, Coefficients)>,
    ) {
        match matrix {
            Some((mat, coef)) => self.assemble_with(cfg, vel, acc, wrench, residual, Some((mat, &coef))),
            None => self.assemble_with(cfg, vel, acc, wrench, residual, None),
        }
    }

    /// The residual alone, as [`System::assemble`] without a matrix (what Newton iterations with
    /// a kept factorization evaluate).
    pub fn residual(&self, cfg: &Config, vel: &[f64], acc: &[f64], wrench: &Vector6<f64>, residual: &mut [f64]) {
        self.assemble_with(cfg, vel, acc, wrench, residual, None);
    }

    /// Inlined into both callers, so the residual-only path carries no matrix code.
    #[inline(always)]
    fn assemble_with(
        &self,
        cfg: &Config,
        vel: &[f64],
        acc: &[f64],
        wrench: &Vector6<f64>,
        residual: &mut [f64],
        mut matrix: Option<(&mut ChainMatrix, &Coefficients)>,
    ) {
        let c0 = self.cabin_offset();
        if let Some((mat, _)) = matrix.as_mut() {
            mat.set_zero();
        }
        let rot = cfg.orientation.to_rotation_matrix().into_inner();
        let mut cabin_res = Vector6::<f64>::zeros();
        let mut cabin_k = Matrix6::<f64>::zeros(); // ∂r_cabin/∂q_cabin (before T)
        for i in 0..self.cables() {
            self.assemble_cable(i, cfg, &rot, acc, residual, &mut cabin_res, &mut cabin_k, matrix.as_mut());
        }

        // the rigid cabin about its centre point
        let g = self.net.spec.gravity;
        let world = self.body.transformed(&rot, &cfg.position);
        let v3 = |v: &[f64], k: usize| Vec3::new(v[c0 + k], v[c0 + k + 1], v[c0 + k + 2]);
        let (omega, a, alpha) = (v3(vel, 3), v3(acc, 0), v3(acc, 3));
        match matrix.as_mut() {
            Some((mat, coef)) => {
                let body = BodyTerms::new(&world, &cfg.position, &omega, &a, &alpha, &g);
                cabin_res += body.residual - wrench;
                let mut kt = cabin_k + body.stiffness;
                for r in 0..6 {
                    let row = kt.fixed_view::<1, 3>(r, 3) * coef.rotation_tangent;
                    kt.fixed_view_mut::<1, 3>(r, 3).copy_from(&row);
                }
                mat.cabin += body.mass * coef.mass + body.gyroscopic * coef.damping + kt * coef.stiffness;
            }
            None => cabin_res += BodyTerms::residual(&world, &cfg.position, &omega, &a, &alpha, &g) - wrench,
        }
        residual[c0..c0 + 6].copy_from_slice(cabin_res.as_slice());
        // Rayleigh damping: r += C v
        if let Some(cd) = &self.damping {
            cd.mul_add(vel, residual);
            if let Some((mat, coef)) = matrix.as_mut() {
                mat.add_scaled(coef.damping, cd.matrix());
            }
        }
        if self.support == Support::Fixed {
            residual[c0..c0 + 6].fill(0.0);
        }
    }

    /// One cable's free nodes and elements: their rows of the residual (overwritten), their
    /// force and moment on the cabin (added to `cabin_res`), and with `matrix` their blocks and
    /// their stiffness on the cabin (added to `cabin_k`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn assemble_cable(
        &self,
        i: usize,
        cfg: &Config,
        rot: &Mat3,
        acc: &[f64],
        residual: &mut [f64],
        cabin_res: &mut Vector6<f64>,
        cabin_k: &mut Matrix6<f64>,
        mut matrix: Option<&mut (&mut ChainMatrix, &Coefficients)>,
    ) {
        let (m, ea) = (self.free_nodes(), self.net.spec.ea);
        let g = self.net.spec.gravity;
        let (l0, mn) = (self.element_length[i], self.node_mass[i]);
        let d = rot * self.net.attachments[i];
        let attach = cfg.position + d;
        let nodes = &cfg.nodes[i * m..(i + 1) * m];
        let (r, a) = (&mut residual[3 * i * m..3 * (i + 1) * m], &acc[3 * i * m..3 * (i + 1) * m]);
        // Elements e = 0 … m run from point e to point e + 1 (point 0: the anchor, m + 1: the
        // attachment); free node j is point j + 1. Element e completes node e − 1: its inertia
        // and weight, the pull of the element before it (`carry`) and of this one.
        let mut from = self.net.anchors[i];
        let mut carry = Vec3::zeros();
        let mut rows = r.chunks_exact_mut(3).zip(a.chunks_exact(3));
        for e in 0..=m {
            let to = if e < m { nodes[e] } else { attach };
            let delta = to - from;
            from = to;
            // the force on the element's first point; minus on its second
            let (pull, bar) = match matrix {
                Some(_) => {
                    let bar = Bar::new(&delta, ea, l0);
                    (bar.dir * bar.force, Some(bar))
                }
                None => (Bar::pull(&delta, ea, l0), None),
            };
            if e > 0 {
                let (rj, aj) = rows.next().expect("one row per free node");
                let f = vec3(aj) * mn - g * mn + carry - pull;
                rj.copy_from_slice(f.as_slice());
            }
            carry = pull;
            if e == m {
                // the second point is the attachment: generalized force on the cabin
                let mom = d.cross(&pull);
                *cabin_res += Vector6::new(pull.x, pull.y, pull.z, mom.x, mom.y, mom.z);
            }
            let (Some((mat, coef)), Some(bar)) = (matrix.as_mut(), bar) else { continue };
            if e > 0 {
                mat.diag[i * m + e - 1] += Mat3::identity() * (coef.mass * mn);
            }
            let ke = if coef.slack_as_taut && bar.is_slack() {
                bar.dir * bar.dir.transpose() * (ea / l0)
            } else {
                bar.stiffness(ea, l0)
            };
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
                // cabin coupling: r_cabin += Bᵀ(pull), pull depends on attach − point(m), and B
                // maps a cabin increment (δr, δθ) to the attachment point's displacement
                let mut b = Matrix3x6::<f64>::zeros();
                b.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
                b.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&d)));
                let kb = ke * b; // 3×6
                *cabin_k += b.transpose() * kb;
                // the arm rotates: ∂(d × F)/∂θ = [F]×[d]×
                let mut block = cabin_k.fixed_view_mut::<3, 3>(3, 3);
                block += turning_arm_stiffness(&pull, &d);
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

    /// What velocity-level unknown `index` is: a free node's coordinate or the cabin's.
    pub fn unknown_name(&self, index: usize) -> String {
        let c0 = self.cabin_offset();
        let axis = ["x", "y", "z"];
        if index < c0 {
            let m = self.free_nodes();
            let (node, k) = (index / 3, index % 3);
            format!("cable {} node {} (from the anchor) {}", node / m, node % m + 1, axis[k])
        } else if index < c0 + 3 {
            format!("cabin translation {}", axis[index - c0])
        } else if index < c0 + 6 {
            format!("cabin rotation {}", axis[index - c0 - 3])
        } else {
            format!("unknown {index} (of {})", self.dim())
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
