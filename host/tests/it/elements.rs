//! The nonlinear element library (issue 11, item 2) end to end.
//!
//! # The Jenkins element's describing function (H = 1)
//!
//! A spring `k_t` in series with a Coulomb slider of slip force `F_s`, driven by
//! `u = x cos(theta)`, sticks for `x <= F_s/k_t` (`f = k_t u`). For larger `x` the
//! steady loop, on the descending half `theta in [0, pi]`, starts in stick at the
//! turning point, `f = F_s - k_t x (1 - cos theta)`, until `f = -F_s` at
//! `cos theta* = 1 - 2 F_s/(k_t x)`, then slips with `f = -F_s`; the ascending
//! half is the mirror image, `f(theta + pi) = -f(theta)`. Its first harmonic
//! `f ~ F_c cos(theta) + F_s1 sin(theta)` is
//!
//! ```text
//! F_c  = (2/pi) int_0^pi f cos = k_t x (theta* - sin(2 theta*)/2) / pi,
//! F_s1 = (2/pi) int_0^pi f sin = -(4 F_s/pi) (1 - F_s/(k_t x)),
//! ```
//!
//! (with `2 F_s - k_t x = -k_t x cos theta*` and `sin^2 theta* = (1 - cos)(1 + cos)`),
//! and the loop area, the energy dissipated per cycle, is
//! `W = -pi x F_s1 = 4 F_s (x - F_s/k_t)`. The H = 1 EPMC of
//! `m q'' + c q' + k q + f = 0` (`M q'' - 2 D omega M q' + ... = 0`, `eq:EPMC`)
//! balances the cosine and sine parts: `omega^2 = (k + F_c/x) / m` and
//! `2 D omega m omega x = c omega x - F_s1`, i.e.
//! `D = (c + (4 F_s/(pi omega x)) (1 - F_s/(k_t x))) / (2 omega m)`. Stick limit:
//! `omega^2 = (k + k_t)/m`, `D = c/(2 omega m)`; gross slip (`x -> inf`):
//! `F_c/x -> 0` and `F_s1/x -> 0`, the structure without the element.
//!
//! The AFT samples the loop at `N` instants; with the turning points on samples
//! (`N` even) the sampled forces are exact and the only error is the quadrature
//! of the kink at `theta*`, `O(N^-2)`; `N = 2^16` gives agreement to ~2e-11.
//!
//! # The Jenkins joint on the paper beam (`examples/jenkins_joint.toml`)
//!
//! Tip grounded through `k_t = 1e4 N/m`, `F_s = 0.5 N` (no cubic spring), the
//! shaker at 2l/3, 1 V, 0.8 .. 1.4 omega0 at 2 % per pseudo period (omega0 =
//! 356.2 rad/s; the stuck joint raises the linear frequency, gross slip brings
//! it back to omega0). Recorded (2026-12-01; NMA H = 7, 256 AFT samples, 79
//! branch points, 275 in the refined table):
//!
//! | | peak tip amplitude | at | steepest drop after the peak ("jump-down") |
//! |---|---|---|---|
//! | `reference` | 2.394e-4 m | 1.1046 omega0 | 1.1789 omega0 |
//! | `nlmode` | 2.326e-4 m | 1.0997 omega0 | 1.2039 omega0 |
//!
//! RMS difference of `nlmode` against `reference`: tip 2.5 % of the reference
//! peak, force 1.4 % of the largest force; peak -2.8 %. The softening friction
//! resonance has no hardening jump: the "jump-down" is the steep flank after
//! the peak, where the sweep leaves the resonance.
use crate::common::{expect_failure, scenario, tmpdir};
use host::methods;
use host::model::Setup;
use host::scenario::{Method, Scenario};
use nalgebra::{DMatrix, DVector};
use nlmode::nma::{nonlinear_modal_analysis, AmplitudeRange, ContinuationOptions, NmaOptions};
use nlmode::structure::{ElasticDryFriction, StructuralModel, UnilateralSpring};
use std::f64::consts::PI;
use std::path::Path;

fn one_dof(m: f64, k: f64, c: f64) -> StructuralModel {
    let mut s = StructuralModel::new(
        DMatrix::from_element(1, 1, m),
        DMatrix::from_element(1, 1, k),
    );
    s.damping = DMatrix::from_element(1, 1, c);
    s.add_named_point("x", DVector::from_element(1, 1.0))
        .unwrap();
    s
}

/// The H = 1 describing function of the module docs: `(omega, D)` at amplitude `x`.
fn jenkins_backbone(m: f64, k: f64, c: f64, kt: f64, fs: f64, x: f64) -> (f64, f64) {
    let (fc, fs1) = if x <= fs / kt {
        (kt * x, 0.0)
    } else {
        let th = (1.0 - 2.0 * fs / (kt * x)).acos();
        (
            kt * x * (th - (2.0 * th).sin() / 2.0) / PI,
            -4.0 * fs * (1.0 - fs / (kt * x)) / PI,
        )
    };
    let om = ((k + fc / x) / m).sqrt();
    (om, (c - fs1 / (om * x)) / (2.0 * om * m))
}

#[test]
fn jenkins_h1_epmc_backbone_and_damping_equal_the_describing_function() {
    let (m, k, c, kt, fs) = (1.0, 1e4, 0.5, 3e3, 1.0);
    let mut s = one_dof(m, k, c);
    s.add_nonlinear(
        "joint",
        DVector::from_element(1, 1.0),
        ElasticDryFriction::new(kt, fs).unwrap(),
    )
    .unwrap();
    let opts = NmaOptions {
        harmonics: 1,
        samples: Some(1 << 16),
        amplitude: AmplitudeRange::Modal {
            log10_start: -4.0,
            log10_end: 0.0,
        },
        // the stick-slip transition is a corner of the branch and D(a) has a
        // sharp maximum near 2 F_s/k_t: small steps there
        continuation: ContinuationOptions {
            ds: 0.1,
            dsmin: Some(1e-5),
            ..Default::default()
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&s, &opts).unwrap();
    // the exact play AFT makes the branch smooth: the continuation takes few
    // steps; every one is checked against the closed form
    println!("{} branch points", r.branch.len());
    assert!(r.branch.len() >= 10, "{} points", r.branch.len());
    let (mut stick, mut slip) = (0, 0);
    for b in &r.branch {
        // m = 1: the modal amplitude is the displacement amplitude
        let x = b.amplitude;
        let (om, d) = jenkins_backbone(m, k, c, kt, fs, x);
        assert!(
            (b.omega_rad_s / om - 1.0).abs() < 1e-8,
            "x = {x:e}: omega {} vs {om}",
            b.omega_rad_s
        );
        assert!(
            (b.damping_ratio - d).abs() < 1e-8 * d.max(1e-3),
            "x = {x:e}: D {} vs {d}",
            b.damping_ratio
        );
        // the energy dissipated per cycle by the element = the EPMC's negative
        // damping work minus the viscous part: 4 F_s (x - F_s/k_t)
        let w = (2.0 * b.damping_ratio * b.omega_rad_s * m - c) * PI * b.omega_rad_s * x * x;
        let w_exact = 4.0 * fs * (x - fs / kt).max(0.0);
        assert!(
            (w - w_exact).abs() < 1e-8 * (4.0 * fs * x),
            "x = {x:e}: W {w} vs {w_exact}"
        );
        if x < fs / kt {
            stick += 1;
            // stick limit: linear with k_t
            let om_stick = ((k + kt) / m).sqrt();
            assert!((b.omega_rad_s / om_stick - 1.0).abs() < 1e-12);
            assert!((b.damping_ratio - c / (2.0 * om_stick * m)).abs() < 1e-12);
        } else {
            slip += 1;
        }
    }
    assert!(stick >= 2 && slip >= 6, "{stick} stick, {slip} slip points");
    // gross-slip limit: the structure without the element
    let last = r.branch.last().unwrap();
    assert!(last.amplitude > 0.99, "{}", last.amplitude);
    let om_k = (k / m).sqrt();
    assert!(
        (last.omega_rad_s / om_k - 1.0).abs() < 2e-4,
        "{}",
        last.omega_rad_s
    );
    assert!((last.damping_ratio - c / (2.0 * om_k * m)).abs() < 2e-4);
}

#[test]
fn unilateral_spring_gives_the_bilinear_frequency() {
    // contact from u = 0 (gap 0): stiffness k for u < 0, k + k_c for u > 0; the
    // exact period pi/w1 + pi/w2 gives omega = 2 w1 w2 / (w1 + w2) at every
    // amplitude (with a gap, in the limit of large amplitude). Harmonic Balance
    // truncates the non-smooth motion: the H = 1 error is ~1e-2, H = 25 is
    // within 1e-4 (measured 2.6e-5), the tolerance stated here.
    let (m, k, kc) = (1.0, 1e4, 3e4);
    let mut s = one_dof(m, k, 0.0);
    s.add_nonlinear(
        "contact",
        DVector::from_element(1, 1.0),
        UnilateralSpring::new(kc, 0.0).unwrap(),
    )
    .unwrap();
    let (w1, w2) = ((k / m).sqrt(), ((k + kc) / m).sqrt());
    let exact = 2.0 * w1 * w2 / (w1 + w2);
    let opts = NmaOptions {
        harmonics: 25,
        samples: Some(4096),
        conservative: true,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end: -2.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&s, &opts).unwrap();
    for b in &r.branch {
        assert!(
            (b.omega_rad_s / exact - 1.0).abs() < 1e-4,
            "a = {:e}: omega {} vs {exact}",
            b.amplitude,
            b.omega_rad_s
        );
    }
    // and with a gap, the large-amplitude limit
    let mut s = one_dof(m, k, 0.0);
    s.add_nonlinear(
        "contact",
        DVector::from_element(1, 1.0),
        UnilateralSpring::new(kc, 1e-5).unwrap(),
    )
    .unwrap();
    let opts = NmaOptions {
        amplitude: AmplitudeRange::Modal {
            log10_start: -1.0,
            log10_end: 0.0,
        },
        ..opts
    };
    let r = nonlinear_modal_analysis(&s, &opts).unwrap();
    let last = r.branch.last().unwrap();
    assert!(
        (last.omega_rad_s / exact - 1.0).abs() < 1e-4,
        "{}",
        last.omega_rad_s
    );
}

fn example() -> Scenario {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(root.join("examples/jenkins_joint.toml")).unwrap();
    Scenario::parse(&text).unwrap()
}

#[test]
fn scenario_elements_build_at_points_and_between_points() {
    let sc = example();
    let s = Setup::new(&sc).unwrap();
    assert_eq!(s.model.nonlinear.len(), 1);
    let e = &s.model.nonlinear[0];
    assert_eq!(e.name, "joint");
    assert!(e.law.hysteresis().is_some());
    // the tip is a Craig-Bampton master: the element direction is the tip's
    assert_eq!(e.direction, s.model.point("tip").unwrap().direction);
    // every type, grounded and relative, on the beam; the shorthand adds to them
    let text = r#"
[structure]
k3_n_per_m3 = 6e9
[[nonlinearity]]
type = "cubic-spring"
point = "2l3"
k3_n_per_m3 = 1e9
[[nonlinearity]]
type = "polynomial-spring"
points = ["tip", "2l3"]
coefficients = { "2" = 1e5, "3" = 2e9 }
[[nonlinearity]]
type = "unilateral-spring"
point = "tip"
stiffness_n_per_m = 1e5
gap_m = 1e-3
[[nonlinearity]]
type = "tanh-friction"
point = "l3"
slip_force_n = 0.2
regularization_velocity_m_s = 1e-3
[[nonlinearity]]
type = "elastic-dry-friction"
points = ["l3", "tip"]
tangential_stiffness_n_per_m = 1e4
slip_force_n = 0.5
[[nonlinearity]]
type = "quadratic-damper"
name = "air"
point = "tip"
c2_n_s2_per_m2 = 0.1
"#;
    let sc = Scenario::parse(text).unwrap();
    let s = Setup::new(&sc).unwrap();
    let names: Vec<&str> = s.model.nonlinear.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "cubic_spring",
            "nonlinearity0",
            "nonlinearity1",
            "nonlinearity2",
            "nonlinearity3",
            "nonlinearity4",
            "air"
        ]
    );
    // masters tip, 2l3, l3 (+ 10 modes); a relative element is e_a - e_b
    assert_eq!(s.model.ndof(), 13);
    let p = |n: &str| s.model.point(n).unwrap().direction.clone();
    assert_eq!(s.model.nonlinear[2].direction, p("tip") - p("2l3"));
    assert_eq!(s.model.nonlinear[5].direction, p("l3") - p("tip"));
    // without [[nonlinearity]] the beam is the paper's, bit for bit
    let a = Setup::new(&Scenario::default_scenario()).unwrap();
    let mut sc0 = Scenario::default_scenario();
    sc0.nonlinearity.clear();
    let b = Setup::new(&sc0).unwrap();
    assert_eq!(a.model.stiffness, b.model.stiffness);
    assert_eq!(
        a.model.nonlinear[0].direction,
        b.model.nonlinear[0].direction
    );
}

/// Peaks, steepest drops and RMS difference of `nlmode` against `reference` on
/// the example (recorded numbers in the module docs).
#[test]
fn jenkins_joint_on_the_beam_by_reference_and_nlmode() {
    let sc = example();
    assert_eq!(sc.run.methods, [Method::Reference, Method::Nlmode]);
    let setup = Setup::new(&sc).unwrap();
    let (nma, _) = methods::nma_table(&setup, &sc, false).unwrap();
    eprintln!("{}", nma.note);
    let model = methods::reduced_model(&setup, &nma.table, None).unwrap();
    let (nl, _) = methods::slow_flow(
        "nlmode",
        &setup,
        &model,
        &sc.slowflow.options(Method::Nlmode),
    )
    .unwrap();
    let rf = methods::reference(&setup, &sc, &mut |_| {}).unwrap();
    let (e_nl, e_rf) = (&nl.envelope, &rf.envelope);
    let cmp = e_nl.compare_with(
        &e_rf.omega_rad_s,
        &e_rf.force_amplitude_n,
        &e_rf.tip_amplitude_m,
    );
    let peak = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    let w0 = setup.omega0_rad_s;
    let at_peak = |e: &nlmode::envelope::Envelope| {
        let i = (0..e.tip_amplitude_m.len())
            .max_by(|&a, &b| e.tip_amplitude_m[a].total_cmp(&e.tip_amplitude_m[b]))
            .unwrap();
        e.omega_rad_s[i] / w0
    };
    eprintln!(
        "reference: peak {:.4e} m at {:.4} omega0, jump-down {:?}; nlmode: peak {:.4e} m at {:.4} omega0, jump-down {:?}; rms tip {:.3e}, rms force {:.3e}, peak rel {:.3e}",
        peak(&e_rf.tip_amplitude_m),
        at_peak(e_rf),
        host::results::jump_down(&e_rf.omega_rad_s, &e_rf.tip_amplitude_m).map(|w| w / w0),
        peak(&e_nl.tip_amplitude_m),
        at_peak(e_nl),
        host::results::jump_down(&e_nl.omega_rad_s, &e_nl.tip_amplitude_m).map(|w| w / w0),
        cmp.rms_tip_rel,
        cmp.rms_force_rel,
        cmp.peak_tip_rel,
    );
    assert!(e_rf.tip_amplitude_m.iter().all(|v| v.is_finite()));
    assert!(e_nl.tip_amplitude_m.iter().all(|v| v.is_finite()));
    let (p_rf, p_nl) = (peak(&e_rf.tip_amplitude_m), peak(&e_nl.tip_amplitude_m));
    assert!((p_rf - 2.394e-4).abs() < 0.01e-4, "reference peak {p_rf}");
    assert!((p_nl - 2.326e-4).abs() < 0.01e-4, "nlmode peak {p_nl}");
    assert!((at_peak(e_rf) - 1.1046).abs() < 2e-3 && (at_peak(e_nl) - 1.0997).abs() < 2e-3);
    let drop = |e: &nlmode::envelope::Envelope| {
        host::results::jump_down(&e.omega_rad_s, &e.tip_amplitude_m).unwrap() / w0
    };
    assert!((drop(e_rf) - 1.1789).abs() < 2e-3 && (drop(e_nl) - 1.2039).abs() < 2e-3);
    assert!(cmp.overlap > 100);
    assert!(
        cmp.rms_tip_rel < 0.03 && cmp.rms_force_rel < 0.02,
        "{cmp:?}"
    );
}

#[test]
fn matrices_elements_between_points_and_cb_masters() {
    let dir = tmpdir("mtx");
    // four masses in a chain, grounded at the first
    let m3 = "%%MatrixMarket matrix coordinate real symmetric\n4 4 4\n1 1 1.0\n2 2 1.0\n3 3 1.0\n4 4 1.0\n";
    let k3 = "%%MatrixMarket matrix coordinate real symmetric\n4 4 7\n1 1 2e4\n2 1 -1e4\n2 2 2e4\n3 2 -1e4\n3 3 2e4\n4 3 -1e4\n4 4 1e4\n";
    std::fs::write(dir.join("M.mtx"), m3).unwrap();
    std::fs::write(dir.join("K.mtx"), k3).unwrap();
    let sc = |reduction: &str, extra: &str| {
        format!(
            "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
             rayleigh = [0.0, 1e-4]\nreduction = \"{reduction}\"\ncb_modes = 1\n{extra}\
             [[structure.point]]\nname = \"a\"\ndof = 0\n[[structure.point]]\nname = \"b\"\ndof = 1\n\
             [[structure.point]]\nname = \"c\"\ndof = 2\n\
             [[nonlinearity]]\ntype = \"elastic-dry-friction\"\npoints = [\"c\", \"b\"]\n\
             tangential_stiffness_n_per_m = 1e3\nslip_force_n = 0.1\n\
             [[exciter]]\npoint = \"a\"\n[output]\nresponse_point = \"c\"\n"
        )
    };
    let parse = |text: &str| scenario(&dir, text);
    let full = Setup::new(&parse(&sc("none", ""))).unwrap();
    assert_eq!(full.model.nonlinear.len(), 1);
    assert_eq!(
        full.model.nonlinear[0].direction.as_slice(),
        &[0.0, -1.0, 1.0, 0.0]
    );
    // Craig-Bampton: the default masters are a (exciter), c and b (element)
    let cb = Setup::new(&parse(&sc("craig-bampton", ""))).unwrap();
    assert_eq!(cb.model.ndof(), 4);
    let p = |n: &str| cb.model.point(n).unwrap().direction.clone();
    assert_eq!(cb.model.nonlinear[0].direction, p("c") - p("b"));
    // user masters must contain the element points
    let e = Setup::new(&parse(&sc(
        "craig-bampton",
        "cb_masters = [\"a\", \"c\"]\n",
    )))
    .err()
    .unwrap();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("structure.cb_masters") && msg.contains("'b'"),
        "{msg}"
    );
    // an unknown point names the key
    let bad = sc("none", "").replace("[\"c\", \"b\"]", "[\"c\", \"x\"]");
    let e = Scenario::parse(&bad).unwrap_err();
    assert_eq!(e.key, "nonlinearity[0].points[1]");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_nonlinearity_input_names_the_key_and_exits_2() {
    let dir = tmpdir("bad");
    let cases: &[(&str, &[&str])] = &[
        (
            "[[nonlinearity]]\ntype = \"cubic-sprng\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n",
            &["nonlinearity[0].type", "cubic-spring", "elastic-dry-friction"],
        ),
        (
            "[[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"tap\"\nk3_n_per_m3 = 1.0\n",
            &["nonlinearity[0].point", "tap", "tip"],
        ),
        (
            "[[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n\
             [[nonlinearity]]\ntype = \"elastic-dry-friction\"\npoint = \"tip\"\n\
             tangential_stiffness_n_per_m = 1e4\nslip_force_n = -1.0\n",
            &["nonlinearity[1].slip_force_n", "-1"],
        ),
        (
            "[[nonlinearity]]\ntype = \"unilateral-spring\"\npoint = \"tip\"\nstiffness_n_per_m = -5.0\ngap_m = 0.0\n",
            &["nonlinearity[0].stiffness_n_per_m", "-5"],
        ),
        (
            "[[nonlinearity]]\ntype = \"tanh-friction\"\npoint = \"tip\"\nslip_force_n = 1.0\n",
            &["nonlinearity[0].regularization_velocity_m_s", "missing"],
        ),
        (
            "[[nonlinearity]]\ntype = \"quadratic-damper\"\npoint = \"tip\"\nc2_n_s2_per_m2 = 1.0\ngap_m = 0.0\n",
            &["nonlinearity[0].gap_m", "not a parameter"],
        ),
        (
            "[[nonlinearity]]\ntype = \"polynomial-spring\"\npoint = \"tip\"\ncoefficients = { \"0\" = 1.0 }\n",
            &["nonlinearity[0].coefficients.0", "power"],
        ),
        (
            "[[nonlinearity]]\ntype = \"cubic-spring\"\npoints = [\"tip\"]\nk3_n_per_m3 = 1.0\n",
            &["nonlinearity[0].points", "two different"],
        ),
        (
            "[[nonlinearity]]\ntype = \"cubic-spring\"\nk3_n_per_m3 = 1.0\n",
            &["nonlinearity[0].point", "missing"],
        ),
        (
            "[[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\nstiffnes_n_per_m = 1.0\n",
            &["nonlinearity[0]", "stiffnes_n_per_m"],
        ),
    ];
    for (toml, needles) in cases {
        expect_failure(&dir, "nma", toml, needles);
    }
    std::fs::remove_dir_all(&dir).ok();
}
