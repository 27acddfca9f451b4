//! Natural frequencies and mode shapes about a static equilibrium.
//!
//! The full tangent stiffness K — elastic and geometric stiffness of every element, the
//! stiffness of the cable-end forces acting on the cabin's rotating arms, and of the weights
//! acting at the cabin's centre of mass — and the mass matrix M (lumped nodes, the cabin's
//! rigid-body mass about its centre point) give `K φ = ω² M φ`. Both keep the chain structure of
//! [`ChainMatrix`], and the lowest modes come from shift-invert Lanczos
//! ([`crate::eigen`]) with that structure's linear-cost factorization: O(n) memory and time
//! per mode, where a dense solve costs O(n²) memory and O(n³) time.
//!
//! Symmetry, which the Lanczos method needs. M is symmetric (lumped masses; the spatial inertia
//! about the centre point). In K, the node blocks and the node–cabin coupling are symmetric by
//! construction, and the cabin's rotation block is `Σ [pᵢ]×[dᵢ]× − [m g]×[c]×` plus symmetric
//! terms (pᵢ the pull of cable i on its arm dᵢ, c the arm of the weight). Since
//! `[a]×[b]× − [b]×[a]× = [a × b]×`, its antisymmetric part is `−½ [Σ dᵢ × pᵢ − c × m g]×`:
//! half the unbalanced moment on the cabin. At a static equilibrium in these coordinates
//! (world-frame rotation increments, at rest) K is therefore symmetric; the asymmetry left
//! measures how well the equilibrium was found and is reported, then removed.

use feedcore::rigid::{skew, turning_arm_stiffness};
use nalgebra::{Matrix3, Matrix6, Vector6};
use thiserror::Error;

use crate::chain_matrix::{ChainFactor, ChainMatrix};
use crate::eigen::{self, EigenError, LanczosOptions, LanczosStats, Pencil, ShiftedFactor};
use crate::element::Bar;
use crate::system::{Coefficients, Config, Support, System};

#[derive(Clone, Debug)]
pub struct Modes {
    /// Ascending. A negative value is an unstable direction: −√|λ|/2π.
    pub frequencies_hz: Vec<f64>,
    /// Mass-normalized shapes (φᵀ M φ = 1), laid out like the system's velocity vectors
    /// (free nodes, then the cabin; all zero for the cabin when it is held fixed). The sign is
    /// fixed: the largest entry is positive.
    pub shapes: Vec<Vec<f64>>,
    /// Largest asymmetry of K before symmetrization, relative to its largest entry: zero at an
    /// exact equilibrium, so it measures how well the equilibrium was found.
    pub stiffness_asymmetry: f64,
    /// Largest residual of the shift-inverted problem, `|λ|·‖K⁻¹Mφ − φ/λ‖_M`, over the modes
    /// returned, recomputed after the solve: a bound on the relative error of each λ.
    pub residual: f64,
    /// The eigen solver's work.
    pub stats: LanczosStats,
}

impl Modes {
    /// The cabin's part (translation, rotation) of mode `k`.
    pub fn cabin_part(&self, k: usize) -> Vector6<f64> {
        let s = &self.shapes[k];
        Vector6::from_column_slice(&s[s.len() - 6..])
    }
}

#[derive(Clone, Debug, PartialEq, Error)]
pub enum ModesError {
    #[error("the lumped mass {mass} kg of free node {node} (cable {cable}) is not positive")]
    NodeMass { cable: usize, node: usize, mass: f64 },
    #[error("the cabin's mass matrix about its centre point is not positive definite")]
    CabinMass,
    #[error(transparent)]
    Eigen(#[from] EigenError),
}

/// The tangent stiffness (symmetrized) and the mass matrix at a configuration at rest.
#[derive(Clone, Debug)]
pub struct Tangent {
    pub stiffness: ChainMatrix,
    pub mass: ChainMatrix,
    /// Largest `|K_ij − K_ji|` before symmetrization over the largest `|K_ij|`.
    pub asymmetry: f64,
}

/// Terms of the tangent stiffness a modal hypothesis leaves out (docs/reproduction.md, "Table 2");
/// the default drops none. Only for comparisons with linearisations that lack them: the
/// equations of motion keep every term.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dropped {
    /// `Σ [pᵢ]×[dᵢ]×`: the cable-end forces pᵢ turning with the cabin's arms dᵢ.
    pub cable_end_rotation: bool,
    /// `−[m g]×[c]×`: the weight acting at the centre of mass c, which turns with the cabin.
    pub weight_rotation: bool,
}

/// The cabin's rotation–rotation stiffness from the cable-end forces turning with their arms,
/// `Σ [pᵢ]×[dᵢ]×` (as `System::assemble` adds it), and from the weight, `−[m g]×[c]×` (as its
/// `BodyTerms` has it), for the hypotheses that drop them.
pub(crate) fn rotational_load_stiffness(sys: &System, cfg: &Config) -> (Matrix3<f64>, Matrix3<f64>) {
    let (m, ea) = (sys.free_nodes(), sys.net.spec.ea);
    let mut cables = Matrix3::zeros();
    for i in 0..sys.cables() {
        let (attach, d) = sys.attachment(cfg, i);
        let last = if m > 0 { cfg.nodes[i * m + m - 1] } else { sys.net.anchors[i] };
        let pull = Bar::pull(&(attach - last), ea, sys.element_length[i]);
        cables += turning_arm_stiffness(&pull, &d);
    }
    let rot = cfg.orientation.to_rotation_matrix().into_inner();
    let world = sys.body.transformed(&rot, &cfg.position);
    let weight = turning_arm_stiffness(&-(sys.net.spec.gravity * world.mass), &(world.com - cfg.position));
    (cables, weight)
}

/// K and M of `sys` at `cfg`, at rest and without external wrench.
pub fn tangent(sys: &System, cfg: &Config) -> Tangent {
    tangent_dropping(sys, cfg, Dropped::default())
}

/// As [`tangent`], without the terms `dropped` names (subtracted before the symmetrization: a
/// single dropped term leaves K unsymmetric by the moment it carries, and its symmetric part is
/// kept).
pub fn tangent_dropping(sys: &System, cfg: &Config, dropped: Dropped) -> Tangent {
    let n = sys.dim();
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut k = sys.new_matrix();
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut k, Coefficients::STIFFNESS)));
    if dropped != Dropped::default() {
        let (cables, weight) = rotational_load_stiffness(sys, cfg);
        let mut block = k.cabin.fixed_view_mut::<3, 3>(3, 3);
        if dropped.cable_end_rotation {
            block -= cables;
        }
        if dropped.weight_rotation {
            block -= weight;
        }
    }
    let mut m = sys.new_matrix();
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut m, Coefficients::MASS)));
    let asymmetry = symmetrize(&mut k);
    Tangent { stiffness: k, mass: m, asymmetry }
}

/// Replaces `k` by its symmetric part; returns its former asymmetry relative to its largest
/// entry. Only the cabin rows and columns can be asymmetric: node blocks are symmetric by
/// construction and blocks (j, j+1), (j+1, j) are stored once.
fn symmetrize(k: &mut ChainMatrix) -> f64 {
    let amax = |it: &mut dyn Iterator<Item = f64>| it.fold(0.0f64, |a, x| a.max(x.abs()));
    let largest = amax(&mut k.diag.iter().flat_map(|b| b.iter().copied()))
        .max(amax(&mut k.upper.iter().flat_map(|b| b.iter().copied())))
        .max(amax(&mut k.node_cabin.iter().flat_map(|b| b.iter().copied())))
        .max(amax(&mut k.cabin_node.iter().flat_map(|b| b.iter().copied())))
        .max(k.cabin.amax());
    let mut asym = (k.cabin - k.cabin.transpose()).amax();
    for b in &k.diag {
        asym = asym.max((b - b.transpose()).amax());
    }
    for (nc, cn) in k.node_cabin.iter_mut().zip(k.cabin_node.iter_mut()) {
        asym = asym.max((*nc - cn.transpose()).amax());
        let s = (*nc + cn.transpose()) * 0.5;
        *nc = s;
        *cn = s.transpose();
    }
    for b in k.diag.iter_mut() {
        *b = (*b + b.transpose()) * 0.5;
    }
    k.cabin = (k.cabin + k.cabin.transpose()) * 0.5;
    if largest > 0.0 { asym / largest } else { 0.0 }
}

/// The pencil (K, M) in the chain structure; the cabin's unknowns are held at zero when the
/// cabin is fixed.
struct ChainPencil<'a> {
    tangent: &'a Tangent,
    cabin_fixed: bool,
}

/// The factorization of `S = K − σM` with one step of iterative refinement per solve
/// (`x ← x + S̃⁻¹(b − S x)`). The chain elimination inverts 3×3 blocks explicitly; on the LT50m
/// chains (axial stiffness ~4000× the transverse one) its solves leave a residual of ~1e-8 of
/// the right-hand side, which shifted the cabin frequencies by up to 1.2e-9; one refinement step
/// brings the residual to ~1e-12 (measured) for one more solve and one product.
struct RefinedFactor {
    factor: ChainFactor,
    matrix: ChainMatrix,
    correction: Vec<f64>,
}

impl ShiftedFactor for RefinedFactor {
    fn solve_in_place(&mut self, b: &mut [f64]) {
        self.correction.copy_from_slice(b);
        self.factor.solve_in_place(b);
        // correction = S x − b, then x −= S̃⁻¹ correction
        self.correction.iter_mut().for_each(|r| *r = -*r);
        self.matrix.mul_add(b, &mut self.correction);
        self.factor.solve_in_place(&mut self.correction);
        for (x, d) in b.iter_mut().zip(&self.correction) {
            *x -= d;
        }
    }
    fn negative_eigenvalues(&self) -> usize {
        self.factor.negative_eigenvalues()
    }
}

impl Pencil for ChainPencil<'_> {
    type Factor = RefinedFactor;

    fn dim(&self) -> usize {
        self.tangent.mass.dim()
    }

    fn free_dim(&self) -> usize {
        if self.cabin_fixed { self.dim() - 6 } else { self.dim() }
    }

    fn constrain(&self, x: &mut [f64]) {
        if self.cabin_fixed {
            let n = x.len();
            x[n - 6..].fill(0.0);
        }
    }

    fn mass_mul(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        self.tangent.mass.mul_add(x, y);
        self.constrain(y);
    }

    fn factorize_shifted(&self, sigma: f64) -> Result<RefinedFactor, String> {
        let mut matrix = self.tangent.stiffness.clone();
        matrix.add_scaled(-sigma, &self.tangent.mass);
        let factor = matrix.factorize(self.cabin_fixed)?;
        Ok(RefinedFactor { factor, correction: vec![0.0; matrix.dim()], matrix })
    }
}

/// Bytes the modal analysis of `count` modes holds at its peak for a system of `unknowns`
/// unknowns, beyond the system itself; zero without modes. Linear in the unknowns: the Lanczos
/// basis (about 2·count + 8 vectors, see [`crate::eigen`]) with the modes found and returned
/// (3·count vectors in all), K, M and the factorization of K − σM (chain matrices, ~40 doubles
/// per unknown), and the dense Ritz problem of the basis (two m × m matrices, m its size).
/// Measured peak of `master modes` on LT50m C (above 1 mode): +3.0 doubles per unknown and mode
/// (320 elements per cable, 6 → 200 modes: +29 MB).
pub fn memory_estimate(unknowns: f64, count: usize) -> f64 {
    if count == 0 {
        return 0.0;
    }
    let k = count as f64;
    let basis = (2.0 * k + 8.0).max(k + 16.0).min(unknowns);
    8.0 * (unknowns * (3.0 * k + 40.0) + 2.0 * basis * basis)
}

/// The `count` lowest modes of `sys` at the equilibrium configuration `cfg` (at rest, no
/// external wrench).
pub fn modes(sys: &System, cfg: &Config, count: usize) -> Result<Modes, ModesError> {
    modes_dropping(sys, cfg, count, Dropped::default())
}

/// As [`modes`], with the tangent stiffness lacking the terms `dropped` names.
pub fn modes_dropping(sys: &System, cfg: &Config, count: usize, dropped: Dropped) -> Result<Modes, ModesError> {
    let t = tangent_dropping(sys, cfg, dropped);
    check_mass(sys, &t.mass)?;
    let pencil = ChainPencil { tangent: &t, cabin_fixed: sys.support == Support::Fixed };
    let eig = eigen::lowest(&pencil, count, &LanczosOptions::default())?;
    // Recomputed residual of the shift-inverted problem, `‖K⁻¹Mφ − φ/λ‖_M · |λ|` (‖φ‖_M = 1):
    // it bounds the relative error of λ (to first order; the operator is M-self-adjoint).
    let mut factor =
        pencil.factorize_shifted(0.0).map_err(|detail| EigenError::Factorization { sigma: 0.0, detail })?;
    let n = pencil.dim();
    let (mut ax, mut mr) = (vec![0.0; n], vec![0.0; n]);
    let mut residual = 0.0f64;
    let mut shapes = Vec::with_capacity(eig.vectors.len());
    for (&lambda, phi) in eig.values.iter().zip(eig.vectors) {
        pencil.mass_mul(&phi, &mut ax);
        factor.solve_in_place(&mut ax);
        pencil.constrain(&mut ax);
        for (a, p) in ax.iter_mut().zip(&phi) {
            *a -= p / lambda;
        }
        pencil.mass_mul(&ax, &mut mr);
        let r: f64 = ax.iter().zip(&mr).map(|(a, b)| a * b).sum::<f64>().max(0.0).sqrt();
        residual = residual.max(r * lambda.abs());
        shapes.push(with_fixed_sign(phi));
    }
    let frequencies_hz =
        eig.values.iter().map(|l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI)).collect();
    Ok(Modes { frequencies_hz, shapes, stiffness_asymmetry: t.asymmetry, residual, stats: eig.stats })
}

/// Node masses positive and the cabin's mass matrix positive definite: M is then positive
/// definite, as the M inner product needs.
fn check_mass(sys: &System, m: &ChainMatrix) -> Result<(), ModesError> {
    for (k, b) in m.diag.iter().enumerate() {
        if !(b[(0, 0)] > 0.0) {
            let nodes = sys.free_nodes();
            return Err(ModesError::NodeMass { cable: k / nodes, node: k % nodes + 1, mass: b[(0, 0)] });
        }
    }
    if sys.support == Support::Free && m.cabin.cholesky().is_none() {
        return Err(ModesError::CabinMass);
    }
    Ok(())
}

/// The shape with its largest entry made positive (an eigenvector's sign is arbitrary; this
/// makes the output reproducible).
fn with_fixed_sign(mut phi: Vec<f64>) -> Vec<f64> {
    let big = phi.iter().copied().fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
    if big < 0.0 {
        phi.iter_mut().for_each(|x| *x = -*x);
    }
    phi
}

/// The six frequencies (Hz, ascending) of the cabin, with everything riding on it, on six
/// massless straight cables: each cable a spring along its chord of axial stiffness `EA/L₀`
/// (L₀ its unstretched length; the sag's softening ignored) and, with `geometric`, the
/// geometric stiffness `T/L (I − uuᵀ)` of a straight string under its cabin-end tension T (L
/// the chord); the cabin's rotational load stiffness as in the full model. The simplified model
/// a linearisation without cable dynamics would use (docs/reproduction.md).
pub fn straight_cable_frequencies(sys: &System, cfg: &Config, geometric: bool) -> Vec<f64> {
    let mut tensions = vec![(0.0, 0.0); sys.cables()];
    sys.end_tensions(cfg, &mut tensions);
    let mut k = Matrix6::<f64>::zeros();
    for (i, (_, t)) in tensions.iter().enumerate() {
        let (attach, d) = sys.attachment(cfg, i);
        let chord = attach - sys.net.anchors[i];
        let (l, u) = (chord.norm(), chord.normalize());
        let uu = u * u.transpose();
        let mut ke = uu * (sys.net.spec.ea / sys.lengths[i]);
        if geometric {
            ke += (Matrix3::identity() - uu) * (t / l);
        }
        let mut b = nalgebra::Matrix3x6::<f64>::zeros();
        b.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        b.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&d)));
        k += b.transpose() * ke * b;
    }
    let (cables, weight) = rotational_load_stiffness(sys, cfg);
    let mut block = k.fixed_view_mut::<3, 3>(3, 3);
    block += cables + weight;
    let k = (k + k.transpose()) * 0.5;
    let rot = cfg.orientation.to_rotation_matrix().into_inner();
    let m = sys.body.transformed(&rot, &cfg.position).spatial_matrix_about(&cfg.position);
    let Some(chol) = m.cholesky() else { return vec![f64::NAN; 6] };
    let l_inv = chol.l().try_inverse().unwrap_or_else(|| Matrix6::from_element(f64::NAN));
    let a = l_inv * k * l_inv.transpose();
    let mut lambda: Vec<f64> = a.symmetric_eigen().eigenvalues.iter().copied().collect();
    lambda.sort_by(f64::total_cmp);
    lambda.iter().map(|l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI)).collect()
}
