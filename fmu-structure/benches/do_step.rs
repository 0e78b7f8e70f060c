//! Time per DoStep of the structure model at the co-simulation macro step
//! (1e-5 s) and at 1e-3 s, on a table shaped like the paper's beam mode
//! (omega0 = 356.2 rad/s, hardening to 2 omega0, 100 amplitude points, H = 13),
//! driven near resonance. Through the `CoSimModel` interface, i.e. without the
//! few nanoseconds of the C entry point (state check, catch_unwind).
//! `macro step` is what an extrapolating Jacobi master asks per step at
//! 1e-5 s: set `F`, get `x`, `v`, `x_tip`, get `dx/dt`, `dv/dt`, set `dF/dt`, DoStep.
use criterion::{criterion_group, criterion_main, Criterion};
use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use nlmode::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
use structure::{vr, Structure};

fn paper_like_table() -> ModalTable {
    let (n, h) = (100, 13);
    let w0: f64 = 356.2;
    let amplitude: Vec<f64> = (0..n).map(|j| 1e-4 * 1.07f64.powi(j)).collect();
    let a_max = *amplitude.last().unwrap();
    let c = 3.0 * w0 * w0 / (a_max * a_max);
    let shape = |name: &str, phi: f64| PointShape {
        name: name.into(),
        re: amplitude
            .iter()
            .map(|a| {
                (0..=h)
                    .map(|k| {
                        if k == 1 {
                            phi
                        } else {
                            1e-3 * a / (k as f64 + 1.0)
                        }
                    })
                    .collect()
            })
            .collect(),
        im: amplitude
            .iter()
            .map(|a| {
                (0..=h)
                    .map(|k| if k == 1 { 0.0 } else { 1e-4 * a })
                    .collect()
            })
            .collect(),
    };
    ModalTable {
        format: MODAL_TABLE_FORMAT.into(),
        version: MODAL_TABLE_VERSION,
        description: "bench".into(),
        harmonics: h,
        omega_rad_s: amplitude
            .iter()
            .map(|a| (w0 * w0 + c * a * a).sqrt())
            .collect(),
        damping_ratio: amplitude
            .iter()
            .map(|a| 0.004 * w0 / (w0 * w0 + c * a * a).sqrt())
            .collect(),
        points: vec![shape("tip", 1.43), shape("l3", 0.32), shape("2l3", 1.04)],
        amplitude,
        coordinates: vec![],
        truncated_at_fold: None,
        accuracy: None,
        linear_modes: None,
    }
}

/// A structure instance with the table in `dir`, past initialization.
fn initialized(dir: &std::path::Path, log: &Logger) -> Structure {
    let mut m = Structure::instantiate(&InstantiateContext {
        instance_name: "b",
        resource_dir: Some(dir.to_path_buf()),
        logger: log,
    })
    .unwrap();
    m.exit_initialization_mode(log).unwrap();
    m
}

fn bench(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("structure-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    paper_like_table()
        .write(&dir.join("modal_table.json"))
        .unwrap();
    let log = Logger::silent();
    for h in [1e-5, 1e-3] {
        let mut m = initialized(&dir, &log);
        let mut t: f64 = 0.0;
        c.bench_function(&format!("structure DoStep h = {h:e} s"), |b| {
            b.iter(|| {
                m.set_real(vr::F, 2.0 * (356.2 * t).cos()).unwrap();
                m.do_step(t, h, &log).unwrap();
                t += h;
                m.get_real(vr::X)
            })
        });
    }
    let h = 1e-5;
    let mut m = initialized(&dir, &log);
    let mut t: f64 = 0.0;
    c.bench_function(
        "structure macro step with output derivatives h = 1e-5 s",
        |b| {
            b.iter(|| {
                m.set_real(vr::F, 2.0 * (356.2 * t).cos()).unwrap();
                let y = m.get_real(vr::X) + m.get_real(vr::V) + m.get_real(vr::X_TIP);
                let dx = m.get_real_output_derivative(vr::X, 1).unwrap();
                let dv = m.get_real_output_derivative(vr::V, 1).unwrap();
                m.set_real_input_derivative(vr::F, 1, -2.0 * 356.2 * (356.2 * t).sin())
                    .unwrap();
                m.do_step(t, h, &log).unwrap();
                t += h;
                y + dx + dv
            })
        },
    );
    std::fs::remove_dir_all(&dir).ok();
}

criterion_group!(benches, bench);
criterion_main!(benches);
