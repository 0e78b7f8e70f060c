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
}

/// NMA of the scenario's structure (or the table file it names) on the mode
/// `setup.mode_index`, amplitude range at the response point, every named point
/// of the model (response point, exciter points) in the table; the primary
/// branch refined to [`RefineOptions`]' default accuracy and ended its
/// `fold_margin` before the first fold ([`nlmode::nma::NmaResult::refined_table`]).
///
/// [`RefineOptions`]: nlmode::nma::RefineOptions
pub fn nma_table(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    conservative: bool,
) -> Result<(Nma, Option<nlmode::nma::NmaResult>)> {
    use nlmode::nma::epmc::ModalBasis;
    use nlmode::nma::{
        nonlinear_modal_analysis_with_basis, AmplitudeRange, NmaOptions, RefineOptions, TablePolicy,
    };
    let t0 = Instant::now();
    if let Some(path) = &sc.nma.table {
        let table = nlmode::nma::ModalTable::read(std::path::Path::new(path))
            .with_context(|| "nma.table".to_string())?;
        let note = format!(
            "modal table read from {path} ({} points)",
            table.amplitude.len()
        );
        return Ok((
            Nma {
                table,
                wall_time_s: t0.elapsed().as_secs_f64(),
                note,
            },
            None,
        ));
    }
    let opts = NmaOptions {
        harmonics: sc.nma.harmonics,
        mode_index: setup.mode_index,
        amplitude: AmplitudeRange::Point {
            name: setup.response_point.clone(),
            start_m: crate::scenario::NMA_START_TIP_AMPLITUDE_M,
            end_m: sc.nma.max_tip_amplitude_m,
        },
        conservative,
        points: setup.model.points.iter().map(|p| p.name.clone()).collect(),
        // the refinement's Newton guesses
        store_coordinates: true,
        // the table is the primary branch: the loops beyond its fold are not computed
        stop_at_first_fold: true,
        ..Default::default()
    };
    let basis = std::sync::Arc::new(
        ModalBasis::new(&setup.model, conservative).map_err(|e| anyhow::anyhow!("nma: {e}"))?,
    );
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
                    "; warning: {e}; table from the branch computed so far (last point a = {:.4e}, omega = {:.2} rad/s)",
                    b.amplitude, b.omega_rad_s
                );
                (p.clone(), w)
            }
            _ => return Err(anyhow::anyhow!("nma: {e}")),
        },
    };
    let table = res
        .refined_table(
            &setup.model,
            basis,
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .map_err(|e| anyhow::anyhow!("nma: {e}"))?;
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
    let note = format!(
        "NMA (H = {}, {}): {} branch points, {} in the refined table{acc}, {} Newton iterations, {:.1} ms{fold}",
        res.harmonics,
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
        },
        Some(res),
    ))
}
