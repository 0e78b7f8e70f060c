//! The first-order modulation terms (`SlowFlowOptions::rate_terms`,
//! `nlmode::reduced::rate`): an exact equivalence that fixes the rate
//! term's factor and sign, the linear beam and the paper's cases against the
//! full-order `reference`.
use super::reduced::paper;
use nalgebra::DMatrix;
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::excitation::LinearSweep;
use nlmode::nma::modal_basis::ModalBasis;
use nlmode::reduced::problems::duffing_table;
use nlmode::reduced::{ForceEnvelope, ReducedModel, SlowFlowOptions, SlowFlowResult};
use nlmode::Complex64;

const W0: f64 = 100.0;
const D0: f64 = 0.005;

/// A dashpot `c` \[N s/m\] from `point` to ground (`A_1 = [c]`): `Z_G = i Omega c`.
fn dashpot(point: &str, c_n_s_per_m: f64) -> LinearAttachment {
    LinearAttachment {
        name: "dashpot".into(),
        coefficients: vec![
            DMatrix::zeros(1, 1),
            DMatrix::from_element(1, 1, c_n_s_per_m),
        ],
        b2: DMatrix::from_element(1, 1, 1.0),
        interface_points: vec![point.into()],
        input_map: DMatrix::zeros(1, 0),
        state_names: vec!["x_s".into()],
        input_names: vec![],
    }
}

fn tips(r: &SlowFlowResult) -> Vec<f64> {
    r.samples.iter().map(|s| s.tip_amplitude_m).collect()
}

fn max_rel(x: &[f64], y: &[f64]) -> f64 {
    let peak = y.iter().cloned().fold(0.0, f64::max);
    x.iter()
        .zip(y)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / peak
}

/// A dashpot `c` at a point with shape `phi` is modal damping: with the rate
/// terms the slow flow of the structure with the dashpot is the slow flow
/// of the structure with `2 D' omega = 2 D omega + c phi^2` and no
/// attachment, through resonance at 2 % per pseudo period (the dashpot's
/// `z_s = c phi^2` joins `2 D omega` in the `A'` term; a wrong factor or
/// sign of `z_s` or of the damping's own rate term breaks it). The rate
/// terms change this sweep by more than 1e-3 of the peak, so the
/// equivalence is not met by terms too small to matter.
#[test]
fn a_dashpots_rate_term_is_the_modal_dampings() {
    let phi = 0.8;
    let c = 0.6; // 2 D omega = 1.0: the dashpot more than doubles it
    let table = |d: f64| {
        duffing_table(
            W0,
            d,
            0.0,
            &[("p", Complex64::new(phi, 0.0))],
            "p",
            1.0,
            40,
            1,
        )
    };
    let sweep = LinearSweep::per_pseudo_period(W0, 0.9, 1.1, 0.02, 1.0).unwrap();
    let env = ForceEnvelope::constant(Complex64::new(1.0, 0.0), 0.9 * W0, 1.1 * W0).unwrap();
    let model = |d: f64| {
        ReducedModel::new(&table(d), "p", "p")
            .unwrap()
            .with_imposed_force("p", env.clone())
            .unwrap()
    };
    let with_dashpot = model(D0)
        .with_linear_attachment(&dashpot("p", c), &[])
        .unwrap();
    let d_equiv = D0 + c * phi * phi / (2.0 * W0);
    let opts = |rate_terms| SlowFlowOptions {
        rate_terms,
        rtol: 1e-10,
        atol_rel: 1e-12,
        channel_tol: 1e-12,
        ..Default::default()
    };
    let a = with_dashpot.simulate_sweep(&sweep, &opts(true)).unwrap();
    let b = model(d_equiv).simulate_sweep(&sweep, &opts(true)).unwrap();
    let a_nm = with_dashpot.simulate_sweep(&sweep, &opts(false)).unwrap();
    let (d, effect) = (
        max_rel(&tips(&a), &tips(&b)),
        max_rel(&tips(&a_nm), &tips(&a)),
    );
    eprintln!("dashpot vs modal damping with the rate terms: {d:.2e}; the rate terms change the sweep by {effect:.2e}");
    assert!(d < 1e-7, "{d}");
    assert!(effect > 1e-3, "{effect}");
}

/// `(tip RMS, force RMS, peak)` of `nlmode` on `ps` with the shaker at
/// `point` against the full-order `reference`, with `n` residual modes and
/// with or without the rate terms (relative to the reference's peaks).
fn against_reference(
    ps: &nlmode::structure::PaperStructure,
    table: &nlmode::nma::ModalTable,
    point: &str,
    sweep: &LinearSweep,
    reference: &nlmode::reference::Envelope,
    (n, rate_terms): (usize, bool),
) -> [f64; 3] {
    let sh = LinearAttachment::shaker("shaker", &ShakerParams::paper(), point).unwrap();
    let mut model = ReducedModel::new(table, "tip", point)
        .unwrap()
        .with_linear_attachment(&sh, &[Complex64::new(1.0, 0.0)])
        .unwrap();
    if n > 0 {
        model = model.with_residual_modes(table, n).unwrap();
    }
    let opts = SlowFlowOptions {
        rate_terms,
        ..Default::default()
    };
    let r = model.simulate_sweep(sweep, &opts).unwrap();
    let (tip, force) = paper::rms_differences(&r.envelope(), reference, ps.omega0_rad_s);
    let p_ref = reference
        .tip_amplitude_m
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    let peak = r.summary().unwrap().peak_tip_amplitude_m / p_ref - 1.0;
    [tip, force, peak]
}

fn with_linear_modes(
    ps: &nlmode::structure::PaperStructure,
    mut table: nlmode::nma::ModalTable,
) -> nlmode::nma::ModalTable {
    let names: Vec<String> = table.points.iter().map(|p| p.name.clone()).collect();
    table.linear_modes = ModalBasis::new(&ps.model, false)
        .unwrap()
        .linear_modes(&ps.model, 0, &names);
    table
}

fn pct(x: [f64; 3]) -> String {
    format!(
        "tip {:.2} %, force {:.2} %, peak {:+.2} %",
        100.0 * x[0],
        100.0 * x[1],
        100.0 * x[2]
    )
}

/// The paper's cases (shaker at l/3 and 2l/3, 1 to 10 V, 2 % and 10 % per
/// pseudo period, 0.8 to 1.8 omega0) against the full-order `reference`:
/// with the rate terms and the ten other modes as residual modes `nlmode`
/// is no worse than the paper's model in any figure (tip and force RMS, peak),
/// and on case (a) (2l/3, 10 V, 2 %) within 1.0 % tip RMS (issue 25's
/// target; the paper's model: 2.1 %).
#[test]
fn first_order_terms_with_residual_modes_are_no_worse_on_the_papers_cases() {
    let ps = paper::structure();
    let w0 = ps.omega0_rad_s;
    let table = with_linear_modes(&ps, paper::table(&ps));
    for (point, volts, rate) in [
        ("2l3", 10.0, 0.02),
        ("l3", 10.0, 0.02),
        ("2l3", 10.0, 0.10),
        ("2l3", 5.0, 0.02),
        ("2l3", 1.0, 0.02),
    ] {
        let sweep = LinearSweep::per_pseudo_period(w0, 0.8, 1.8, rate, volts).unwrap();
        let reference = paper::reference(&ps, point, &sweep).envelope;
        let run = |n, r| against_reference(&ps, &table, point, &sweep, &reference, (n, r));
        let (paper_model, first_order) = (run(0, false), run(10, true));
        eprintln!(
            "{point}, {volts} V, {rate}: eq:NM {}; rate terms + 10 residual modes {}; rate terms alone {}",
            pct(paper_model),
            pct(first_order),
            pct(run(0, true))
        );
        for k in 0..3 {
            assert!(
                first_order[k].abs() <= paper_model[k].abs(),
                "{point} {volts} V {rate}: {} vs {}",
                pct(first_order),
                pct(paper_model)
            );
        }
        if (point, volts, rate) == ("2l3", 10.0, 0.02) {
            assert!(first_order[0] <= 0.010, "{}", pct(first_order));
        }
    }
}

/// The linear beam (`k3 = 0`, no nonlinear error of the single-mode
/// theory) with the shaker at 2l/3 through resonance at 2 % per pseudo
/// period: the rate terms (sweep and shaker) bring `nlmode` closer to the
/// full-order transient, by a third in tip RMS and peak.
#[test]
fn on_the_linear_beam_the_rate_terms_follow_the_full_order_transient() {
    let ps = paper_linear();
    let table = with_linear_modes(&ps, paper::table(&ps));
    let sweep = LinearSweep::per_pseudo_period(ps.omega0_rad_s, 0.8, 1.3, 0.02, 1.0).unwrap();
    let reference = paper::reference(&ps, "2l3", &sweep).envelope;
    let run = |n, r| against_reference(&ps, &table, "2l3", &sweep, &reference, (n, r));
    let (plain, first_order) = (run(10, false), run(10, true));
    eprintln!(
        "linear beam, 10 residual modes: eq:NM {}; rate terms {}",
        pct(plain),
        pct(first_order)
    );
    // measured: tip 1.23 -> 0.81 %, peak -1.81 -> -1.10 %
    assert!(
        first_order[0] < 0.75 * plain[0] && first_order[2].abs() < 0.75 * plain[2].abs(),
        "{} vs {}",
        pct(first_order),
        pct(plain)
    );
}

fn paper_linear() -> nlmode::structure::PaperStructure {
    nlmode::structure::paper_structure(&nlmode::structure::PaperStructureOptions {
        k3_n_per_m3: 0.0,
        ..Default::default()
    })
    .unwrap()
}

/// The linear beam with the shaker at 2l/3 (2 V) and a lightly damped TMD
/// at the tip (the issue-25 case's: 13.8 g, 1600 N/m, damping ratio 0.02)
/// through resonance at 2 % per pseudo period: the TMD's state carried
/// (`attachments = "dynamic"`) together with the ten other modes as residual
/// modes (the attachments' states coupled through the residual receptance,
/// `nlmode::reduced::dynamic`), against the full-order `reference` of the
/// same assembly.
#[test]
fn tmd_states_with_residual_modes_follow_the_full_order_transient() {
    let ps = paper_linear();
    let w0 = ps.omega0_rad_s;
    let table = with_linear_modes(&ps, paper::table(&ps));
    let sh = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let (m_t, k_t) = (0.0138_f64, 1600.0_f64);
    let c_t = 2.0 * 0.02 * (k_t * m_t).sqrt();
    let tmd = LinearAttachment::tuned_mass_damper("tmd", "tip", m_t, k_t, c_t).unwrap();
    let sweep = LinearSweep::per_pseudo_period(w0, 0.7, 1.3, 0.02, 2.0).unwrap();
    let reference = nlmode::reference::simulate_sweep(
        &ps.model,
        &[sh.clone(), tmd.clone()],
        &sweep,
        &nlmode::reference::ReferenceOptions::default(),
    )
    .unwrap()
    .envelope;
    let p_ref = reference
        .tip_amplitude_m
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    let run = |n: usize, rate_terms: bool| {
        let mut model = ReducedModel::new(&table, "tip", "2l3")
            .unwrap()
            .with_linear_attachment(&sh, &[Complex64::new(1.0, 0.0)])
            .unwrap()
            .with_linear_attachment(&tmd, &[])
            .unwrap();
        if n > 0 {
            model = model.with_residual_modes(&table, n).unwrap();
        }
        let opts = SlowFlowOptions {
            attachments: nlmode::reduced::AttachmentStates::Dynamic,
            rate_terms,
            ..Default::default()
        };
        let r = model.simulate_sweep(&sweep, &opts).unwrap();
        let (tip, force) = paper::rms_differences(&r.envelope(), &reference, w0);
        let peak = r.summary().unwrap().peak_tip_amplitude_m / p_ref - 1.0;
        [tip, force, peak]
    };
    let (alone, residual, both) = (run(0, false), run(10, false), run(10, true));
    eprintln!(
        "linear beam + shaker + TMD, TMD carried: {}; with 10 residual modes {}; and the rate terms {}",
        pct(alone),
        pct(residual),
        pct(both)
    );
    // measured (the TMD's pole exact, nlmode::reduced::dynamic "Exact
    // poles"): 1.97 / 2.87 / -3.41 % -> 1.79 / 2.47 / -3.06 % with the
    // residual modes; the rate terms then take the peak to -0.54 % and the
    // force to 1.79 %, the tip RMS to 2.20 % (with the first-order pole:
    // 3.18 / 4.26 / -3.81, 3.14 / 3.86 / -3.35 and 3.84 / 3.23 / -0.54 %);
    // all three within issue 25's TMD targets (3 / 3 / 1 %)
    for k in 0..3 {
        assert!(
            residual[k].abs() < alone[k].abs(),
            "{} vs {}",
            pct(residual),
            pct(alone)
        );
    }
    assert!(
        both[2].abs() < 0.01 && both[1] < residual[1] && both[0] < 0.03 && both[1] < 0.03,
        "{}",
        pct(both)
    );
}

/// The carried states through the residual receptance reduce to the
/// quasi-steady residual-mode model (`eq:NM` with `Z_G -> (I + Z_G G)^-1
/// Z_G`, exact for a linear structure) in a steady state: a slow sweep
/// (1e-4 per pseudo period) of the linear beam with shaker and TMD, the TMD
/// carried or condensed, with and without residual modes. With the paper's
/// shaker alone (fast poles only) nothing is carried and the dynamic model
/// is the quasi-steady one bit for bit.
#[test]
fn carried_states_through_residual_modes_reduce_to_the_steady_condensation() {
    let ps = paper_linear();
    let w0 = ps.omega0_rad_s;
    let table = with_linear_modes(&ps, paper::table(&ps));
    let sh = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let tmd = LinearAttachment::tuned_mass_damper("tmd", "tip", 0.0138, 1600.0, 0.188).unwrap();
    let model = |with_tmd: bool, n: usize| {
        let mut m = ReducedModel::new(&table, "tip", "2l3")
            .unwrap()
            .with_linear_attachment(&sh, &[Complex64::new(1.0, 0.0)])
            .unwrap();
        if with_tmd {
            m = m.with_linear_attachment(&tmd, &[]).unwrap();
        }
        if n > 0 {
            m = m.with_residual_modes(&table, n).unwrap();
        }
        m
    };
    let opts = |states| SlowFlowOptions {
        attachments: states,
        output_samples: 401,
        ..Default::default()
    };
    use nlmode::reduced::AttachmentStates::{Dynamic, QuasiSteady};
    let slow = LinearSweep::per_pseudo_period(w0, 0.9, 1.1, 1e-4, 1.0).unwrap();
    // after the start-up transient (the first tenth: from rest the carried
    // TMD beats, the condensed one cannot)
    let run = |n: usize, states| {
        let t = tips(&model(true, n).simulate_sweep(&slow, &opts(states)).unwrap());
        t[t.len() / 10..].to_vec()
    };
    let (d0, d10, q0, q10) = (
        run(0, Dynamic),
        run(10, Dynamic),
        run(0, QuasiSteady),
        run(10, QuasiSteady),
    );
    let d = max_rel(&d10, &q10);
    // what the residual modes add, carried and condensed
    let contribution = |with: &[f64], without: &[f64]| -> Vec<f64> {
        with.iter().zip(without).map(|(a, b)| a - b).collect()
    };
    let (cd, cq) = (contribution(&d10, &d0), contribution(&q10, &q0));
    let size = cq.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let dc = cd
        .iter()
        .zip(&cq)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()))
        / size;
    let peak = q10.iter().cloned().fold(0.0, f64::max);
    eprintln!(
        "slow sweep, TMD carried vs condensed with 10 residual modes: {d:.2e} of the peak; the residual modes add up to {:.2e} of the peak, carried vs condensed {dc:.2e} of that",
        size / peak
    );
    assert!(d < 2e-2, "{d}");
    assert!(size > 1e-3 * peak && dc < 0.1, "{size} {dc}");
    let fast = LinearSweep::per_pseudo_period(w0, 0.9, 1.1, 0.02, 1.0).unwrap();
    let m = model(false, 10);
    let dynamic = m.simulate_sweep(&fast, &opts(Dynamic)).unwrap();
    let quasi = m.simulate_sweep(&fast, &opts(QuasiSteady)).unwrap();
    assert_eq!(tips(&dynamic), tips(&quasi));
}
