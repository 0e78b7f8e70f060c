//! Steady state of `eq:NM` (`a' = theta' = 0`): all roots in `a` of
//! `a |K(a, Omega)| = |phi(a)^H f_ex(a, Omega)|` at each `Omega`, their
//! stability from the slow-flow Jacobian, and the single-mode linear steady
//! state (`linear-steady`, `eq:LMss`) with the force drop (`eq:forcedrop`).
use super::output::{Channels, OutputStates};
use super::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use crate::table::TableError;
use num_complex::Complex64;
use serde::Serialize;

/// One steady-state solution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SteadyPoint {
    /// Excitation frequency \[rad/s\].
    pub omega_rad_s: f64,
    /// Modal amplitude `a` \[sqrt(kg) m\].
    pub a: f64,
    /// Phase lag `theta` \[rad\].
    pub theta_rad: f64,
    /// Stable as a fixed point of the slow flow (both Jacobian eigenvalues in
    /// the open left half plane).
    pub stable: bool,
    /// Eigenvalues of the 2 x 2 slow-flow Jacobian at the fixed point \[1/s\].
    pub eigenvalues: [Complex64; 2],
    /// `omega(a)` in force \[rad/s\].
    pub modal_frequency_rad_s: f64,
    /// Fundamental tip amplitude \[m\].
    pub tip_amplitude_m: f64,
    /// Fundamental drive-point amplitude \[m\].
    pub drive_amplitude_m: f64,
    /// Fundamental drive-point force amplitude \[N\].
    pub force_amplitude_n: f64,
    /// Force phase relative to the excitation \[rad\].
    pub force_phase_rad: f64,
}

/// All steady-state solutions at one frequency, sorted by amplitude.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SteadyFrequency {
    pub omega_rad_s: f64,
    pub solutions: Vec<SteadyPoint>,
    /// `a |K| < |phi^H f|` still holds at the table's largest amplitude: a
    /// further solution may exist above the range, where the model is undefined.
    pub exceeds_table: bool,
}

/// The single-mode linear steady state (`linear-steady`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearSteady {
    pub points: Vec<SteadyPoint>,
    /// Linear natural frequency used (`omega0`, frequency error applied) \[rad/s\].
    pub omega0_rad_s: f64,
    /// `|F|` at the structural resonance `Omega = omega0` \[N\].
    pub force_at_resonance_n: f64,
    /// Blocked force `|F0| = |T_G u_hat|` at `omega0` \[N\].
    pub blocked_force_at_resonance_n: f64,
    /// `1 - |F|/|F0|` at `Omega = omega0` (`eq:forcedrop`).
    pub force_drop: f64,
}

/// Brent's root finder on a bracket `[a, b]` with `f(a) f(b) <= 0`.
/// Hand-written (a few lines; no root-finding crate is among the workspace's
/// dependencies) so that it takes a fallible closure.
fn brent(
    mut f: impl FnMut(f64) -> Result<f64, ReducedError>,
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
    xtol: f64,
) -> Result<f64, ReducedError> {
    if fa == 0.0 {
        return Ok(a);
    }
    if fb == 0.0 {
        return Ok(b);
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if fb * fc > 0.0 {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 0.5 * xtol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return Ok(b);
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b)?;
    }
    Ok(b)
}

impl ReducedModel {
    /// All steady-state solutions of `eq:NM` at each `Omega` for the sweep
    /// amplitude `amplitude` (`u_hat`).
    ///
    /// Roots of `R(a) = a^2 |K(a, Omega)|^2 - |phi^H f_ex|^2` on `[0, a_max]` (the
    /// squared form has the same roots and needs no square roots): `R` is
    /// sampled on the table's grid refined adaptively where `K` or the modal
    /// force vary (see `refine_scan`), the resonance dip
    /// (where `Re K` changes sign, i.e. `omega(a)^2 + Re Z_A = Omega^2`, often
    /// narrower than a grid cell) is located by Brent's method on `Re K` and
    /// added to the samples, and every sign change of `R` is refined by Brent's
    /// method.
    pub fn steady_state(
        &self,
        omegas: &[f64],
        amplitude: f64,
    ) -> Result<Vec<SteadyFrequency>, ReducedError> {
        let (_, amax) = self.table.amplitude_range();
        // R and Re K are sampled at a = 0 and at the table's nodes, where the
        // interpolant equals the tabulated values: gather them once.
        let mut scan: Vec<f64> = vec![0.0];
        scan.extend(self.grid.iter().copied().filter(|&a| a <= amax));
        let mut node_data = Vec::with_capacity(scan.len());
        for &a in &scan {
            let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
            let p = self.gather(a, &mut phi)?;
            node_data.push((p, phi));
        }
        let xtol = 1e-14 * self.a_scale;
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        let mut counts = Vec::with_capacity(omegas.len());
        let mut fixed = FixedPoints::default();
        let mut samples: Vec<(f64, f64, f64)> = Vec::with_capacity(4 * scan.len());
        let mut nodes: Vec<(f64, Complex64, Complex64)> = Vec::with_capacity(scan.len());
        for &w in omegas {
            self.fill_channels(w, amplitude, &mut ch)?;
            let fi = self.imposed_at(w)?;
            let terms = |a: f64| -> Result<(f64, f64), ReducedError> {
                let (k, f, _, _) = self.nm_terms(a, w, &ch, fi)?;
                Ok((a * a * k.norm_sqr() - f.norm_sqr(), k.re))
            };
            // K and F at the nodes, then adaptive refinement between them
            nodes.clear();
            for (&a, (p, phi)) in scan.iter().zip(&node_data) {
                let (k, f, _) = self.terms_with(p, phi, w, &ch, &fi);
                nodes.push((a, k, f));
            }
            samples.clear();
            let r_of =
                |a: f64, k: Complex64, f: Complex64| (a, a * a * k.norm_sqr() - f.norm_sqr(), k.re);
            samples.push(r_of(nodes[0].0, nodes[0].1, nodes[0].2));
            for j in 0..nodes.len() - 1 {
                self.refine_scan(nodes[j], nodes[j + 1], 0, w, &ch, fi, &mut |a, k, f| {
                    samples.push(r_of(a, k, f))
                })?;
            }
            // resonance dips (often narrower than a grid cell): where Re K
            // changes sign, |K| is smallest
            let n0 = samples.len();
            for j in 0..n0 - 1 {
                let (a0, _, k0) = samples[j];
                let (a1, _, k1) = samples[j + 1];
                if k0 * k1 < 0.0 {
                    let ab = brent(|a| Ok(terms(a)?.1), a0, a1, k0, k1, xtol)?;
                    let (r, kr) = terms(ab)?;
                    samples.push((ab, r, kr));
                }
            }
            samples.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut solutions = Vec::new();
            for j in 0..samples.len() {
                let (a0, r0, _) = samples[j];
                if r0 == 0.0 {
                    solutions.push(a0);
                    continue;
                }
                if j + 1 < samples.len() {
                    let (a1, r1, _) = samples[j + 1];
                    if r0 * r1 < 0.0 {
                        solutions.push(brent(|a| Ok(terms(a)?.0), a0, a1, r0, r1, xtol)?);
                    }
                }
            }
            let exceeds_table = samples.last().map(|s| s.1 < 0.0).unwrap_or(false);
            counts.push((w, solutions.len(), exceeds_table));
            for a in solutions {
                let (k, f, _, _) = self.nm_terms(a, w, &ch, fi)?;
                // A = a e^{i theta} with K A = f  =>  theta = arg f - arg K
                let amp = if a > 0.0 {
                    Complex64::from_polar(a, f.arg() - k.arg())
                } else {
                    Complex64::new(0.0, 0.0)
                };
                fixed.push(self, w, amp, &ch, fi)?;
            }
        }
        // the output quantities of all fixed points in one batch
        let mut points = self.steady_points(&fixed)?.into_iter();
        Ok(counts
            .into_iter()
            .map(|(w, count, exceeds_table)| SteadyFrequency {
                omega_rad_s: w,
                solutions: points.by_ref().take(count).collect(),
                exceeds_table,
            })
            .collect())
    }

    /// Adaptive sampling of `K(a)`, `F(a)` on `[p0.a, p1.a]` for the root scan:
    /// an interval is bisected (geometrically) while `K` or `F` change by more
    /// than 10 % of their smaller magnitude, so that `R(a)` is resolved wherever
    /// the modal properties, the attachment impedance or the distance to
    /// resonance vary (the table's own grid can be far coarser, e.g. where an
    /// NMA took large steps). Where `K` and `F` are nearly constant,
    /// `R = a^2 |K|^2 - |F|^2` increases monotonically and has at most one root.
    /// Pushes the right end of every final sub-interval.
    #[allow(clippy::too_many_arguments)]
    fn refine_scan(
        &self,
        p0: (f64, Complex64, Complex64),
        p1: (f64, Complex64, Complex64),
        depth: usize,
        w: f64,
        ch: &[Complex64],
        fi: ImposedForces,
        push: &mut dyn FnMut(f64, Complex64, Complex64),
    ) -> Result<(), ReducedError> {
        let (a0, k0, f0) = p0;
        let (a1, k1, f1) = p1;
        let split = depth < 16
            && a0 > 0.0
            && ((k1 - k0).norm_sqr() > 0.01 * k0.norm_sqr().min(k1.norm_sqr())
                || (f1 - f0).norm_sqr() > 0.01 * f0.norm_sqr().min(f1.norm_sqr()));
        if !split {
            push(a1, k1, f1);
            return Ok(());
        }
        let am = (a0 * a1).sqrt();
        let (km, fm, _, _) = self.nm_terms(am, w, ch, fi)?;
        let pm = (am, km, fm);
        self.refine_scan(p0, pm, depth + 1, w, ch, fi, push)?;
        self.refine_scan(pm, p1, depth + 1, w, ch, fi, push)
    }

    /// Output quantities and stability of collected fixed points.
    fn steady_points(&self, fixed: &FixedPoints) -> Result<Vec<SteadyPoint>, ReducedError> {
        let n = fixed.omega.len();
        let imposed_n: &[Complex64] = if self.imposed_at_drive() {
            &fixed.imposed_n
        } else {
            &[]
        };
        let samples = self.output_samples(&OutputStates {
            t_s: &vec![f64::NAN; n],
            omega_rad_s: &fixed.omega,
            amplitude: &fixed.amplitude,
            channels: Channels::Rows(&fixed.channels),
            imposed_n,
        })?;
        Ok(samples
            .iter()
            .zip(&fixed.eigenvalues)
            .map(|(s, &eigenvalues)| SteadyPoint {
                omega_rad_s: s.omega_rad_s,
                a: s.a,
                theta_rad: s.theta_rad(),
                stable: eigenvalues.iter().all(|l| l.re < 0.0),
                eigenvalues,
                modal_frequency_rad_s: s.modal_frequency_rad_s,
                tip_amplitude_m: s.tip_amplitude_m,
                drive_amplitude_m: s.drive_amplitude_m,
                force_amplitude_n: s.force_amplitude_n,
                force_phase_rad: s.force_phase_rad(),
            })
            .collect())
    }

    /// Eigenvalues of the slow-flow Jacobian `d(Re A', Im A')/d(Re A, Im A)` at
    /// fixed `Omega` (central differences; one-sided at the top of the table).
    fn jacobian_eigenvalues(
        &self,
        w: f64,
        amp: Complex64,
        ch: &[Complex64],
        fi: ImposedForces,
    ) -> Result<[Complex64; 2], ReducedError> {
        let y = [amp.re, amp.im];
        let h = 1e-7 * amp.norm().max(1e-6 * self.a_scale);
        let mut j = [[0.0; 2]; 2];
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        for c in 0..2 {
            let mut yp = y;
            let mut ym = y;
            yp[c] += h;
            ym[c] -= h;
            let f0 = self.rhs(&y, w, ch, &fi, &mut phi)?;
            let (fp, fm, den) = match (
                self.rhs(&yp, w, ch, &fi, &mut phi),
                self.rhs(&ym, w, ch, &fi, &mut phi),
            ) {
                (Ok(fp), Ok(fm)) => (fp, fm, 2.0 * h),
                (Err(ReducedError::Table(TableError::AboveRange { .. })), Ok(fm)) => (f0, fm, h),
                (Ok(fp), Err(ReducedError::Table(TableError::AboveRange { .. }))) => (fp, f0, h),
                (Err(e), _) | (_, Err(e)) => return Err(e),
            };
            for r in 0..2 {
                j[r][c] = (fp[r] - fm[r]) / den;
            }
        }
        let tr = j[0][0] + j[1][1];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        let disc = Complex64::new(0.25 * tr * tr - det, 0.0).sqrt();
        Ok([0.5 * tr + disc, 0.5 * tr - disc])
    }

    /// The single-mode linear steady state (`linear-steady`): constant `omega0`,
    /// `D0`, `phi0` ([`Self::linear`]), `A = phi0^H f_ex / K(Omega)` at each
    /// `Omega`, and the force drop `1 - |F|/|F0|` at `Omega = omega0`
    /// (`eq:forcedrop`, here from the generic attachment model).
    pub fn linear_steady(
        &self,
        omegas: &[f64],
        amplitude: f64,
    ) -> Result<LinearSteady, ReducedError> {
        let lin = self.linear()?;
        let mut ch = vec![Complex64::new(0.0, 0.0); lin.nch];
        let (omega0, _) = lin.linear_properties()?;
        let mut fixed = FixedPoints::default();
        // the requested frequencies, then omega0 for the force drop
        for &w in omegas.iter().chain([&omega0]) {
            lin.fill_channels(w, amplitude, &mut ch)?;
            let fi = lin.imposed_at(w)?;
            let (k, f, _, _) = lin.nm_terms(0.0, w, &ch, fi)?;
            fixed.push(&lin, w, f / k, &ch, fi)?;
        }
        let mut points = lin.steady_points(&fixed)?;
        let res = points.pop().ok_or(ReducedError::EmptyResult)?;
        let f0 = lin.blocked_force(omega0, amplitude)?.norm();
        Ok(LinearSteady {
            points,
            omega0_rad_s: omega0,
            force_at_resonance_n: res.force_amplitude_n,
            blocked_force_at_resonance_n: f0,
            force_drop: 1.0 - res.force_amplitude_n / f0,
        })
    }
}

/// Fixed points of the slow flow collected for one batched output evaluation.
#[derive(Debug, Default)]
struct FixedPoints {
    omega: Vec<f64>,
    amplitude: Vec<Complex64>,
    /// The channels of each point in turn (`nch` per point).
    channels: Vec<Complex64>,
    /// The imposed force at the drive point of each point (output column).
    imposed_n: Vec<Complex64>,
    eigenvalues: Vec<[Complex64; 2]>,
}

impl FixedPoints {
    /// Adds the fixed point `A` at `Omega` with its stability eigenvalues.
    fn push(
        &mut self,
        model: &ReducedModel,
        w: f64,
        amp: Complex64,
        ch: &[Complex64],
        fi: ImposedForces,
    ) -> Result<(), ReducedError> {
        self.eigenvalues
            .push(model.jacobian_eigenvalues(w, amp, ch, fi)?);
        self.omega.push(w);
        self.amplitude.push(amp);
        self.channels.extend_from_slice(ch);
        self.imposed_n.push(model.drive_imposed(&fi));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_roots_to_tolerance() {
        let f = |x: f64| Ok(x * x * x - 2.0 * x - 5.0);
        let r = brent(f, 2.0, 3.0, -1.0, 16.0, 1e-14).unwrap();
        assert!((r - 2.0945514815423265).abs() < 1e-13, "{r}");
        let g = |x: f64| Ok((x - 0.3).signum());
        let r = brent(g, 0.0, 1.0, -1.0, 1.0, 1e-12).unwrap();
        assert!((r - 0.3).abs() < 1e-11, "{r}");
    }
}
