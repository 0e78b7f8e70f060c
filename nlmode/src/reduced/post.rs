//! Post-processing (paper Section 3.2, 5.2): physical displacements from
//! `eq:ansatz` with all harmonics of the mode, the interface forces of
//! `eq:fc1` at the fundamental and their higher harmonics (`eq:fc1` holds at
//! any frequency, so harmonic `n` of the coupling force is
//! `F_n = -Z_G(n Omega) u_G,n + delta_{n1} T_G(Omega) u_hat`), and time signals
//! synthesized along a sweep for overlay with the reference.
use super::sweep::OmegaCache;
use super::{ImposedForces, ReducedError, ReducedModel, SlowFlowResult, MAX_INTERFACE};
use num_complex::Complex64;
use serde::Serialize;

/// Time signals synthesized from a slow-flow result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeSignals {
    pub t_s: Vec<f64>,
    /// Excitation frequency \[rad/s\].
    pub omega_rad_s: Vec<f64>,
    /// Tip displacement with all harmonics \[m\].
    pub tip_m: Vec<f64>,
    /// Drive-point displacement with all harmonics \[m\].
    pub drive_m: Vec<f64>,
    /// Force on the structure at the drive point with all harmonics \[N\].
    pub force_n: Vec<f64>,
}

impl ReducedModel {
    /// Displacement harmonics `q_n = a phi_n(a) e^{i n theta}`, `n = 0..=H`, of
    /// the named point for the complex modal amplitude `A = a e^{i theta}`
    /// (`eq:ansatz`: `q(t) = Re(sum_n q_n e^{i n Phi})`) \[m\].
    pub fn displacement_harmonics(
        &self,
        point: &str,
        amp: Complex64,
    ) -> Result<Vec<Complex64>, ReducedError> {
        let p = self.table.point_index(point)?;
        self.harmonics_at(p, amp)
    }

    fn harmonics_at(&self, p: usize, amp: Complex64) -> Result<Vec<Complex64>, ReducedError> {
        let a = amp.norm();
        let mut phi = vec![Complex64::new(0.0, 0.0); self.table.harmonics() + 1];
        self.table.shape_all(p, a, &mut phi)?;
        let e = if a > 0.0 {
            amp / a
        } else {
            Complex64::new(1.0, 0.0)
        };
        Ok(phi
            .iter()
            .enumerate()
            .map(|(n, ph)| a * ph * e.powu(n as u32))
            .collect())
    }

    /// Fundamental interface forces on the structure of every attachment,
    /// `F_G = -Z_G(Omega) u_G + T_G(Omega) u_hat` (`eq:fc1`), one vector per
    /// attachment (one entry per interface point) \[N\].
    pub fn interface_forces(
        &self,
        omega_rad_s: f64,
        amplitude: f64,
        amp: Complex64,
    ) -> Result<Vec<Vec<Complex64>>, ReducedError> {
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        self.fill_channels(omega_rad_s, amplitude, &mut ch)?;
        let a = amp.norm();
        let mut out: Vec<Vec<Complex64>> = Vec::with_capacity(self.ports.len());
        for port in &self.ports {
            let nc = port.points.len();
            let u = port
                .points
                .iter()
                .map(|&p| Ok(self.table.shape(p, 1, a)? * amp))
                .collect::<Result<Vec<_>, ReducedError>>()?;
            let o = port.offset;
            out.push(
                (0..nc)
                    .map(|r| {
                        ch[o + nc * nc + r]
                            - (0..nc)
                                .map(|c| ch[o + r * nc + c] * u[c])
                                .sum::<Complex64>()
                    })
                    .collect(),
            );
        }
        // residual modes merge every attachment into one port: split it again
        if let Some(res) = &self.residual {
            if let Some(merged) = out.pop() {
                let mut rest = merged.as_slice();
                for &k in &res.split {
                    let (head, tail) = rest.split_at(k.min(rest.len()));
                    out.push(head.to_vec());
                    rest = tail;
                }
            }
        }
        Ok(out)
    }

    /// Harmonics `F_n`, `n = 0..=H`, of the force on the structure at the
    /// drive point (all attachments there, plus the imposed force at `n = 1`)
    /// \[N\]: `F(t) = Re(sum_n F_n e^{i n Phi})`.
    pub fn force_harmonics(
        &self,
        omega_rad_s: f64,
        amplitude: f64,
        amp: Complex64,
    ) -> Result<Vec<Complex64>, ReducedError> {
        let h = self.table.harmonics();
        let mut chs = vec![vec![Complex64::new(0.0, 0.0); self.nch]; h + 1];
        for (n, ch) in chs.iter_mut().enumerate() {
            self.fill_channels_at(
                n as f64 * omega_rad_s,
                if n == 1 { amplitude } else { 0.0 },
                ch,
            )?;
        }
        let fi = self.imposed_at(omega_rad_s)?;
        self.force_harmonics_with(&chs, amp, fi)
    }

    /// `chs[n]`: channels at `n Omega` (with `T_G u_hat` only in `chs[1]`).
    fn force_harmonics_with(
        &self,
        chs: &[Vec<Complex64>],
        amp: Complex64,
        fi: ImposedForces,
    ) -> Result<Vec<Complex64>, ReducedError> {
        let h = self.table.harmonics();
        let a = amp.norm();
        let e = if a > 0.0 {
            amp / a
        } else {
            Complex64::new(1.0, 0.0)
        };
        let mut out = vec![Complex64::new(0.0, 0.0); h + 1];
        let mut phis = vec![Complex64::new(0.0, 0.0); h + 1];
        let mut u = vec![[Complex64::new(0.0, 0.0); MAX_INTERFACE]; h + 1];
        for port in &self.ports {
            let nc = port.points.len();
            for (c, &p) in port.points.iter().enumerate() {
                self.table.shape_all(p, a, &mut phis)?;
                for n in 0..=h {
                    u[n][c] = a * phis[n] * e.powu(n as u32);
                }
            }
            let o = port.offset;
            for (r, &p) in port.points.iter().enumerate() {
                if p != self.drive {
                    continue;
                }
                for n in 0..=h {
                    let ch = &chs[n];
                    let mut z = Complex64::new(0.0, 0.0);
                    for c in 0..nc {
                        z += ch[o + r * nc + c] * u[n][c];
                    }
                    out[n] += -z;
                    if n == 1 {
                        out[n] += ch[o + nc * nc + r];
                    }
                }
            }
        }
        if self.imposed_at_drive() && h >= 1 {
            out[1] += self.drive_imposed(&fi);
        }
        Ok(out)
    }

    /// Adds the residual modes' displacement at every harmonic `n` to the tip
    /// and drive-point harmonics: `G(n Omega) F_G,n` with the interface
    /// forces `F_G,n = delta_{n1} T_G u_hat - Z_G(n Omega) u_G,n` of the
    /// merged port (`chs[n]`, the residual flexibility already in them) and
    /// the imposed forces at `n = 1` ([`super::residual`]).
    fn add_residual_harmonics(
        &self,
        chs: &[Vec<Complex64>],
        amp: Complex64,
        fi: ImposedForces,
        omega: f64,
        tip: &mut [Complex64],
        drive: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        let Some(res) = &self.residual else {
            return Ok(());
        };
        let h = self.table.harmonics();
        let mut add = |n: usize, point: usize, f: Complex64| {
            let w = n as f64 * omega;
            tip[n] += res.modes.receptance(self.tip, point, w) * f;
            drive[n] += res.modes.receptance(self.drive, point, w) * f;
        };
        if let Some(port) = self.ports.first() {
            let nc = port.points.len();
            let u = port
                .points
                .iter()
                .map(|&p| self.harmonics_at(p, amp))
                .collect::<Result<Vec<_>, _>>()?;
            for (r, &pr) in port.points.iter().enumerate() {
                for n in 0..=h {
                    let ch = &chs[n];
                    let mut f = if n == 1 {
                        ch[port.offset + nc * nc + r]
                    } else {
                        Complex64::new(0.0, 0.0)
                    };
                    for (c, uc) in u.iter().enumerate() {
                        f -= ch[port.offset + r * nc + c] * uc[n];
                    }
                    add(n, pr, f);
                }
            }
        }
        if h >= 1 {
            for (imp, &f) in self.imposed.iter().zip(fi.forces()) {
                add(1, imp.point, f);
            }
        }
        Ok(())
    }

    /// Time signals with all harmonics at the times `t_s` (inside the
    /// result's time span): `A(t)` interpolated linearly between the output
    /// samples, `Phi(t)` exact from the sweep, displacements from `eq:ansatz`,
    /// force harmonics from `eq:fc1` at `n Omega` (attachment quantities
    /// tabulated per harmonic over the sweep's range, as in the integration).
    pub fn synthesize(
        &self,
        result: &SlowFlowResult,
        t_s: &[f64],
        opts_channel_tol: f64,
    ) -> Result<TimeSignals, ReducedError> {
        let sweep = &result.sweep;
        let h = self.table.harmonics();
        let (lo, hi) = {
            let (s, e) = (sweep.omega_start_rad_s, sweep.omega_end_rad_s);
            (s.min(e), s.max(e))
        };
        let mut caches = Vec::with_capacity(h + 1);
        let mut ch0 = vec![Complex64::new(0.0, 0.0); self.nch];
        self.fill_channels_at(0.0, 0.0, &mut ch0)?;
        for n in 1..=h {
            let amp = if n == 1 { sweep.amplitude } else { 0.0 };
            caches.push(OmegaCache::build(
                self,
                n as f64 * lo,
                n as f64 * hi,
                amp,
                opts_channel_tol,
            )?);
        }
        let mut chs = vec![vec![Complex64::new(0.0, 0.0); self.nch]; h + 1];
        chs[0] = ch0;
        let mut out = TimeSignals {
            t_s: Vec::with_capacity(t_s.len()),
            omega_rad_s: Vec::with_capacity(t_s.len()),
            tip_m: Vec::with_capacity(t_s.len()),
            drive_m: Vec::with_capacity(t_s.len()),
            force_n: Vec::with_capacity(t_s.len()),
        };
        for &t in t_s {
            let Some(amp) = result.amplitude_at(t) else {
                continue;
            };
            let w = sweep.omega_rad_s(t);
            let phase = Complex64::from_polar(1.0, sweep.phase_rad(t));
            for n in 1..=h {
                caches[n - 1].eval(n as f64 * w, &mut chs[n]);
            }
            let fi = self.imposed_at(w)?;
            let fh = self.force_harmonics_with(&chs, amp, fi)?;
            let synth = |c: &[Complex64]| {
                c.iter()
                    .enumerate()
                    .map(|(n, x)| (x * phase.powu(n as u32)).re)
                    .sum::<f64>()
            };
            let mut tip = self.harmonics_at(self.tip, amp)?;
            let mut drive = self.harmonics_at(self.drive, amp)?;
            if self.residual.is_some() {
                self.add_residual_harmonics(&chs, amp, fi, w, &mut tip, &mut drive)?;
            }
            out.t_s.push(t);
            out.omega_rad_s.push(w);
            out.tip_m.push(synth(&tip));
            out.drive_m.push(synth(&drive));
            out.force_n.push(synth(&fh));
        }
        Ok(out)
    }
}
