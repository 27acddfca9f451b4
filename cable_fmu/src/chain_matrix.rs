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
//! cabin: the cost is linear in the number of nodes.

use feedcore::Mat3;
use nalgebra::{Matrix3x6, Matrix6, Matrix6x3, SVector, Vector6};

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

    pub fn set_zero(&mut self) {
        self.diag.iter_mut().for_each(|b| b.fill(0.0));
        self.upper.iter_mut().for_each(|b| b.fill(0.0));
        self.node_cabin.iter_mut().for_each(|b| b.fill(0.0));
        self.cabin_node.iter_mut().for_each(|b| b.fill(0.0));
        self.cabin.fill(0.0);
    }

    /// `self += s · other`.
    pub fn add_scaled(&mut self, s: f64, other: &ChainMatrix) {
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
        let xc = Vector6::from_column_slice(&x[c0..c0 + 6]);
        let mut yc = Vector6::zeros();
        for c in 0..self.cables {
            for j in 0..m {
                let k = c * m + j;
                let mut acc = self.diag[k] * get3(x, k);
                if j + 1 < m {
                    acc += self.upper[c * (m - 1) + j] * get3(x, k + 1);
                }
                if j > 0 {
                    acc += self.upper[c * (m - 1) + j - 1].tr_mul(&get3(x, k - 1));
                }
                if j + 1 == m {
                    acc += self.node_cabin[c] * xc;
                    yc += self.cabin_node[c] * get3(x, k);
                }
                add3(y, k, &acc);
            }
        }
        yc += self.cabin * xc;
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
    pub fn factorize(&self, cabin_fixed: bool) -> Result<ChainFactor, String> {
        let mut f = ChainFactor::new(self.cables, self.nodes);
        self.factorize_into(cabin_fixed, &mut f)?;
        Ok(f)
    }

    /// As [`ChainMatrix::factorize`], reusing the storage of `f` (no allocation).
    pub fn factorize_into(&self, cabin_fixed: bool, f: &mut ChainFactor) -> Result<(), String> {
        let m = self.nodes;
        assert!(f.cables == self.cables && f.nodes == m, "factor storage of the wrong shape");
        let mut condensed = self.cabin;
        for c in 0..self.cables {
            for j in 0..m {
                let k = c * m + j;
                let d = if j == 0 {
                    self.diag[k]
                } else {
                    let u = &self.upper[c * (m - 1) + j - 1];
                    self.diag[k] - f.forward[c * (m - 1) + j - 1] * u
                };
                let dinv = d.try_inverse().ok_or_else(|| format!("singular block at cable {c}, node {j}"))?;
                f.dinv[k] = dinv;
                if j + 1 < m {
                    let u = &self.upper[c * (m - 1) + j];
                    f.forward[c * (m - 1) + j] = u.transpose() * dinv;
                    f.backward[c * (m - 1) + j] = dinv * u;
                }
            }
            if m > 0 {
                let dinv = f.dinv[c * m + m - 1];
                f.dinv_p[c] = dinv * self.node_cabin[c];
                f.q_dinv[c] = self.cabin_node[c] * dinv;
                condensed -= f.q_dinv[c] * self.node_cabin[c];
            }
        }
        f.set_cabin(condensed, cabin_fixed)
    }
}

/// A factorized [`ChainMatrix`]; solves in place, without allocating.
#[derive(Clone, Debug)]
pub struct ChainFactor {
    cables: usize,
    nodes: usize,
    dinv: Vec<Mat3>,
    /// Uᵀ_{j} D'⁻¹_{j}: eliminates node j from the row of node j+1.
    forward: Vec<Mat3>,
    /// D'⁻¹_{j} U_{j}: back substitution from node j+1 to node j.
    backward: Vec<Mat3>,
    dinv_p: Vec<Matrix3x6<f64>>,
    q_dinv: Vec<Matrix6x3<f64>>,
    /// The cabin block after condensing the chains onto it; its LU follows from it.
    condensed: Matrix6<f64>,
    /// `None` when the cabin is held fixed.
    cabin_lu: Option<nalgebra::linalg::LU<f64, nalgebra::U6, nalgebra::U6>>,
}

impl ChainFactor {
    pub fn new(cables: usize, nodes: usize) -> ChainFactor {
        ChainFactor {
            cables,
            nodes,
            dinv: vec![Mat3::zeros(); cables * nodes],
            forward: vec![Mat3::zeros(); cables * nodes.saturating_sub(1)],
            backward: vec![Mat3::zeros(); cables * nodes.saturating_sub(1)],
            dinv_p: vec![Matrix3x6::zeros(); cables],
            q_dinv: vec![Matrix6x3::zeros(); cables],
            condensed: Matrix6::zeros(),
            cabin_lu: None,
        }
    }

    fn set_cabin(&mut self, condensed: Matrix6<f64>, cabin_fixed: bool) -> Result<(), String> {
        self.condensed = condensed;
        self.cabin_lu = None;
        if !cabin_fixed {
            let lu = condensed.lu();
            if !lu.is_invertible() {
                return Err("singular condensed cabin block".into());
            }
            self.cabin_lu = Some(lu);
        }
        Ok(())
    }

    /// Every number of the factorization, for saving a simulation state.
    pub fn encode(&self, out: &mut Vec<f64>) {
        out.push(if self.cabin_lu.is_some() { 1.0 } else { 0.0 });
        for b in self.dinv.iter().chain(&self.forward).chain(&self.backward) {
            out.extend_from_slice(b.as_slice());
        }
        for b in &self.dinv_p {
            out.extend_from_slice(b.as_slice());
        }
        for b in &self.q_dinv {
            out.extend_from_slice(b.as_slice());
        }
        out.extend_from_slice(self.condensed.as_slice());
    }

    /// Rebuilds a factorization from [`ChainFactor::encode`]d numbers (the cabin LU is
    /// recomputed from the condensed block: the same bits).
    pub fn decode(cables: usize, nodes: usize, data: &[f64]) -> Result<ChainFactor, String> {
        let mut f = ChainFactor::new(cables, nodes);
        f.decode_into(data)?;
        Ok(f)
    }

    /// As [`ChainFactor::decode`], into this factorization's storage (same shape; no allocation).
    pub fn decode_into(&mut self, data: &[f64]) -> Result<(), String> {
        let blocks3 = self.dinv.len() + self.forward.len() + self.backward.len();
        let expected = 1 + 9 * blocks3 + 36 * self.cables + 36;
        if data.len() != expected {
            return Err(format!("factorization data has {} numbers, expected {expected}", data.len()));
        }
        let mut it = data[1..].chunks_exact(9);
        for b in self.dinv.iter_mut().chain(self.forward.iter_mut()).chain(self.backward.iter_mut()) {
            b.copy_from_slice(it.next().expect("length checked"));
        }
        let rest = &data[1 + 9 * blocks3..];
        let mut it = rest.chunks_exact(18);
        for b in self.dinv_p.iter_mut() {
            b.copy_from_slice(it.next().expect("length checked"));
        }
        for b in self.q_dinv.iter_mut() {
            b.copy_from_slice(it.next().expect("length checked"));
        }
        self.set_cabin(Matrix6::from_column_slice(&rest[36 * self.cables..]), data[0] == 0.0)
    }

    /// The number of negative eigenvalues of the factorized matrix, when it is symmetric: block
    /// elimination is a congruence, so by Sylvester's law of inertia the pivot blocks (the
    /// eliminated node blocks and the condensed cabin block) carry the matrix's inertia. With the
    /// cabin held fixed, of the node part only. Eigen solvers use it as a Sturm count.
    pub fn negative_eigenvalues(&self) -> usize {
        let negative = |eig: &[f64]| eig.iter().filter(|&&l| l < 0.0).count();
        let nodes: usize =
            self.dinv.iter().map(|d| negative((d + d.transpose()).symmetric_eigenvalues().as_slice())).sum();
        let cabin = match self.cabin_lu {
            Some(_) => negative((self.condensed + self.condensed.transpose()).symmetric_eigenvalues().as_slice()),
            None => 0,
        };
        nodes + cabin
    }

    /// Overwrites `b` with the solution of `S x = b`.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let m = self.nodes;
        let c0 = 3 * self.cables * m;
        // forward elimination along each chain, condensing onto the cabin
        let mut bc: SVector<f64, 6> = Vector6::from_column_slice(&b[c0..c0 + 6]);
        for c in 0..self.cables {
            for j in 1..m {
                let k = c * m + j;
                let y = get3(b, k) - self.forward[c * (m - 1) + j - 1] * get3(b, k - 1);
                set3(b, k, &y);
            }
            if m > 0 {
                bc -= self.q_dinv[c] * get3(b, c * m + m - 1);
            }
        }
        let xc = match &self.cabin_lu {
            Some(lu) => lu.solve(&bc).unwrap_or_else(Vector6::zeros),
            None => Vector6::zeros(),
        };
        b[c0..c0 + 6].copy_from_slice(xc.as_slice());
        // back substitution from the cabin to the towers
        for c in 0..self.cables {
            if m == 0 {
                continue;
            }
            let last = c * m + m - 1;
            let x = self.dinv[last] * get3(b, last) - self.dinv_p[c] * xc;
            set3(b, last, &x);
            for j in (0..m - 1).rev() {
                let k = c * m + j;
                let x = self.dinv[k] * get3(b, k) - self.backward[c * (m - 1) + j] * get3(b, k + 1);
                set3(b, k, &x);
            }
        }
    }
}

#[inline]
pub fn get3(v: &[f64], node: usize) -> Vec3 {
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
        }
    }
}
