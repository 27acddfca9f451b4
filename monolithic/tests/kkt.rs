//! The structured solve of the monolithic model's iteration matrix (chains condensed onto the
//! cabin, rigid bodies eliminated, dense constraint Schur complement) against a dense LU of the
//! same matrix written out in full.

use cable::chain_matrix::ChainMatrix;
use feedcore::rigid::left_jacobian_so3;
use feedcore::scene::Scene;
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};
use monolithic::kkt::Kkt;
use nalgebra::{DMatrix, DVector, Matrix3x6, Matrix6, Matrix6x3};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, SYSTEM_BODIES};
use stewart::{RigidMotion, Stewart};

fn random() -> impl FnMut() -> f64 {
    let mut seed = 11u64;
    move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    }
}

#[test]
fn structured_solve_matches_a_dense_lu() {
    let mut rnd = random();
    let scene = Scene::load(format!("{}/../scenes/lt50m_C.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let stewart = Stewart::from_scene(&scene).unwrap();
    let cabin = RigidMotion::at_rest(Vec3::new(0.0, 0.0, 9.8), feedcore::Quat::identity());
    let bodies = stewart.system_motion(&cabin, 3.0).unwrap();
    let mut rows = Box::new([ConstraintRow::EMPTY; CONSTRAINTS]);
    stewart.joints().evaluate(&bodies, &stewart.strokes(3.0).unwrap(), &mut rows);

    for (cables, nodes) in [(2, 3), (6, 1), (3, 0)] {
        // chain part: symmetric, diagonally dominant node blocks; any cabin coupling
        let mut chain = ChainMatrix::zeros(cables, nodes);
        for b in chain.diag.iter_mut() {
            let r = Mat3::from_fn(|_, _| rnd());
            *b = r * r.transpose() + Mat3::identity() * 5.0;
        }
        for b in chain.upper.iter_mut() {
            *b = Mat3::from_fn(|_, _| rnd());
        }
        for b in chain.node_cabin.iter_mut() {
            *b = Matrix3x6::from_fn(|_, _| rnd());
        }
        for b in chain.cabin_node.iter_mut() {
            *b = Matrix6x3::from_fn(|_, _| rnd());
        }
        chain.cabin = Matrix6::from_fn(|_, _| rnd()) + Matrix6::identity() * 40.0;
        let blocks: [Matrix6<f64>; BODIES] =
            std::array::from_fn(|_| Matrix6::from_fn(|_, _| rnd()) + Matrix6::identity() * 30.0);
        let tangents: [Mat3; SYSTEM_BODIES] =
            std::array::from_fn(|_| left_jacobian_so3(&Vec3::new(rnd(), rnd(), rnd())));
        let scale = 7.0;

        let mut kkt = Kkt::new(cables, nodes, &rows);
        kkt.factorize(&chain, &blocks, &rows, &tangents, scale).unwrap();

        // the same matrix, dense
        let nc = chain.dim();
        let motion = nc + 6 * BODIES;
        let n = motion + CONSTRAINTS;
        let mut a = DMatrix::<f64>::zeros(n, n);
        a.view_mut((0, 0), (nc, nc)).copy_from(&chain.to_dense());
        for (b, block) in blocks.iter().enumerate() {
            a.view_mut((nc + 6 * b, nc + 6 * b), (6, 6)).copy_from(block);
        }
        for (k, row) in rows.iter().enumerate() {
            for s in 0..2 {
                let b = row.bodies[s];
                let o = kkt.body_offset(b);
                assert_eq!(o, if b == CABIN { nc - 6 } else { nc + 6 * b });
                let g = row.jacobian[s];
                let rot = tangents[b].transpose() * Vec3::new(g[3], g[4], g[5]);
                for q in 0..6 {
                    a[(o + q, motion + k)] += g[q];
                    a[(motion + k, o + q)] += scale * if q < 3 { g[q] } else { rot[q - 3] };
                }
            }
        }
        let rhs: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let dense = a.clone().lu().solve(&DVector::from_column_slice(&rhs)).unwrap();
        let mut x = rhs.clone();
        kkt.solve(&mut x);
        let scale_x = dense.amax();
        let err = x.iter().zip(dense.iter()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        eprintln!("{cables} cables × {nodes} nodes: largest difference {err:.2e} (solution up to {scale_x:.2e})");
        assert!(err <= 1e-10 * scale_x, "structured and dense solves differ by {err:e}");
        // and it is a solution
        let residual = (&a * DVector::from_column_slice(&x) - DVector::from_column_slice(&rhs)).amax();
        assert!(residual <= 1e-10 * a.amax() * scale_x, "residual {residual:e}");
    }
}
