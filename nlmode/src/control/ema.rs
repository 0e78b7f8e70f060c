//! Virtual experimental nonlinear modal analysis: a modal table
//! ([`ModalTable`], `nlmode-modal-table` version 1) from the levels of a
//! phase-resonance test ([`super::pll`]), with the shape measured at the drive
//! point and at the response point (the tip), as a test rig with a force
//! sensor and two displacement (or acceleration) sensors gives it.
//!
//! # Derivation (force appropriation at phase resonance)
//!
//! The structure alone, with the measured force `F(t)` at the drive point as
//! its external force (the attachment is not condensed: its force is
//! measured), obeys the single-nonlinear-mode equation `eq:NMpre` with
//! `f_ex + f_c = e_d F` (`e_d` the drive point's direction). At a settled level
//! (`a' = 0`, `theta' = 0`) whose fundamental lags the force by 90 degrees, the
//! excitation frequency is the modal frequency, `Omega = omega(a)`, and
//! `eq:NMpre` reduces to its imaginary part, the force appropriation
//!
//! ```text
//! 2 D(a) omega(a)^2 a = |phi_d,1(a) F_1|,
//! ```
//!
//! `F_1` the fundamental of the measured force and `phi_d,1` the fundamental
//! of the mass-normalized shape at the drive point. The drive point moves with
//! `X_d,1 = a phi_d,1 e^{i psi_0}` (`eq:ansatz`). A single-point test cannot
//! measure the modal mass: one scaling comes from outside the nonlinear test,
//! the linear modal mass at the drive point `m_d = 1/|phi_d(0)|^2` (a low-level
//! linear modal test gives it), the one the power balance of the level took
//! ([`super::pll`]: `D_P = P / (Omega m_d sum_h (h Omega)^2 |X_h|^2)`, so `m_d`
//! is recovered from the level's `P`, `D_P` and harmonics). With it
//!
//! ```text
//! phi_d,1 = 1/sqrt(m_d),     a = |X_d,1| / phi_d,1,
//! D = P_1 phi_d,1^2 / (Omega^3 |X_d,1|^2),   P_1 = 1/2 Re(F_1 conj(i Omega X_d,1)),
//! ```
//!
//! the force appropriation of the fundamental (`2 D omega^2 a = phi_d,1
//! |F_1| sin(lag)`, the lag 90 degrees up to the settled phase error). This
//! `D` is the fundamental's, the one `eq:NM` needs; the power balance's `D_P`
//! also counts the work of the harmonics (the stinger force's third harmonic
//! grows beyond its fundamental on the paper beam), which is why
//! `phase_resonance.csv`'s `damping_ratio` differs from the table's at high
//! levels. The measured `phi_d,1` stays at its linear value while a numerical
//! mode's `|phi_d,1(a)|` changes with `a`: off phase resonance the measured
//! model's drive-point receptance is that of the linear modal mass, the
//! single-point appropriation error of the measured table.
//!
//! The shape harmonics at the points follow from the measured harmonics `X_n`
//! of each point relative to the modal phase `psi = theta + psi_0`, `psi_0 =
//! arg X_d,1` (so that `phi_d,1` is real and positive):
//!
//! ```text
//! phi_n = X_n e^{-i n psi_0} / a,     n = 0..=H.
//! ```
//!
//! Levels that did not settle, with a non-positive damping ratio, force or
//! power, or
//! whose `a` does not increase beyond the previous level's (the table's
//! amplitude must be strictly increasing) are left out and reported.
use super::pll::PllLevel;
use crate::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
use num_complex::Complex64;

/// Errors of the measured modal table; each carries the numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmaError {
    #[error(
        "measured modal table: {usable} usable level(s) of {total} (need at least 2 settled \
         levels with positive damping and force and increasing modal amplitude){skipped}"
    )]
    TooFewLevels {
        usable: usize,
        total: usize,
        /// The reasons the other levels were left out, one `; ...` each.
        skipped: String,
    },
    #[error("measured modal table: point names must be non-empty (drive '{drive}', response '{response}')")]
    BadPointName { drive: String, response: String },
}

/// A level left out of the measured table, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedLevel {
    /// The level's voltage amplitude \[V\].
    pub voltage_v: f64,
    /// Why it was left out (with its numbers).
    pub reason: String,
}

/// One level of the measured table: the modal amplitude and the measured
/// `phi_d,1` (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredModalPoint {
    /// Voltage amplitude of the level \[V\].
    pub voltage_v: f64,
    /// Modal amplitude `a` \[sqrt(kg) m\].
    pub amplitude: f64,
    /// Modal frequency (the settled excitation frequency) \[rad/s\].
    pub omega_rad_s: f64,
    /// Modal damping ratio of the fundamental's appropriation \[-\].
    pub damping_ratio: f64,
    /// `phi_d,1 = 1/sqrt(m_d)` \[1/sqrt(kg)\].
    pub phi_drive: f64,
}

/// The measured modal table and how it was made from the levels.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredModalTable {
    pub table: ModalTable,
    /// The levels in the table, in the table's order.
    pub points: Vec<MeasuredModalPoint>,
    /// The levels left out.
    pub skipped: Vec<SkippedLevel>,
}

/// The modal table of the phase-resonance `levels` (module docs): points
/// `drive_point` and `response_point` (one point if they are the same name),
/// harmonics `0..=H` with `H` the levels' demodulated order. At least two
/// levels must be usable.
pub fn modal_table_from_phase_resonance(
    levels: &[PllLevel],
    drive_point: &str,
    response_point: &str,
) -> Result<MeasuredModalTable, EmaError> {
    if drive_point.is_empty() || response_point.is_empty() {
        return Err(EmaError::BadPointName {
            drive: drive_point.into(),
            response: response_point.into(),
        });
    }
    let mut skipped = Vec::new();
    let mut used: Vec<(&PllLevel, MeasuredModalPoint)> = Vec::new();
    for l in levels {
        let (x1, f1) = (l.drive_amplitude_m(), l.force_amplitude_n());
        let skip = |reason: String| SkippedLevel {
            voltage_v: l.voltage_v,
            reason,
        };
        if !l.settled {
            skipped.push(skip(format!(
                "did not settle (phase error {:.3e} rad)",
                l.phase_error_rad
            )));
            continue;
        }
        let (w, d) = (l.omega_rad_s, l.damping_ratio);
        if !(d.is_finite() && d > 0.0 && f1.is_finite() && f1 > 0.0 && x1.is_finite() && x1 > 0.0) {
            skipped.push(skip(format!(
                "damping ratio {d:.4e}, |F_1| = {f1:.4e} N, |X_d,1| = {x1:.4e} m: expected positive"
            )));
            continue;
        }
        // the drive-point modal mass the power balance took: D = P / (Omega m_d
        // sum_h (h Omega)^2 |X_h|^2)
        let h = &l.harmonics;
        let kinetic: f64 = (1..h.drive_m.len())
            .map(|n| (n as f64 * w).powi(2) * h.drive_m[n].norm_sqr())
            .sum();
        let m_d = l.power_w / (w * d * kinetic);
        // the fundamental's power P_1 = 1/2 Re(F_1 conj(i Omega X_1))
        let p1 = 0.5 * (h.force_n[1] * (Complex64::new(0.0, w) * h.drive_m[1]).conj()).re;
        if !(m_d.is_finite() && m_d > 0.0 && p1 > 0.0) {
            skipped.push(skip(format!(
                "input power {:.4e} W, fundamental power {p1:.4e} W: expected positive",
                l.power_w
            )));
            continue;
        }
        // eq:NMpre at phase resonance: 2 D_1 omega^2 a = phi_d |F_1| sin(lag), X_d = a phi_d
        let phi_d = 1.0 / m_d.sqrt();
        let a = x1 / phi_d;
        let d = p1 * phi_d * phi_d / (w * w * w * x1 * x1);
        let p = MeasuredModalPoint {
            voltage_v: l.voltage_v,
            amplitude: a,
            omega_rad_s: w,
            damping_ratio: d,
            phi_drive: phi_d,
        };
        match used.last() {
            Some((_, prev)) if a <= prev.amplitude => skipped.push(skip(format!(
                "modal amplitude a = {a:.6e} not above the previous level's {:.6e} ({} V)",
                prev.amplitude, prev.voltage_v
            ))),
            _ => used.push((l, p)),
        }
    }
    if used.len() < 2 {
        return Err(EmaError::TooFewLevels {
            usable: used.len(),
            total: levels.len(),
            skipped: skipped
                .iter()
                .map(|s| format!("; {} V: {}", s.voltage_v, s.reason))
                .collect(),
        });
    }
    let harmonics = used
        .iter()
        .map(|(l, _)| {
            let h = &l.harmonics;
            h.drive_m.len().min(h.tip_m.len()).saturating_sub(1)
        })
        .min()
        .unwrap_or(1)
        .max(1);
    let shape = |name: &str, signal: fn(&PllLevel) -> &[Complex64]| -> PointShape {
        let (mut re, mut im) = (Vec::new(), Vec::new());
        for (l, p) in &used {
            let psi0 = l.harmonics.drive_m[1].arg();
            let x = signal(l);
            let phi: Vec<Complex64> = (0..=harmonics)
                .map(|n| x.get(n).copied().unwrap_or_default())
                .enumerate()
                .map(|(n, xn)| xn * Complex64::from_polar(1.0 / p.amplitude, -(n as f64) * psi0))
                .collect();
            re.push(phi.iter().map(|c| c.re).collect());
            im.push(phi.iter().map(|c| c.im).collect());
        }
        PointShape {
            name: name.to_string(),
            re,
            im,
        }
    };
    let mut points = vec![shape(drive_point, |l| &l.harmonics.drive_m)];
    if response_point != drive_point {
        points.push(shape(response_point, |l| &l.harmonics.tip_m));
    }
    let pts: Vec<MeasuredModalPoint> = used.iter().map(|(_, p)| *p).collect();
    let table = ModalTable {
        format: MODAL_TABLE_FORMAT.into(),
        version: MODAL_TABLE_VERSION,
        description: format!(
            "measured by a virtual phase-resonance test: {} levels ({} left out), force \
             appropriation at phase resonance (eq:NMpre), drive point '{drive_point}', \
             response point '{response_point}', H = {harmonics}",
            pts.len(),
            skipped.len()
        ),
        harmonics,
        amplitude: pts.iter().map(|p| p.amplitude).collect(),
        omega_rad_s: pts.iter().map(|p| p.omega_rad_s).collect(),
        damping_ratio: pts.iter().map(|p| p.damping_ratio).collect(),
        points,
        coordinates: Vec::new(),
        truncated_at_fold: None,
        accuracy: None,
        linear_modes: None,
    };
    Ok(MeasuredModalTable {
        table,
        points: pts,
        skipped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::PeriodHarmonics;

    /// A settled level of a single DOF (mass `m`, `phi = 1/sqrt(m)`) at phase
    /// resonance: drive = tip amplitude `x`, force from the appropriation.
    fn level(u: f64, m: f64, w: f64, d: f64, x: f64, phase: f64) -> PllLevel {
        let f = 2.0 * d * w * w * x * m; // |F_1| = 2 D w^2 a / phi, a = x sqrt(m)
        let xd = Complex64::from_polar(x, phase);
        let fh = Complex64::from_polar(f, phase + std::f64::consts::FRAC_PI_2);
        // a third harmonic at the drive point, 1 % of the fundamental
        let x3 = Complex64::from_polar(0.01 * x, 3.0 * phase + 0.2);
        let h = PeriodHarmonics {
            force_n: vec![
                Complex64::default(),
                fh,
                Complex64::default(),
                Complex64::default(),
            ],
            drive_m: vec![Complex64::default(), xd, Complex64::default(), x3],
            tip_m: vec![
                Complex64::default(),
                2.0 * xd,
                Complex64::default(),
                2.0 * x3,
            ],
            current_amplitude_a: 0.0,
        };
        PllLevel {
            voltage_v: u,
            settled: true,
            periods: 100,
            time_s: 1.0,
            omega_rad_s: w,
            phase_error_rad: 0.0,
            amplitude_change: 0.0,
            harmonics: h,
            // the power balance with m_d = m: D = P / (w m sum (h w)^2 |X_h|^2)
            power_w: d * w * m * (w * w * x * x + 9.0 * w * w * (0.01 * x).powi(2)),
            damping_ratio: d,
        }
    }

    #[test]
    fn force_appropriation_gives_the_mass_normalized_shape_and_amplitude() {
        let m = 2.0;
        let levels = [
            level(1.0, m, 100.0, 0.01, 1e-3, 0.3),
            level(2.0, m, 110.0, 0.012, 2e-3, -1.0),
            // not settled: left out
            PllLevel {
                settled: false,
                ..level(3.0, m, 120.0, 0.012, 3e-3, 0.0)
            },
            // amplitude below the previous level: left out
            level(4.0, m, 115.0, 0.012, 1.5e-3, 0.0),
            level(5.0, m, 130.0, 0.015, 4e-3, 2.0),
        ];
        let r = modal_table_from_phase_resonance(&levels, "drive", "tip").unwrap();
        r.table.validate().unwrap();
        assert_eq!(r.table.harmonics, 3);
        assert_eq!(r.skipped.len(), 2, "{:?}", r.skipped);
        assert_eq!((r.skipped[0].voltage_v, r.skipped[1].voltage_v), (3.0, 4.0));
        let phi = 1.0 / m.sqrt();
        for (j, (x, w)) in [(1e-3, 100.0), (2e-3, 110.0), (4e-3, 130.0)]
            .into_iter()
            .enumerate()
        {
            assert!((r.table.amplitude[j] / (x * m.sqrt()) - 1.0).abs() < 1e-12);
            assert_eq!(r.table.omega_rad_s[j], w);
            let d = [0.01, 0.012, 0.015][j];
            assert!((r.table.damping_ratio[j] / d - 1.0).abs() < 1e-12);
            let (d, t) = (&r.table.points[0], &r.table.points[1]);
            // drive point: real, positive, mass-normalized fundamental
            assert!((d.re[j][1] - phi).abs() < 1e-12 && d.im[j][1].abs() < 1e-12);
            assert!((t.re[j][1] - 2.0 * phi).abs() < 1e-12 && t.im[j][1].abs() < 1e-12);
            // the third harmonic relative to the modal phase: 1 % at angle 0.2
            let p3 = Complex64::new(d.re[j][3], d.im[j][3]) / phi;
            assert!(
                (p3 - Complex64::from_polar(0.01, 0.2)).norm() < 1e-12,
                "{p3}"
            );
        }
        // fewer than two usable levels: the error names the levels left out
        let e = modal_table_from_phase_resonance(&levels[2..4], "drive", "tip").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("1 usable level(s) of 2") && msg.contains("3 V: did not settle"),
            "{msg}"
        );
    }
}
