//! Costs of the monolithic model at C (h = 0.01 s): one step, 100 s, and the linear algebra of a
//! Newton iteration — the structured solve (chains condensed onto the cabin, rigid bodies
//! eliminated, the constraints' Schur complement leg by leg) against a dense LU and a sparse LU
//! of the same reduced system (the cabin's condensed block, the 13 Stewart bodies and their 78
//! constraints: 162 unknowns), which is how the linear algebra was chosen.

use cable::chain_matrix::ChainMatrix;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::sparse::linalg::lu;
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, Mat, Par};
use feedcore::benchkit::{bench, human};
use feedcore::rigid::left_jacobian_so3;
use feedcore::scene::Scene;
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};
use monolithic::Monolithic;
use monolithic::kkt::Kkt;
use nalgebra::{Matrix3x6, Matrix6, Matrix6x3};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, SYSTEM_BODIES};
use stewart::{RigidMotion, Stewart};

fn main() {
    let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/lt50m_C.toml")).unwrap();
    println!("monolithic model, scene {} ({} elements per cable), h = 0.01 s", scene.name, scene.cables.elements);
    let mut m = Monolithic::new(&scene).unwrap();
    bench("one step", 1.0, || m.step(0.01).unwrap());
    bench("one step and its sample", 1.0, || {
        m.step(0.01).unwrap();
        m.sample()
    });
    let mut runs: Vec<f64> = (0..3)
        .map(|_| {
            let mut m = Monolithic::new(&scene).unwrap();
            let start = std::time::Instant::now();
            for _ in 0..10_000 {
                m.step(0.01).unwrap();
            }
            start.elapsed().as_secs_f64()
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    println!("{:<48} {:>12} median of 3", "100 s simulated (steps only)", human(runs[1]));

    // the linear algebra of one Newton iteration, on the model's structure
    let stewart = Stewart::from_scene(&scene).unwrap();
    let cabin = RigidMotion::at_rest(scene.target_position(), scene.target_orientation());
    let bodies = stewart.system_motion(&cabin, 3.0).unwrap();
    let mut rows = Box::new([ConstraintRow::EMPTY; CONSTRAINTS]);
    stewart.joints().evaluate(&bodies, &stewart.strokes(3.0).unwrap(), &mut rows);
    let mut seed = 5u64;
    let mut rnd = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let (cables, nodes) = (6, scene.cables.elements - 1);
    let mut chain = ChainMatrix::zeros(cables, nodes);
    for b in chain.diag.iter_mut() {
        let r = Mat3::from_fn(|_, _| rnd());
        *b = r * r.transpose() + Mat3::identity() * 5.0;
    }
    chain.upper.iter_mut().for_each(|b| *b = Mat3::from_fn(|_, _| rnd()));
    chain.node_cabin.iter_mut().for_each(|b| *b = Matrix3x6::from_fn(|_, _| rnd()));
    chain.cabin_node.iter_mut().for_each(|b| *b = Matrix6x3::from_fn(|_, _| rnd()));
    chain.cabin = Matrix6::from_fn(|_, _| rnd()) + Matrix6::identity() * 40.0;
    let blocks: [Matrix6<f64>; BODIES] =
        std::array::from_fn(|_| Matrix6::from_fn(|_, _| rnd()) + Matrix6::identity() * 30.0);
    let tangents: [Mat3; SYSTEM_BODIES] =
        std::array::from_fn(|_| left_jacobian_so3(&(Vec3::new(rnd(), rnd(), rnd()) * 1e-3)));
    let mut kkt = Kkt::new(cables, nodes, &rows);
    let n = chain.dim() + 6 * BODIES + CONSTRAINTS;
    let mut x: Vec<f64> = (0..n).map(|_| rnd()).collect();
    println!("linear algebra of a Newton iteration ({n} unknowns; reduced system 162)");
    bench("structured: factorize", 1.0, || kkt.factorize(&chain, &blocks, &rows, &tangents, 7.0).unwrap());
    bench("structured: solve", 1.0, || kkt.solve(&mut x));

    // the reduced system written out: cabin (0..6), bodies (6..84), multipliers (84..162)
    let offset = |b: usize| if b == CABIN { 0 } else { 6 + 6 * b };
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    for b in 0..SYSTEM_BODIES {
        let block = if b == CABIN { chain.cabin } else { blocks[b] };
        for i in 0..6 {
            for j in 0..6 {
                entries.push((offset(b) + i, offset(b) + j, block[(i, j)]));
            }
        }
    }
    for (k, row) in rows.iter().enumerate() {
        for s in 0..2 {
            let o = offset(row.bodies[s]);
            for q in 0..6 {
                entries.push((o + q, 84 + k, row.jacobian[s][q]));
                entries.push((84 + k, o + q, 7.0 * row.jacobian[s][q]));
            }
        }
    }
    let r = 162;
    let mut rhs: Vec<f64> = (0..r).map(|_| rnd()).collect();
    // dense LU (faer, partial pivoting)
    let mut dense = Mat::<f64>::zeros(r, r);
    let (mut perm, mut perm_inv) = (vec![0usize; r], vec![0usize; r]);
    let mut stack = MemBuffer::new(StackReq::any_of(&[
        factor::lu_in_place_scratch::<usize, f64>(r, r, Par::Seq, Default::default()),
        solve::solve_in_place_scratch::<usize, f64>(r, 1, Par::Seq),
    ]));
    bench("dense LU of the reduced system: factorize", 1.0, || {
        dense.fill(0.0);
        for (i, j, v) in &entries {
            dense[(*i, *j)] += v;
        }
        factor::lu_in_place(
            dense.as_mut(),
            &mut perm,
            &mut perm_inv,
            Par::Seq,
            MemStack::new(&mut stack),
            Default::default(),
        );
    });
    let mut b = Mat::<f64>::from_fn(r, 1, |i, _| rhs[i]);
    bench("dense LU of the reduced system: solve", 1.0, || {
        let p = faer::perm::PermRef::new_checked(&perm, &perm_inv, r);
        solve::solve_in_place(dense.as_ref(), dense.as_ref(), p, b.as_mut(), Par::Seq, MemStack::new(&mut stack));
    });
    // sparse LU (faer; symbolic analysis once)
    let pairs: Vec<Pair<usize, usize>> = entries.iter().map(|(i, j, _)| Pair { row: *i, col: *j }).collect();
    let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(r, r, &pairs).unwrap();
    let values: Vec<f64> = entries.iter().map(|e| e.2).collect();
    let sym = lu::factorize_symbolic_lu(symbolic.as_ref(), Default::default()).unwrap();
    let mut numeric = lu::NumericLu::new();
    let mut sstack = MemBuffer::new(StackReq::any_of(&[
        sym.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
        sym.solve_in_place_scratch::<f64>(1, Par::Seq),
    ]));
    bench("sparse LU of the reduced system: factorize", 1.0, || {
        let mat = SparseColMat::new_from_argsort(symbolic.clone(), &argsort, &values).unwrap();
        sym.factorize_numeric_lu(&mut numeric, mat.as_ref(), Par::Seq, MemStack::new(&mut sstack), Default::default())
            .unwrap();
    });
    let mut sb = Mat::<f64>::from_fn(r, 1, |i, _| rhs[i]);
    bench("sparse LU of the reduced system: solve", 1.0, || {
        lu::LuRef::new_unchecked(&sym, &numeric).solve_in_place_with_conj(
            Conj::No,
            sb.as_mut(),
            Par::Seq,
            MemStack::new(&mut sstack),
        );
    });
    rhs.clear();
}
