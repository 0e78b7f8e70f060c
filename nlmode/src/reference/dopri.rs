//! The assembled system integrated by the explicit adaptive Dormand-Prince 5(4)
//! of [`crate::dopri`] (the one implementation, shared with the slow flow),
//! kept for comparison with the exponential method.
//!
//! The right-hand side is evaluated into the integrator's preallocated
//! `nalgebra` vectors; the error of a component is scaled by the running
//! maximum of its modulus (the states oscillate through zero), and the step
//! follows the elementary controller (on case (a) 87 k steps against 120 k
//! with the PI controller: the step is bounded by stability, not accuracy).
//! Samples on the output grid come from the method's 4th-order continuous
//! extension.
//!
//! The method is explicit: its stable step is bounded by about `3.3 / |lambda_max|`
//! of the assembled system (stinger and Craig-Bampton modes), which is what makes
//! it slow here and useless for the unreduced FE model.
use super::assembly::FirstOrderSystem;
use super::{IntegrationStats, ReferenceError, SampleGrid, StepControl};
use crate::dopri::{self, Controller, ErrorScale, Stop, Tolerances};
use nalgebra::DVector;

/// Integrate from `z0` at `t = 0` over the sample grid, calling
/// `on_sample(i, z, element_states)` at `t = i dt`.
pub(crate) fn integrate(
    sys: &FirstOrderSystem,
    z0: &DVector<f64>,
    grid: SampleGrid,
    input: &super::InputSignals,
    ctl: &StepControl,
    on_sample: &mut super::SampleWithStates,
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    let (dt, n) = (grid.interval_s, grid.count);
    let nz = sys.nz();
    let t_end = n as f64 * dt;
    let mut f = vec![0.0; sys.m()];
    // hysteretic element states: frozen over a step (the stages evaluate the
    // elements from the state at the step start), advanced once it is accepted
    let states = std::cell::RefCell::new(sys.initial_element_states(z0));
    let hysteretic = sys.has_hysteresis();
    let rhs = |t: f64, z: &DVector<f64>, dz: &mut DVector<f64>| -> Result<(), ReferenceError> {
        sys.rhs(&input(t), z, &states.borrow(), &mut f, dz);
        Ok(())
    };
    let tol = Tolerances {
        rtol: ctl.rtol,
        atol: DVector::from_element(nz, ctl.atol),
        controller: Controller::Integral,
        scale: ErrorScale::RunningMax,
        h_max: t_end,
        h_min: 1e-14 * t_end.max(dt),
        max_steps: ctl.max_steps,
        h0: Some((1e-3 * dt).min(t_end)),
    };
    let mut zmax = z0.abs();
    let mut sample_z = DVector::zeros(nz);
    let mut next_sample = 1usize;
    let mut next_progress = 0.0;
    on_sample(0, z0, &states.borrow());
    let (stats, stop) = dopri::integrate(rhs, 0.0, z0.clone(), t_end, &tol, |d, z| {
        // samples inside (t, t + h] from the continuous extension
        let t_new = d.t0 + d.h;
        while next_sample <= n && (next_sample as f64 * dt) <= t_new * (1.0 + 1e-14) {
            let ts = (next_sample as f64 * dt).clamp(d.t0, t_new);
            d.eval_into(ts, &mut sample_z);
            on_sample(next_sample, &sample_z, &states.borrow());
            next_sample += 1;
        }
        if hysteretic {
            sys.advance_element_states(z, &mut states.borrow_mut());
        }
        ctl.check_state(z, zmax.as_mut_slice(), t_new)?;
        let frac = t_new / t_end;
        if frac >= next_progress {
            progress(frac.min(1.0));
            next_progress = frac + 0.01;
        }
        Ok(())
    });
    let stats = IntegrationStats {
        steps: stats.accepted_steps,
        rejected: stats.rejected_steps,
        rhs_evals: stats.rhs_evaluations,
        ..Default::default()
    };
    match stop {
        None => Ok(stats),
        // the assembled right-hand side cannot fail: errors come from the
        // state checks of the observer
        Some(Stop::Rhs { error, .. } | Stop::Observer { error, .. }) => Err(error),
        Some(Stop::StepTooSmall { t, h }) => Err(ReferenceError::StepSizeCollapse {
            time_s: t,
            step_s: h,
        }),
        Some(Stop::MaxSteps { t }) => Err(ReferenceError::TooManySteps {
            time_s: t,
            steps: ctl.max_steps,
        }),
        Some(Stop::NotFinite { t }) => Err(ReferenceError::NonFinite { time_s: t }),
    }
}
