//! Explicit adaptive Dormand-Prince 5(4) (Hairer, Norsett & Wanner, *Solving
//! ODEs I*, Table II.5.2), kept for comparison with the exponential method.
//!
//! Hand-written rather than taken from a crate because the loop must evaluate
//! the right-hand side into preallocated `nalgebra` vectors (the assembled system
//! is evaluated millions of times), report our typed errors with time and step,
//! and sample on the output grid by dense output; it is 100 lines. Samples
//! between steps use the cubic Hermite interpolant of `z` and `z'` at both step
//! ends (FSAL gives `z'` for free), accurate to `O(h^4)`.
//!
//! The method is explicit: its stable step is bounded by about `3.3 / |lambda_max|`
//! of the assembled system (stinger and Craig-Bampton modes), which is what makes
//! it slow here and useless for the unreduced FE model.
use super::assembly::FirstOrderSystem;
use super::{IntegrationStats, ReferenceError, SampleGrid, StepControl};
use nalgebra::DVector;

const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// Fifth-order solution minus the embedded fourth-order one.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Integrate from `z0` at `t = 0` over the sample grid, calling `on_sample(i, z)`
/// at `t = i dt`.
pub(crate) fn integrate(
    sys: &FirstOrderSystem,
    z0: &DVector<f64>,
    grid: SampleGrid,
    input: &dyn Fn(f64) -> f64,
    ctl: &StepControl,
    on_sample: &mut dyn FnMut(usize, &DVector<f64>),
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    let (dt, n) = (grid.interval_s, grid.count);
    let nz = sys.nz();
    let mut f = vec![0.0; sys.m()];
    let mut stats = IntegrationStats::default();
    let t_end = n as f64 * dt;
    let mut t = 0.0;
    let mut z = z0.clone();
    let mut k: Vec<DVector<f64>> = (0..7).map(|_| DVector::zeros(nz)).collect();
    let mut stage = DVector::zeros(nz);
    let mut znew = DVector::zeros(nz);
    let mut zmax = z.abs();
    let mut sample_z = DVector::zeros(nz);
    sys.rhs(input(0.0), &z, &mut f, &mut k[0]);
    stats.rhs_evals += 1;
    let mut h = (1e-3 * dt).min(t_end);
    let mut next_sample = 1usize;
    on_sample(0, &z);
    let mut next_progress = 0.0;
    while next_sample <= n {
        if stats.steps + stats.rejected >= ctl.max_steps {
            return Err(ReferenceError::TooManySteps {
                time_s: t,
                steps: ctl.max_steps,
            });
        }
        if h < 1e-14 * t.max(dt) {
            return Err(ReferenceError::StepSizeCollapse {
                time_s: t,
                step_s: h,
            });
        }
        h = h.min(t_end - t).max(0.0);
        if h <= 0.0 {
            // only rounding remains: emit the last sample at t_end
            h = 1e-14 * t_end;
        }
        for st in 1..7 {
            stage.copy_from(&z);
            for (j, a) in A[st].iter().enumerate().take(st) {
                if *a != 0.0 {
                    stage.axpy(h * a, &k[j], 1.0);
                }
            }
            let (head, tail) = k.split_at_mut(st);
            let _ = head;
            sys.rhs(input(t + C[st] * h), &stage, &mut f, &mut tail[0]);
            stats.rhs_evals += 1;
        }
        // stage 7 was evaluated at the fifth-order solution (FSAL)
        znew.copy_from(&stage);
        let mut acc = 0.0;
        for i in 0..nz {
            let mut e = 0.0;
            for (j, ej) in E.iter().enumerate() {
                e += ej * k[j][i];
            }
            let sc = ctl.atol + ctl.rtol * zmax[i].max(znew[i].abs());
            acc += (h * e / sc).powi(2);
        }
        let err = (acc / nz as f64).sqrt();
        if !err.is_finite() {
            if !znew.iter().all(|x| x.is_finite()) && h < 1e-10 * dt {
                return Err(ReferenceError::NonFinite { time_s: t });
            }
            stats.rejected += 1;
            h *= 0.2;
            continue;
        }
        if err > 1.0 {
            stats.rejected += 1;
            h *= (0.9 * err.powf(-0.2)).max(0.2);
            continue;
        }
        // accepted: samples inside (t, t + h] by Hermite interpolation
        let t_new = t + h;
        while next_sample <= n && (next_sample as f64 * dt) <= t_new * (1.0 + 1e-14) {
            let ts = next_sample as f64 * dt;
            let th = ((ts - t) / h).clamp(0.0, 1.0);
            let h00 = (1.0 + 2.0 * th) * (1.0 - th) * (1.0 - th);
            let h10 = th * (1.0 - th) * (1.0 - th);
            let h01 = th * th * (3.0 - 2.0 * th);
            let h11 = th * th * (th - 1.0);
            sample_z.copy_from(&z);
            sample_z.scale_mut(h00);
            sample_z.axpy(h10 * h, &k[0], 1.0);
            sample_z.axpy(h01, &znew, 1.0);
            sample_z.axpy(h11 * h, &k[6], 1.0);
            on_sample(next_sample, &sample_z);
            next_sample += 1;
        }
        t = t_new;
        std::mem::swap(&mut z, &mut znew);
        k.swap(0, 6);
        stats.steps += 1;
        ctl.check_state(&z, zmax.as_mut_slice(), t)?;
        let frac = t / t_end;
        if frac >= next_progress {
            progress(frac.min(1.0));
            next_progress = frac + 0.01;
        }
        h *= (0.9 * err.max(1e-10).powf(-0.2)).clamp(0.2, 5.0);
    }
    Ok(stats)
}
