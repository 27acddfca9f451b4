//! The sparsity of the cable–cabin system: every cable is a chain of 3×3 node blocks
//! (block tridiagonal), and only its last node couples to the cabin's 6 degrees of freedom.
//!
//! ```text
//!  ┌ D U          ┐  cable 0: nodes 0 … m−1
//!  │ Uᵀ D U       │
//!  │   Uᵀ D     P │  ← last node couples to the cabin (P: 3×6)
//!  │        …     │  cables 1 …
//!  └      Q     A ┘  ← cabin (A: 6×6), Q: 6×3 per cable
//! ```
//!
//! The node–node blocks are symmetric (they come from bar elements, lumped masses and a
//! symmetric damping matrix); the cabin blocks need not be. Factorizing eliminates each chain
//! from the tower end towards the cabin (block Thomas algorithm) and condenses it onto the
//! cabin ([`ChainElimination`]): the cost is linear in the number of nodes. The condensed 6×6
//! cabin block is then factorized alone ([`ChainFactor`]) or inside a larger system (the
//! monolithic model's, with the Stewart platform).

use feedcore::Mat3;
use nalgebra::{Matrix3x6, Matrix6, Matrix6x3, Vector6};

use feedcore::Vec3;

/// A matrix with the cable–cabin sparsity. Vectors it acts on are laid out as all free nodes
/// (cable-major, 3 entries each) followed by the cabin's 6 (translation, rotation).
#[derive(Clone, Debug)]
pub struct ChainMatrix {
    pub cables: usize,
    /// Free nodes per cable.
    pub nodes: usize,
    /// Diagonal node blocks, `cables × nodes`.
    pub diag: Vec<Mat3>,
    /// Block (j, j+1) of each chain, `cables × (nodes − 1)`; block (j+1, j) is its transpose.
    pub upper: Vec<Mat3>,
    /// Last node × cabin, per cable.
    pub node_cabin: Vec<Matrix3x6<f64>>,
    /// Cabin × last node, per cable.
    pub cabin_node: Vec<Matrix6x3<f64>>,
    pub cabin: Matrix6<f64>,
}

impl ChainMatrix {
    pub fn zeros(cables: usize, nodes: usize) -> ChainMatrix {
        ChainMatrix {
            cables,
            nodes,
            diag: vec![Mat3::zeros(); cables * nodes],
            upper: vec![Mat3::zeros(); cables * nodes.saturating_sub(1)],
            node_cabin: vec![Matrix3x6::zeros(); cables],
            cabin_node: vec![Matrix6x3::zeros(); cables],
            cabin: Matrix6::zeros(),
        }
    }

    pub fn dim(&self) -> usize {
        3 * self.cables * self.nodes + 6
    }

    pub(crate) fn set_zero(&mut self) {
        self.diag.iter_mut().for_each(|b| b.fill(0.0));
        self.upper.iter_mut().for_each(|b| b.fill(0.0));
        self.node_cabin.iter_mut().for_each(|b| b.fill(0.0));
        self.cabin_node.iter_mut().for_each(|b| b.fill(0.0));
        self.cabin.fill(0.0);
    }

    /// `self += s · other`.
    pub(crate) fn add_scaled(&mut self, s: f64, other: &ChainMatrix) {
        for (a, b) in self.diag.iter_mut().zip(&other.diag) {
            *a += b * s;
        }
        for (a, b) in self.upper.iter_mut().zip(&other.upper) {
            *a += b * s;
        }
        for (a, b) in self.node_cabin.iter_mut().zip(&other.node_cabin) {
            *a += b * s;
        }
        for (a, b) in self.cabin_node.iter_mut().zip(&other.cabin_node) {
            *a += b * s;
        }
        self.cabin += other.cabin * s;
    }

    /// `y += self · x`.
    pub fn mul_add(&self, x: &[f64], y: &mut [f64]) {
        let m = self.nodes;
        let c0 = 3 * self.cables * m;
        let l = m.saturating_sub(1);
        let xc = Vector6::from_column_slice(&x[c0..c0 + 6]);
        let mut yc = self.cabin * xc;
        for c in 0..self.cables {
            if m == 0 {
                continue;
            }
            let (xs, ys) = (&x[3 * c * m..3 * (c + 1) * m], &mut y[3 * c * m..3 * (c + 1) * m]);
            let (diag, upper) = (&self.diag[c * m..(c + 1) * m], &self.upper[c * l..(c + 1) * l]);
            // y_j += D_j x_j + U_j x_{j+1} + U_{j−1}ᵀ x_{j−1}; the last term is carried over
            let mut xs = xs.chunks_exact(3).map(vec3);
            let mut x_cur = xs.next().expect("m > 0");
            let mut carry = Vec3::zeros();
            for (j, (yj, d)) in ys.chunks_exact_mut(3).zip(diag).enumerate() {
                let mut acc = d * x_cur + carry;
                match xs.next() {
                    Some(x_next) => {
                        let u = &upper[j];
                        acc += u * x_next;
                        carry = u.tr_mul(&x_cur);
                        x_cur = x_next;
                    }
                    None => {
                        acc += self.node_cabin[c] * xc;
                        yc += self.cabin_node[c] * x_cur;
                    }
                }
                add_to(yj, &acc);
            }
        }
        for i in 0..6 {
            y[c0 + i] += yc[i];
        }
    }

    /// Dense copy (for eigen solves and tests).
    pub fn to_dense(&self) -> nalgebra::DMatrix<f64> {
        let n = self.dim();
        let mut d = nalgebra::DMatrix::zeros(n, n);
        let m = self.nodes;
        let c0 = 3 * self.cables * m;
        for c in 0..self.cables {
            for j in 0..m {
                let k = c * m + j;
                d.fixed_view_mut::<3, 3>(3 * k, 3 * k).copy_from(&self.diag[k]);
                if j + 1 < m {
                    let u = &self.upper[c * (m - 1) + j];
                    d.fixed_view_mut::<3, 3>(3 * k, 3 * k + 3).copy_from(u);
                    d.fixed_view_mut::<3, 3>(3 * k + 3, 3 * k).copy_from(&u.transpose());
                }
            }
            if m > 0 {
                let k = c * m + m - 1;
                d.fixed_view_mut::<3, 6>(3 * k, c0).copy_from(&self.node_cabin[c]);
                d.fixed_view_mut::<6, 3>(c0, 3 * k).copy_from(&self.cabin_node[c]);
            }
        }
        d.fixed_view_mut::<6, 6>(c0, c0).copy_from(&self.cabin);
        d
    }

    /// Factorizes by block elimination of each chain towards the cabin, then LU of the
    /// condensed 6×6 cabin block. With `cabin_fixed` the cabin's unknowns are held at zero.
    pub fn factorize(&self, cabin_fixed: bool) -> Result<ChainFactor, FactorError> {
        let mut f = ChainFactor::new(self.cables, self.nodes);
        self.factorize_into(cabin_fixed, &mut f)?;
        Ok(f)
    }

    /// As [`ChainMatrix::factorize`], reusing the storage of `f` (no allocation).
    pub fn factorize_into(&self, cabin_fixed: bool, f: &mut ChainFactor) -> Result<(), FactorError> {
        let condensed = f.chains.eliminate(self)?;
        f.set_cabin(condensed, cabin_fixed)
    }
}

/// A [`ChainMatrix`] whose link blocks are symmetric — a stiffness or damping matrix assembled
/// from two-node elements — held with its products in fewer operations: with
/// `R_j = D_j + U_{j−1} + U_j` and `f_j = U_j (x_{j+1} − x_j)`, node j gets
/// `R_j x_j + f_j − f_{j−1}` (two 3×3 products per node instead of three). Exact.
#[derive(Clone, Debug)]
pub struct LinkedChain {
    matrix: ChainMatrix,
    nodal: Vec<Mat3>,
}

impl LinkedChain {
    /// The matrix in link form; without symmetric link blocks, a plain [`ChainMatrix::mul_add`]
    /// is kept (`nodal` empty).
    pub fn new(matrix: ChainMatrix) -> LinkedChain {
        let symmetric = matrix.upper.iter().all(|u| *u == u.transpose());
        let (m, l) = (matrix.nodes, matrix.nodes.saturating_sub(1));
        let nodal = if symmetric {
            (0..matrix.cables * m)
                .map(|k| {
                    let (c, j) = (k / m.max(1), k % m.max(1));
                    let mut r = matrix.diag[k];
                    if j > 0 {
                        r += matrix.upper[c * l + j - 1];
                    }
                    if j + 1 < m {
                        r += matrix.upper[c * l + j];
                    }
                    r
                })
                .collect()
        } else {
            Vec::new()
        };
        LinkedChain { matrix, nodal }
    }

    pub fn matrix(&self) -> &ChainMatrix {
        &self.matrix
    }

    /// `y += self · x`.
    pub fn mul_add(&self, x: &[f64], y: &mut [f64]) {
        let a = &self.matrix;
        if self.nodal.is_empty() {
            return a.mul_add(x, y);
        }
        let m = a.nodes;
        let c0 = 3 * a.cables * m;
        let l = m.saturating_sub(1);
        let xc = Vector6::from_column_slice(&x[c0..c0 + 6]);
        let mut yc = a.cabin * xc;
        for c in 0..a.cables {
            if m == 0 {
                continue;
            }
            let (xs, ys) = (&x[3 * c * m..3 * (c + 1) * m], &mut y[3 * c * m..3 * (c + 1) * m]);
            let (nodal, upper) = (&self.nodal[c * m..(c + 1) * m], &a.upper[c * l..(c + 1) * l]);
            let mut xs = xs.chunks_exact(3).map(vec3);
            let mut x_cur = xs.next().expect("m > 0");
            let mut f_before = Vec3::zeros();
            for (j, (yj, r)) in ys.chunks_exact_mut(3).zip(nodal).enumerate() {
                let mut acc = r * x_cur - f_before;
                match xs.next() {
                    Some(x_next) => {
                        let f = upper[j] * (x_next - x_cur);
                        acc += f;
                        f_before = f;
                        x_cur = x_next;
                    }
                    None => {
                        acc += a.node_cabin[c] * xc;
                        yc += a.cabin_node[c] * x_cur;
                    }
                }
                add_to(yj, &acc);
            }
        }
        for i in 0..6 {
            y[c0 + i] += yc[i];
        }
    }
}

/// Why a chain matrix cannot be factorized or a factorization cannot be restored.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FactorError {
    #[error("singular block at cable {cable}, node {node}")]
    SingularNode { cable: usize, node: usize },
    #[error("singular condensed cabin block")]
    SingularCabin,
    #[error("factorization data has {found} numbers, expected {expected}")]
    DataLength { found: usize, expected: usize },
}

/// Callers that report errors as text keep using `?`.
impl From<FactorError> for String {
    fn from(e: FactorError) -> String {
        e.to_string()
    }
}

/// The chains of a [`ChainMatrix`] eliminated onto the cabin (block Thomas algorithm along each
/// chain, from the tower towards the cabin). What is left is the condensed 6×6 cabin block (the
/// Schur complement), which the caller factorizes — alone, or inside a larger system.
///
/// The node–node blocks are symmetric, so the eliminated chain is too: one block per link,
/// `D'⁻¹_j U_j`, serves the forward elimination (as its transpose) and the back substitution.
#[derive(Clone, Debug)]
pub struct ChainElimination {
    cables: usize,
    nodes: usize,
    /// D'⁻¹_j: inverse pivot blocks.
    dinv: Vec<Mat3>,
    /// D'⁻¹_j U_j: back substitution from node j+1 to node j; its transpose eliminates node j
    /// from the row of node j+1.
    link: Vec<Mat3>,
    /// D'⁻¹ P and Q D'⁻¹ of each chain's last node.
    dinv_p: Vec<Matrix3x6<f64>>,
    q_dinv: Vec<Matrix6x3<f64>>,
}

impl ChainElimination {
    pub fn new(cables: usize, nodes: usize) -> ChainElimination {
        ChainElimination {
            cables,
            nodes,
            dinv: vec![Mat3::zeros(); cables * nodes],
            link: vec![Mat3::zeros(); cables * nodes.saturating_sub(1)],
            dinv_p: vec![Matrix3x6::zeros(); cables],
            q_dinv: vec![Matrix6x3::zeros(); cables],
        }
    }

    /// The inverse pivot blocks D'⁻¹_j, every cable's nodes in turn (each has the inertia of its
    /// pivot block).
    pub(crate) fn inverse_pivots(&self) -> &[Mat3] {
        &self.dinv
    }

    /// Eliminates the chains of `a`; returns its cabin block condensed onto the cabin.
    pub fn eliminate(&mut self, a: &ChainMatrix) -> Result<Matrix6<f64>, FactorError> {
        let m = self.nodes;
        assert!(a.cables == self.cables && a.nodes == m, "factor storage of the wrong shape");
        let mut condensed = a.cabin;
        let l = m.saturating_sub(1);
        for c in 0..self.cables {
            let (diag, upper) = (&a.diag[c * m..(c + 1) * m], &a.upper[c * l..(c + 1) * l]);
            let (dinv, link) = (&mut self.dinv[c * m..(c + 1) * m], &mut self.link[c * l..(c + 1) * l]);
            for j in 0..m {
                // D'_j = D_j − U_{j−1}ᵀ D'⁻¹_{j−1} U_{j−1}
                let d = if j == 0 { diag[0] } else { diag[j] - upper[j - 1].tr_mul(&link[j - 1]) };
                let inv = d.try_inverse().ok_or(FactorError::SingularNode { cable: c, node: j })?;
                dinv[j] = inv;
                if j + 1 < m {
                    link[j] = inv * upper[j];
                }
            }
            if m > 0 {
                let inv = dinv[m - 1];
                self.dinv_p[c] = inv * a.node_cabin[c];
                self.q_dinv[c] = a.cabin_node[c] * inv;
                condensed -= self.q_dinv[c] * a.node_cabin[c];
            }
        }
        Ok(condensed)
    }

    /// Forward elimination of the right-hand side `b` along every chain (in place); returns the
    /// cabin's right-hand side condensed like the matrix.
    pub fn forward(&self, b: &mut [f64]) -> Vector6<f64> {
        let m = self.nodes;
        let c0 = 3 * self.cables * m;
        let l = m.saturating_sub(1);
        let mut bc = Vector6::from_column_slice(&b[c0..c0 + 6]);
        if m == 0 {
            return bc;
        }
        for (c, bs) in b[..c0].chunks_exact_mut(3 * m).enumerate() {
            let link = &self.link[c * l..(c + 1) * l];
            let mut nodes = bs.chunks_exact_mut(3);
            let mut y = vec3(nodes.next().expect("m > 0"));
            for (bj, link) in nodes.zip(link) {
                y = vec3(bj) - link.tr_mul(&y);
                bj.copy_from_slice(y.as_slice());
            }
            bc -= self.q_dinv[c] * y;
        }
        bc
    }

    /// Back substitution (in place) from the cabin's solution `xc` to the towers; the cabin's
    /// entries of `b` are set to `xc`.
    pub fn backward(&self, b: &mut [f64], xc: &Vector6<f64>) {
        let m = self.nodes;
        let c0 = 3 * self.cables * m;
        let l = m.saturating_sub(1);
        b[c0..c0 + 6].copy_from_slice(xc.as_slice());
        if m == 0 {
            return;
        }
        for (c, bs) in b[..c0].chunks_exact_mut(3 * m).enumerate() {
            let (dinv, link) = (&self.dinv[c * m..(c + 1) * m], &self.link[c * l..(c + 1) * l]);
            let mut nodes = bs.chunks_exact_mut(3).rev();
            let last = nodes.next().expect("m > 0");
            let mut x = dinv[m - 1] * vec3(last) - self.dinv_p[c] * xc;
            last.copy_from_slice(x.as_slice());
            for ((bj, dinv), link) in nodes.zip(dinv[..m - 1].iter().rev()).zip(link.iter().rev()) {
                x = dinv * vec3(bj) - link * x;
                bj.copy_from_slice(x.as_slice());
            }
        }
    }

    /// How the first and the last free node of `cable` follow the cabin's unknowns `x_c` when
    /// no node carries a right-hand side (a load on the cabin alone): `x_first = F·x_c`,
    /// `x_last = L·x_c`; returns (F, L). The back substitution with a zero right-hand side,
    /// multiplied out once.
    pub(crate) fn end_response(&self, cable: usize) -> (Matrix3x6<f64>, Matrix3x6<f64>) {
        let m = self.nodes;
        if m == 0 {
            return (Matrix3x6::zeros(), Matrix3x6::zeros());
        }
        let l = m - 1;
        let last = -self.dinv_p[cable];
        let first = self.link[cable * l..(cable + 1) * l].iter().rev().fold(last, |t, link| -(link * t));
        (first, last)
    }

    /// Numbers of [`ChainElimination::encode`].
    fn encoded_len(&self) -> usize {
        9 * (self.dinv.len() + self.link.len()) + 36 * self.cables
    }

    fn encode(&self, out: &mut Vec<f64>) {
        for b in self.dinv.iter().chain(&self.link) {
            out.extend_from_slice(b.as_slice());
        }
        for b in &self.dinv_p {
            out.extend_from_slice(b.as_slice());
        }
        for b in &self.q_dinv {
            out.extend_from_slice(b.as_slice());
        }
    }

    /// Reads what [`ChainElimination::encode`] wrote (length checked by the caller).
    fn decode(&mut self, data: &[f64]) {
        let mut blocks = data.chunks_exact(9);
        for b in self.dinv.iter_mut().chain(self.link.iter_mut()) {
            b.copy_from_slice(blocks.next().expect("length checked"));
        }
        let rest = &data[9 * (self.dinv.len() + self.link.len())..];
        let mut blocks = rest.chunks_exact(18);
        for b in self.dinv_p.iter_mut() {
            b.copy_from_slice(blocks.next().expect("length checked"));
        }
        for b in self.q_dinv.iter_mut() {
            b.copy_from_slice(blocks.next().expect("length checked"));
        }
    }
}

/// A factorized [`ChainMatrix`]: the chains eliminated and the condensed cabin block's LU;
/// solves in place, without allocating.
#[derive(Clone, Debug)]
pub struct ChainFactor {
    chains: ChainElimination,
    /// The cabin block after condensing the chains onto it; its LU follows from it.
    condensed: Matrix6<f64>,
    /// `None` when the cabin is held fixed.
    cabin_lu: Option<nalgebra::linalg::LU<f64, nalgebra::U6, nalgebra::U6>>,
}

impl ChainFactor {
    pub fn new(cables: usize, nodes: usize) -> ChainFactor {
        ChainFactor { chains: ChainElimination::new(cables, nodes), condensed: Matrix6::zeros(), cabin_lu: None }
    }

    fn set_cabin(&mut self, condensed: Matrix6<f64>, cabin_fixed: bool) -> Result<(), FactorError> {
        self.condensed = condensed;
        self.cabin_lu = None;
        if !cabin_fixed {
            let lu = condensed.lu();
            if !lu.is_invertible() {
                return Err(FactorError::SingularCabin);
            }
            self.cabin_lu = Some(lu);
        }
        Ok(())
    }

    /// Every number of the factorization, for saving a simulation state.
    pub(crate) fn encode(&self, out: &mut Vec<f64>) {
        out.push(if self.cabin_lu.is_some() { 1.0 } else { 0.0 });
        self.chains.encode(out);
        out.extend_from_slice(self.condensed.as_slice());
    }

    /// Rebuilds a factorization from [`ChainFactor::encode`]d numbers (the cabin LU is
    /// recomputed from the condensed block: the same bits).
    pub fn decode(cables: usize, nodes: usize, data: &[f64]) -> Result<ChainFactor, FactorError> {
        let mut f = ChainFactor::new(cables, nodes);
        f.decode_into(data)?;
        Ok(f)
    }

    /// As [`ChainFactor::decode`], into this factorization's storage (same shape; no allocation).
    pub(crate) fn decode_into(&mut self, data: &[f64]) -> Result<(), FactorError> {
        let chain_len = self.chains.encoded_len();
        let expected = 1 + chain_len + 36;
        if data.len() != expected {
            return Err(FactorError::DataLength { found: data.len(), expected });
        }
        self.chains.decode(&data[1..1 + chain_len]);
        self.set_cabin(Matrix6::from_column_slice(&data[1 + chain_len..]), data[0] == 0.0)
    }

    /// The cabin's part of the solution of `S x = b` when `b` is zero on every node and `load`
    /// on the cabin (its nodes follow from [`ChainFactor::end_response`]).
    pub(crate) fn solve_cabin_load(&self, load: &Vector6<f64>) -> Vector6<f64> {
        match &self.cabin_lu {
            Some(lu) => lu.solve(load).unwrap_or_else(Vector6::zeros),
            None => Vector6::zeros(),
        }
    }

    /// See [`ChainElimination::end_response`].
    pub(crate) fn end_response(&self, cable: usize) -> (Matrix3x6<f64>, Matrix3x6<f64>) {
        self.chains.end_response(cable)
    }

    /// The number of negative eigenvalues of the factorized matrix, when it is symmetric: block
    /// elimination is a congruence, so by Sylvester's law of inertia the pivot blocks (the
    /// eliminated node blocks and the condensed cabin block) carry the matrix's inertia. With the
    /// cabin held fixed, of the node part only. Eigen solvers use it as a Sturm count.
    pub(crate) fn negative_eigenvalues(&self) -> usize {
        let negative = |eig: &[f64]| eig.iter().filter(|&&l| l < 0.0).count();
        let nodes: usize = self
            .chains
            .inverse_pivots()
            .iter()
            .map(|d| negative((d + d.transpose()).symmetric_eigenvalues().as_slice()))
            .sum();
        let cabin = match self.cabin_lu {
            Some(_) => negative((self.condensed + self.condensed.transpose()).symmetric_eigenvalues().as_slice()),
            None => 0,
        };
        nodes + cabin
    }

    /// Overwrites `b` with the solution of `S x = b`.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let bc = self.chains.forward(b);
        let xc = match &self.cabin_lu {
            Some(lu) => lu.solve(&bc).unwrap_or_else(Vector6::zeros),
            None => Vector6::zeros(),
        };
        self.chains.backward(b, &xc);
    }
}

/// A 3-vector from a slice of three.
#[inline]
pub(crate) fn vec3(v: &[f64]) -> Vec3 {
    let v: &[f64; 3] = v.try_into().expect("three entries");
    Vec3::new(v[0], v[1], v[2])
}

/// Adds a 3-vector to a slice of three.
#[inline]
pub(crate) fn add_to(v: &mut [f64], x: &Vec3) {
    let v: &mut [f64; 3] = v.try_into().expect("three entries");
    v[0] += x.x;
    v[1] += x.y;
    v[2] += x.z;
}

#[inline]
pub(crate) fn get3(v: &[f64], node: usize) -> Vec3 {
    Vec3::new(v[3 * node], v[3 * node + 1], v[3 * node + 2])
}

#[inline]
pub fn set3(v: &mut [f64], node: usize, x: &Vec3) {
    v[3 * node..3 * node + 3].copy_from_slice(x.as_slice());
}

#[inline]
pub fn add3(v: &mut [f64], node: usize, x: &Vec3) {
    v[3 * node] += x.x;
    v[3 * node + 1] += x.y;
    v[3 * node + 2] += x.z;
}

#[inline]
pub fn sub3(v: &mut [f64], node: usize, x: &Vec3) {
    v[3 * node] -= x.x;
    v[3 * node + 1] -= x.y;
    v[3 * node + 2] -= x.z;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random well-conditioned matrix with the chain pattern solves like its dense copy.
    #[test]
    fn structured_solve_and_product_match_dense() {
        let mut seed = 7u64;
        let mut rnd = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for nodes in [0, 1, 2, 7] {
            let mut s = ChainMatrix::zeros(3, nodes);
            for b in s.diag.iter_mut() {
                let r = Mat3::from_fn(|_, _| rnd());
                *b = r * r.transpose() + Mat3::identity() * 4.0;
            }
            for b in s.upper.iter_mut() {
                *b = Mat3::from_fn(|_, _| rnd());
            }
            for b in s.node_cabin.iter_mut() {
                *b = Matrix3x6::from_fn(|_, _| rnd());
            }
            for b in s.cabin_node.iter_mut() {
                *b = Matrix6x3::from_fn(|_, _| rnd());
            }
            s.cabin = Matrix6::from_fn(|_, _| rnd()) + Matrix6::identity() * 8.0;
            let n = s.dim();
            let x: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut y = vec![0.0; n];
            s.mul_add(&x, &mut y);
            // the link form of its symmetric part multiplies the same
            let mut sym = s.clone();
            sym.upper.iter_mut().for_each(|u| *u = (*u + u.transpose()) * 0.5);
            let (mut ys, mut yl) = (vec![0.0; n], vec![0.0; n]);
            sym.mul_add(&x, &mut ys);
            LinkedChain::new(sym).mul_add(&x, &mut yl);
            for i in 0..n {
                assert!((ys[i] - yl[i]).abs() < 1e-12, "link form row {i}");
            }
            let dense = s.to_dense();
            let yd = &dense * nalgebra::DVector::from_column_slice(&x);
            for i in 0..n {
                assert!((y[i] - yd[i]).abs() < 1e-12, "product row {i}");
            }
            let f = s.factorize(false).unwrap();
            f.solve_in_place(&mut y);
            for i in 0..n {
                assert!((y[i] - x[i]).abs() < 1e-11, "solve row {i}: {} vs {}", y[i], x[i]);
            }
            // a load on the cabin alone: the cabin's solution and the chain ends' response
            let load = Vector6::from_fn(|_, _| rnd());
            let mut full = vec![0.0; n];
            full[n - 6..].copy_from_slice(load.as_slice());
            f.solve_in_place(&mut full);
            let xc = f.solve_cabin_load(&load);
            assert!((xc - Vector6::from_column_slice(&full[n - 6..])).amax() < 1e-12);
            for c in 0..3 {
                let (first, last) = f.end_response(c);
                if nodes > 0 {
                    let (k0, k1) = (c * nodes, c * nodes + nodes - 1);
                    assert!((first * xc - get3(&full, k0)).amax() < 1e-12, "first node of cable {c}");
                    assert!((last * xc - get3(&full, k1)).amax() < 1e-12, "last node of cable {c}");
                }
            }
        }
    }
}
