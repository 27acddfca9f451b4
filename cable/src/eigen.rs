//! The lowest eigenpairs of a symmetric pencil `K φ = λ M φ` (M positive definite) by
//! shift-invert Lanczos in the M inner product, with thick restarts, checked by a Sturm count.
//!
//! Why this method. With K and M symmetric, `A = (K − σM)⁻¹ M` is self-adjoint in the inner
//! product `⟨x, y⟩ = xᵀ M y`, so a Krylov basis that is M-orthonormal projects it onto a small
//! symmetric matrix (Lanczos; symmetric Ritz problem, real Ritz values). The eigenvalues of A,
//! `θ = 1/(λ − σ)`, are largest for the λ nearest the shift and spread apart where the λ crowd,
//! so a basis of a few times k vectors holds the k wanted ones. Each step costs one solve with
//! a factorization computed once, one product with M and the orthogonalization against the
//! basis: O(n·m) for m basis vectors; memory O(n·m).
//!
//! * Thick restart (Krylov–Schur form): when the basis is full, the best Ritz vectors are kept
//!   and the basis grows again from the residual direction, so m stays bounded.
//! * Full re-orthogonalization (classical Gram–Schmidt, twice): no ghost copies.
//! * Repeated eigenvalues: a Krylov space grown from one vector holds only one direction of each
//!   eigenspace, so a pair of equal frequencies (a symmetric net) would lose one. After each
//!   pass the inertia of `K − σ̂M` (Sylvester's law: the number of its negative pivots equals
//!   the number of eigenvalues below σ̂) is compared with what was found below σ̂, just above the
//!   k-th value; if some are missing, another pass runs in the M-orthogonal complement of
//!   everything found so far. The result is the k eigenvalues nearest σ, and for a stable
//!   system (K positive definite, σ = 0) provably the k lowest.

use nalgebra::{DMatrix, SymmetricEigen};
use thiserror::Error;

/// A factorization of `K − σM`.
pub trait ShiftedFactor {
    /// Overwrites `b` with `(K − σM)⁻¹ b`.
    fn solve_in_place(&mut self, b: &mut [f64]);
    /// The number of negative eigenvalues of `K − σM` (its inertia).
    fn negative_eigenvalues(&self) -> usize;
}

/// A symmetric pencil (K, M), M positive definite on the unknowns that are not held.
pub trait Pencil {
    type Factor: ShiftedFactor;
    /// Length of the vectors.
    fn dim(&self) -> usize;
    /// Number of unknowns not held at zero: the size of the eigenproblem.
    fn free_dim(&self) -> usize;
    /// Sets the held unknowns of `x` to zero.
    fn constrain(&self, x: &mut [f64]);
    /// `y = M x`.
    fn mass_mul(&self, x: &[f64], y: &mut [f64]);
    /// Factorizes `K − σM`, or says why it cannot.
    fn factorize_shifted(&self, sigma: f64) -> Result<Self::Factor, String>;
}

#[derive(Clone, Copy, Debug)]
pub struct LanczosOptions {
    /// The shift σ: eigenvalues nearest it are found.
    pub shift: f64,
    /// A Ritz pair is converged when `‖A y − θ y‖_M ≤ tolerance·|θ|` (‖y‖_M = 1).
    pub tolerance: f64,
    /// Restarts allowed per pass.
    pub max_restarts: usize,
    /// Seed of the start vectors (the result does not depend on it beyond round-off).
    pub seed: u64,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        LanczosOptions { shift: 0.0, tolerance: 1e-10, max_restarts: 200, seed: 0x5eed_1a2c_205a_u64 }
    }
}

/// Work done, for reports and cost checks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LanczosStats {
    /// Lanczos passes (more than one when the Sturm count found missing eigenvalues).
    pub passes: usize,
    pub restarts: usize,
    /// Solves with the factorization (= products with A).
    pub solves: usize,
    /// Factorizations (the shift and every Sturm count).
    pub factorizations: usize,
    /// Largest basis held at once.
    pub basis_size: usize,
}

/// Eigenpairs in ascending order of λ; vectors M-orthonormal.
#[derive(Clone, Debug)]
pub struct Eigenpairs {
    pub values: Vec<f64>,
    pub vectors: Vec<Vec<f64>>,
    pub stats: LanczosStats,
}

/// Restarts without halving the largest residual after which the iteration is taken as stalled.
const STALLED_AFTER: usize = 12;

#[derive(Clone, Debug, PartialEq, Error)]
pub enum EigenError {
    #[error("cannot factorize K − σM at σ = {sigma:e}: {detail} (is the system a mechanism, or σ an eigenvalue?)")]
    Factorization { sigma: f64, detail: String },
    #[error(
        "shift-invert Lanczos did not converge: {converged} of {wanted} eigenpairs within the relative \
         residual {tolerance:e} after {restarts} restarts (largest residual {residual:.2e})"
    )]
    NotConverged { wanted: usize, converged: usize, restarts: usize, tolerance: f64, residual: f64 },
    #[error(
        "shift-invert Lanczos stalled: the largest residual of the {wanted} wanted eigenpairs stopped \
         decreasing at {residual:.2e} after {restarts} restarts, above the tolerance {tolerance:e}: the \
         round-off of the shifted solves of {unknowns} unknowns; use fewer elements per cable (`cables.elements`)"
    )]
    Stalled { wanted: usize, unknowns: usize, restarts: usize, tolerance: f64, residual: f64 },
    #[error(
        "the Sturm count finds {count} eigenvalues below {sigma:e}, the Lanczos passes found {found} of them \
         after {passes} passes: the missing ones lie far from the shift (an unstable equilibrium has \
         negative eigenvalues)"
    )]
    Missed { sigma: f64, count: usize, found: usize, passes: usize },
    #[error(
        "shift-invert Lanczos broke down: {detail} (masses or stiffnesses too large or too small for \
         double precision?)"
    )]
    Breakdown { detail: String },
}

/// The `count` eigenpairs of the pencil nearest `opts.shift` (the lowest ones when K − σM is
/// positive definite), ascending.
pub fn lowest<P: Pencil>(pencil: &P, count: usize, opts: &LanczosOptions) -> Result<Eigenpairs, EigenError> {
    let free = pencil.free_dim();
    let count = count.min(free);
    let mut stats = LanczosStats::default();
    let mut found: Vec<(f64, Vec<f64>)> = Vec::new();
    if count == 0 {
        return Ok(Eigenpairs { values: vec![], vectors: vec![], stats });
    }
    let factorize = |sigma: f64, stats: &mut LanczosStats| {
        stats.factorizations += 1;
        pencil.factorize_shifted(sigma).map_err(|detail| EigenError::Factorization { sigma, detail })
    };
    let mut factor = factorize(opts.shift, &mut stats)?;
    let mut rng = Rng(opts.seed);
    let max_passes = count + 2;
    let mut last_check = (0.0, 0, 0);
    for _ in 0..max_passes {
        stats.passes += 1;
        let want = count.min(free - found.len());
        let locked: Vec<&[f64]> = found.iter().map(|(_, v)| v.as_slice()).collect();
        let mut pass = Pass::new(pencil, &mut factor, &locked, opts, &mut rng);
        let new = pass.run(want, &mut stats)?;
        found.extend(new.into_iter().map(|(theta, y)| (opts.shift + 1.0 / theta, y)));
        found.sort_by(|a, b| a.0.total_cmp(&b.0));
        if found.len() == free {
            break; // every eigenpair
        }
        // Sturm check just above the count-th value.
        let top = found[count - 1].0;
        let sigma = top + 1e-6 * top.abs().max(f64::MIN_POSITIVE.sqrt());
        let below = factorize(sigma, &mut stats)?.negative_eigenvalues();
        let have = found.iter().filter(|(l, _)| *l < sigma).count();
        if have >= below {
            found.truncate(count);
            let (values, vectors) = found.into_iter().unzip();
            return Ok(Eigenpairs { values, vectors, stats });
        }
        last_check = (sigma, below, have);
    }
    if found.len() == free {
        found.truncate(count);
        let (values, vectors) = found.into_iter().unzip();
        return Ok(Eigenpairs { values, vectors, stats });
    }
    let (sigma, count, found) = last_check;
    Err(EigenError::Missed { sigma, count, found, passes: stats.passes })
}

/// One Krylov–Schur pass in the M-orthogonal complement of the `locked` vectors.
struct Pass<'a, P: Pencil> {
    pencil: &'a P,
    factor: &'a mut P::Factor,
    locked: &'a [&'a [f64]],
    opts: &'a LanczosOptions,
    rng: &'a mut Rng,
    /// Scratch: M times a vector.
    mx: Vec<f64>,
    /// Scratch: Gram–Schmidt coefficients.
    coef: Vec<f64>,
}

impl<'a, P: Pencil> Pass<'a, P> {
    fn new(
        pencil: &'a P,
        factor: &'a mut P::Factor,
        locked: &'a [&'a [f64]],
        opts: &'a LanczosOptions,
        rng: &'a mut Rng,
    ) -> Self {
        Pass { pencil, factor, locked, opts, rng, mx: vec![0.0; pencil.dim()], coef: Vec::new() }
    }

    fn m_norm(&mut self, x: &[f64]) -> f64 {
        self.pencil.mass_mul(x, &mut self.mx);
        dot(x, &self.mx).max(0.0).sqrt()
    }

    /// Makes `w` M-orthogonal to `basis` (classical Gram–Schmidt, twice); adds the
    /// coefficients to `h` (if given).
    fn orthogonalize(&mut self, w: &mut [f64], basis: &[&[f64]], mut h: Option<&mut [f64]>) {
        self.coef.resize(basis.len(), 0.0);
        for _ in 0..2 {
            self.pencil.mass_mul(w, &mut self.mx);
            for (c, v) in self.coef.iter_mut().zip(basis) {
                *c = dot(v, &self.mx);
            }
            for (c, v) in self.coef.iter().zip(basis) {
                axpy(-c, v, w);
            }
            if let Some(h) = h.as_deref_mut() {
                for (hi, c) in h.iter_mut().zip(&self.coef) {
                    *hi += c;
                }
            }
        }
    }

    /// A random unit vector M-orthogonal to the locked vectors and to `basis`. A few tries: a
    /// random vector lies almost inside the span of the others only by bad luck, or when the
    /// M inner product over- or underflows (then every try fails alike).
    fn random_vector(&mut self, basis: &[Vec<f64>]) -> Result<Vec<f64>, EigenError> {
        const TRIES: usize = 16;
        let n = self.pencil.dim();
        for _ in 0..TRIES {
            let mut x: Vec<f64> = (0..n).map(|_| self.rng.next()).collect();
            self.pencil.constrain(&mut x);
            let start = self.m_norm(&x);
            if !(start > 0.0 && start.is_finite()) {
                return Err(EigenError::Breakdown { detail: format!("the M-norm of a start vector is {start:e}") });
            }
            let locked = self.locked;
            self.orthogonalize(&mut x, locked, None);
            let refs: Vec<&[f64]> = basis.iter().map(Vec::as_slice).collect();
            self.orthogonalize(&mut x, &refs, None);
            let norm = self.m_norm(&x);
            if norm > 1e-8 * start && norm.is_finite() {
                x.iter_mut().for_each(|v| *v /= norm);
                return Ok(x);
            }
        }
        Err(EigenError::Breakdown {
            detail: format!(
                "no start vector M-orthogonal to the {} found in {TRIES} tries",
                basis.len() + self.locked.len()
            ),
        })
    }

    /// The `want` Ritz pairs (θ, y) of largest |θ| in the complement, converged.
    fn run(&mut self, want: usize, stats: &mut LanczosStats) -> Result<Vec<(f64, Vec<f64>)>, EigenError> {
        let free = self.pencil.free_dim() - self.locked.len();
        let want = want.min(free);
        let m = free.min((2 * want + 8).max(want + 16));
        stats.basis_size = stats.basis_size.max(m + 1);
        let n = self.pencil.dim();
        let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
        let first = self.random_vector(&basis)?;
        basis.push(first);
        // Projected matrix: A V_k = V_k H[..k, ..k] + v_k H[k, ..k] (row k: coupling to the next vector).
        let mut h = DMatrix::<f64>::zeros(m + 1, m);
        let mut start = 0;
        let mut restarts = 0;
        // stagnation: the best largest residual so far and the restart that brought it
        let mut best = (f64::INFINITY, 0);
        let mut w = vec![0.0; n];
        let mut col = vec![0.0; m + 1];
        loop {
            let mut size = m;
            for j in start..m {
                self.pencil.mass_mul(&basis[j], &mut w);
                self.factor.solve_in_place(&mut w);
                self.pencil.constrain(&mut w);
                stats.solves += 1;
                let norm0 = self.m_norm(&w);
                let locked = self.locked;
                self.orthogonalize(&mut w, locked, None);
                col[..=j].fill(0.0);
                {
                    let refs: Vec<&[f64]> = basis.iter().map(Vec::as_slice).collect();
                    self.orthogonalize(&mut w, &refs, Some(&mut col[..=j]));
                }
                for i in 0..=j {
                    h[(i, j)] = col[i];
                }
                if j + 1 == free {
                    size = j + 1; // the basis spans the whole complement: H is exact
                    break;
                }
                let beta = self.m_norm(&w);
                if !(beta.is_finite() && norm0.is_finite()) {
                    // NaN in H would keep the symmetric eigensolver below from converging
                    return Err(EigenError::Breakdown {
                        detail: format!(
                            "the M-norm of a Lanczos vector is {:e}",
                            if norm0.is_finite() { beta } else { norm0 }
                        ),
                    });
                }
                if beta > 1e-12 * norm0 {
                    h[(j + 1, j)] = beta;
                    basis.push(w.iter().map(|x| x / beta).collect());
                } else {
                    // an invariant subspace: continue with a fresh direction
                    h[(j + 1, j)] = 0.0;
                    let r = self.random_vector(&basis)?;
                    basis.push(r);
                }
            }
            // Rayleigh–Ritz on the projected matrix (symmetric up to round-off).
            let hs = DMatrix::from_fn(size, size, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
            let eig = SymmetricEigen::new(hs);
            let mut order: Vec<usize> = (0..size).collect();
            order.sort_by(|&a, &b| eig.eigenvalues[b].abs().total_cmp(&eig.eigenvalues[a].abs()));
            let exact = size == free;
            let coupling = |i: usize| -> f64 {
                if exact { 0.0 } else { (0..size).map(|j| h[(size, j)] * eig.eigenvectors[(j, i)]).sum() }
            };
            let residual = |i: usize| coupling(i).abs() / eig.eigenvalues[i].abs().max(f64::MIN_POSITIVE);
            let converged = order[..want].iter().take_while(|&&i| residual(i) <= self.opts.tolerance).count();
            if converged == want {
                let pairs = order[..want]
                    .iter()
                    .map(|&i| (eig.eigenvalues[i], combine(&basis[..size], eig.eigenvectors.column(i).as_slice())))
                    .collect();
                return Ok(pairs);
            }
            restarts += 1;
            stats.restarts += 1;
            let worst = order[..want].iter().map(|&i| residual(i)).fold(0.0, f64::max);
            if worst < 0.5 * best.0 {
                best = (worst, restarts);
            } else if restarts - best.1 >= STALLED_AFTER {
                // round-off, not the basis, limits the residual: more restarts would not help
                return Err(EigenError::Stalled {
                    wanted: want,
                    unknowns: n,
                    restarts,
                    tolerance: self.opts.tolerance,
                    residual: best.0,
                });
            }
            if restarts > self.opts.max_restarts {
                return Err(EigenError::NotConverged {
                    wanted: want,
                    converged,
                    restarts: self.opts.max_restarts,
                    tolerance: self.opts.tolerance,
                    residual: worst,
                });
            }
            // Thick restart: keep the best `keep` Ritz vectors and the next basis vector.
            let keep = (want + (size - want) / 2).clamp(want.max(1), size - 1);
            let next = basis.pop().expect("the basis has its next vector");
            let kept: Vec<Vec<f64>> =
                order[..keep].iter().map(|&i| combine(&basis, eig.eigenvectors.column(i).as_slice())).collect();
            let couplings: Vec<f64> = order[..keep].iter().map(|&i| coupling(i)).collect();
            h.fill(0.0);
            for (k, &i) in order[..keep].iter().enumerate() {
                h[(k, k)] = eig.eigenvalues[i];
                h[(keep, k)] = couplings[k];
            }
            basis = kept;
            basis.push(next);
            start = keep;
        }
    }
}

/// `Σ_j c_j v_j`.
fn combine(vectors: &[Vec<f64>], c: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; vectors[0].len()];
    for (v, &cj) in vectors.iter().zip(c) {
        axpy(cj, v, &mut y);
    }
    y
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// Start vectors: a fixed linear congruential sequence in [−0.5, 0.5).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dense pencil with a prescribed spectrum: `M = B Bᵀ + I` (B random) and
    /// `K = M^{1/2} Q Λ Qᵀ M^{1/2}`, so the eigenvalues are exactly Λ.
    struct Dense {
        k: DMatrix<f64>,
        m: DMatrix<f64>,
    }

    struct DenseFactor {
        lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
        negative: usize,
    }

    impl ShiftedFactor for DenseFactor {
        fn solve_in_place(&mut self, b: &mut [f64]) {
            let x = self.lu.solve(&nalgebra::DVector::from_column_slice(b)).unwrap();
            b.copy_from_slice(x.as_slice());
        }
        fn negative_eigenvalues(&self) -> usize {
            self.negative
        }
    }

    impl Pencil for Dense {
        type Factor = DenseFactor;
        fn dim(&self) -> usize {
            self.k.nrows()
        }
        fn free_dim(&self) -> usize {
            self.dim()
        }
        fn constrain(&self, _: &mut [f64]) {}
        fn mass_mul(&self, x: &[f64], y: &mut [f64]) {
            y.copy_from_slice((&self.m * nalgebra::DVector::from_column_slice(x)).as_slice());
        }
        fn factorize_shifted(&self, sigma: f64) -> Result<DenseFactor, String> {
            let s = &self.k - &self.m * sigma;
            // the inertia from the symmetric eigenvalues (an independent route to the count)
            let negative = s.clone().symmetric_eigenvalues().iter().filter(|&&l| l < 0.0).count();
            Ok(DenseFactor { lu: s.lu(), negative })
        }
    }

    fn pencil(spectrum: &[f64], seed: u64) -> Dense {
        let n = spectrum.len();
        let mut rng = Rng(seed);
        let b = DMatrix::from_fn(n, n, |_, _| rng.next());
        let m = &b * b.transpose() + DMatrix::identity(n, n);
        let q = DMatrix::from_fn(n, n, |_, _| rng.next()).qr().q();
        let e = m.clone().symmetric_eigen();
        let sqrt_m =
            &e.eigenvectors * DMatrix::from_diagonal(&e.eigenvalues.map(f64::sqrt)) * e.eigenvectors.transpose();
        let k = &sqrt_m
            * &q
            * DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(spectrum))
            * q.transpose()
            * &sqrt_m;
        Dense { k: (&k + k.transpose()) * 0.5, m }
    }

    fn check(p: &Dense, spectrum: &[f64], count: usize) -> LanczosStats {
        let mut sorted = spectrum.to_vec();
        sorted.sort_by(f64::total_cmp);
        let e = lowest(p, count, &LanczosOptions::default()).unwrap();
        assert_eq!(e.values.len(), count.min(spectrum.len()));
        for (i, (l, want)) in e.values.iter().zip(&sorted).enumerate() {
            assert!((l - want).abs() < 1e-10 * want.abs().max(1.0), "λ{i}: {l} vs {want}");
            // K φ = λ M φ, and the vectors are M-orthonormal
            let phi = nalgebra::DVector::from_column_slice(&e.vectors[i]);
            let r = &p.k * &phi - &p.m * &phi * *l;
            assert!(r.amax() < 1e-8 * (&p.k * &phi).amax(), "residual of pair {i}");
            for (j, other) in e.vectors.iter().enumerate() {
                let g = (phi.transpose() * &p.m * nalgebra::DVector::from_column_slice(other))[(0, 0)];
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g - expected).abs() < 1e-10, "⟨φ{i}, φ{j}⟩_M = {g}");
            }
        }
        e.stats
    }

    /// Distinct eigenvalues: one pass, and the Sturm count confirms it.
    #[test]
    fn distinct_spectrum() {
        let spectrum: Vec<f64> = (0..120).map(|i| 1.0 + 0.37 * i as f64 + 0.01 * (i * i) as f64).collect();
        let stats = check(&pencil(&spectrum, 3), &spectrum, 8);
        assert_eq!(stats.passes, 1);
    }

    /// A triple and a double eigenvalue among the lowest: a Krylov space from one vector holds
    /// one direction of each (in exact arithmetic; round-off may reveal the others after
    /// restarts), the Sturm count notices missing copies and further passes in the complement
    /// find them.
    #[test]
    fn repeated_eigenvalues_are_all_found() {
        let mut spectrum = vec![2.0, 2.0, 2.0, 3.5, 5.0, 5.0];
        spectrum.extend((0..80).map(|i| 7.0 + i as f64));
        let stats = check(&pencil(&spectrum, 11), &spectrum, 7);
        eprintln!("random pencil: {stats:?}");
        // Diagonal K and M = I, and a first start vector without components along two copies of
        // the triple eigenvalue: diagonal operators keep those entries exactly zero, so no
        // round-off can reveal them and only the Sturm count finds them.
        let diagonal = Dense {
            k: DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&spectrum)),
            m: DMatrix::identity(spectrum.len(), spectrum.len()),
        };
        let blind = FirstStartBlind { inner: diagonal, calls: std::cell::Cell::new(0) };
        let e = lowest(&blind, 7, &LanczosOptions::default()).unwrap();
        eprintln!("diagonal pencil: {:?} {:?}", e.values, e.stats);
        for (l, want) in e.values.iter().zip(&spectrum) {
            assert!((l - want).abs() < 1e-12 * want);
        }
        assert!(e.stats.passes >= 2, "the copies need another pass: {:?}", e.stats);
    }

    /// Hides coordinates 1 and 2 from the first start vector only.
    struct FirstStartBlind {
        inner: Dense,
        calls: std::cell::Cell<usize>,
    }

    impl Pencil for FirstStartBlind {
        type Factor = DenseFactor;
        fn dim(&self) -> usize {
            self.inner.dim()
        }
        fn free_dim(&self) -> usize {
            self.inner.dim()
        }
        fn constrain(&self, x: &mut [f64]) {
            if self.calls.replace(self.calls.get() + 1) == 0 {
                x[1] = 0.0;
                x[2] = 0.0;
            }
        }
        fn mass_mul(&self, x: &[f64], y: &mut [f64]) {
            self.inner.mass_mul(x, y);
        }
        fn factorize_shifted(&self, sigma: f64) -> Result<DenseFactor, String> {
            self.inner.factorize_shifted(sigma)
        }
    }

    /// A negative eigenvalue far from the shift is reported as missed, never silently dropped.
    #[test]
    fn a_far_unstable_eigenvalue_is_reported() {
        let mut spectrum = vec![-40.0];
        spectrum.extend((0..60).map(|i| 1.0 + i as f64));
        let err = lowest(&pencil(&spectrum, 4), 3, &LanczosOptions::default()).unwrap_err();
        eprintln!("{err}");
        assert!(matches!(err, EigenError::Missed { count, found, .. } if count > found), "{err:?}");
    }

    /// Asking for every eigenpair of a small pencil spans the whole space (exact Ritz values).
    #[test]
    fn whole_spectrum_of_a_small_pencil() {
        let spectrum = [4.0, 1.0, 9.0, 1.0, 16.0, 2.5, 7.0];
        check(&pencil(&spectrum, 5), &spectrum, 20);
    }

    /// Eigenvalues on both sides of the shift: the ones nearest it come out, ascending, and
    /// negative ones (an unstable direction) are kept.
    #[test]
    fn nearest_the_shift_on_both_sides() {
        let mut spectrum = vec![-0.5, 0.8, 1.5];
        spectrum.extend((0..60).map(|i| 4.0 + i as f64));
        check(&pencil(&spectrum, 9), &spectrum, 3);
    }

    /// Solves with relative errors of 1e-7, like the round-off of a huge mesh: the residual
    /// cannot fall below about that, so the iteration is reported as stalled after a few restarts
    /// instead of running all `max_restarts`.
    struct Noisy {
        inner: Dense,
    }

    struct NoisyFactor {
        inner: DenseFactor,
        rng: Rng,
    }

    impl ShiftedFactor for NoisyFactor {
        fn solve_in_place(&mut self, b: &mut [f64]) {
            self.inner.solve_in_place(b);
            let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for x in b.iter_mut() {
                *x += 1e-7 * scale * self.rng.next();
            }
        }
        fn negative_eigenvalues(&self) -> usize {
            self.inner.negative_eigenvalues()
        }
    }

    impl Pencil for Noisy {
        type Factor = NoisyFactor;
        fn dim(&self) -> usize {
            self.inner.dim()
        }
        fn free_dim(&self) -> usize {
            self.inner.dim()
        }
        fn constrain(&self, _: &mut [f64]) {}
        fn mass_mul(&self, x: &[f64], y: &mut [f64]) {
            self.inner.mass_mul(x, y);
        }
        fn factorize_shifted(&self, sigma: f64) -> Result<NoisyFactor, String> {
            Ok(NoisyFactor { inner: self.inner.factorize_shifted(sigma)?, rng: Rng(17) })
        }
    }

    #[test]
    fn a_residual_held_up_by_round_off_is_reported_as_stalled() {
        let spectrum: Vec<f64> = (0..150).map(|i| 1.0 + 0.5 * i as f64).collect();
        let noisy = Noisy { inner: pencil(&spectrum, 21) };
        let opts = LanczosOptions::default();
        let err = lowest(&noisy, 6, &opts).unwrap_err();
        eprintln!("{err}");
        match err {
            EigenError::Stalled { restarts, residual, unknowns, .. } => {
                assert!(restarts < opts.max_restarts / 4, "stopped early: {restarts} restarts");
                assert!(residual > opts.tolerance && residual < 1e-4, "held near the noise: {residual:e}");
                assert_eq!(unknowns, 150);
            }
            other => panic!("expected Stalled, got {other:?}"),
        }
    }
}
