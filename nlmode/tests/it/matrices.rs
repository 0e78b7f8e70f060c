//! The user's structure from Matrix Market files (`nlmode::structure::matrices`):
//! the reader's formats agree, and every bad input gives its typed error with
//! the key, file and numbers.
use nalgebra::DMatrix;
use nlmode::structure::matrices::{read_matrix_market_str, write_matrix_market};
use nlmode::structure::{
    matrix_structure, paper_structure, read_matrix_market, MatricesError, MatrixDamping,
    MatrixRole, MatrixStructureOptions, PaperStructureOptions,
};
use std::path::{Path, PathBuf};

const M: MatrixRole = MatrixRole::Mass;

fn read(text: &str) -> Result<DMatrix<f64>, MatricesError> {
    read_matrix_market_str(M, Path::new("m.mtx"), text)
}

/// A 3-DOF chain: masses 1, 2, 3 kg, springs 100, 200, 300 N/m (first to ground).
fn chain() -> (DMatrix<f64>, DMatrix<f64>) {
    let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 2.0, 3.0]));
    let k = DMatrix::from_row_slice(
        3,
        3,
        &[
            300.0, -200.0, 0.0, -200.0, 500.0, -300.0, 0.0, -300.0, 300.0,
        ],
    );
    (m, k)
}

fn opts(m: DMatrix<f64>, k: DMatrix<f64>) -> MatrixStructureOptions {
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
        points: vec![("a".into(), 0), ("b".into(), 2)],
        cubic_spring: Some(("b".into(), 1e6)),
        craig_bampton: Some((vec!["b".into()], 1)),
        allow_rigid_body_modes: false,
    }
}

#[test]
fn coordinate_array_symmetric_general_give_the_same_matrix() {
    let (_, k) = chain();
    let sym = write_matrix_market(&k);
    let general = "%%MatrixMarket matrix coordinate real general\n% a comment\n3 3 7\n\
        1 1 300\n1 2 -200\n2 1 -200\n2 2 500\n2 3 -300\n3 2 -300\n3 3 300\n";
    // array: column-major, all entries; symmetric array: the lower triangle by columns
    let array = "%%MatrixMarket matrix array real general\n3 3\n300\n-200\n0\n-200\n500\n-300\n0\n-300\n300\n";
    let array_sym =
        "%%MatrixMarket matrix array real symmetric\n3 3\n300\n-200\n0\n500\n-300\n300\n";
    for (name, text) in [
        ("coordinate symmetric", sym.as_str()),
        ("coordinate general", general),
        ("array general", array),
        ("array symmetric", array_sym),
    ] {
        let a = read(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(a, k, "{name}");
    }
    // writing and reading back keeps every bit
    let b = paper_structure(&PaperStructureOptions::default()).unwrap();
    let m = &b.beam.model.mass;
    assert_eq!(&read(&write_matrix_market(m)).unwrap(), m);
}

#[test]
fn bad_files_name_the_key_file_and_line() {
    let e = read_matrix_market(M, Path::new("/nonexistent/M.mtx")).unwrap_err();
    assert!(matches!(e, MatricesError::Io { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("mass_mtx") && msg.contains("/nonexistent/M.mtx"),
        "{msg}"
    );
    let e = read("%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n2 x 3.0\n")
        .unwrap_err();
    match &e {
        MatricesError::Malformed { line, .. } => assert_eq!(*line, Some(4), "{e}"),
        _ => panic!("{e}"),
    }
    assert!(
        e.to_string().contains("line 4") && e.to_string().contains("m.mtx"),
        "{e}"
    );
    let e = read("%%MatrixMarket matrix coordinate real general\n2 3 1\n1 1 1.0\n").unwrap_err();
    assert!(
        matches!(
            e,
            MatricesError::NotSquare {
                rows: 2,
                cols: 3,
                ..
            }
        ),
        "{e}"
    );
    let e = read("%%MatrixMarket matrix coordinate real general\n2 2 1\n1 1 NaN\n").unwrap_err();
    assert!(matches!(e, MatricesError::NonFinite { .. }), "{e}");
    let e = read("%%MatrixMarket matrix coordinate real general\n2 2 1\n3 1 1.0\n").unwrap_err();
    assert!(matches!(e, MatricesError::Malformed { .. }), "{e}");
    assert!(read("").is_err());
}

#[test]
fn a_good_model_builds_and_reduces() {
    let (m, k) = chain();
    let s = matrix_structure(&opts(m, k)).unwrap();
    assert_eq!(s.model.ndof(), 2);
    assert_eq!(s.full_ndof, 3);
    assert_eq!(s.rigid_body_modes, 0);
    assert_eq!(s.model.nonlinear.len(), 1);
    assert!(s.model.point("a").is_ok() && s.model.point("b").is_ok());
    // omega0 of the chain (smallest root of det(K - w^2 M) = 0) against the modal analysis
    let full = nlmode::structure::modal_analysis(s.full.as_ref().unwrap(), 1).unwrap();
    assert_eq!(full.omega_rad_s[0], s.omega0_rad_s);
    let w2 = s.omega0_rad_s.powi(2);
    let (m, k) = chain();
    let det = (k - m * w2).determinant();
    assert!(det.abs() < 1e-9 * 300f64.powi(3), "{det}");
}

fn err(o: MatrixStructureOptions) -> String {
    matrix_structure(&o).unwrap_err().to_string()
}

#[test]
fn every_bad_model_gives_its_message() {
    let (m, k) = chain();
    // sizes differ
    let o = opts(m.clone(), DMatrix::identity(2, 2));
    let e = err(o);
    assert!(
        e.contains("stiffness_mtx") && e.contains("2x2") && e.contains("3x3"),
        "{e}"
    );
    // not symmetric
    let mut ka = k.clone();
    ka[(0, 1)] = -199.0;
    let e = err(opts(m.clone(), ka));
    assert!(
        e.contains("stiffness_mtx") && e.contains("not symmetric"),
        "{e}"
    );
    // M not positive definite (symmetric, positive diagonal, indefinite)
    let mut mi = m.clone();
    mi[(0, 1)] = 5.0;
    mi[(1, 0)] = 5.0;
    let e = err(opts(mi, k.clone()));
    assert!(
        e.contains("mass_mtx") && e.contains("positive definite"),
        "{e}"
    );
    // negative diagonal of K
    let mut kn = k.clone();
    kn[(1, 1)] = -1.0;
    let e = err(opts(m.clone(), kn));
    assert!(
        e.contains("stiffness_mtx") && e.contains("-1e0") && e.contains("row 1"),
        "{e}"
    );
    // K indefinite with a positive diagonal
    let mut ki = k.clone();
    ki[(0, 0)] = 100.0;
    let e = err(opts(m.clone(), ki));
    assert!(e.contains("not positive semi-definite"), "{e}");
    // rigid-body mode (free chain): refused, then accepted with the key
    let mut kf = k.clone();
    kf[(0, 0)] = 200.0;
    let e = err(opts(m.clone(), kf.clone()));
    assert!(
        e.contains("1 rigid-body mode") && e.contains("allow_rigid_body_modes"),
        "{e}"
    );
    let mut o = opts(m.clone(), kf);
    o.allow_rigid_body_modes = true;
    o.craig_bampton = None;
    o.damping = MatrixDamping::StiffnessProportional {
        ratio: 0.01,
        mode_index: 1,
    };
    let s = matrix_structure(&o).unwrap();
    assert_eq!(s.rigid_body_modes, 1);
    assert!(s.omega0_rad_s > 0.0);
    // dof out of range, duplicate names, unknown points
    let mut o = opts(m.clone(), k.clone());
    o.points.push(("c".into(), 3));
    let e = err(o);
    assert!(
        e.contains("`c`") && e.contains("dof = 3") && e.contains("3 rows"),
        "{e}"
    );
    let mut o = opts(m.clone(), k.clone());
    o.points.push(("a".into(), 1));
    assert!(err(o).contains("`a` is used twice"));
    let mut o = opts(m.clone(), k.clone());
    o.cubic_spring = Some(("nowhere".into(), 1e6));
    let e = err(o);
    assert!(
        e.contains("nonlinear_point") && e.contains("nowhere"),
        "{e}"
    );
    let mut o = opts(m.clone(), k.clone());
    o.craig_bampton = Some((vec!["zz".into()], 1));
    assert!(err(o).contains("cb_masters"));
    // negative or non-finite stiffness / damping parameters
    let mut o = opts(m.clone(), k.clone());
    o.cubic_spring = Some(("b".into(), -1.0));
    assert!(err(o).contains("k3_n_per_m3 = -1"));
    let mut o = opts(m.clone(), k.clone());
    o.damping = MatrixDamping::Rayleigh {
        alpha_per_s: f64::NAN,
        beta_s: 0.0,
    };
    assert!(err(o).contains("rayleigh[0]"));
    let mut o = opts(m.clone(), k.clone());
    o.damping = MatrixDamping::Matrix(DMatrix::from_diagonal_element(3, 3, -0.1));
    o.damping_path = Some(PathBuf::from("C.mtx"));
    let e = err(o);
    assert!(e.contains("damping_mtx") && e.contains("C.mtx"), "{e}");
    let mut o = opts(m, k);
    o.damping = MatrixDamping::StiffnessProportional {
        ratio: 0.01,
        mode_index: 3,
    };
    assert!(err(o).contains("damping_mode"));
}

/// Not a timed test (run with `--ignored --nocapture`): reading a model from
/// Matrix Market text and reducing it by Craig-Bampton to 20 modes with the
/// dense path (nalgebra), on the paper beam with 1001 nodes (2000 DOFs). The
/// issue's 20,000-DOF target needs a sparse path (sparse Cholesky, a sparse
/// eigensolver for the fixed-interface modes), not built yet.
#[test]
#[ignore]
fn measure_read_and_reduce_2000_dofs() {
    use nlmode::structure::BeamSpec;
    let b = BeamSpec {
        n_nodes: 1001,
        ..BeamSpec::paper()
    }
    .assemble()
    .unwrap();
    let (mt, kt) = (
        write_matrix_market(&b.model.mass),
        write_matrix_market(&b.model.stiffness),
    );
    let t0 = std::time::Instant::now();
    let m = read_matrix_market_str(M, Path::new("M.mtx"), &mt).unwrap();
    let k = read_matrix_market_str(MatrixRole::Stiffness, Path::new("K.mtx"), &kt).unwrap();
    let t_read = t0.elapsed().as_secs_f64();
    let tip = b.translation_dof(1000).unwrap();
    let mut o = opts(m, k);
    o.points = vec![("tip".into(), tip)];
    o.cubic_spring = Some(("tip".into(), 6e9));
    o.craig_bampton = Some((vec!["tip".into()], 20));
    let s = matrix_structure(&o).unwrap();
    let t_all = t0.elapsed().as_secs_f64();
    println!(
        "{} DOFs: read {t_read:.3} s, read + checks + modes + Craig-Bampton (20 modes) {t_all:.3} s, omega0 = {:.3} rad/s",
        s.full_ndof,
        s.omega0_rad_s
    );
}
