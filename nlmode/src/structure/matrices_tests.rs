//! Tests of `matrices.rs`.
use super::*;
use crate::structure::sparse::sparse_from_triplets;

/// The 3-DOF chain of `tests/it/matrices.rs` and a 30-node beam (58 DOFs),
/// through the dense and the sparse Craig-Bampton paths.
fn chain() -> (DMatrix<f64>, DMatrix<f64>) {
    let m = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0, 3.0]));
    let k = DMatrix::from_row_slice(
        3,
        3,
        &[
            300.0, -200.0, 0.0, -200.0, 500.0, -300.0, 0.0, -300.0, 300.0,
        ],
    );
    (m, k)
}

fn opts(m: DMatrix<f64>, k: DMatrix<f64>, pts: Vec<(String, usize)>) -> MatrixStructureOptions {
    let last = pts.last().unwrap().0.clone();
    MatrixStructureOptions {
        mass: m,
        mass_path: "M.mtx".into(),
        stiffness: k,
        stiffness_path: "K.mtx".into(),
        damping: MatrixDamping::StiffnessProportional {
            ratio: 0.01,
            mode_index: 0,
        },
        damping_path: None,
        points: pts,
        cubic_spring: Some((last.clone(), 1e6)),
        craig_bampton: Some((vec![last], 1)),
        allow_rigid_body_modes: false,
    }
}

fn to_sparse(o: &MatrixStructureOptions) -> MatrixStructureOptions<SparseMatrix> {
    o.map_matrices(sparse_from_dense)
}

#[test]
fn sparse_path_equals_the_dense_one() {
    let beam = crate::structure::BeamSpec {
        n_nodes: 30,
        ..crate::structure::BeamSpec::paper()
    }
    .assemble()
    .unwrap();
    let (cm, ck) = chain();
    let tip = beam.translation_dof(29).unwrap();
    let mid = beam.translation_dof(15).unwrap();
    let mut beam_opts = opts(
        beam.model.mass.clone(),
        beam.model.stiffness.clone(),
        vec![("mid".into(), mid), ("tip".into(), tip)],
    );
    beam_opts.craig_bampton = Some((vec!["tip".into(), "mid".into()], 8));
    beam_opts.damping = MatrixDamping::Rayleigh {
        alpha_per_s: 0.5,
        beta_s: 1e-5,
    };
    let mut chain_opts = opts(cm.clone(), ck, vec![("a".into(), 0), ("b".into(), 2)]);
    chain_opts.damping = MatrixDamping::Matrix(cm * 0.1);
    for o in [chain_opts, beam_opts] {
        let d = matrix_structure(&o).unwrap();
        let s = matrix_structure_sparse_cb(&to_sparse(&o)).unwrap();
        // small models take the dense path through matrix_structure_sparse
        let via = matrix_structure_sparse(&to_sparse(&o)).unwrap();
        assert_eq!(via.omega0_rad_s, d.omega0_rad_s);
        assert!(s.full.is_none() && s.full_ndof == d.full_ndof);
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
        assert!(rel(s.omega0_rad_s, d.omega0_rad_s) < 1e-9);
        assert!(rel(s.damping_ratio, d.damping_ratio) < 1e-9);
        assert_eq!(s.rigid_body_modes, 0);
        for (a, b) in s.interface_omega_rad_s.iter().zip(&d.interface_omega_rad_s) {
            assert!(rel(*a, *b) < 1e-9, "{a} vs {b}");
        }
        // the reduced models' spectra and their points / spring
        let n = s.model.ndof();
        let ws = modal_analysis(&s.model, n).unwrap().omega_rad_s;
        let wd = modal_analysis(&d.model, n).unwrap().omega_rad_s;
        for (a, b) in ws.iter().zip(&wd) {
            assert!(rel(*a, *b) < 1e-9, "{a} vs {b}");
        }
        assert_eq!(s.model.points.len(), d.model.points.len());
        assert_eq!(s.model.nonlinear.len(), 1);
        let (es, ed) = (
            &s.model.nonlinear[0].direction,
            &d.model.nonlinear[0].direction,
        );
        assert_eq!(es[0], ed[0]);
    }
}

#[test]
fn sparse_path_checks() {
    let (m, k) = chain();
    let pts = vec![("a".into(), 0), ("b".into(), 2)];
    let err = |o: MatrixStructureOptions| {
        matrix_structure_sparse_cb(&to_sparse(&o))
            .unwrap_err()
            .to_string()
    };
    let mut ka = k.clone();
    ka[(0, 1)] += 1.0;
    let e = err(opts(m.clone(), ka, pts.clone()));
    assert!(
        e.contains("stiffness_mtx") && e.contains("not symmetric"),
        "{e}"
    );
    let mut mi = m.clone();
    mi[(0, 1)] = 5.0;
    mi[(1, 0)] = 5.0;
    let e = err(opts(mi, k.clone(), pts.clone()));
    assert!(
        e.contains("mass_mtx") && e.contains("not positive definite"),
        "{e}"
    );
    let mut kn = k.clone();
    kn[(0, 0)] = 50.0;
    let e = err(opts(m.clone(), kn, pts.clone()));
    assert!(e.contains("not positive semi-definite"), "{e}");
    // free chain: one rigid-body mode, refused unless allowed
    let mut kf = k.clone();
    kf[(0, 0)] = 200.0;
    let e = err(opts(m.clone(), kf.clone(), pts.clone()));
    assert!(e.contains("1 rigid-body mode"), "{e}");
    let mut o = opts(m.clone(), kf, pts.clone());
    o.allow_rigid_body_modes = true;
    o.craig_bampton = Some((vec!["a".into(), "b".into()], 1));
    o.damping = MatrixDamping::StiffnessProportional {
        ratio: 0.01,
        mode_index: 1,
    };
    let s = matrix_structure_sparse_cb(&to_sparse(&o)).unwrap();
    assert_eq!(s.rigid_body_modes, 1);
    let e = err(opts(
        m.clone(),
        k.clone(),
        vec![("a".into(), 0), ("c".into(), 3)],
    ));
    assert!(e.contains("`c`") && e.contains("dof = 3"), "{e}");
    // reduction = "none" above the dense cap
    let big = sparse_from_triplets(
        DENSE_MAX_DOF + 1,
        &(0..=DENSE_MAX_DOF).map(|i| (i, i, 1.0)).collect::<Vec<_>>(),
    )
    .unwrap();
    let mut o = to_sparse(&opts(m, k, pts));
    o.mass = big.clone();
    o.stiffness = big;
    o.craig_bampton = None;
    let e = matrix_structure_sparse(&o).unwrap_err();
    assert!(matches!(e, MatricesError::TooLargeForDense { ndof, .. } if ndof == DENSE_MAX_DOF + 1));
    assert!(e.to_string().contains("craig-bampton"));
}

/// A small solid model (hexahedral plate, consistent mass, 576 DOFs): the
/// sparse path (one factorisation of K for the full model's modes, the
/// fixed-interface modes and the constraint modes) equals the dense one:
/// omega0, the damping ratio, the fixed-interface frequencies and the reduced
/// spectrum to 1e-9, the reduced M, K, C to 1e-9 of their largest entry
/// after aligning the modes' signs; the stage timings are reported.
#[test]
fn solid_plate_sparse_equals_dense() {
    use crate::structure::solid::{Elastic, HexPlate};
    let p = HexPlate {
        length_m: 0.3,
        width_m: 0.1,
        thickness_m: 0.01,
        nx: 12,
        ny: 3,
        nz: 2,
        material: Elastic::steel(),
    };
    let (m, k) = p.assemble().unwrap();
    let (tip, drive) = (p.dof(12, 1, 2, 2).unwrap(), p.dof(8, 2, 2, 2).unwrap());
    let mut o = to_sparse(&opts(
        DMatrix::zeros(1, 1),
        DMatrix::zeros(1, 1),
        vec![("tip".into(), tip), ("drive".into(), drive)],
    ));
    o.mass = m;
    o.stiffness = k;
    o.craig_bampton = Some((vec!["tip".into(), "drive".into()], 10));
    o.damping = MatrixDamping::Rayleigh {
        alpha_per_s: 2.0,
        beta_s: 1e-6,
    };
    let s = matrix_structure_sparse_cb(&o).unwrap();
    let d = matrix_structure(&o.map_matrices(sparse_to_dense)).unwrap();
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(s.omega0_rad_s, d.omega0_rad_s) < 1e-9);
    assert!(rel(s.damping_ratio, d.damping_ratio) < 1e-9);
    for (a, b) in s.interface_omega_rad_s.iter().zip(&d.interface_omega_rad_s) {
        assert!(rel(*a, *b) < 1e-9, "{a} vs {b}");
    }
    let nb = 2;
    let sign: Vec<f64> = (0..12)
        .map(|j| {
            if j < nb {
                1.0
            } else {
                s.transform.column(j).dot(&d.transform.column(j)).signum()
            }
        })
        .collect();
    let flip = |a: &DMatrix<f64>| DMatrix::from_fn(12, 12, |i, j| a[(i, j)] * sign[i] * sign[j]);
    for (what, a, b) in [
        ("M", &s.model.mass, &d.model.mass),
        ("K", &s.model.stiffness, &d.model.stiffness),
        ("C", &s.model.damping, &d.model.damping),
    ] {
        let err = (flip(a) - b).amax() / b.amax();
        assert!(err < 1e-9, "{what}: {err:e}");
    }
    let ws = modal_analysis(&s.model, 12).unwrap().omega_rad_s;
    let wd = modal_analysis(&d.model, 12).unwrap().omega_rad_s;
    for (a, b) in ws.iter().zip(&wd) {
        assert!(rel(*a, *b) < 1e-9, "{a} vs {b}");
    }
    let t = s.timings.unwrap();
    assert!(t.factor_nnz > o.stiffness.compute_nnz() / 2);
    assert!(t.memory_estimate_bytes > 8 * t.factor_nnz as u64);
    assert_eq!(t.lanczos_basis.len(), 2);
    assert!(d.timings.is_none());
}

/// The memory estimate refuses a model above the limit before factorising,
/// with the numbers; the same model passes under a sufficient limit.
#[test]
fn memory_estimate_refuses_above_the_limit() {
    use crate::structure::solid::HexPlate;
    let p = HexPlate::benchmark(600);
    let (m, k) = p.assemble().unwrap();
    let n = m.nrows();
    let mut o = to_sparse(&opts(
        DMatrix::zeros(1, 1),
        DMatrix::zeros(1, 1),
        vec![("tip".into(), n - 1)],
    ));
    o.mass = m;
    o.stiffness = k;
    o.craig_bampton = Some((vec!["tip".into()], 3));
    let limited = |limit| SparseOptions {
        memory_limit_bytes: Some(limit),
        ..Default::default()
    };
    let e = matrix_structure_sparse_cb_with(&o, &limited(1_000_000)).unwrap_err();
    let MatricesError::Structure(StructureError::MemoryLimit {
        ndof,
        factor_nnz,
        needed_bytes,
        limit_bytes,
        ..
    }) = e.clone()
    else {
        panic!("{e}");
    };
    assert_eq!((ndof, limit_bytes), (n, 1_000_000));
    assert!(needed_bytes > limit_bytes && factor_nnz > 0);
    let text = e.to_string();
    assert!(
        text.contains(&format!("{n}-DOF")) && text.contains("0.00 GB"),
        "{text}"
    );
    let s = matrix_structure_sparse_cb_with(&o, &limited(needed_bytes)).unwrap();
    assert_eq!(s.timings.unwrap().memory_estimate_bytes, needed_bytes);
}

#[test]
fn sparse_writer_round_trips() {
    let (_, k) = chain();
    let s = sparse_from_dense(&k);
    let text = write_matrix_market_sparse(&s);
    assert_eq!(text, write_matrix_market(&k));
    let back =
        read_matrix_market_sparse_str(MatrixRole::Stiffness, Path::new("K.mtx"), &text).unwrap();
    assert_eq!(sparse_to_dense(&back), k);
}

#[test]
fn reader_errors_keep_the_key_file_and_line() {
    let e = read_matrix_market_sparse_str(
        MatrixRole::Damping,
        Path::new("C.mtx"),
        "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 1 inf\n",
    )
    .unwrap_err();
    assert!(
        matches!(e, MatricesError::NonFinite { line: Some(3), .. }),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("damping_mtx") && msg.contains("C.mtx") && msg.contains("line 3"),
        "{msg}"
    );
}
