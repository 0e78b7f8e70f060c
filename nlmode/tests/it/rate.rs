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
