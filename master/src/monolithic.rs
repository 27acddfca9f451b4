//! The monolithic reference model: the paper's eq. (7) for the whole system in one set of
//! equations, integrated without any co-simulation splitting.
//!
//! Bodies: every cable node (point masses, the end node included), the cabin and the 13 Stewart
//! bodies (rigid, absolute coordinates, orientations on SO(3)). Constraints with Lagrange
//! multipliers: the spherical joint of every cable end on its attachment point, and the Hooke,
//! prismatic, spherical and driving (stroke ℓ_k(t)) constraints of the Stewart platform
//! ([`stewart_fmu::constraints`]). Integration: index-3 generalized-α in the Arnold–Brüls form
//! (equations of motion and Φ(q, t) = 0 enforced at t_{n+1}), Newton on the position increments
//! and the multipliers, with the sparse LU of the KKT matrix (faer; symbolic analysis done once,
//! numeric factorization kept while Newton converges with it).
//!
//! It links the model crates directly and shares their element law (`cable_fmu::element::Bar`),
//! the rigid-body terms (`feedcore::rigid::BodyTerms`), the Stewart joint equations and the
//! cable structure's damping matrix, but none of their solution procedures.
//!
//! Start: the cables and the cabin at rest in the static equilibrium with the platform at its
//! starting pose; the Stewart bodies already on their prescribed relative motion (with the
//! abrupt start, at full speed): the same initial state as the co-simulation.

use std::fmt;

use cable_fmu::chain_matrix::ChainMatrix;
use cable_fmu::element::Bar;
use cable_fmu::model::{CableCabin, Payload};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu;
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, Mat, Par};
use feedcore::genalpha::GenAlpha;
use feedcore::rigid::{BodyTerms, MassProperties, exp_so3, left_jacobian_so3, skew};
use feedcore::scene::{LEGS, Scene};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Matrix6, Vector6};
use stewart_fmu::constraints::{CABIN, CONSTRAINTS, DRIVING, ROWS_PER_LEG, SYSTEM_BODIES};
use stewart_fmu::{ConstraintRow, RigidMotion, Stewart, Stroke};

/// Rigid bodies of the model: the cabin, then the 13 Stewart bodies in their own order.
const RIGID: usize = 1 + BODIES;

#[derive(Debug)]
pub struct MonolithicError {
    pub time: f64,
    pub reason: String,
}

impl fmt::Display for MonolithicError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "monolithic model stopped at t = {:.6} s: {}", self.time, self.reason)
    }
}

impl std::error::Error for MonolithicError {}

/// Pose of a rigid body: reference point (cabin centre point, or a Stewart body's centre of
/// mass) and orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pose {
    position: Vec3,
    orientation: Quat,
}

/// Everything that determines the future of a run.
#[derive(Clone, Debug)]
struct State {
    time: f64,
    nodes: Vec<Vec3>,
    bodies: [Pose; RIGID],
    velocity: Vec<f64>,
    acceleration: Vec<f64>,
    pseudo_acceleration: Vec<f64>,
    multipliers: Vec<f64>,
}

/// Where each unknown sits: cable nodes (3 each, cable-major, end node last), rigid bodies (6
/// each: cabin first), multipliers (cable joints, then the Stewart rows).
#[derive(Clone, Copy, Debug)]
struct Layout {
    cables: usize,
    elements: usize,
}

impl Layout {
    fn n_q(self) -> usize {
        3 * self.cables * self.elements + 6 * RIGID
    }
    fn n(self) -> usize {
        self.n_q() + 3 * self.cables + CONSTRAINTS
    }
    fn node(self, i: usize, j: usize) -> usize {
        3 * (i * self.elements + j)
    }
    fn body(self, b: usize) -> usize {
        3 * self.cables * self.elements + 6 * b
    }
    fn lambda(self, k: usize) -> usize {
        self.n_q() + k
    }
}

/// The KKT matrix's sparse LU: pattern and symbolic analysis once; numeric factors, workspace
/// and right-hand side kept and reused (no allocation per solve).
struct Kkt {
    symbolic: SymbolicSparseColMat<usize>,
    argsort: faer::sparse::Argsort<usize>,
    lu: lu::SymbolicLu<usize>,
    numeric: lu::NumericLu<usize, f64>,
    /// Step size of the current numeric factors (`None`: not factorized).
    h: Option<f64>,
    stack: MemBuffer,
    rhs: Mat<f64>,
}

impl Kkt {
    fn new(n: usize, pairs: &[(usize, usize)]) -> Result<Kkt, Box<dyn std::error::Error>> {
        let idx: Vec<Pair<usize, usize>> = pairs.iter().map(|&(row, col)| Pair { row, col }).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &idx)?;
        let lu = lu::factorize_symbolic_lu(symbolic.as_ref(), Default::default())?;
        let need = lu
            .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())
            .or(lu.solve_in_place_scratch::<f64>(1, Par::Seq));
        Ok(Kkt {
            symbolic,
            argsort,
            lu,
            numeric: lu::NumericLu::new(),
            h: None,
            stack: MemBuffer::new(need),
            rhs: Mat::zeros(n, 1),
        })
    }

    /// Numeric factorization of the matrix with these values (in the recorded order).
    fn factorize(&mut self, values: &[f64], h: f64) -> Result<(), String> {
        let mat = SparseColMat::new_from_argsort(self.symbolic.clone(), &self.argsort, values)
            .map_err(|e| format!("sparse matrix: {e:?}"))?;
        self.h = None;
        self.lu
            .factorize_numeric_lu(
                &mut self.numeric,
                mat.as_ref(),
                Par::Seq,
                MemStack::new(&mut self.stack),
                Default::default(),
            )
            .map_err(|e| format!("singular KKT matrix: {e:?}"))?;
        self.h = Some(h);
        Ok(())
    }

    /// `out = −A⁻¹ r`.
    fn solve_negated(&mut self, r: &[f64], out: &mut [f64]) {
        for (i, x) in r.iter().enumerate() {
            self.rhs[(i, 0)] = -x;
        }
        lu::LuRef::new_unchecked(&self.lu, &self.numeric).solve_in_place_with_conj(
            Conj::No,
            self.rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.stack),
        );
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.rhs[(i, 0)];
        }
    }
}

impl State {
    /// Overwrites every field with `other`'s, keeping the allocations.
    fn copy_from(&mut self, other: &State) {
        self.time = other.time;
        self.nodes.copy_from_slice(&other.nodes);
        self.bodies = other.bodies;
        self.velocity.copy_from_slice(&other.velocity);
        self.acceleration.copy_from_slice(&other.acceleration);
        self.pseudo_acceleration.copy_from_slice(&other.pseudo_acceleration);
        self.multipliers.copy_from_slice(&other.multipliers);
    }

    /// A placeholder without storage (to move a state out of a field for a moment).
    fn clone_empty(&self) -> State {
        State {
            time: 0.0,
            nodes: Vec::new(),
            bodies: self.bodies,
            velocity: Vec::new(),
            acceleration: Vec::new(),
            pseudo_acceleration: Vec::new(),
            multipliers: Vec::new(),
        }
    }
}

/// Records the matrix entries in a fixed traversal order the first time, then only values.
struct Assembler {
    pairs: Option<Vec<(usize, usize)>>,
    values: Vec<f64>,
}

impl Assembler {
    fn entry(&mut self, row: usize, col: usize, value: f64) {
        if let Some(p) = self.pairs.as_mut() {
            p.push((row, col));
        }
        self.values.push(value);
    }

    fn block3(&mut self, row: usize, col: usize, m: &Mat3) {
        for r in 0..3 {
            for c in 0..3 {
                self.entry(row + r, col + c, m[(r, c)]);
            }
        }
    }

    fn block6(&mut self, row: usize, col: usize, m: &Matrix6<f64>) {
        for r in 0..6 {
            for c in 0..6 {
                self.entry(row + r, col + c, m[(r, c)]);
            }
        }
    }
}

/// What to assemble: `mass·M + damping·C + stiffness·K·T` and the constraint rows `scale·Φ_q·T`.
#[derive(Clone, Copy, Debug)]
struct Coefficients {
    mass: f64,
    damping: f64,
    stiffness: f64,
    constraint_scale: f64,
}

/// Results of one time point.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub time: f64,
    pub cabin: RigidMotion,
    /// What the Stewart platform exerts on the cabin (force; moment about the centre point).
    pub wrench: Vector6<f64>,
    /// Actuator tensions, N.
    pub actuator_forces: [f64; LEGS],
    /// Largest |Φ| of all position constraints (m or rad).
    pub constraint_residual: f64,
}

/// The monolithic model of a scene.
pub struct Monolithic {
    stewart: Stewart,
    lay: Layout,
    anchors: Vec<Vec3>,
    attachments: Vec<Vec3>,
    ea: f64,
    element_length: Vec<f64>,
    /// Node masses per cable: interior, end.
    node_mass: Vec<(f64, f64)>,
    gravity: Vec3,
    /// Body-frame mass properties of the rigid bodies (about their reference points).
    rigid: [MassProperties; RIGID],
    /// Rayleigh damping of the cable structure in the cable model's layout (free nodes, cabin).
    damping: ChainMatrix,
    coef: GenAlpha,
    tol: f64,
    max_iter: usize,
    state: State,
    // linear algebra: pattern once, numeric factorization while it serves
    kkt: Option<Kkt>,
    // scratch
    assembler: Assembler,
    residual: Vec<f64>,
    trial: State,
    increment: Vec<f64>,
    delta: Vec<f64>,
    strokes: [Stroke; LEGS],
    rows: Box<[ConstraintRow; CONSTRAINTS]>,
    damp_in: Vec<f64>,
    damp_out: Vec<f64>,
}

impl Monolithic {
    /// Builds the model of `scene` at its static equilibrium, from time 0.
    pub fn new(scene: &Scene) -> Result<Monolithic, Box<dyn std::error::Error>> {
        let cc = CableCabin::build(scene, 0)?;
        let stewart = Stewart::from_scene(scene)?;
        let sys = cc.system(Payload::External);
        let (cables, elements) = (sys.cables(), sys.net.spec.elements);
        let eq_cfg = cc.equilibrium_config();
        // nodes: the cable model's free nodes and the attachment points
        let mut nodes = Vec::with_capacity(cables * elements);
        for i in 0..cables {
            let m = elements - 1;
            nodes.extend_from_slice(&eq_cfg.nodes[i * m..i * m + m]);
            nodes.push(sys.attachment(&eq_cfg, i).0);
        }
        let cabin = RigidMotion::at_rest(cc.equilibrium.position, cc.equilibrium.orientation);
        let placed = stewart.system_motion(&cabin, 0.0)?;
        let mut bodies = [Pose { position: cabin.position, orientation: cabin.orientation }; RIGID];
        let mut rigid = [sys.net.cabin; RIGID];
        let inertias = stewart.body_inertias();
        let n_q = 3 * cables * elements + 6 * RIGID;
        let mut velocity = vec![0.0; n_q];
        for s in 0..BODIES {
            let m = &placed[s];
            bodies[1 + s] = Pose { position: m.position, orientation: m.orientation };
            rigid[1 + s] =
                MassProperties { mass: inertias[s].mass, com: Vec3::zeros(), inertia_com: inertias[s].inertia };
            let o = 3 * cables * elements + 6 * (1 + s);
            velocity[o..o + 3].copy_from_slice(m.velocity.as_slice());
            velocity[o + 3..o + 6].copy_from_slice(m.angular_velocity.as_slice());
        }
        let n_lambda = 3 * cables + CONSTRAINTS;
        let state = State {
            time: 0.0,
            nodes,
            bodies,
            velocity,
            acceleration: vec![0.0; n_q],
            pseudo_acceleration: vec![0.0; n_q],
            multipliers: vec![0.0; n_lambda],
        };
        let s = &scene.solver;
        let mut model = Monolithic {
            lay: Layout { cables, elements },
            anchors: sys.net.anchors.clone(),
            attachments: sys.net.attachments.clone(),
            ea: sys.net.spec.ea,
            element_length: sys.element_length.clone(),
            node_mass: sys.node_mass.iter().zip(&sys.lengths).map(|(m, l)| (*m, sys.net.end_node_mass(*l))).collect(),
            gravity: sys.net.spec.gravity,
            rigid,
            damping: sys.damping.clone().expect("the scene model carries its damping"),
            coef: GenAlpha::new(s.rho_inf),
            tol: s.newton_tol,
            max_iter: s.newton_max_iter,
            trial: state.clone(),
            state,
            stewart,
            kkt: None,
            assembler: Assembler { pairs: None, values: Vec::new() },
            residual: vec![0.0; n_q + n_lambda],
            increment: vec![0.0; n_q],
            delta: vec![0.0; n_q + n_lambda],
            strokes: [Stroke::default(); LEGS],
            rows: Box::new([ConstraintRow::EMPTY; CONSTRAINTS]),
            damp_in: vec![0.0; sys.dim()],
            damp_out: vec![0.0; sys.dim()],
        };
        model.build_pattern()?;
        model.initial_acceleration()?;
        Ok(model)
    }

    /// Stewart system body index (cabin = [`CABIN`]) → rigid body index here (cabin = 0).
    fn rigid_index(k: usize) -> usize {
        if k == CABIN { 0 } else { k + 1 }
    }

    /// Records the sparsity pattern (once) and its symbolic LU.
    fn build_pattern(&mut self) -> Result<(), Box<dyn std::error::Error>> {
        let st = self.state.clone();
        self.strokes = self.stewart.strokes(st.time)?;
        self.assembler = Assembler { pairs: Some(Vec::new()), values: Vec::new() };
        let coef = Coefficients { mass: 1.0, damping: 1.0, stiffness: 1.0, constraint_scale: 1.0 };
        self.assemble(&st, [Vec3::zeros(); RIGID], Some(coef));
        let pairs = self.assembler.pairs.take().expect("recording");
        self.kkt = Some(Kkt::new(self.lay.n(), &pairs)?);
        Ok(())
    }

    /// The system motion the Stewart constraints are written for.
    fn system_motion(lay: Layout, st: &State) -> [RigidMotion; SYSTEM_BODIES] {
        std::array::from_fn(|k| {
            let b = Self::rigid_index(k);
            let o = lay.body(b);
            let v = &st.velocity;
            let mut m = RigidMotion::at_rest(st.bodies[b].position, st.bodies[b].orientation);
            m.velocity = Vec3::new(v[o], v[o + 1], v[o + 2]);
            m.angular_velocity = Vec3::new(v[o + 3], v[o + 4], v[o + 5]);
            m
        })
    }

    /// Residual of eq. (7) at `st` (into `self.residual`: equations of motion, then the
    /// constraints scaled by `coef.constraint_scale`), and with `coef` the matrix values into
    /// the assembler, in the recorded order. `theta`: rotation increments of the rigid bodies in
    /// the current step (for the tangent of exp).
    fn assemble(&mut self, st: &State, theta: [Vec3; RIGID], coef: Option<Coefficients>) {
        let lay = self.lay;
        let motion = Self::system_motion(lay, st);
        let Monolithic {
            stewart,
            anchors,
            attachments,
            ea,
            element_length,
            node_mass,
            gravity,
            rigid,
            damping,
            residual: r,
            assembler: asm,
            strokes,
            rows,
            damp_in,
            damp_out,
            ..
        } = self;
        r.iter_mut().for_each(|x| *x = 0.0);
        asm.values.clear();
        let scale = coef.map_or(1.0, |c| c.constraint_scale);
        let (g, ea, ne) = (*gravity, *ea, lay.elements);
        let node = |i: usize, j: usize| lay.node(i, j);
        let add = |r: &mut [f64], o: usize, v: &Vec3| {
            r[o] += v.x;
            r[o + 1] += v.y;
            r[o + 2] += v.z;
        };
        let tangents: [Mat3; RIGID] = std::array::from_fn(|b| left_jacobian_so3(&theta[b]));
        let cabin = st.bodies[0];
        let cabin_o = lay.body(0);
        let rot_c = cabin.orientation.to_rotation_matrix().into_inner();
        let mut cabin_geo = Mat3::zeros();

        // cables: nodes, elements, end joints
        for i in 0..lay.cables {
            let (l0, (mn, me)) = (element_length[i], node_mass[i]);
            for j in 0..ne {
                let mass = if j + 1 == ne { me } else { mn };
                let o = node(i, j);
                let a = Vec3::new(st.acceleration[o], st.acceleration[o + 1], st.acceleration[o + 2]);
                add(r, o, &(a * mass - g * mass));
                if let Some(c) = coef {
                    asm.block3(o, o, &(Mat3::identity() * (c.mass * mass)));
                }
            }
            for e in 0..ne {
                let from = if e == 0 { anchors[i] } else { st.nodes[i * ne + e - 1] };
                let to = st.nodes[i * ne + e];
                let bar = Bar::new(&(to - from), ea, l0);
                let pull = bar.dir * bar.force;
                add(r, node(i, e), &pull);
                if e > 0 {
                    add(r, node(i, e - 1), &(-pull));
                }
                if let Some(c) = coef {
                    let k = bar.stiffness(ea, l0) * c.stiffness;
                    asm.block3(node(i, e), node(i, e), &k);
                    if e > 0 {
                        asm.block3(node(i, e - 1), node(i, e - 1), &k);
                        asm.block3(node(i, e - 1), node(i, e), &(-k));
                        asm.block3(node(i, e), node(i, e - 1), &(-k));
                    }
                }
            }
            // spherical joint: Φ = x_end − (r + R a) = 0
            let d = rot_c * attachments[i];
            let end = node(i, ne - 1);
            let lo = lay.lambda(3 * i);
            let lambda = Vec3::new(st.multipliers[3 * i], st.multipliers[3 * i + 1], st.multipliers[3 * i + 2]);
            let phi = st.nodes[i * ne + ne - 1] - cabin.position - d;
            add(r, end, &lambda);
            add(r, cabin_o, &(-lambda));
            add(r, cabin_o + 3, &(-d.cross(&lambda)));
            for k in 0..3 {
                r[lo + k] += scale * phi[k];
            }
            if let Some(c) = coef {
                let s = c.constraint_scale;
                let id = Mat3::identity();
                // rows of the joint: ∂Φ/∂(x_end, δr, δθ) = (I, −I, [d]×)
                asm.block3(lo, end, &(id * s));
                asm.block3(lo, cabin_o, &(-id * s));
                asm.block3(lo, cabin_o + 3, &(skew(&d) * tangents[0] * s));
                // the multiplier's force on the node and on the cabin
                asm.block3(end, lo, &id);
                asm.block3(cabin_o, lo, &(-id));
                asm.block3(cabin_o + 3, lo, &(-skew(&d)));
                // the moment −d × λ turns with the cabin
                cabin_geo -= skew(&lambda) * skew(&d);
            }
        }

        // rigid bodies
        for b in 0..RIGID {
            let p = st.bodies[b];
            let rot = p.orientation.to_rotation_matrix().into_inner();
            let world = rigid[b].transformed(&rot, &p.position);
            let o = lay.body(b);
            let v3 = |v: &[f64], k: usize| Vec3::new(v[o + k], v[o + k + 1], v[o + k + 2]);
            let terms = BodyTerms::new(
                &world,
                &p.position,
                &v3(&st.velocity, 3),
                &v3(&st.acceleration, 0),
                &v3(&st.acceleration, 3),
                &g,
            );
            for k in 0..6 {
                r[o + k] += terms.residual[k];
            }
            if let Some(c) = coef {
                let mut k = terms.stiffness;
                if b == 0 {
                    let mut blk = k.fixed_view_mut::<3, 3>(3, 3);
                    blk += cabin_geo;
                }
                let mut kt = k * c.stiffness;
                for row in 0..6 {
                    let v = kt.fixed_view::<1, 3>(row, 3) * tangents[b];
                    kt.fixed_view_mut::<1, 3>(row, 3).copy_from(&v);
                }
                let mut m = terms.mass * c.mass + terms.gyroscopic * c.damping + kt;
                if b == 0 {
                    m += damping.cabin * c.damping;
                }
                asm.block6(o, o, &m);
            }
        }

        // Stewart joints
        stewart.joints().evaluate(&motion, strokes, rows);
        let l0 = lay.lambda(3 * lay.cables);
        for (k, row) in rows.iter().enumerate() {
            let lambda = st.multipliers[3 * lay.cables + k];
            for n in 0..2 {
                let o = lay.body(Self::rigid_index(row.bodies[n]));
                for q in 0..6 {
                    r[o + q] += row.jacobian[n][q] * lambda;
                }
            }
            r[l0 + k] += scale * row.value;
            if let Some(c) = coef {
                for n in 0..2 {
                    let b = Self::rigid_index(row.bodies[n]);
                    let o = lay.body(b);
                    let jr = row.jacobian[n].fixed_rows::<3>(3).transpose() * tangents[b];
                    for q in 0..3 {
                        asm.entry(l0 + k, o + q, c.constraint_scale * row.jacobian[n][q]);
                        asm.entry(l0 + k, o + 3 + q, c.constraint_scale * jr[q]);
                        asm.entry(o + q, l0 + k, row.jacobian[n][q]);
                        asm.entry(o + 3 + q, l0 + k, row.jacobian[n][3 + q]);
                    }
                }
            }
        }

        // Rayleigh damping of the cable structure, in the cable model's layout
        let m = ne - 1;
        for i in 0..lay.cables {
            for j in 0..m {
                let (src, dst) = (node(i, j), 3 * (i * m + j));
                damp_in[dst..dst + 3].copy_from_slice(&st.velocity[src..src + 3]);
            }
        }
        let c0 = 3 * lay.cables * m;
        damp_in[c0..c0 + 6].copy_from_slice(&st.velocity[cabin_o..cabin_o + 6]);
        damp_out.iter_mut().for_each(|x| *x = 0.0);
        damping.mul_add(damp_in, damp_out);
        for i in 0..lay.cables {
            for j in 0..m {
                let (dst, src) = (node(i, j), 3 * (i * m + j));
                for k in 0..3 {
                    r[dst + k] += damp_out[src + k];
                }
            }
        }
        for k in 0..6 {
            r[cabin_o + k] += damp_out[c0 + k];
        }
        if let Some(c) = coef {
            let d = &*damping;
            for i in 0..lay.cables {
                for j in 0..m {
                    asm.block3(node(i, j), node(i, j), &(d.diag[i * m + j] * c.damping));
                    if j + 1 < m {
                        let u = d.upper[i * (m - 1) + j] * c.damping;
                        asm.block3(node(i, j), node(i, j + 1), &u);
                        asm.block3(node(i, j + 1), node(i, j), &u.transpose());
                    }
                }
                if m > 0 {
                    let last = node(i, m - 1);
                    for q in 0..3 {
                        for k in 0..6 {
                            asm.entry(last + q, cabin_o + k, d.node_cabin[i][(q, k)] * c.damping);
                            asm.entry(cabin_o + k, last + q, d.cabin_node[i][(k, q)] * c.damping);
                        }
                    }
                }
            }
        }
    }

    /// Consistent initial accelerations and multipliers: [M Φ_qᵀ; Φ_q 0] [v̇; λ] = [f − g; γ].
    fn initial_acceleration(&mut self) -> Result<(), MonolithicError> {
        let st = self.state.clone();
        let t = st.time;
        let fail = |reason: String| MonolithicError { time: t, reason };
        self.assemble(
            &st,
            [Vec3::zeros(); RIGID],
            Some(Coefficients { mass: 1.0, damping: 0.0, stiffness: 0.0, constraint_scale: 1.0 }),
        );
        self.factorize(0.0).map_err(&fail)?;
        // right-hand side: −(residual without inertia and without multipliers) and γ
        let (lay, nq) = (self.lay, self.lay.n_q());
        let mut zeroed = st.clone();
        zeroed.acceleration.iter_mut().for_each(|x| *x = 0.0);
        zeroed.multipliers.iter_mut().for_each(|x| *x = 0.0);
        self.assemble(&zeroed, [Vec3::zeros(); RIGID], None);
        let mut rhs: Vec<f64> = self.residual.clone();
        // γ: cable joints (centripetal of the attachment point), Stewart rows
        let o = lay.body(0);
        let w = Vec3::new(st.velocity[o + 3], st.velocity[o + 4], st.velocity[o + 5]);
        let rot_c = st.bodies[0].orientation.to_rotation_matrix().into_inner();
        for i in 0..lay.cables {
            let d = rot_c * self.attachments[i];
            let gamma = w.cross(&w.cross(&d));
            for k in 0..3 {
                rhs[nq + 3 * i + k] = -gamma[k];
            }
        }
        for (k, row) in self.rows.iter().enumerate() {
            rhs[nq + 3 * lay.cables + k] = -row.gamma;
        }
        let mut sol = vec![0.0; rhs.len()];
        self.kkt.as_mut().expect("built").solve_negated(&rhs, &mut sol);
        self.kkt.as_mut().expect("built").h = None; // factors of M, not of an iteration matrix
        self.state.acceleration.copy_from_slice(&sol[..nq]);
        self.state.pseudo_acceleration.copy_from_slice(&sol[..nq]);
        self.state.multipliers.copy_from_slice(&sol[nq..]);
        if sol.iter().any(|x| !x.is_finite()) {
            return Err(fail("the initial accelerations are not finite".into()));
        }
        Ok(())
    }

    /// Numeric factorization of the assembled values, for step size `h`.
    fn factorize(&mut self, h: f64) -> Result<(), String> {
        let Monolithic { kkt, assembler, .. } = self;
        kkt.as_mut().expect("pattern built at construction").factorize(&assembler.values, h)
    }

    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// One step of size `h`.
    pub fn step(&mut self, h: f64) -> Result<usize, MonolithicError> {
        let t1 = self.state.time + h;
        let fail = |reason: String| MonolithicError { time: t1, reason };
        self.strokes = self.stewart.strokes(t1).map_err(|e| fail(e.to_string()))?;
        let ga = self.coef;
        let (bp, gp) = (ga.beta_prime(h), ga.gamma_prime(h));
        let nq = self.lay.n_q();
        let c_acc = 1.0 / (1.0 - ga.alpha_m);
        let mut trial = std::mem::replace(&mut self.trial, self.state.clone_empty());
        trial.copy_from(&self.state);
        {
            let st = &self.state;
            for i in 0..nq {
                let vd1 = st.acceleration[i];
                let a1 = c_acc
                    * ((1.0 - ga.alpha_f) * vd1 + ga.alpha_f * st.acceleration[i]
                        - ga.alpha_m * st.pseudo_acceleration[i]);
                trial.acceleration[i] = vd1;
                trial.velocity[i] =
                    st.velocity[i] + h * (1.0 - ga.gamma) * st.pseudo_acceleration[i] + h * ga.gamma * a1;
                self.increment[i] =
                    h * st.velocity[i] + h * h * (0.5 - ga.beta) * st.pseudo_acceleration[i] + h * h * ga.beta * a1;
            }
            trial.multipliers.copy_from_slice(&st.multipliers);
            trial.time = t1;
        }
        self.place(&mut trial);
        let coef = Coefficients { mass: bp, damping: gp, stiffness: 1.0, constraint_scale: bp };
        let mut previous = f64::INFINITY;
        let mut fresh = false;
        let mut converged = false;
        let mut iterations = 0;
        for it in 0..self.max_iter {
            let stale = self.kkt.as_ref().and_then(|k| k.h) != Some(h);
            let theta = self.thetas();
            if stale || (it > 0 && !fresh && it >= self.max_iter / 2) {
                self.assemble(&trial, theta, Some(coef));
                self.factorize(h).map_err(&fail)?;
                fresh = true;
            } else {
                self.assemble(&trial, theta, None);
            }
            // the constraint rows of the residual carry the same scale as the matrix
            for k in nq..self.residual.len() {
                self.residual[k] *= coef.constraint_scale;
            }
            let Monolithic { kkt, residual, delta, .. } = self;
            kkt.as_mut().expect("built").solve_negated(residual, delta);
            let delta = &self.delta;
            let dmax = delta[..nq].iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if !dmax.is_finite() {
                return Err(fail("the Newton correction is not finite (the motion diverged)".into()));
            }
            for i in 0..nq {
                self.increment[i] += delta[i];
                trial.acceleration[i] += bp * delta[i];
                trial.velocity[i] += gp * delta[i];
            }
            for (l, d) in trial.multipliers.iter_mut().zip(&delta[nq..]) {
                *l += d;
            }
            self.place(&mut trial);
            iterations = it + 1;
            let rate = dmax / previous;
            if dmax <= self.tol || (it > 0 && rate < 0.2 && rate / (1.0 - rate) * dmax <= 0.1 * self.tol) {
                converged = true;
                break;
            }
            // An old factorization that contracts by less than 10× per iteration costs a third
            // iteration every step (the platform's geometry turns under it): refresh it.
            if !fresh && it > 0 && dmax > 0.1 * previous {
                let theta = self.thetas();
                self.assemble(&trial, theta, Some(coef));
                self.factorize(h).map_err(&fail)?;
                fresh = true;
            }
            previous = dmax;
        }
        if !converged {
            self.trial = trial;
            return Err(fail(format!(
                "Newton did not converge in {} iterations (last correction {previous:.3e})",
                self.max_iter
            )));
        }
        for i in 0..nq {
            trial.pseudo_acceleration[i] = c_acc
                * ((1.0 - ga.alpha_f) * trial.acceleration[i] + ga.alpha_f * self.state.acceleration[i]
                    - ga.alpha_m * self.state.pseudo_acceleration[i]);
        }
        self.trial = std::mem::replace(&mut self.state, trial);
        Ok(iterations)
    }

    /// Rotation increments of the rigid bodies in the current step.
    fn thetas(&self) -> [Vec3; RIGID] {
        std::array::from_fn(|b| {
            let o = self.lay.body(b) + 3;
            Vec3::new(self.increment[o], self.increment[o + 1], self.increment[o + 2])
        })
    }

    /// Positions of `trial` from the step's start and the increment.
    fn place(&self, trial: &mut State) {
        for (k, (x, x0)) in trial.nodes.iter_mut().zip(&self.state.nodes).enumerate() {
            *x = x0 + Vec3::new(self.increment[3 * k], self.increment[3 * k + 1], self.increment[3 * k + 2]);
        }
        for b in 0..RIGID {
            let o = self.lay.body(b);
            let u = &self.increment;
            trial.bodies[b].position = self.state.bodies[b].position + Vec3::new(u[o], u[o + 1], u[o + 2]);
            trial.bodies[b].orientation =
                exp_so3(&Vec3::new(u[o + 3], u[o + 4], u[o + 5])) * self.state.bodies[b].orientation;
        }
    }

    /// Cabin motion, Stewart wrench, actuator forces and constraint residual now.
    pub fn sample(&mut self) -> Sample {
        let lay = self.lay;
        let st = &self.state;
        let o = lay.body(0);
        let v3 = |v: &[f64], k: usize| Vec3::new(v[o + k], v[o + k + 1], v[o + k + 2]);
        let cabin = RigidMotion {
            position: st.bodies[0].position,
            orientation: st.bodies[0].orientation,
            velocity: v3(&st.velocity, 0),
            angular_velocity: v3(&st.velocity, 3),
            acceleration: v3(&st.acceleration, 0),
            angular_acceleration: v3(&st.acceleration, 3),
        };
        let motion = Self::system_motion(lay, st);
        self.stewart.joints().evaluate(&motion, &self.strokes, &mut self.rows);
        let mut wrench = Vector6::zeros();
        let mut phi = 0.0f64;
        let mut actuator_forces = [0.0; LEGS];
        for (k, row) in self.rows.iter().enumerate() {
            let lambda = st.multipliers[3 * lay.cables + k];
            for n in 0..2 {
                if row.bodies[n] == CABIN {
                    wrench -= row.jacobian[n] * lambda;
                }
            }
            phi = phi.max(row.value.abs());
            if k % ROWS_PER_LEG == DRIVING {
                actuator_forces[k / ROWS_PER_LEG] = lambda;
            }
        }
        let rot_c = st.bodies[0].orientation.to_rotation_matrix().into_inner();
        for i in 0..lay.cables {
            let end = st.nodes[i * lay.elements + lay.elements - 1];
            phi = phi.max((end - st.bodies[0].position - rot_c * self.attachments[i]).amax());
        }
        Sample { time: st.time, cabin, wrench, actuator_forces, constraint_residual: phi }
    }
}
