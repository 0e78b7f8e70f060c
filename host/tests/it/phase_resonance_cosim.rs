//! `phase-resonance` with `model = "cosim"`: the controller FMU closing the
//! loop around the structure FMU (single nonlinear mode) and the shaker FMU,
//! against the phase-locked loop on the full-order reference, per voltage
//! level (paper beam, exciter at 2l/3, default loop options).
//!
//! Measured (test profile, two tests running at once on two shared cores;
//! relative differences cosim / reference - 1):
//!
//! | master, h | U [V] | omega | q_tip,1 | x_drive,1 | F_1 | loop time |
//! |---|---|---|---|---|---|---|
//! | iterative, 1e-5 s | 1 | -3.5e-6 | -3.8e-4 | -3.8e-4 | -4.5e-4 | 44 s for both levels (268k macro steps; reference PLL 1.0 s) |
//! | iterative, 1e-5 s | 5 | 7.1e-5 | 2.3e-4 | 2.3e-4 | -2.45e-2 | |
//! | jacobi, 1e-5 s | 1 | 5.9e-6 | 7.6e-4 | 7.6e-4 | 6.9e-4 | 41 s (270k macro steps) |
//! | jacobi, 1e-5 s | 5 | 2.4e-4 | 1.3e-3 | 1.3e-3 | -2.47e-2 | |
//!
//! Frequency and response amplitudes agree within 1.3e-3. The force
//! fundamental at 5 V is 2.5 % below the reference's with the structure
//! FMU's default, `eq:NM`'s projection of the force on the mode's
//! fundamental: at phase resonance the fundamental only balances the
//! damping, and the stinger force's third harmonic (`|F_3|/|F_1|` = 0.92 at
//! 5 V) works on the mode's own third harmonic at the drive point, a 2.5 %
//! share of the input power (`phase_resonance.rs`) that this projection does
//! not see (12 % at 10 V). So the fundamental tolerance of the default is
//! 3 % at 5 V and 1 % at 1 V; `harmonic_force_projection` (the force on every
//! harmonic of the mode, `nlmode::oscillator` module `projection`) takes the
//! power in and is within 1 % up to 10 V (the last test). The first test
//! runs the linear range (0.5 and 1 V) at 2e-5 s; the others run 1e-5 s
//! (about 3-5 s each in the test profile).
use crate::common::tmpdir;
use host::controlled::{phase_resonance, PHASE_RESONANCE_COLUMNS};
use host::methods;
use host::model::Setup;
use host::scenario::{PhaseResonanceModel, Scenario};
use std::time::Instant;

/// The structure FMU's options of a run.
#[derive(Clone, Copy)]
struct StructureOptions {
    residual_modes: usize,
    harmonic_force_projection: bool,
}

const SINGLE_MODE: StructureOptions = StructureOptions {
    residual_modes: 0,
    harmonic_force_projection: false,
};

#[allow(clippy::needless_range_loop)] // the levels of two envelopes and their tolerances
fn compare(
    name: &str,
    algorithm: &str,
    macro_step_s: f64,
    levels: &[f64],
    force_tol: &[f64],
    structure: StructureOptions,
) -> Vec<String> {
    let list: Vec<String> = levels.iter().map(|u| format!("{u:?}")).collect();
    let text = format!(
        "[run]\nmethods = [\"phase-resonance\"]\n[[exciter]]\nlocation = \"2l/3\"\n\
         [output]\nplots = false\n[cosim]\nalgorithm = \"{algorithm}\"\nmacro_step_s = {macro_step_s}\n\
         residual_modes = {}\nharmonic_force_projection = {}\n\
         [phase_resonance]\nvoltage_levels_v = [{}]\n",
        structure.residual_modes,
        structure.harmonic_force_projection,
        list.join(", ")
    );
    let mut sc = Scenario::parse(&text).unwrap();
    let setup = Setup::new(&sc).unwrap();
    let (nma, _) = methods::nma_table(&setup, &sc, false).unwrap();
    let t0 = Instant::now();
    let reference =
        phase_resonance(&setup, &sc, &nma.table, &tmpdir(&format!("{name}-ref"))).unwrap();
    let t_ref = t0.elapsed().as_secs_f64();
    sc.phase_resonance.model = PhaseResonanceModel::Cosim;
    let dir = tmpdir(&format!("{name}-{algorithm}"));
    let t0 = Instant::now();
    let r = phase_resonance(&setup, &sc, &nma.table, &dir).unwrap();
    let t_cosim = t0.elapsed().as_secs_f64();
    eprintln!(
        "reference PLL {t_ref:.2} s, three-FMU loop {t_cosim:.2} s ({:?} macro steps)",
        r.summary.get::<u64>("steps")
    );
    // the remedy named where the force's harmonics do work (module docs)
    let (remedy, others): (Vec<String>, Vec<String>) = r
        .summary
        .warnings
        .iter()
        .cloned()
        .partition(|w| w.contains("set [cosim] harmonic_force_projection = true"));
    assert!(others.is_empty(), "{others:?}");
    assert!(remedy.is_empty() || !structure.harmonic_force_projection);
    let csv = std::fs::read_to_string(dir.join("phase_resonance.csv")).unwrap();
    eprintln!("{csv}");
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(&header[..7], &PHASE_RESONANCE_COLUMNS[..]);
    assert_eq!(csv.lines().count(), levels.len() + 1);
    assert_eq!(
        r.summary.get::<bool>("harmonic_force_projection"),
        structure.harmonic_force_projection.then_some(true)
    );
    let (a, b) = (&reference.envelope, &r.envelope);
    for i in 0..levels.len() {
        let rel = |x: f64, y: f64| x / y - 1.0;
        let dw = rel(b.omega_rad_s[i], a.omega_rad_s[i]);
        let dq = rel(b.tip_amplitude_m[i], a.tip_amplitude_m[i]);
        let df = rel(b.force_amplitude_n[i], a.force_amplitude_n[i]);
        let dd = rel(
            b.drive_amplitude_m.as_ref().unwrap()[i],
            a.drive_amplitude_m.as_ref().unwrap()[i],
        );
        eprintln!(
            "level {i} ({} V): omega {dw:.2e}, |q_tip,1| {dq:.2e}, |F_1| {df:.2e}, |x_drive,1| {dd:.2e}",
            levels[i]
        );
        for d in [dw, dq, dd] {
            assert!(d.abs() < 0.01, "{d}");
        }
        // the force fundamental: see the module docs
        assert!(df.abs() < force_tol[i], "{df}");
    }
    remedy
}

#[test]
fn three_fmu_loop_matches_the_reference_pll() {
    let remedy = compare(
        "linear",
        "iterative",
        2e-5,
        &[0.5, 1.0],
        &[0.01, 0.01],
        SINGLE_MODE,
    );
    assert!(remedy.is_empty(), "{remedy:?}");
}

#[test]
fn three_fmu_loop_matches_the_reference_pll_up_the_backbone() {
    let remedy = compare(
        "backbone",
        "iterative",
        1e-5,
        &[1.0, 5.0],
        &[0.01, 0.03],
        SINGLE_MODE,
    );
    // 5 V: the harmonics' 2.5 % share of the power, the remedy named
    assert_eq!(remedy.len(), 1, "{remedy:?}");
    assert!(remedy[0].contains("at 5 V"), "{remedy:?}");
    eprintln!("{}", remedy[0]);
}

/// The structure FMU with its ten residual modes (`[cosim] residual_modes`,
/// issue 25) and the fundamental projection: the stinger force's higher
/// harmonics drive the beam's other modes. Measured (test profile): 1 V
/// omega -2.9e-6, q_tip -3.8e-4, F_1 -4.5e-4; 5 V omega 7.1e-5, q_tip
/// 2.2e-4, **F_1 -2.45e-2**, the same as the single mode to 1e-5. So the
/// force fundamental's deficit at 5 V is not the other modes' linear
/// response to the force harmonics (the residual modes carry that, and it
/// is small: their receptance at 3 Omega is a few per cent of the mode's at
/// resonance) but the force's work on the mode's own harmonics, which the
/// projection on the fundamental drops (the last test). The tolerances stay
/// those of the single mode.
#[test]
fn three_fmu_loop_with_residual_modes_up_the_backbone() {
    let structure = StructureOptions {
        residual_modes: 10,
        ..SINGLE_MODE
    };
    compare(
        "residual",
        "iterative",
        1e-5,
        &[1.0, 5.0],
        &[0.01, 0.03],
        structure,
    );
}

/// Issue 25's target: the three-FMU loop with the structure FMU's force on
/// every harmonic of the mode (`harmonic_force_projection`,
/// `nlmode::oscillator` module `projection`) and its ten residual modes,
/// within 1 % of the reference PLL in the settled frequency, the response
/// and the force fundamentals at 1, 5 and 10 V. Measured (test profile,
/// iterative master, 1e-5 s; omega / q_tip,1 / F_1 / x_drive,1):
///
/// | U [V] | omega | q_tip,1 | F_1 | x_drive,1 |
/// |---|---|---|---|---|
/// | 1 | -2.9e-6 | -3.8e-4 | -3.8e-4 | -3.8e-4 |
/// | 5 | -3.9e-5 | -3.3e-4 | -1.2e-3 | -3.3e-4 |
/// | 10 | -2.2e-5 | -2.5e-4 | -2.4e-3 | -2.6e-4 |
///
/// (Without the residual modes: F_1 -1.6e-3 at 5 V, -5.5e-3 at 10 V.)
/// The force fundamental is the figure the projection moves (the single
/// mode's -2.45e-2 at 5 V and -1.24e-1 at 10 V): the stinger force's third
/// harmonic, `|F_3|/|F_1|` = 0.9 and 2.0, works on the mode's own third
/// harmonic at the drive point. The tolerance, 1 %, is the issue's; a
/// projection on the fundamental alone misses it by 2.5 and 12 times.
#[test]
fn three_fmu_loop_with_harmonic_projection_within_one_percent() {
    let structure = StructureOptions {
        residual_modes: 10,
        harmonic_force_projection: true,
    };
    compare(
        "projection",
        "iterative",
        1e-5,
        &[1.0, 5.0, 10.0],
        &[0.01; 3],
        structure,
    );
}

/// More harmonics than the controller FMU outputs: an error naming the key,
/// before anything is packaged or run.
#[test]
fn too_many_harmonics_name_the_key() {
    let text = "[run]\nmethods = [\"phase-resonance\"]\n[[exciter]]\nlocation = \"2l/3\"\n\
                [output]\nplots = false\n\
                [phase_resonance]\nmodel = \"cosim\"\nvoltage_levels_v = [1.0]\n\
                [phase_resonance.pll]\nharmonics = 7\n";
    let sc = Scenario::parse(text).unwrap();
    let setup = Setup::new(&sc).unwrap();
    let (nma, _) = methods::nma_table(&setup, &sc, false).unwrap();
    let dir = tmpdir("harmonics");
    let e = phase_resonance(&setup, &sc, &nma.table, &dir).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("phase_resonance.pll.harmonics = 7") && msg.contains("at most 5"),
        "{msg}"
    );
    assert!(!dir.join("phase_resonance_fmus").exists());
}
