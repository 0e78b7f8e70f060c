//! Tests of `nlmode::frf` (method `linear-frf`): hand-derived closed forms on
//! small models, `eq:fhfhNull` / `eq:forcedrop`, the measured-force drive-point
//! FRF, bad input, and (with the paper's beam) the force drop at resonance.
use nalgebra::{DMatrix, DVector};
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::frf::{
    assembled_frf, force_drop_closed_form, force_ratio_closed_form, linear_force_drop, mass_ratio,
    modal_mass, structure_receptance, FrfError,
};
use nlmode::structure::{
    modal_analysis, paper_structure, NamedPoint, PaperStructureOptions, StructuralModel,
};
use nlmode::Complex64;

fn c(re: f64) -> Complex64 {
    Complex64::new(re, 0.0)
}

fn unit(n: usize, i: usize) -> DVector<f64> {
    let mut v = DVector::zeros(n);
    v[i] = 1.0;
    v
}

/// 2-DOF chain: m1 = 1 kg, m2 = 2 kg; ground-1 spring 2e5, 1-2 spring 1e5;
/// dashpots 2 and 1 N s/m in parallel. Points `p1` (DOF 1), `p2` (DOF 2).
fn chain2() -> StructuralModel {
    StructuralModel {
        mass: DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 2.0]),
        stiffness: DMatrix::from_row_slice(2, 2, &[3e5, -1e5, -1e5, 1e5]),
        damping: DMatrix::from_row_slice(2, 2, &[3.0, -1.0, -1.0, 1.0]),
        nonlinear: vec![],
        points: vec![
            NamedPoint {
                name: "p1".into(),
                direction: unit(2, 0),
            },
            NamedPoint {
                name: "p2".into(),
                direction: unit(2, 1),
            },
        ],
    }
}

/// A tuned-mass damper (mass m on spring k and dashpot d to the interface point).
fn tmd(point: &str, m: f64, k: f64, d: f64) -> LinearAttachment {
    LinearAttachment::tuned_mass_damper("tmd", point, m, k, d).unwrap()
}

/// Solves the 2 x 2 system by Cramer's rule.
fn cramer(d: [[Complex64; 2]; 2], r: [Complex64; 2]) -> [Complex64; 2] {
    let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
    [
        (r[0] * d[1][1] - d[0][1] * r[1]) / det,
        (d[0][0] * r[1] - d[1][0] * r[0]) / det,
    ]
}

fn close(a: Complex64, b: Complex64, tol: f64) -> bool {
    (a - b).norm() <= tol * b.norm().max(1e-300)
}

#[test]
fn two_attachments_on_two_dofs_match_hand_derived_closed_form() {
    let model = chain2();
    let sp = ShakerParams::paper();
    let (mt, kt, dt) = (0.2, 3e4, 4.0);
    // Case A: shaker (elastic stinger) at p1 with 7 V, TMD at p2.
    // Case B: shaker at p1 with 7 V, rigid-stinger shaker at p2 with 2i V.
    let rigid = sp.with_rigid_stinger();
    let omegas: Vec<f64> = vec![0.0, 50.0, 250.0, 316.0, 400.0, 694.0, 2000.0];
    let u1 = c(7.0);
    let u2 = Complex64::new(0.0, 2.0);
    let case_a = assembled_frf(
        &model,
        &[
            LinearAttachment::shaker("s1", &sp, "p1").unwrap(),
            tmd("p2", mt, kt, dt),
        ],
        &[DVector::from_element(1, u1), DVector::zeros(0)],
        &omegas,
    )
    .unwrap();
    let case_b = assembled_frf(
        &model,
        &[
            LinearAttachment::shaker("s1", &sp, "p1").unwrap(),
            LinearAttachment::shaker("s2", &rigid, "p2").unwrap(),
        ],
        &[DVector::from_element(1, u1), DVector::from_element(1, u2)],
        &omegas,
    )
    .unwrap();
    for (i, &w) in omegas.iter().enumerate() {
        // Structure dynamic stiffness by hand.
        let d11 = Complex64::new(3e5 - w * w * 1.0, 3.0 * w);
        let d12 = Complex64::new(-1e5, -w);
        let d22 = Complex64::new(1e5 - w * w * 2.0, 1.0 * w);
        let z1 = sp.closed_form_interface_impedance(w);
        let t1 = sp.closed_form_blocked_force(w, u1);
        // TMD impedance: -W^2 m (k + i W d)/(k + i W d - W^2 m).
        let kd = Complex64::new(kt, w * dt);
        let zt = -w * w * mt * kd / (kd - w * w * mt);
        let q = cramer([[d11 + z1, d12], [d12, d22 + zt]], [t1, c(0.0)]);
        let f1 = t1 - z1 * q[0];
        let ft = -zt * q[1];
        let p = &case_a[i];
        assert_eq!(p.omega_rad_s, w);
        assert_eq!((p.force_n.len(), p.points.len()), (2, 2));
        assert!(
            close(p.points[0], q[0], 1e-9),
            "{w}: {} vs {}",
            p.points[0],
            q[0]
        );
        assert!(
            close(p.points[1], q[1], 1e-9),
            "{w}: {} vs {}",
            p.points[1],
            q[1]
        );
        assert!(
            close(p.force_n[0], f1, 1e-9),
            "{w}: {} vs {f1}",
            p.force_n[0]
        );
        if w > 0.0 {
            assert!(
                close(p.force_n[1], ft, 1e-9),
                "{w}: {} vs {ft}",
                p.force_n[1]
            );
        } else {
            assert!(p.force_n[1].norm() < 1e-12);
        }
        // Case B.
        let z2 = rigid.closed_form_interface_impedance(w);
        let t2 = rigid.closed_form_blocked_force(w, u2);
        let q = cramer([[d11 + z1, d12], [d12, d22 + z2]], [t1, t2]);
        let p = &case_b[i];
        assert!(close(p.points[0], q[0], 1e-9));
        assert!(close(p.points[1], q[1], 1e-9));
        assert!(close(p.force_n[0], t1 - z1 * q[0], 1e-9));
        assert!(close(p.force_n[1], t2 - z2 * q[1], 1e-9));
    }
}

#[test]
fn measured_force_drive_point_frf_is_the_structures_own() {
    // With one attachment the drive-point response over the measured force is
    // the receptance of the structure alone, whatever the shaker does.
    let model = chain2();
    let omegas: Vec<f64> = (1..200).map(|i| i as f64 * 5.0).collect();
    for point in ["p1", "p2"] {
        let att = LinearAttachment::shaker("s", &ShakerParams::paper(), point).unwrap();
        let frf =
            assembled_frf(&model, &[att], &[DVector::from_element(1, c(3.0))], &omegas).unwrap();
        let h = structure_receptance(&model, point, point, &omegas).unwrap();
        let h_cross = structure_receptance(&model, point, "p2", &omegas).unwrap();
        let idx = if point == "p1" { 0 } else { 1 };
        for (p, (hd, hc)) in frf.iter().zip(h.iter().zip(&h_cross)) {
            assert!(close(p.points[idx] / p.force_n[0], *hd, 1e-9));
            assert!(close(p.points[1] / p.force_n[0], *hc, 1e-9));
        }
    }
    // Receptance by hand at one frequency: H11 = D22/det.
    let w = 123.0;
    let h = structure_receptance(&model, "p1", "p1", &[w]).unwrap()[0];
    let d11 = Complex64::new(3e5 - w * w, 3.0 * w);
    let d12 = Complex64::new(-1e5, -w);
    let d22 = Complex64::new(1e5 - 2.0 * w * w, w);
    assert!(close(h, d22 / (d11 * d22 - d12 * d12), 1e-12));
}

#[test]
fn single_dof_with_rigid_ideal_shaker_is_eq_fhfhnull() {
    // 1-DOF structure m, k, c: phi_ex = 1/sqrt(m), single mode exact. A rigid
    // stinger and a negligible inductance (omega_c -> infinity) are exactly the
    // assumptions of eq:fhfhNull.
    let (m, k): (f64, f64) = (2.5, 4e5);
    let omega0 = (k / m).sqrt();
    let d0 = 0.004;
    let model = StructuralModel {
        mass: DMatrix::from_element(1, 1, m),
        stiffness: DMatrix::from_element(1, 1, k),
        damping: DMatrix::from_element(1, 1, 2.0 * d0 * omega0 * m),
        nonlinear: vec![],
        points: vec![NamedPoint {
            name: "x".into(),
            direction: unit(1, 0),
        }],
    };
    let mut sp = ShakerParams::paper().with_rigid_stinger();
    sp.inductance_h = 1e-15;
    let mu = mass_ratio(sp.armature_mass_kg, modal_mass(1.0 / m.sqrt()));
    assert!((mu - 0.043 / 2.5).abs() < 1e-15);
    let ra = sp.omega_a() / omega0;
    let etas: Vec<f64> = (1..=40).map(|i| 0.05 * i as f64).collect();
    let omegas: Vec<f64> = etas.iter().map(|e| e * omega0).collect();
    let u = c(10.0);
    let frf = assembled_frf(
        &model,
        &[LinearAttachment::shaker("s", &sp, "x").unwrap()],
        &[DVector::from_element(1, u)],
        &omegas,
    )
    .unwrap();
    let f0 = sp.force_constant_n_per_a * 10.0 / sp.resistance_ohm;
    for (p, &eta) in frf.iter().zip(&etas) {
        let cf = force_ratio_closed_form(eta, d0, mu, ra, 1.36);
        assert!(
            close(p.force_n[0] / f0, cf, 1e-9),
            "eta {eta}: {} vs {cf}",
            p.force_n[0] / f0
        );
    }
    // eq:forcedrop is |eq:fhfhNull| at eta = 1.
    let fd = force_drop_closed_form(d0, mu, ra, 1.36);
    assert!((fd - force_ratio_closed_form(1.0, d0, mu, ra, 1.36).norm()).abs() < 1e-14);
    let drop = linear_force_drop(&model, &sp, "x", omega0).unwrap();
    assert!((1.0 - drop - fd).abs() < 1e-9);
    // The paper's shaker (elastic stinger, real L) is close but not identical.
    let drop_real = linear_force_drop(&model, &ShakerParams::paper(), "x", omega0).unwrap();
    assert!(
        (drop_real - drop).abs() < 0.01 && (drop_real - drop).abs() > 1e-6,
        "{drop_real} {drop}"
    );
}

#[test]
fn closed_forms_hand_computed() {
    // mu = 5 %, omega_a/omega0 = 2, D_a = 1.36, D0 = 0.4 %:
    // 2 D0 / sqrt(mu^2 (4 - 1)^2 + 4 (D0 + 2 mu D_a)^2) = 0.008 / sqrt(0.0225 + 0.0784).
    let fd = force_drop_closed_form(0.004, 0.05, 2.0, 1.36);
    assert!((fd - 0.008 / 0.1009f64.sqrt()).abs() < 1e-15, "{fd}");
    assert!((fd - 0.025185).abs() < 1e-6);
    // No exciter: no force drop, ratio 1 everywhere.
    assert!((force_drop_closed_form(0.004, 0.0, 2.0, 1.36) - 1.0).abs() < 1e-15);
    assert!((force_ratio_closed_form(0.7, 0.004, 0.0, 2.0, 1.36) - c(1.0)).norm() < 1e-15);
    // Static limit eta = 0: 1 / (1 + mu (omega_a/omega0)^2).
    assert!((force_ratio_closed_form(0.0, 0.004, 0.05, 2.0, 1.36) - c(1.0 / 1.2)).norm() < 1e-15);
    // High-frequency limit: 1/(1 + mu).
    let hf = force_ratio_closed_form(1e6, 0.004, 0.05, 2.0, 1.36);
    assert!((hf - c(1.0 / 1.05)).norm() < 1e-6);
    assert!((modal_mass(Complex64::new(0.6, 0.8) * 0.5) - 4.0).abs() < 1e-14);
    assert!((mass_ratio(0.043, 0.92) - 0.046739).abs() < 1e-6);
}

#[test]
fn bad_frf_inputs_are_rejected() {
    let model = chain2();
    let att = LinearAttachment::shaker("s", &ShakerParams::paper(), "p1").unwrap();
    assert_eq!(
        assembled_frf(&model, std::slice::from_ref(&att), &[], &[1.0]).unwrap_err(),
        FrfError::AttachmentInputs {
            expected: 1,
            found: 0
        }
    );
    assert!(matches!(
        assembled_frf(
            &model,
            std::slice::from_ref(&att),
            &[DVector::zeros(3)],
            &[1.0]
        ),
        Err(FrfError::Attachment(
            nlmode::attachment::AttachmentError::InputCount {
                expected: 1,
                found: 3,
                ..
            }
        ))
    ));
    assert!(matches!(
        assembled_frf(
            &model,
            std::slice::from_ref(&att),
            &[DVector::from_element(1, c(1.0))],
            &[1.0, f64::NAN]
        ),
        Err(FrfError::NonFiniteOmega { .. })
    ));
    let mut away = att.clone();
    away.interface_points = vec!["elsewhere".into()];
    assert!(matches!(
        assembled_frf(&model, &[away], &[DVector::from_element(1, c(1.0))], &[1.0]),
        Err(FrfError::Attachment(
            nlmode::attachment::AttachmentError::UnknownPoint { .. }
        ))
    ));
    assert!(matches!(
        structure_receptance(&model, "p1", "nope", &[1.0]),
        Err(FrfError::UnknownPoint { .. })
    ));
    // Undamped 1-DOF at its resonance, no attachment: singular.
    let undamped = StructuralModel {
        mass: DMatrix::from_element(1, 1, 1.0),
        stiffness: DMatrix::from_element(1, 1, 4.0),
        damping: DMatrix::zeros(1, 1),
        nonlinear: vec![],
        points: vec![],
    };
    assert_eq!(
        assembled_frf(&undamped, &[], &[], &[2.0]).unwrap_err(),
        FrfError::SingularDynamicStiffness { omega_rad_s: 2.0 }
    );
}

/// Timing (not a pass/fail performance test): `cargo test --release -p nlmode
/// --test it -- --ignored --nocapture frf::frf_timing`.
#[test]
#[ignore]
fn frf_timing() {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let model = ps.model;
    assert_eq!(model.mass.nrows(), 11);
    let att = LinearAttachment::shaker("s", &ShakerParams::paper(), "2l3").unwrap();
    let omegas: Vec<f64> = (0..500).map(|i| 200.0 + i as f64).collect();
    let u = [DVector::from_element(1, c(10.0))];
    let atts = [att];
    let n = 50;
    let t = std::time::Instant::now();
    for _ in 0..n {
        let r = assembled_frf(&model, &atts, &u, &omegas).unwrap();
        assert_eq!(r.len(), 500);
    }
    let dt = t.elapsed().as_secs_f64() / n as f64;
    println!(
        "assembled_frf: 500 frequencies, 11 DOF, 1 shaker: {:.3} ms",
        dt * 1e3
    );
}

/// The paper's beam (Craig-Bampton, 11 DOFs): force drop at resonance from the
/// assembled FRF against eq:forcedrop with mu from the modal mass `1/phi_ex^2`.
#[test]
fn paper_beam_force_drop_matches_eq_forcedrop() {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let model = &ps.model;
    let modes = modal_analysis(model, 1).unwrap();
    let omega0 = modes.omega_rad_s[0];
    assert!(
        (omega0 / ps.omega0_rad_s - 1.0).abs() < 1e-3,
        "{omega0} vs {}",
        ps.omega0_rad_s
    );
    // Modal damping ratio of mode 1 of the reduced model: phi^T C phi = 2 D0 omega0.
    let phi = modes.shape(0);
    let d0 = (phi.transpose() * &model.damping * &phi)[(0, 0)] / (2.0 * omega0);
    assert!((d0 - 0.004).abs() < 1e-5, "D0 = {d0}");
    let sp = ShakerParams::paper();
    let ra = sp.omega_a() / omega0;
    let mut results = vec![];
    for (point, mmod_expected, drop_expected) in [("2l3", 0.92, 0.97), ("l3", 10.0, 0.765)] {
        let e = &model
            .points
            .iter()
            .find(|p| p.name == point)
            .unwrap()
            .direction;
        let mmod = modal_mass(modes.deflection(0, e));
        let mu = mass_ratio(sp.armature_mass_kg, mmod);
        assert!(
            (mmod / mmod_expected - 1.0).abs() < 0.03,
            "{point}: m_mod = {mmod}"
        );
        let closed = 1.0 - force_drop_closed_form(d0, mu, ra, sp.damping_ratio());
        let assembled = linear_force_drop(model, &sp, point, omega0).unwrap();
        results.push((point, mmod, mu, closed, assembled));
        assert!(
            (assembled - closed).abs() < 0.01,
            "{point}: FRF {assembled} vs eq:forcedrop {closed}"
        );
        assert!(
            (assembled - drop_expected).abs() < 0.012,
            "{point}: {assembled}"
        );
        // Drive-point and tip FRF with the measured force are the structure's own.
        let omegas: Vec<f64> = (0..=60).map(|i| omega0 * (0.7 + 0.01 * i as f64)).collect();
        let att = LinearAttachment::shaker("s", &sp, point).unwrap();
        let frf =
            assembled_frf(model, &[att], &[DVector::from_element(1, c(10.0))], &omegas).unwrap();
        let ip = model.points.iter().position(|p| p.name == point).unwrap();
        let it = model.points.iter().position(|p| p.name == "tip").unwrap();
        let h = structure_receptance(model, point, point, &omegas).unwrap();
        let h_tip = structure_receptance(model, point, "tip", &omegas).unwrap();
        for (p, (hd, ht)) in frf.iter().zip(h.iter().zip(&h_tip)) {
            assert!(close(p.points[ip] / p.force_n[0], *hd, 1e-8));
            assert!(close(p.points[it] / p.force_n[0], *ht, 1e-8));
        }
        // The force minimum of the FRF lies at the structural resonance (within 1 %).
        let imin = (0..frf.len())
            .min_by(|&a, &b| {
                frf[a].force_n[0]
                    .norm()
                    .total_cmp(&frf[b].force_n[0].norm())
            })
            .unwrap();
        assert!(
            (frf[imin].omega_rad_s / omega0 - 1.0).abs() <= 0.011,
            "{}",
            frf[imin].omega_rad_s / omega0
        );
    }
    for (point, mmod, mu, closed, assembled) in results {
        println!("{point}: m_mod = {mmod:.4} kg, mu = {:.3} %, force drop eq:forcedrop = {:.2} %, assembled FRF = {:.2} %",
            mu * 100.0, closed * 100.0, assembled * 100.0);
    }
}

#[test]
#[ignore]
fn frf_timing_parts() {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let model = ps.model;
    let omegas: Vec<f64> = (0..500).map(|i| 200.0 + i as f64).collect();
    let n = 50;
    let t = std::time::Instant::now();
    for _ in 0..n {
        assembled_frf(&model, &[], &[], &omegas).unwrap();
    }
    println!(
        "no attachment: {:.3} ms",
        t.elapsed().as_secs_f64() / n as f64 * 1e3
    );
    let cd = nlmode::attachment::Condenser::new(
        &LinearAttachment::shaker("s", &ShakerParams::paper(), "2l3").unwrap(),
    )
    .unwrap();
    let t = std::time::Instant::now();
    for _ in 0..n {
        for &w in &omegas {
            cd.condense(w).unwrap();
        }
    }
    println!(
        "condense only: {:.3} ms",
        t.elapsed().as_secs_f64() / n as f64 * 1e3
    );
}
