//! The nonlinear mode of the scenario's structure (or the modal table it names):
//! what every single-mode method reads (`RunContext::table`).
use crate::model::Setup;
use anyhow::{Context, Result};
use std::time::Instant;

/// The nonlinear mode used by the single-mode methods.
pub struct Nma {
    pub table: nlmode::nma::ModalTable,
    pub wall_time_s: f64,
    /// One line describing how the table was obtained.
    pub note: String,
    /// What the user must know about the table: missed accuracy targets with
    /// the worst value and where, a gap it ends at, a truncation to raise, the
    /// continuation's warnings, a stop before the requested amplitude
    /// (`summary.json` `warnings`, printed by `host run` and `host nma`).
    pub warnings: Vec<String>,
}

/// The [`NmaOptions`](nlmode::nma::NmaOptions) of the scenario's `[nma]` on
/// `setup`'s structure: mode `setup.mode_index`, amplitude range
/// `[nma] start_amplitude_m ..= max_tip_amplitude_m` at the response point,
/// every named point of the model (response point, exciter points) stored.
/// `harmonics` is `H` (the fixed order, or the candidate of `"auto"`).
pub fn nma_options(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    harmonics: usize,
    conservative: bool,
) -> nlmode::nma::NmaOptions {
    nlmode::nma::NmaOptions {
        harmonics,
        samples: sc.nma.samples,
        mode_index: setup.mode_index,
        amplitude: nlmode::nma::AmplitudeRange::Point {
            name: setup.response_point.clone(),
            start_m: sc.nma.start_amplitude_m,
            end_m: sc.nma.max_tip_amplitude_m,
        },
        conservative,
        points: setup.model.points.iter().map(|p| p.name.clone()).collect(),
        // the refinement's Newton guesses
        store_coordinates: true,
        // the table is the primary branch: the loops beyond its fold are not computed
        stop_at_first_fold: true,
        ..Default::default()
    }
}

/// An NMA error as the scenario key it comes from (`nma.mode`, `nma.samples`,
/// `nma.start_amplitude_m`, `nma.harmonics`), or `nma` for the others.
pub fn nma_error(e: nlmode::nma::NmaError) -> anyhow::Error {
    use nlmode::nma::NmaError as E;
    let key = match &e {
        E::ModeIndexOutOfRange { .. } => "nma.mode",
        E::TooFewSamples { .. } | E::TooManySamples { .. } => "nma.samples",
        E::InvalidAmplitudeRange { .. } => "nma.start_amplitude_m",
        E::NoHarmonics { .. } | E::AutoHarmonicsNotFound { .. } => "nma.harmonics",
        _ => "nma",
    };
    anyhow::anyhow!("{key}: {e}")
}

/// [`nma_error`] of the NMA's continuation: a start point where Newton does
/// not converge (the response at the start amplitude is far from linear)
/// names the scenario key the user moved from its default that makes it so:
/// `structure.k3_n_per_m3`, else `nma.start_amplitude_m`.
fn nma_start_error(sc: &crate::scenario::Scenario, e: nlmode::nma::NmaError) -> anyhow::Error {
    use crate::scenario::{BeamStructureSpec, StructureSpec};
    if !matches!(e, nlmode::nma::NmaError::StartNotConverged { .. }) {
        return nma_error(e);
    }
    let s = sc.nma.start_amplitude_m;
    let (k3, k3_default) = match &sc.structure {
        StructureSpec::Beam(b) => (b.k3_n_per_m3, BeamStructureSpec::default().k3_n_per_m3),
        StructureSpec::Matrices(m) => (m.k3_n_per_m3, 0.0),
    };
    if k3 > 0.0 && k3 != k3_default {
        anyhow::anyhow!(
            "structure.k3_n_per_m3 = {k3:e} N/m^3: the nonlinear mode cannot start ({e}); expected a cubic \
             stiffness for which the response at the start tip amplitude nma.start_amplitude_m = {s:e} m is \
             still nearly linear (a smaller k3_n_per_m3, or a smaller nma.start_amplitude_m)"
        )
    } else if s != crate::scenario::NMA_START_TIP_AMPLITUDE_M {
        anyhow::anyhow!(
            "nma.start_amplitude_m = {s:e} m: the nonlinear mode cannot start there ({e}); expected a tip \
             amplitude at which the response is still nearly linear (a smaller start_amplitude_m)"
        )
    } else {
        nma_error(e)
    }
}

/// How each `elastic-dry-friction` element's slider starts the AFT's periodic
/// march (`initial_slider`), for the notes of `host nma` and `host run`.
pub fn initial_slider_note(sc: &crate::scenario::Scenario) -> Option<String> {
    let v: Vec<String> = sc
        .nonlinearity
        .iter()
        .enumerate()
        .filter(|(_, nl)| nl.kind == crate::scenario::NonlinearityKind::ElasticDryFriction)
        .map(|(i, nl)| {
            format!(
                "'{}' initial_slider = \"{}\"",
                nl.element_name(i),
                nl.initial_slider.unwrap_or_default().as_str()
            )
        })
        .collect();
    (!v.is_empty()).then(|| format!("elastic-dry-friction: {}", v.join(", ")))
}

/// NMA of the scenario's structure (or the table file it names) on the mode
/// `setup.mode_index` ([`nma_options`]); the primary branch refined to
/// [`RefineOptions`]' default accuracy and ended its `fold_margin` before the
/// first fold ([`nlmode::nma::NmaResult::refined_table`]). With `harmonics =
/// "auto"` the order is chosen by [`nlmode::nma::auto_harmonics`].
///
/// [`RefineOptions`]: nlmode::nma::RefineOptions
/// The structure's other linear modes at the table's points, for residual
/// modes (`[slowflow] residual_modes`), with the structure's damping also
/// for a conservative table.
fn linear_modes(
    setup: &Setup,
    basis: &nlmode::nma::modal_basis::ModalBasis,
    res: &nlmode::nma::NmaResult,
    conservative: bool,
) -> Option<nlmode::nma::LinearModes> {
    use nlmode::nma::modal_basis::ModalBasis;
    if conservative {
        ModalBasis::new(&setup.model, false)
            .ok()
            .and_then(|b| b.linear_modes(&setup.model, res.mode_index, &res.point_names))
    } else {
        basis.linear_modes(&setup.model, res.mode_index, &res.point_names)
    }
}

pub fn nma_table(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    conservative: bool,
) -> Result<(Nma, Option<nlmode::nma::NmaResult>)> {
    use nlmode::nma::modal_basis::ModalBasis;
    use nlmode::nma::{
        auto_harmonics, nonlinear_modal_analysis_with_basis, RefineOptions, TablePolicy,
    };
    let t0 = Instant::now();
    if let Some(path) = &sc.nma.table {
        // a device such as /dev/zero would be read without end: regular files only
        cosim::file::open_regular(std::path::Path::new(path)).map_err(|e| {
            anyhow::anyhow!(
                "nma.table = \"{path}\": expected a modal-table JSON file (docs/modal_table.md): {e}"
            )
        })?;
        let table = nlmode::nma::ModalTable::read(std::path::Path::new(path))
            .with_context(|| format!("nma.table = \"{path}\""))?;
        let note = format!(
            "modal table read from {path} ({} points)",
            table.amplitude.len()
        );
        let warnings = table
            .accuracy
            .as_ref()
            .map(|a| a.warnings())
            .unwrap_or_default();
        return Ok((
            Nma {
                table,
                wall_time_s: t0.elapsed().as_secs_f64(),
                note,
                warnings,
            },
            None,
        ));
    }
    let basis = std::sync::Arc::new(
        ModalBasis::new(&setup.model, conservative).map_err(|e| anyhow::anyhow!("nma: {e}"))?,
    );
    let mut auto_note = String::new();
    let harmonics = match sc.nma.harmonics.fixed() {
        Some(h) => h,
        None => {
            let opts = nma_options(setup, sc, 1, conservative);
            let a = auto_harmonics(
                &setup.model,
                basis.clone(),
                &opts,
                TablePolicy::PrimaryBranch,
                &RefineOptions::default(),
                1,
            )
            .map_err(|e| nma_start_error(sc, e))?;
            let (_, dw, dd, ds) = a.tried.last().copied().unwrap_or_default();
            auto_note = format!(
                ", harmonics = \"auto\": H = {} agrees with H = {} within omega {dw:.1e}, D {dd:.1e}, shapes {ds:.1e}",
                a.harmonics,
                a.harmonics + nlmode::nma::AUTO_HARMONICS_STEP
            );
            a.harmonics
        }
    };
    let opts = nma_options(setup, sc, harmonics, conservative);
    let mut warnings = Vec::new();
    // a continuation failure keeps the branch computed so far (the note says so)
    let (res, failure) = match nonlinear_modal_analysis_with_basis(
        &setup.model,
        basis.clone(),
        &opts,
    ) {
        Ok(r) => (r, String::new()),
        Err(e) => match e.partial() {
            Some(p) if p.branch.len() >= 2 => {
                let b = p.branch.last().expect("non-empty");
                let w = format!(
                    "nma: {e}; the modal table ends at the branch computed so far (last point a = {:.4e}, omega = {:.2} rad/s)",
                    b.amplitude, b.omega_rad_s
                );
                warnings.push(w.clone());
                (p.clone(), format!("; warning: {w}"))
            }
            _ => return Err(nma_start_error(sc, e)),
        },
    };
    warnings.extend(res.warnings.iter().map(|w| format!("nma: {w}")));
    let linear_modes = linear_modes(setup, &basis, &res, conservative);
    let table = res
        .refined_table(
            &setup.model,
            basis,
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .map_err(nma_error)?;
    let mut table = table;
    table.linear_modes = linear_modes;
    if let Some(acc) = &table.accuracy {
        warnings.extend(acc.warnings());
    }
    warnings.extend(fold_warning(&res, &table));
    let wall = t0.elapsed().as_secs_f64();
    let fold = match table.truncated_at_fold {
        Some(a) => format!(
            ", primary branch to the first fold a = {a:.4e}, tabulated up to a = {:.4e}",
            table.amplitude.last().copied().unwrap_or(f64::NAN)
        ),
        None => String::new(),
    };
    let acc = match &table.accuracy {
        Some(acc) => format!(
            ", PCHIP within omega {:.1e}, D {:.1e}, shapes {:.1e} (relative; {} HB checks{})",
            acc.omega_rel,
            acc.damping_rel,
            acc.shape_rel,
            acc.checks,
            if acc.capped { ", capped" } else { "" }
        ),
        None => String::new(),
    };
    let slider = initial_slider_note(sc)
        .map(|n| format!(", {n}"))
        .unwrap_or_default();
    let note = format!(
        "NMA (H = {}, {} AFT samples, mode {}, {}): {} branch points, {} in the refined table{acc}, {} Newton iterations, {:.1} ms{fold}{auto_note}{slider}",
        res.harmonics,
        res.samples,
        sc.nma.mode,
        if conservative { "conservative" } else { "damped" },
        res.branch.len(),
        table.amplitude.len(),
        res.newton_iterations,
        1e3 * wall
    ) + &failure;
    Ok((
        Nma {
            table,
            wall_time_s: wall,
            note,
            warnings,
        },
        Some(res),
    ))
}

/// The warning for a table that ends at a fold of the amplitude that is not
/// an internal resonance (e.g. a friction chain whose mode shape changes
/// through slip): past it `a` is not single-valued, so no single-mode table
/// can go on, while the backbone (`*_branch.csv`) continues. A fold at an
/// internal resonance is described in the note's loop list instead.
pub fn fold_warning(
    res: &nlmode::nma::NmaResult,
    table: &nlmode::nma::ModalTable,
) -> Option<String> {
    let a_fold = table.truncated_at_fold?;
    let fold = res.folds.iter().find(|f| f.amplitude == a_fold)?;
    if fold.internal_resonance.is_some() {
        return None;
    }
    let a_max = res.branch.iter().map(|b| b.amplitude).fold(0.0, f64::max);
    let d_max = res
        .branch
        .iter()
        .map(|b| b.damping_ratio)
        .fold(0.0, f64::max);
    Some(format!(
        "modal table: ends at a fold of the modal amplitude at a = {a_fold:.4e} (omega = {:.2} rad/s; not an internal resonance): beyond it a is not single-valued, so the single-mode methods stop there; the backbone continues to a = {a_max:.4e} (damping ratio up to {d_max:.3}) in the *_branch.csv files; for responses past the fold use `hb` (the full model)",
        fold.omega_rad_s
    ))
}
