//! Tests of `nlmode::attachment`: localization (`eq:L1L2`), impedance and
//! condensation (`eq:fc1`) against the closed forms of the paper's Section 4,
//! generic attachments with hand-derived impedances, and bad input.
use nalgebra::{DMatrix, DVector};
use nlmode::attachment::{
    condensed_sum, ArmatureDamping, AttachmentError, LinearAttachment, ShakerParams, Stinger,
};
use nlmode::structure::{NamedPoint, StructuralModel};
use nlmode::Complex64;

/// A 2-DOF chain with two named points; `drive` is a non-unit mixture to make
/// sure `E` enters as given.
fn two_dof() -> StructuralModel {
    StructuralModel {
        mass: DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 2.0]),
        stiffness: DMatrix::from_row_slice(2, 2, &[3e5, -1e5, -1e5, 1e5]),
        damping: DMatrix::from_row_slice(2, 2, &[3.0, -1.0, -1.0, 1.0]),
        nonlinear: vec![],
        points: vec![
            NamedPoint {
                name: "drive".into(),
                direction: DVector::from_vec(vec![0.6, 0.8]),
            },
            NamedPoint {
                name: "tip".into(),
                direction: DVector::from_vec(vec![0.0, 1.0]),
            },
        ],
    }
}

fn rel_err(a: &DMatrix<Complex64>, b: &DMatrix<Complex64>) -> f64 {
    (a - b).norm() / b.norm().max(f64::MIN_POSITIVE)
}

fn c(re: f64) -> Complex64 {
    Complex64::new(re, 0.0)
}

const OMEGAS: [f64; 7] = [0.0, 10.0, 346.0, 356.2, 693.8, 5000.0, 1e5];

#[test]
fn shaker_localization_spans_paper_spaces() {
    let model = two_dof();
    for params in [
        ShakerParams::paper(),
        ShakerParams::paper().with_rigid_stinger(),
    ] {
        let att = LinearAttachment::shaker("shaker", &params, "drive").unwrap();
        let n = att.ndim();
        let e = att.interface_vectors(&model).unwrap();
        let l1 = att.l1(&model).unwrap();
        let l2 = att.l2().unwrap();
        let b1 = att.b1(&model).unwrap();
        // Paper: L1 = [0; 0; 1] e^T (last state is the interface displacement).
        let mut l1_paper = DMatrix::<f64>::zeros(n, 2);
        l1_paper.row_mut(n - 1).copy_from(&e.transpose());
        assert!((&l1 - &l1_paper).norm() < 1e-14, "L1 = {l1}");
        // Paper: L2 = [I; 0]; same column space <=> same orthogonal projector.
        let mut l2_paper = DMatrix::<f64>::zeros(n, n - 1);
        l2_paper
            .view_mut((0, 0), (n - 1, n - 1))
            .fill_with_identity();
        let proj = &l2 * l2.transpose();
        let proj_paper = &l2_paper * l2_paper.transpose();
        assert!((proj - proj_paper).norm() < 1e-14);
        assert_eq!(l2.ncols(), n - 1);
        // Orthonormal.
        assert!((l2.transpose() * &l2 - DMatrix::identity(n - 1, n - 1)).norm() < 1e-14);
        // B L = 0.
        assert!((&b1 + &att.b2 * &l1).norm() < 1e-12);
        assert!((&att.b2 * &l2).norm() < 1e-12);
    }
}

#[test]
fn generic_localization_for_a_non_boolean_b2() {
    // B2 with mixed entries, 2 constraints on 4 states.
    let b2 = DMatrix::from_row_slice(2, 4, &[1.0, 2.0, 0.0, -1.0, 0.0, 1.0, 3.0, 0.5]);
    let att = LinearAttachment {
        name: "generic".into(),
        coefficients: vec![DMatrix::identity(4, 4)],
        b2: b2.clone(),
        interface_points: vec!["drive".into(), "tip".into()],
        input_map: DMatrix::zeros(4, 0),
        state_names: (0..4).map(|i| format!("x{i}")).collect(),
        input_names: vec![],
    };
    let model = two_dof();
    let l1 = att.l1(&model).unwrap();
    let l2 = att.l2().unwrap();
    let b1 = att.b1(&model).unwrap();
    assert_eq!(l2.shape(), (4, 2));
    assert!((&b1 + &b2 * &l1).norm() < 1e-12);
    assert!((&b2 * &l2).norm() < 1e-12);
    assert!((l2.transpose() * &l2 - DMatrix::identity(2, 2)).norm() < 1e-12);
    // L1 is the minimum-norm solution: its columns are orthogonal to null(B2).
    assert!((l2.transpose() * &l1).norm() < 1e-12);
    // pinv(B2) from the SVD agrees with the right inverse B2^T (B2 B2^T)^{-1}.
    let loc = att.localization().unwrap();
    let right_inv = b2.transpose() * (&b2 * b2.transpose()).try_inverse().unwrap();
    assert!((&loc.pinv_b2 - right_inv).norm() < 1e-12);
}

#[test]
fn shaker_condensation_equals_closed_form() {
    let model = two_dof();
    let e = DMatrix::from_column_slice(2, 1, &[c(0.6), c(0.8)]);
    for params in [
        ShakerParams::paper(),
        ShakerParams::paper().with_rigid_stinger(),
    ] {
        let att = LinearAttachment::shaker("shaker", &params, "drive").unwrap();
        for &w in &OMEGAS {
            let zg_cf = params.closed_form_interface_impedance(w);
            let tg_cf = params.closed_form_blocked_force(w, c(1.0));
            let zg = att.interface_impedance(w).unwrap();
            let tg = att.interface_input_force(w).unwrap();
            assert!(
                (zg[(0, 0)] - zg_cf).norm() < 1e-10 * zg_cf.norm(),
                "{w}: {} vs {zg_cf}",
                zg[(0, 0)]
            );
            assert!(
                (tg[(0, 0)] - tg_cf).norm() < 1e-10 * tg_cf.norm(),
                "{w}: {} vs {tg_cf}",
                tg[(0, 0)]
            );
            let (zq, fmap) = att.condensed(&model, w).unwrap();
            let zq_cf = &e * e.transpose() * zg_cf;
            assert!(rel_err(&zq, &zq_cf) < 1e-10);
            assert!(rel_err(&fmap, &(&e * tg_cf)) < 1e-10);
            // The full-size blocks of eq:fc1 give the same Z_q (paper's formula verbatim).
            let blk = att.impedance_blocks(&model, w).unwrap();
            let z22inv = blk.z22.clone().try_inverse().unwrap();
            let zq_blocks = &blk.z11 - &blk.z12 * &z22inv * &blk.z21;
            assert!(rel_err(&zq_blocks, &zq_cf) < 1e-10);
        }
    }
}

#[test]
fn shaker_closed_forms_against_independent_numbers() {
    let p = ShakerParams::paper();
    // Static: z_a(0) = k_a, series with k_s.
    let ks = 2.6e7;
    let z0 = p.closed_form_interface_impedance(0.0);
    assert!((z0 - c(ks * 2.07e4 / (ks + 2.07e4))).norm() < 1e-9 * z0.norm());
    // Static blocked force: G u / R scaled by k_s/(k_a + k_s).
    let f0 = p.closed_form_blocked_force(0.0, c(10.0));
    assert!((f0 - c(15.5 * 10.0 / 3.0 * ks / (ks + 2.07e4))).norm() < 1e-12 * f0.norm());
    // Electro-mechanical damping at low frequency: Im z_a / W -> d_a + G^2/R.
    let w = 1e-3;
    let za = p.armature_impedance(w);
    assert!((za.im / w - 2.0 * 1.36 * (2.07e4f64 * 0.043).sqrt()).abs() < 1e-6);
    // omega_c / omega0 = 62 with the paper's omega0 = 346 rad/s.
    assert!((p.omega_c() / 346.0 - 62.0).abs() < 0.5);
    assert!((p.omega_a() - (2.07e4f64 / 0.043).sqrt()).abs() < 1e-12);
    assert!((p.damping_ratio() - 1.36).abs() < 1e-12);
    assert!((p.d_a() - 1.0672).abs() < 1e-3, "{}", p.d_a());
}

#[test]
fn state_space_matches_condensation() {
    let p = ShakerParams::paper();
    let ss = p.state_space().unwrap();
    let att = LinearAttachment::shaker("shaker", &p, "drive").unwrap();
    for &w in &OMEGAS {
        let h = ss.transfer(w).unwrap();
        let cond = att.interface_condensation(w).unwrap();
        // F = T_G u - Z_G x.
        let tg = cond.t_g[(0, 0)];
        let zg = cond.z_g[(0, 0)];
        assert!(
            (h[(0, 0)] - tg).norm() < 1e-9 * tg.norm(),
            "{w}: {} vs {tg}",
            h[(0, 0)]
        );
        assert!(
            (h[(0, 1)] + zg).norm() < 1e-9 * zg.norm(),
            "{w}: {} vs {}",
            h[(0, 1)],
            -zg
        );
        // Current and armature displacement against the recovered attachment states.
        let x = att
            .states(
                w,
                &DVector::from_vec(vec![c(1e-4)]),
                &DVector::from_vec(vec![c(2.0)]),
            )
            .unwrap();
        let y = &h * DVector::from_vec(vec![c(2.0), c(1e-4)]);
        assert!((y[1] - x[0]).norm() < 1e-9 * x[0].norm());
        assert!((y[2] - x[1]).norm() < 1e-9 * x[1].norm());
    }
    // Sign: a static structure displacement x > 0 with u = 0 compresses... the
    // force on the structure is negative (restoring), -k_s k_a/(k_s + k_a) x.
    let h0 = ss.transfer(0.0).unwrap();
    assert!(h0[(0, 1)].re < 0.0);
    assert_eq!(
        p.with_rigid_stinger().state_space().unwrap_err(),
        AttachmentError::RigidStingerStateSpace
    );
}

#[test]
fn recovered_states_satisfy_attachment_equations() {
    let p = ShakerParams::paper();
    let att = LinearAttachment::shaker("shaker", &p, "drive").unwrap();
    let loc = att.localization().unwrap();
    let w = 400.0;
    let ug = DVector::from_vec(vec![Complex64::new(3e-4, -1e-4)]);
    let u = DVector::from_vec(vec![c(5.0)]);
    let x = att.states(w, &ug, &u).unwrap();
    let z = att.impedance(w);
    let bu = att.input_map.map(c) * &u;
    // Residual c2 = Z x - f_ex2 is the interface reaction: no component along L2.
    let c2 = &z * &x - bu;
    let l2 = loc.l2.map(c);
    assert!((l2.transpose() * &c2).norm() < 1e-9 * c2.norm());
    // Compatibility B2 x = u_G.
    assert!((att.b2.map(c) * &x - &ug).norm() < 1e-15);
    // Force on the structure F_G = -P^T c2 equals the condensation's -Z_G u_G + T_G u.
    let fg = -(loc.pinv_b2.map(c).transpose() * &c2);
    let cond = att.interface_condensation(w).unwrap();
    assert!((&fg - cond.force(&ug, &u)).norm() < 1e-9 * fg.norm());
}

/// A tuned-mass damper (mass m on spring k and dashpot d to the interface point).
fn tmd(point: &str, m: f64, k: f64, d: f64) -> LinearAttachment {
    LinearAttachment::tuned_mass_damper("tmd", point, m, k, d).unwrap()
}

#[test]
fn generic_attachments_hand_derived_impedances() {
    let model = two_dof();
    // Grounded spring-dashpot, ncon = ndim = 1 (no `2` blocks): Z_G = k + i W d.
    let spring = LinearAttachment {
        name: "spring".into(),
        coefficients: vec![
            DMatrix::from_element(1, 1, 5e4),
            DMatrix::from_element(1, 1, 2.0),
        ],
        b2: DMatrix::from_element(1, 1, 1.0),
        interface_points: vec!["tip".into()],
        input_map: DMatrix::from_element(1, 1, 1.0),
        state_names: vec!["x".into()],
        input_names: vec!["force".into()],
    };
    // Spring between the two points, ncon = ndim = 2: Z_G = k [[1, -1], [-1, 1]].
    let link = LinearAttachment {
        name: "link".into(),
        coefficients: vec![DMatrix::from_row_slice(2, 2, &[7e3, -7e3, -7e3, 7e3])],
        b2: DMatrix::identity(2, 2),
        interface_points: vec!["drive".into(), "tip".into()],
        input_map: DMatrix::zeros(2, 0),
        state_names: vec!["x1".into(), "x2".into()],
        input_names: vec![],
    };
    let (m, k, d) = (0.3, 2e4, 1.5);
    let t = tmd("tip", m, k, d);
    for &w in &OMEGAS {
        let zs = spring.interface_condensation(w).unwrap();
        assert!((zs.z_g[(0, 0)] - Complex64::new(5e4, 2.0 * w)).norm() < 1e-12 * 5e4);
        assert!((zs.t_g[(0, 0)] - c(1.0)).norm() < 1e-15);
        // ncon = ndim: the `2` blocks are empty and Z_q = Z11.
        let blk = link.impedance_blocks(&model, w).unwrap();
        assert_eq!((blk.z22.shape(), blk.z12.shape()), ((0, 0), (2, 0)));
        assert!(rel_err(&link.condensed(&model, w).unwrap().0, &blk.z11) < 1e-14);
        let zl = link.interface_impedance(w).unwrap();
        let zl_cf = DMatrix::from_row_slice(2, 2, &[c(7e3), c(-7e3), c(-7e3), c(7e3)]);
        assert!(rel_err(&zl, &zl_cf) < 1e-14);
        // TMD: Z_G = -W^2 m (k + i W d) / (k + i W d - W^2 m).
        let kd = Complex64::new(k, w * d);
        let zt_cf = -w * w * m * kd / (kd - w * w * m);
        let zt = t.interface_impedance(w).unwrap()[(0, 0)];
        assert!(
            (zt - zt_cf).norm() <= 1e-10 * zt_cf.norm(),
            "{w}: {zt} vs {zt_cf}"
        );
    }
    // Several attachments: the sum of E Z_G E^T and of the imposed forces.
    let atts = [spring.clone(), link.clone(), t.clone()];
    let inputs = [
        DVector::from_vec(vec![c(3.0)]),
        DVector::zeros(0),
        DVector::zeros(0),
    ];
    let w = 250.0;
    let (zq, f) = condensed_sum(&model, &atts, &inputs, w).unwrap();
    let mut zq_ref = DMatrix::<Complex64>::zeros(2, 2);
    for a in &atts {
        zq_ref += a.condensed(&model, w).unwrap().0;
    }
    assert!(rel_err(&zq, &zq_ref) < 1e-14);
    // The spring's input force acts at the tip only.
    assert!((f - DVector::from_vec(vec![c(0.0), c(3.0)])).norm() < 1e-14);
    // Hand-assembled: spring at tip, link between drive (0.6, 0.8) and tip (0, 1).
    let ed = DVector::from_vec(vec![0.6, 0.8]);
    let et = DVector::from_vec(vec![0.0, 1.0]);
    let rel = &ed - &et;
    let kd = Complex64::new(k, w * d);
    let zt = -w * w * m * kd / (kd - w * w * m);
    let zq_hand = (&et * et.transpose()).map(|v| v * (Complex64::new(5e4, 2.0 * w) + zt))
        + (&rel * rel.transpose()).map(|v| c(v * 7e3));
    assert!(rel_err(&zq, &zq_hand) < 1e-12);
}

#[test]
fn singular_z22_is_reported_with_omega() {
    // Undamped TMD: fixed-interface resonance at sqrt(k/m).
    let t = tmd("tip", 0.25, 1e4, 0.0);
    let w = (1e4f64 / 0.25).sqrt();
    match t.interface_impedance(w) {
        Err(AttachmentError::SingularZ22 {
            omega_rad_s,
            condition_number,
            ..
        }) => {
            assert_eq!(omega_rad_s, w);
            assert!(condition_number > 1e12);
        }
        other => panic!("expected SingularZ22, got {other:?}"),
    }
    // Slightly off resonance it is regular.
    assert!(t.interface_impedance(w * 1.001).is_ok());
    // The paper's shaker has a damped armature: regular everywhere.
    let s = LinearAttachment::shaker("s", &ShakerParams::paper(), "drive").unwrap();
    for w in (0..200).map(|i| i as f64 * 50.0) {
        assert!(s.interface_impedance(w).is_ok());
    }
}

#[test]
fn bad_shaker_parameters_are_rejected_by_name() {
    let base = ShakerParams::paper();
    let cases: Vec<(ShakerParams, &str)> = vec![
        (
            ShakerParams {
                inductance_h: 0.0,
                ..base
            },
            "inductance_h",
        ),
        (
            ShakerParams {
                resistance_ohm: -3.0,
                ..base
            },
            "resistance_ohm",
        ),
        (
            ShakerParams {
                force_constant_n_per_a: 0.0,
                ..base
            },
            "force_constant_n_per_a",
        ),
        (
            ShakerParams {
                armature_mass_kg: -0.043,
                ..base
            },
            "armature_mass_kg",
        ),
        (
            ShakerParams {
                armature_stiffness_n_per_m: 0.0,
                ..base
            },
            "armature_stiffness_n_per_m",
        ),
        (
            ShakerParams {
                stinger: Stinger::Elastic {
                    stiffness_n_per_m: 0.0,
                },
                ..base
            },
            "stinger_stiffness_n_per_m",
        ),
    ];
    for (p, name) in cases {
        match p.validate() {
            Err(AttachmentError::NonPositive { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: {other:?}"),
        }
        assert!(LinearAttachment::shaker("s", &p, "drive").is_err());
    }
    match (ShakerParams {
        armature_damping: ArmatureDamping::Viscous(-1.0),
        ..base
    })
    .validate()
    {
        Err(AttachmentError::Negative { name, value }) => {
            assert_eq!(name, "armature_damping_n_s_per_m");
            assert_eq!(value, -1.0);
        }
        other => panic!("{other:?}"),
    }
    match (ShakerParams {
        inductance_h: f64::NAN,
        ..base
    })
    .validate()
    {
        Err(AttachmentError::NotFinite { name, .. }) => assert_eq!(name, "inductance_h"),
        other => panic!("{other:?}"),
    }
    match (ShakerParams {
        armature_damping: ArmatureDamping::Ratio(f64::INFINITY),
        ..base
    })
    .validate()
    {
        Err(AttachmentError::NotFinite { name, .. }) => assert_eq!(name, "armature_damping_ratio"),
        other => panic!("{other:?}"),
    }
    // D_a below the electro-mechanical share G^2/(2 R omega_a m_a) = 1.342.
    match (ShakerParams {
        armature_damping: ArmatureDamping::Ratio(1.0),
        ..base
    })
    .validate()
    {
        Err(AttachmentError::NegativeMechanicalDamping {
            electrical_ratio,
            d_a,
            ..
        }) => {
            assert!(
                (electrical_ratio - 1.342).abs() < 1e-3,
                "{electrical_ratio}"
            );
            assert!(d_a < 0.0);
        }
        other => panic!("{other:?}"),
    }
    // Viscous damping zero is allowed.
    assert!((ShakerParams {
        armature_damping: ArmatureDamping::Viscous(0.0),
        ..base
    })
    .validate()
    .is_ok());
}

#[test]
fn bad_attachment_definitions_are_rejected() {
    let model = two_dof();
    let good = LinearAttachment::shaker("s", &ShakerParams::paper(), "drive").unwrap();
    assert!(good.validate().is_ok());
    assert_eq!(
        (good.ndim(), good.ncon(), good.order(), good.ninput()),
        (3, 1, 2, 1)
    );

    let mut a = good.clone();
    a.coefficients[1] = DMatrix::zeros(2, 2);
    assert!(matches!(
        a.validate(),
        Err(AttachmentError::DimensionMismatch { ref what, expected: 3, found: 2, .. }) if what == "A_1 rows"
    ));

    let mut a = good.clone();
    a.coefficients[0][(1, 1)] = f64::NAN;
    assert!(
        matches!(a.validate(), Err(AttachmentError::NotFinite { ref name, .. }) if name == "A_0")
    );

    let mut a = good.clone();
    a.coefficients.clear();
    assert!(matches!(
        a.validate(),
        Err(AttachmentError::NoCoefficients { .. })
    ));

    let mut a = good.clone();
    a.b2 = DMatrix::from_row_slice(4, 3, &[0.0; 12]);
    a.interface_points = vec!["drive".into(); 4];
    assert!(matches!(
        a.validate(),
        Err(AttachmentError::TooManyConstraints {
            ncon: 4,
            ndim: 3,
            ..
        })
    ));

    // Redundant constraints: rank 1 < ncon = 2.
    let mut a = good.clone();
    a.b2 = DMatrix::from_row_slice(2, 3, &[0.0, 0.0, 1.0, 0.0, 0.0, 2.0]);
    a.interface_points = vec!["drive".into(), "tip".into()];
    assert!(matches!(
        a.localization(),
        Err(AttachmentError::RankDeficientB2 {
            rank: 1,
            ncon: 2,
            ..
        })
    ));

    let mut a = good.clone();
    a.input_map = DMatrix::zeros(2, 1);
    assert!(matches!(
        a.validate(),
        Err(AttachmentError::DimensionMismatch { .. })
    ));

    let mut a = good.clone();
    a.interface_points = vec!["nowhere".into()];
    match a.condensed(&model, 100.0) {
        Err(AttachmentError::UnknownPoint {
            point, available, ..
        }) => {
            assert_eq!(point, "nowhere");
            assert_eq!(available, vec!["drive".to_string(), "tip".to_string()]);
        }
        other => panic!("{other:?}"),
    }

    let mut bad_model = model.clone();
    bad_model.points[0].direction = DVector::zeros(3);
    assert!(matches!(
        good.l1(&bad_model),
        Err(AttachmentError::PointDimension {
            found: 3,
            ndof: 2,
            ..
        })
    ));

    // Wrong number of inputs in the multi-attachment helper.
    assert!(matches!(
        condensed_sum(
            &model,
            std::slice::from_ref(&good),
            &[DVector::zeros(2)],
            10.0
        ),
        Err(AttachmentError::InputCount {
            expected: 1,
            found: 2,
            ..
        })
    ));
}

/// `Z_G(Omega)`, `T_G(Omega)` at `w` and their derivatives by Richardson-
/// extrapolated central differences (error O(d^4)).
fn richardson(
    cd: &nlmode::attachment::Condenser,
    w: f64,
) -> (DMatrix<Complex64>, DMatrix<Complex64>) {
    let central = |d: f64| {
        let (p, m) = (cd.condense(w + d).unwrap(), cd.condense(w - d).unwrap());
        (
            (p.z_g - m.z_g) / Complex64::new(2.0 * d, 0.0),
            (p.t_g - m.t_g) / Complex64::new(2.0 * d, 0.0),
        )
    };
    // small enough for the damper's resonance (half-power bandwidth 3.3 rad/s)
    let d = 1e-4 * w;
    let (z1, t1) = central(d);
    let (z2, t2) = central(0.5 * d);
    let r = |fine: DMatrix<Complex64>, coarse: DMatrix<Complex64>| {
        (fine * Complex64::new(4.0, 0.0) - coarse) / Complex64::new(3.0, 0.0)
    };
    (r(z2, z1), r(t2, t1))
}

#[test]
fn condensation_derivative_is_exact() {
    // the paper's shaker (elastic stinger: internal states, Z22 of size 3),
    // a shaker on a rigid stinger, and a tuned-mass damper; near and away from
    // their resonances
    let elastic = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "drive").unwrap();
    let mut rigid_params = ShakerParams::paper();
    rigid_params.stinger = Stinger::Rigid;
    let rigid = LinearAttachment::shaker("rigid", &rigid_params, "drive").unwrap();
    let damper = tmd("tip", 0.3, 4e4, 2.0);
    for att in [&elastic, &rigid, &damper] {
        let cd = nlmode::attachment::Condenser::new(att).unwrap();
        for w in [50.0, 365.0, 1234.5, 4e3] {
            let (value, exact) = cd.condense_with_derivative(w).unwrap();
            let plain = cd.condense(w).unwrap();
            assert_eq!(value.z_g, plain.z_g, "{} at {w}", att.name);
            assert_eq!(value.t_g, plain.t_g, "{} at {w}", att.name);
            let (dz, dt) = richardson(&cd, w);
            // relative to the scale of the quantity over the step: a wrong
            // factor (k instead of k - 1, a sign of a term) is O(1) off
            let ez = (&exact.z_g - &dz).norm() / (dz.norm() + 1e-300);
            assert!(ez < 1e-7, "{} dZ_G at {w}: {ez:e}", att.name);
            if dt.norm() > 0.0 {
                let et = (&exact.t_g - &dt).norm() / dt.norm();
                assert!(et < 1e-7, "{} dT_G at {w}: {et:e}", att.name);
            } else {
                assert_eq!(exact.t_g.norm(), 0.0);
            }
        }
    }
}

/// The rigid mass and the piezo shunt: their interface impedances by hand,
/// `Z_G = -Omega^2 m` and `Z_G = k_p + i Omega theta^2 / (i Omega C_p + 1/R)`
/// (eliminate `v` from `theta x' + C_p v' + v/R = 0`), and the piezo's
/// recovered voltage `v = -i Omega theta x / (i Omega C_p + 1/R)`.
#[test]
fn rigid_mass_and_piezo_shunt_impedances() {
    let mass = LinearAttachment::rigid_mass("m", "drive", 0.25).unwrap();
    let (cp, r, th, kp) = (1.2e-7, 3.0e4, 0.05, 1.0e4);
    let piezo = LinearAttachment::piezo_shunt("p", "drive", cp, r, th, kp).unwrap();
    for &w in &OMEGAS[1..] {
        let zm = mass.interface_impedance(w).unwrap()[(0, 0)];
        assert!(
            (zm - c(-w * w * 0.25)).norm() <= 1e-12 * (w * w * 0.25),
            "{w}: {zm}"
        );
        let iw = Complex64::new(0.0, w);
        let y = iw * cp + 1.0 / r;
        let expected = c(kp) + iw * th * th / y;
        let zp = piezo.interface_impedance(w).unwrap()[(0, 0)];
        assert!(
            (zp - expected).norm() <= 1e-12 * expected.norm(),
            "{w}: {zp} vs {expected}"
        );
        let x = Complex64::new(1e-3, -2e-4);
        let s = piezo
            .states(w, &DVector::from_element(1, x), &DVector::zeros(0))
            .unwrap();
        let v = -(iw * th * x) / y;
        assert!(
            (s[1] - v).norm() <= 1e-12 * v.norm(),
            "{w}: {} vs {v}",
            s[1]
        );
    }
    for (name, res) in [
        ("mass_kg", LinearAttachment::rigid_mass("m", "x", 0.0).err()),
        (
            "resistance_ohm",
            LinearAttachment::piezo_shunt("p", "x", cp, -1.0, th, kp).err(),
        ),
        (
            "stiffness_n_per_m",
            LinearAttachment::piezo_shunt("p", "x", cp, r, th, -1.0).err(),
        ),
    ] {
        let e = res.expect("rejected").to_string();
        assert!(e.contains(name), "{e}");
    }
}

/// Fixed-interface poles against closed forms: TMD `m s^2 + d s + k = 0`,
/// piezo shunt `s = -1/(R C_p)`, rigid mass none.
#[test]
fn fixed_interface_poles_closed_forms() {
    let (m, k, d) = (0.1, 9000.0, 2.0);
    let mut p = tmd("drive", m, k, d).fixed_interface_poles().unwrap();
    p.sort_by(|a, b| a.im.total_cmp(&b.im));
    let disc = Complex64::new(d * d - 4.0 * m * k, 0.0).sqrt();
    let mut e = [(-d + disc) / (2.0 * m), (-d - disc) / (2.0 * m)];
    e.sort_by(|a, b| a.im.total_cmp(&b.im));
    assert_eq!(p.len(), 2);
    for (a, b) in p.iter().zip(&e) {
        assert!((a - b).norm() <= 1e-10 * b.norm(), "{a} vs {b}");
    }
    let piezo = LinearAttachment::piezo_shunt("p", "x", 1e-7, 2e4, 0.05, 0.0).unwrap();
    let p = piezo.fixed_interface_poles().unwrap();
    assert_eq!(p.len(), 1);
    assert!(
        (p[0] - c(-1.0 / (2e4 * 1e-7))).norm() <= 1e-9 * 500.0,
        "{:?}",
        p
    );
    let mass = LinearAttachment::rigid_mass("m", "x", 1.0).unwrap();
    assert!(mass.fixed_interface_poles().unwrap().is_empty());
}

/// The assembly's linear poles and mode shape: a 1-DOF structure `(m, k)` with a
/// rigid mass `m_r` has the undamped pole `i sqrt(k / (m + m_r))` with shape 1.
#[test]
fn assembled_linear_poles_of_a_mass_loaded_oscillator() {
    let (m, k, mr) = (2.0, 2e5, 0.5);
    let model = StructuralModel {
        mass: DMatrix::from_element(1, 1, m),
        stiffness: DMatrix::from_element(1, 1, k),
        damping: DMatrix::zeros(1, 1),
        nonlinear: vec![],
        points: vec![NamedPoint {
            name: "x".into(),
            direction: DVector::from_element(1, 1.0),
        }],
    };
    let att = LinearAttachment::rigid_mass("m", "x", mr).unwrap();
    let sys = nlmode::reference::AssembledSystem::new(&model, &[att], "x").unwrap();
    let w = (k / (m + mr)).sqrt();
    let s = sys
        .linear_poles()
        .into_iter()
        .find(|s| s.im > 0.0)
        .expect("oscillatory pole");
    assert!(
        (s - Complex64::new(0.0, w)).norm() <= 1e-10 * w,
        "{s} vs {w}"
    );
    let q = sys.structure_mode_shape(s).unwrap();
    assert_eq!(q.len(), 1);
    assert!(q[0].norm() > 0.0);
}
