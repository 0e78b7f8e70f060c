//! Unit tests of [`super`] (the sparse matrices, factorisation and Lanczos).
use super::*;
use crate::structure::modal::generalized_eigen;
use crate::structure::{BeamSpec, BoundaryCondition};

#[test]
fn triplets_sum_duplicates_and_dense_round_trips() {
    let a = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 0, 2.0), (0, 0, 3.0)]).unwrap();
    let d = sparse_to_dense(&a);
    assert_eq!(d, DMatrix::from_row_slice(2, 2, &[4.0, 0.0, 2.0, 0.0]));
    assert_eq!(asymmetry(&a), (2.0, 4.0));
    assert_eq!(sparse_to_dense(&sparse_from_dense(&d)), d);
    assert!(sparse_from_triplets(2, &[(2, 0, 1.0)]).is_none());
    let x = DMatrix::from_row_slice(2, 1, &[1.0, -1.0]);
    assert_eq!(sym_mul(&a, &x), d.transpose() * &x); // A^T x for an unsymmetric A
    assert_eq!(diagonal(&a), vec![4.0, 0.0]);
}

fn beam(n_nodes: usize, boundary: BoundaryCondition) -> (SparseMatrix, SparseMatrix) {
    let b = BeamSpec {
        n_nodes,
        boundary,
        ..BeamSpec::paper()
    }
    .assemble()
    .unwrap();
    (
        sparse_from_dense(&b.model.mass),
        sparse_from_dense(&b.model.stiffness),
    )
}

#[test]
fn lanczos_matches_the_dense_eigensolver() {
    for (nodes, bc) in [
        (61, BoundaryCondition::ClampedFree),
        (6, BoundaryCondition::ClampedFree),
        (41, BoundaryCondition::FreeFree),
    ] {
        let (m, k) = beam(nodes, bc);
        let n = m.nrows();
        let nev = 8.min(n);
        let (wd, pd) =
            generalized_eigen(&sparse_to_dense(&m), &sparse_to_dense(&k), nev, "n").unwrap();
        let (ws, ps) = sparse_modal(&m, &k, nev, "n").unwrap();
        for j in 0..nev {
            if wd[j] == 0.0 {
                assert_eq!(ws[j], 0.0, "{nodes} nodes: rigid-body mode {j}");
                continue;
            }
            let rel = (ws[j] - wd[j]).abs() / wd[j];
            assert!(
                rel < 1e-9,
                "{nodes} nodes, mode {j}: {} vs {}",
                ws[j],
                wd[j]
            );
            let e = (ps.column(j) - pd.column(j)).amax() / pd.column(j).amax();
            assert!(e < 1e-7, "{nodes} nodes, shape {j}: {e:e}");
        }
    }
}

#[test]
fn a_factor_from_other_values_on_a_pattern_is_that_matrix_s_factor() {
    let (_, k) = beam(21, BoundaryCondition::ClampedFree);
    let sym = SymbolicFactor::new(&k).unwrap();
    // K scaled and shifted on its own pattern, against a copy holding these values
    let vals: Vec<f64> = k.val().iter().map(|v| 2.0 * v).collect();
    let mut copy = k.clone();
    copy.val_mut().copy_from_slice(&vals);
    let a = SparseCholesky::with_values(&sym, &k, &vals, Par::Seq).unwrap();
    let b = SparseCholesky::with_symbolic(&sym, &copy, Par::Seq).unwrap();
    assert_eq!(a.values, b.values);
    let mut x = Xorshift(7).block(k.nrows(), 2);
    let mut y = x.clone();
    a.solve_in_place(&mut x);
    b.solve_in_place(&mut y);
    assert_eq!(x, y);
    // wrong length, or not positive definite
    assert!(SparseCholesky::with_values(&sym, &k, &vals[1..], Par::Seq).is_none());
    let neg: Vec<f64> = vals.iter().map(|v| -v).collect();
    assert!(SparseCholesky::with_values(&sym, &k, &neg, Par::Seq).is_none());
}

#[test]
fn the_leading_block_of_a_factor_with_masters_last_solves_the_interior() {
    for ordering in [Ordering::Amd, Ordering::NestedDissection] {
        let (_, k) = beam(41, BoundaryCondition::ClampedFree);
        let n = k.nrows();
        let masters = [n - 2, 10, 3];
        let sym = SymbolicFactor::with_last(&k, ordering, &masters).unwrap();
        assert_eq!(sym.last(), &masters);
        let f = SparseCholesky::with_symbolic(&sym, &k, Par::Seq).unwrap();
        // K_ii on its own
        let mut pos = vec![None; n];
        let interior: Vec<usize> = (0..n).filter(|d| !masters.contains(d)).collect();
        for (i, &d) in interior.iter().enumerate() {
            pos[d] = Some(i);
        }
        let kii = sparse_submatrix(&k, &pos, interior.len());
        let fii = SparseCholesky::new(&kii).unwrap();
        let mut b = Xorshift(3).block(n, 2);
        let mut bi = DMatrix::from_fn(interior.len(), 2, |i, j| b[(interior[i], j)]);
        f.solve_leading_in_place(&mut b);
        fii.solve_in_place(&mut bi);
        for &d in &masters {
            assert_eq!(b.row(d).amax(), 0.0);
        }
        let xi = DMatrix::from_fn(interior.len(), 2, |i, j| b[(interior[i], j)]);
        let e = (&xi - &bi).amax() / bi.amax();
        assert!(e < 1e-10, "{ordering:?}: {e:e}");
        // and the factor is still K's
        let x = Xorshift(5).block(n, 1);
        let mut y = sym_mul(&k, &x);
        f.solve_in_place(&mut y);
        assert!((&y - &x).amax() < 1e-8 * x.amax());
    }
    // a master out of range or repeated: no ordering
    let (_, k) = beam(6, BoundaryCondition::ClampedFree);
    assert!(SymbolicFactor::with_last(&k, Ordering::Amd, &[1, 1]).is_none());
    assert!(SymbolicFactor::with_last(&k, Ordering::Amd, &[k.nrows()]).is_none());
}

#[test]
fn a_basis_without_m_v_gives_the_same_modes() {
    use crate::structure::lanczos::{lanczos_with, Pencil};
    let (m, k) = beam(61, BoundaryCondition::ClampedFree);
    let f = SparseCholesky::new(&k).unwrap();
    let p = Pencil {
        m: &m,
        k: &k,
        fixed: &[],
        par: Par::Seq,
    };
    let a = lanczos_with(&p, &f, 0.0, 8, "n", true).unwrap();
    let b = lanczos_with(&p, &f, 0.0, 8, "n", false).unwrap();
    for (x, y) in a.lambda.iter().zip(&b.lambda) {
        assert!((x - y).abs() < 1e-12 * x, "{x} vs {y}");
    }
    let e = (&a.shapes - &b.shapes).amax() / a.shapes.amax();
    assert!(e < 1e-8, "{e:e}");
}

#[test]
fn indefinite_stiffness_and_bad_counts_are_errors() {
    let m = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 1, 1.0)]).unwrap();
    let k = sparse_from_triplets(2, &[(0, 0, -3.0), (1, 1, 2.0)]).unwrap();
    assert!(matches!(
        sparse_modal(&m, &k, 1, "n"),
        Err(StructureError::NegativeEigenvalue { lambda, .. }) if (lambda + 3.0).abs() < 1e-9
    ));
    let k = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 1, 2.0)]).unwrap();
    assert!(matches!(
        sparse_modal(&m, &k, 3, "n"),
        Err(StructureError::ModeCount { requested: 3, .. })
    ));
    let (w, _) = sparse_modal(&m, &k, 2, "n").unwrap();
    assert!((w[0] - 1.0).abs() < 1e-14 && (w[1] - 2f64.sqrt()).abs() < 1e-14);
}

#[test]
fn asymmetry_by_search_equals_the_transposed_form() {
    let mut rng = Xorshift(0xa5a5_0003);
    for n in [1usize, 2, 7, 40, 300] {
        for case in 0..4 {
            // symmetric, then perturbed, with entries missing on one side
            let mut t = Vec::new();
            for _ in 0..(4 * n) {
                let (i, j) = (
                    ((rng.next() + 1.0) * 0.5 * n as f64) as usize % n,
                    ((rng.next() + 1.0) * 0.5 * n as f64) as usize % n,
                );
                let v = rng.next();
                t.push((i, j, v));
                match case {
                    0 => t.push((j, i, v)),
                    1 => t.push((j, i, v + 1e-3 * rng.next())),
                    2 if rng.next() > 0.0 => t.push((j, i, v)),
                    _ => {}
                }
            }
            let a = sparse_from_triplets(n, &t).unwrap();
            let (fast, slow) = (asymmetry(&a), asymmetry_by_transpose(a.as_ref()));
            assert_eq!(fast, slow, "n {n} case {case}");
            if case == 0 {
                assert_eq!(fast.0, 0.0);
            }
        }
    }
}
