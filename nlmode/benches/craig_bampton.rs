//! Sparse Craig-Bampton of large FE models (issue 11, performance item): read a
//! 20,000-DOF model from Matrix Market files and reduce it to 20 fixed-interface
//! modes (target: below 2 s), against the dense path at 2,000 DOFs; and the NMA
//! time per continuation point of the reduced models of 2,000 and 20,000 DOFs
//! (the same reduced size: it must not depend on the full size).
//!
//! The model (generated here, written to a temporary directory): a plane frame
//! strip of `nx x 20` cells, steel members of 50 mm (axial and Euler-Bernoulli
//! bending stiffness, lumped mass with rotary inertia), 3 DOFs per node
//! (`u`, `v`, `theta`), clamped along its left edge; the cubic spring and the
//! Craig-Bampton master are the transverse DOF `v` of the middle node of the
//! free edge. `nx = 34`: 2,142 DOFs; `nx = 334`: 21,042 DOFs.
//!
//! `read + reduce` is everything `kind = "matrices"` does up to the reduced
//! model: reading both files, the checks (symmetry, `M` positive definite by
//! sparse Cholesky, `K` positive semi-definite and rigid-body modes from the
//! full model's 7 lowest modes), stiffness-proportional damping on mode 1 and
//! the Craig-Bampton reduction.
//!
//! The dense path is timed once (printed), not by criterion: one run takes
//! about 45 s.
//!
//! Measured (release, shared 2-core machine with other builds running,
//! 2026-12-02):
//!
//! | case | result |
//! |---|---|
//! | sparse, 21,042 DOFs, read + reduce to 20 modes | 0.93 s (criterion; 0.87 s single run; target 2 s) |
//! | sparse, 2,142 DOFs | 0.068 s |
//! | dense, 2,142 DOFs | 45.6 s (dense / sparse 670) |
//! | dense vs sparse at 2,142 DOFs | omega0 1.8e-12, omega of the 20th fixed-interface mode 2e-15 relative |
//! | NMA (H = 5) of the reduced 21-DOF model from 2,142 DOFs | 0.151 ms/point (8 points) |
//! | NMA (H = 5) of the reduced 21-DOF model from 21,042 DOFs | 0.169 ms/point (12 points) |
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::nma::{nonlinear_modal_analysis, AmplitudeRange, ContinuationOptions, NmaOptions};
use nlmode::structure::matrices::{
    matrix_structure, matrix_structure_sparse_cb, read_matrix_market, read_matrix_market_sparse,
    write_matrix_market_sparse, MatrixDamping, MatrixRole, MatrixStructure, MatrixStructureOptions,
};
use nlmode::structure::sparse::sparse_from_triplets;
use nlmode::structure::SparseMatrix;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const NY: usize = 20;
const CELL_M: f64 = 0.05;
const E_PA: f64 = 210e9;
const RHO_KG_M3: f64 = 7850.0;
const AREA_M2: f64 = 1e-4;
const INERTIA_M4: f64 = 1e-9;

/// `M`, `K` of the frame strip with `nx` cells along `x` (module docs) and the
/// master DOF.
fn frame(nx: usize) -> (SparseMatrix, SparseMatrix, usize) {
    // node (ix, iy), ix = 1..=nx free; ix = 0 clamped
    let dof = |ix: usize, iy: usize, d: usize| -> Option<usize> {
        (ix > 0).then(|| ((ix - 1) * (NY + 1) + iy) * 3 + d)
    };
    let n = nx * (NY + 1) * 3;
    let (mut kt, mut mt) = (Vec::new(), Vec::new());
    let l = CELL_M;
    let (ea, ei) = (E_PA * AREA_M2 / l, E_PA * INERTIA_M4 / l.powi(3));
    let kl: [[f64; 6]; 6] = [
        [ea, 0.0, 0.0, -ea, 0.0, 0.0],
        [0.0, 12.0 * ei, 6.0 * ei * l, 0.0, -12.0 * ei, 6.0 * ei * l],
        [
            0.0,
            6.0 * ei * l,
            4.0 * ei * l * l,
            0.0,
            -6.0 * ei * l,
            2.0 * ei * l * l,
        ],
        [-ea, 0.0, 0.0, ea, 0.0, 0.0],
        [
            0.0,
            -12.0 * ei,
            -6.0 * ei * l,
            0.0,
            12.0 * ei,
            -6.0 * ei * l,
        ],
        [
            0.0,
            6.0 * ei * l,
            2.0 * ei * l * l,
            0.0,
            -6.0 * ei * l,
            4.0 * ei * l * l,
        ],
    ];
    let half_mass = RHO_KG_M3 * AREA_M2 * l / 2.0;
    let mut element = |a: (usize, usize), b: (usize, usize), c: f64, s: f64| {
        // global = T^T local T, T = diag(R, R), R = [[c, s, 0], [-s, c, 0], [0, 0, 1]]
        let r = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
        let t = |i: usize, j: usize| {
            if i / 3 == j / 3 {
                r[i % 3][j % 3]
            } else {
                0.0
            }
        };
        let mut kg = [[0.0; 6]; 6];
        for (i, row) in kg.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                for (p, klp) in kl.iter().enumerate() {
                    for (q, klpq) in klp.iter().enumerate() {
                        *v += t(p, i) * klpq * t(q, j);
                    }
                }
            }
        }
        let dofs: Vec<Option<usize>> = (0..6)
            .map(|i| {
                let (ix, iy) = if i < 3 { a } else { b };
                dof(ix, iy, i % 3)
            })
            .collect();
        for i in 0..6 {
            for j in 0..6 {
                if let (Some(p), Some(q)) = (dofs[i], dofs[j]) {
                    kt.push((p, q, kg[i][j]));
                }
            }
            if let Some(p) = dofs[i] {
                let m = if i % 3 == 2 {
                    half_mass * l * l / 12.0
                } else {
                    half_mass
                };
                mt.push((p, p, m));
            }
        }
    };
    for ix in 0..=nx {
        for iy in 0..=NY {
            if ix < nx {
                element((ix, iy), (ix + 1, iy), 1.0, 0.0);
            }
            if iy < NY {
                element((ix, iy), (ix, iy + 1), 0.0, 1.0);
            }
        }
    }
    let k = sparse_from_triplets(n, &kt).expect("frame stiffness");
    let m = sparse_from_triplets(n, &mt).expect("frame mass");
    (m, k, dof(nx, NY / 2, 1).expect("free edge"))
}

struct Files {
    dir: PathBuf,
    master: usize,
    ndof: usize,
}

fn write_frame(nx: usize) -> Files {
    let dir = std::env::temp_dir().join(format!("nlmode-cb-bench-{nx}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (m, k, master) = frame(nx);
    std::fs::write(dir.join("M.mtx"), write_matrix_market_sparse(&m)).expect("M.mtx");
    std::fs::write(dir.join("K.mtx"), write_matrix_market_sparse(&k)).expect("K.mtx");
    Files {
        dir,
        master,
        ndof: m.nrows(),
    }
}

fn options<A>(mass: A, stiffness: A, dir: &Path, master: usize) -> MatrixStructureOptions<A> {
    MatrixStructureOptions {
        mass,
        mass_path: dir.join("M.mtx"),
        stiffness,
        stiffness_path: dir.join("K.mtx"),
        damping: MatrixDamping::StiffnessProportional {
            ratio: 0.004,
            mode_index: 0,
        },
        damping_path: None,
        points: vec![("tip".into(), master)],
        cubic_spring: Some(("tip".into(), 1e12)),
        craig_bampton: Some((vec!["tip".into()], 20)),
        allow_rigid_body_modes: false,
    }
}

fn read_and_reduce_sparse(f: &Files) -> MatrixStructure {
    let m = read_matrix_market_sparse(MatrixRole::Mass, &f.dir.join("M.mtx")).expect("M");
    let k = read_matrix_market_sparse(MatrixRole::Stiffness, &f.dir.join("K.mtx")).expect("K");
    matrix_structure_sparse_cb(&options(m, k, &f.dir, f.master)).expect("sparse path")
}

fn read_and_reduce_dense(f: &Files) -> MatrixStructure {
    let m = read_matrix_market(MatrixRole::Mass, &f.dir.join("M.mtx")).expect("M");
    let k = read_matrix_market(MatrixRole::Stiffness, &f.dir.join("K.mtx")).expect("K");
    matrix_structure(&options(m, k, &f.dir, f.master)).expect("dense path")
}

fn time<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let r = f();
    (r, t.elapsed().as_secs_f64())
}

/// NMA of the reduced model (H = 5, `log10 a` = -5 .. -2.5): time per point.
fn nma_per_point(ms: &MatrixStructure) -> (usize, f64) {
    let opts = NmaOptions {
        harmonics: 5,
        amplitude: AmplitudeRange::Modal {
            log10_start: -5.0,
            log10_end: -2.5,
        },
        continuation: ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        },
        store_coordinates: false,
        ..Default::default()
    };
    let (r, t) = time(|| nonlinear_modal_analysis(&ms.model, &opts).expect("NMA"));
    (r.n_points(), 1e3 * t / r.n_points() as f64)
}

fn bench(c: &mut Criterion) {
    let (small, large) = (write_frame(34), write_frame(334));
    let (ds, t_dense) = time(|| read_and_reduce_dense(&small));
    let (ss, t_sparse_small) = time(|| read_and_reduce_sparse(&small));
    let (sl, t_sparse_large) = time(|| read_and_reduce_sparse(&large));
    eprintln!(
        "read + reduce to 20 modes: dense {} DOFs {:.3} s, sparse {} DOFs {:.3} s (dense / sparse {:.1}), sparse {} DOFs {:.3} s (target 2 s)",
        small.ndof,
        t_dense,
        small.ndof,
        t_sparse_small,
        t_dense / t_sparse_small,
        large.ndof,
        t_sparse_large
    );
    let rel = |a: f64, b: f64| (a - b).abs() / b;
    eprintln!(
        "{} DOFs: omega0 {:.6} rad/s, dense vs sparse omega0 {:.1e}, interface omega_20 {:.1e}; {} DOFs: omega0 {:.6} rad/s",
        small.ndof,
        ss.omega0_rad_s,
        rel(ss.omega0_rad_s, ds.omega0_rad_s),
        rel(ss.interface_omega_rad_s[19], ds.interface_omega_rad_s[19]),
        large.ndof,
        sl.omega0_rad_s
    );
    for (label, ms) in [("2k", &ss), ("20k", &sl)] {
        let (points, ms_per_point) = nma_per_point(ms);
        eprintln!(
            "NMA of the reduced {label} model ({} DOFs from {}): {points} points, {ms_per_point:.3} ms/point",
            ms.model.ndof(),
            ms.full_ndof
        );
    }
    let mut group = c.benchmark_group("craig_bampton");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    group.bench_function("sparse_read_reduce_20k", |b| {
        b.iter(|| read_and_reduce_sparse(&large))
    });
    group.finish();
    let _ = std::fs::remove_dir_all(&small.dir);
    let _ = std::fs::remove_dir_all(&large.dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
