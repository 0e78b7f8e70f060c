//! Residual modes (`[slowflow] residual_modes = N`): the nonlinear mode plus
//! `N` linear modes of the structure for the remaining dynamics.
//!
//! # Model
//!
//! The structure's displacement at the table points is the nonlinear mode
//! (`eq:ansatz`) plus linear modes `r = 1..N` of the underlying linear
//! structure other than the continued one (mass-normalised shapes `phi_r`,
//! natural frequencies `omega_r`, modal damping ratios `zeta_r`; stored in the
//! modal table, [`crate::table::LinearModes`]):
//!
//! ```text
//! x = Re( a sum_n psi_n(a) e^{i n (Phi + theta)} ) + sum_r phi_r eta_r,
//! eta_r'' + 2 zeta_r omega_r eta_r' + omega_r^2 eta_r = phi_r^T f_G(t).
//! ```
//!
//! The linear modes are driven by the interface forces `f_G` (attachments and
//! imposed forces) and, being linear and far from the nonlinear mode's
//! frequency, are taken in steady state at each harmonic `n` of the force:
//! `eta_r,n = h_r(n Omega) phi_r^T F_G,n` with the modal receptance
//! `h_r(W) = 1 / (omega_r^2 - W^2 + 2 i zeta_r omega_r W)`. At the interface
//! points this is the residual receptance
//!
//! ```text
//! G(W) = sum_r phi_r,G phi_r,G^T h_r(W)              (ncon x ncon, symmetric),
//! ```
//!
//! and the interface displacement is `u_G = psi_G A + G F_G`. With the
//! attachments of `eq:fc1`, `F_G = -Z_G u_G + T_G u_hat`, so
//!
//! ```text
//! F_G = S (-Z_G psi_G A + T_G u_hat),     S = (I + Z_G G)^{-1}:
//! Z_G -> S Z_G,   T_G -> S T_G,
//! ```
//!
//! the attachments seen through the residual flexibility of the structure
//! (a shaker in series with the other modes' receptance at its stinger).
//! `eq:NM` keeps its form with these `Z_G`, `T_G`; every port of the model is
//! merged into one ([`ThroughResidual`]) because `G` couples the attachments.
//! The outputs add the residual displacement `G(tip, G) F_G` (and the imposed
//! forces' `G(tip, j) F_j`) to the nonlinear mode's fundamental.
//!
//! # What it captures and what it cannot
//!
//! - The quasi-static and dynamic flexibility of the other modes under the
//!   exciters' forces at the fundamental (the force of a stiff stinger at
//!   an exciter point deforms the structure beyond the nonlinear mode's
//!   shape), and at every harmonic `n Omega` of the force in the
//!   post-processing (power the exciter's higher harmonics put into other
//!   modes, e.g. the third harmonic near a second mode at `3 Omega`).
//! - Not: any coupling through the nonlinearity. A residual mode is linear;
//!   energy exchanged with the nonlinear mode through the nonlinear element
//!   (a true internal resonance, `omega_r ~ k omega(a)`) needs a second
//!   nonlinear mode. [`ResidualModes::internal_resonances`] names such modes.
//! - Not: a residual mode near the sweep band's fundamental (its own
//!   transient is not carried; it is in steady state at each `Omega`).
//!
//! With `N = 0` the model is the paper's (the code path is not entered).
use super::{
    AttachmentModelError, Condensed, ImposedForces, InterfaceModel, Port, ReducedError,
    ReducedModel,
};
use crate::table::ModalTable;
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::sync::Arc;

type CMat = DMatrix<Complex64>;

/// The linear modes kept beside the nonlinear mode, at the table's points.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualModes {
    omega_rad_s: Vec<f64>,
    damping_ratio: Vec<f64>,
    /// `shapes[p][r]`: mode `r` at table point `p` \[m / (sqrt(kg) m)\].
    shapes: Vec<Vec<f64>>,
}

impl ResidualModes {
    /// The lowest `n` linear modes stored in `table` (`n >= 1`). Errors name
    /// `residual_modes` and the number available.
    pub fn from_table(table: &ModalTable, n: usize) -> Result<Self, ReducedError> {
        let bad = |why: String| ReducedError::ResidualModes { requested: n, why };
        let lm = table.linear_modes.as_ref().ok_or_else(|| {
            bad(
                "the modal table has no linear modes (`linear_modes`: tables from `host nma` \
                 carry them; measured tables and files written before do not)"
                    .into(),
            )
        })?;
        if n == 0 || n > lm.len() {
            return Err(bad(format!(
                "expected 1 to {} (the linear modes the modal table carries)",
                lm.len()
            )));
        }
        lm.validate(&table.points)?;
        Ok(Self {
            omega_rad_s: lm.omega_rad_s[..n].to_vec(),
            damping_ratio: lm.damping_ratio[..n].to_vec(),
            shapes: lm.points.iter().map(|p| p.shape[..n].to_vec()).collect(),
        })
    }

    /// Number of modes.
    pub fn len(&self) -> usize {
        self.omega_rad_s.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.omega_rad_s.is_empty()
    }

    /// Natural frequencies \[rad/s\].
    pub fn omega_rad_s(&self) -> &[f64] {
        &self.omega_rad_s
    }

    /// `(omega_r, zeta_r)` of mode `r` \[rad/s, -\].
    pub(crate) fn mode(&self, r: usize) -> (f64, f64) {
        (self.omega_rad_s[r], self.damping_ratio[r])
    }

    /// Mode `r` at table point `p` \[m / (sqrt(kg) m)\].
    pub(crate) fn shape(&self, p: usize, r: usize) -> f64 {
        self.shapes[p][r]
    }

    /// Modal receptance `h_r(W)` and its derivative `dh_r/dW`.
    #[inline]
    fn modal(&self, r: usize, w: f64) -> (Complex64, Complex64) {
        let (wr, z) = (self.omega_rad_s[r], self.damping_ratio[r]);
        let den = Complex64::new(wr * wr - w * w, 2.0 * z * wr * w);
        let h = den.inv();
        (h, -Complex64::new(-2.0 * w, 2.0 * z * wr) * h * h)
    }

    /// Residual receptance `G_pq(W) = sum_r phi_r(p) phi_r(q) h_r(W)` between
    /// table points `p` and `q` \[m/N\].
    pub fn receptance(&self, p: usize, q: usize, omega_rad_s: f64) -> Complex64 {
        (0..self.len())
            .map(|r| self.shapes[p][r] * self.shapes[q][r] * self.modal(r, omega_rad_s).0)
            .sum()
    }

    /// `G` and `dG/dW` between the points `rows` and `cols`.
    pub(crate) fn receptance_matrix(&self, points: &[usize], w: f64) -> (CMat, CMat) {
        let n = points.len();
        let (mut g, mut dg) = (CMat::zeros(n, n), CMat::zeros(n, n));
        for r in 0..self.len() {
            let (h, dh) = self.modal(r, w);
            for (i, &p) in points.iter().enumerate() {
                for (j, &q) in points.iter().enumerate() {
                    let s = self.shapes[p][r] * self.shapes[q][r];
                    g[(i, j)] += h * s;
                    dg[(i, j)] += dh * s;
                }
            }
        }
        (g, dg)
    }

    /// Modes within `tol` (relative) of an integer multiple `k = 2..=harmonics`
    /// of a frequency in `[omega_min, omega_max]` \[rad/s\]: `(mode, k)`.
    /// Through the nonlinear element such a mode exchanges energy with the
    /// nonlinear mode (an internal resonance), which residual modes cannot
    /// represent.
    pub fn internal_resonances(
        &self,
        omega_min: f64,
        omega_max: f64,
        harmonics: usize,
        tol: f64,
    ) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (r, &wr) in self.omega_rad_s.iter().enumerate() {
            for k in 2..=harmonics.min(64) {
                let k_f = k as f64;
                if wr >= k_f * omega_min * (1.0 - tol) && wr <= k_f * omega_max * (1.0 + tol) {
                    out.push((r, k));
                    break;
                }
            }
        }
        out
    }
}

/// All attachments of a model seen through the residual flexibility (module
/// docs): `Z_G -> S Z_G`, `T_G -> S T_G`, `S = (I + Z_G G)^{-1}`, with `Z_G`,
/// `T_G` block diagonal over the attachments (inputs concatenated).
#[derive(Debug)]
struct ThroughResidual {
    name: String,
    parts: Vec<Arc<dyn InterfaceModel>>,
    /// Table point of each interface constraint, all attachments in turn.
    points: Vec<usize>,
    point_names: Vec<String>,
    modes: Arc<ResidualModes>,
}

impl ThroughResidual {
    /// Block-diagonal `Z_G`, `T_G` (and their derivatives) of the parts.
    fn stacked(&self, w: f64, derivative: bool) -> Result<[CMat; 4], AttachmentModelError> {
        let nc = self.points.len();
        let ni: usize = self.parts.iter().map(|p| p.ninput()).sum();
        let mut out = [
            CMat::zeros(nc, nc),
            CMat::zeros(nc, ni),
            CMat::zeros(nc, nc),
            CMat::zeros(nc, ni),
        ];
        let (mut r0, mut i0) = (0, 0);
        for part in &self.parts {
            let ((z, t), (dz, dt)) = if derivative {
                part.condense_with_derivative(w)?
            } else {
                let c = part.condense(w)?;
                let (z0, t0) = (CMat::zeros(0, 0), CMat::zeros(0, 0));
                (c, (z0, t0))
            };
            let (m, k) = (z.nrows(), t.ncols());
            if z.ncols() != m || t.nrows() != m || r0 + m > nc || i0 + k > ni {
                return Err(format!(
                    "attachment '{}': condensed sizes {}x{} / {}x{} do not match its interface",
                    part.name(),
                    z.nrows(),
                    z.ncols(),
                    t.nrows(),
                    t.ncols()
                )
                .into());
            }
            out[0].view_mut((r0, r0), (m, m)).copy_from(&z);
            out[1].view_mut((r0, i0), (m, k)).copy_from(&t);
            if derivative {
                out[2].view_mut((r0, r0), (m, m)).copy_from(&dz);
                out[3].view_mut((r0, i0), (m, k)).copy_from(&dt);
            }
            r0 += m;
            i0 += k;
        }
        Ok(out)
    }

    fn through(
        &self,
        w: f64,
        derivative: bool,
    ) -> Result<(Condensed, Condensed), AttachmentModelError> {
        let [z, t, dz, dt] = self.stacked(w, derivative)?;
        let (g, dg) = self.modes.receptance_matrix(&self.points, w);
        let nc = self.points.len();
        let s = (CMat::identity(nc, nc) + &z * &g).try_inverse().ok_or_else(|| {
            format!(
                "I + Z_G G is singular at Omega = {w} rad/s (the attachments resonate on the residual modes alone)"
            )
        })?;
        let (ze, te) = (&s * &z, &s * &t);
        if !derivative {
            return Ok(((ze, te), (CMat::zeros(0, 0), CMat::zeros(0, 0))));
        }
        // dS = -S (dZ G + Z dG) S
        let ds = -(&s * (&dz * &g + &z * &dg) * &s);
        let dze = &ds * &z + &s * &dz;
        let dte = &ds * &t + &s * &dt;
        Ok(((ze, te), (dze, dte)))
    }
}

impl InterfaceModel for ThroughResidual {
    fn name(&self) -> &str {
        &self.name
    }
    fn interface_points(&self) -> Vec<String> {
        self.point_names.clone()
    }
    fn ninput(&self) -> usize {
        self.parts.iter().map(|p| p.ninput()).sum()
    }
    fn condense(&self, omega_rad_s: f64) -> Result<Condensed, AttachmentModelError> {
        Ok(self.through(omega_rad_s, false)?.0)
    }
    fn condense_with_derivative(
        &self,
        omega_rad_s: f64,
    ) -> Result<(Condensed, Condensed), AttachmentModelError> {
        self.through(omega_rad_s, true)
    }
}

/// The residual modes of a [`ReducedModel`] and how its original ports were
/// merged.
#[derive(Debug, Clone)]
pub(crate) struct Residual {
    pub modes: Arc<ResidualModes>,
    /// Interface points of each original attachment (the merged port's rows
    /// in turn), to split its forces per attachment.
    pub split: Vec<usize>,
    /// The original ports (their attachments' states are carried through
    /// the merged port with `attachments = "dynamic"`, [`super::dynamic`]).
    pub ports: Vec<Port>,
}

impl ReducedModel {
    /// Adds `n` residual modes from `table` (the table this model was made
    /// from; module docs). Must come after every attachment; `n = 0` returns
    /// the model unchanged (the paper's `eq:NM`).
    pub fn with_residual_modes(
        mut self,
        table: &ModalTable,
        n: usize,
    ) -> Result<Self, ReducedError> {
        if n == 0 {
            return Ok(self);
        }
        let bad = |why: String| ReducedError::ResidualModes { requested: n, why };
        if self.residual.is_some() {
            return Err(bad("residual modes were added already".into()));
        }
        if table.points.len() != self.point_names.len()
            || table
                .points
                .iter()
                .zip(&self.point_names)
                .any(|(p, q)| &p.name != q)
        {
            return Err(bad(
                "the modal table is not the one the model was made from".into(),
            ));
        }
        let modes = Arc::new(ResidualModes::from_table(table, n)?);
        let split: Vec<usize> = self.ports.iter().map(|p| p.points.len()).collect();
        let originals = self.ports.clone();
        if !self.ports.is_empty() {
            let ports = std::mem::take(&mut self.ports);
            let points: Vec<usize> = ports.iter().flat_map(|p| p.points.clone()).collect();
            let merged = ThroughResidual {
                name: ports
                    .iter()
                    .map(|p| p.model.name().to_string())
                    .collect::<Vec<_>>()
                    .join("+"),
                parts: ports.iter().map(|p| p.model.clone()).collect(),
                point_names: points
                    .iter()
                    .map(|&p| self.point_names[p].clone())
                    .collect(),
                points: points.clone(),
                modes: modes.clone(),
            };
            let port = Port {
                model: Arc::new(merged),
                points,
                input: ports.iter().flat_map(|p| p.input.clone()).collect(),
                offset: 0,
            };
            self.nch = port.nchannels();
            self.ports.push(port);
        }
        self.residual = Some(Residual {
            modes,
            split,
            ports: originals,
        });
        Ok(self)
    }

    /// The residual modes, if any.
    pub fn residual_modes(&self) -> Option<&ResidualModes> {
        self.residual.as_ref().map(|r| r.modes.as_ref())
    }

    /// Residual displacements `G(p, G) F_G + sum_j G(p, j) F_j` at the table
    /// points `targets` (module docs) for the channel row `ch` at `Omega`,
    /// the fundamental shapes `phi_g` at the merged port's points and the
    /// complex modal amplitude `amp` \[m\]; zeros without residual modes.
    pub(crate) fn residual_displacements<const K: usize>(
        &self,
        omega_rad_s: f64,
        ch: &[Complex64],
        phi_g: &[Complex64],
        amp: Complex64,
        imposed: ImposedForces,
        targets: [usize; K],
    ) -> [Complex64; K] {
        let mut out = [Complex64::new(0.0, 0.0); K];
        let Some(res) = &self.residual else {
            return out;
        };
        let modes = &res.modes;
        // the modal forces phi_r^T F of the residual modes, then
        // sum_r phi_r(target) h_r(Omega) phi_r^T F: each h_r once
        let mut g = [Complex64::new(0.0, 0.0); crate::table::MAX_LINEAR_MODES];
        let g = &mut g[..modes.len()];
        let mut add = |point: usize, force: Complex64| {
            for (r, g) in g.iter_mut().enumerate() {
                *g += modes.shapes[point][r] * force;
            }
        };
        if let Some(port) = self.ports.first() {
            let nc = port.points.len();
            for (r, &pr) in port.points.iter().enumerate() {
                let mut f = ch[port.offset + nc * nc + r];
                for (c, phi) in phi_g.iter().enumerate().take(nc) {
                    f -= ch[port.offset + r * nc + c] * phi * amp;
                }
                add(pr, f);
            }
        }
        for (imp, &f) in self.imposed.iter().zip(imposed.forces()) {
            add(imp.point, f);
        }
        for (r, g) in g.iter().enumerate() {
            let hg = modes.modal(r, omega_rad_s).0 * g;
            for (o, &p) in out.iter_mut().zip(&targets) {
                *o += modes.shapes[p][r] * hg;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{LinearModeShape, LinearModes};

    fn table(n_modes: usize) -> ModalTable {
        let mut t = ModalTable::linear(
            100.0,
            0.01,
            &[
                ("tip", Complex64::new(1.0, 0.0)),
                ("drive", Complex64::new(0.5, 0.0)),
            ],
            1e-6,
            1e-2,
        );
        t.linear_modes = Some(LinearModes {
            omega_rad_s: (1..=n_modes).map(|r| 600.0 * r as f64).collect(),
            damping_ratio: vec![0.02; n_modes],
            points: vec![
                LinearModeShape {
                    name: "tip".into(),
                    shape: (0..n_modes).map(|r| 1.0 - 0.1 * r as f64).collect(),
                },
                LinearModeShape {
                    name: "drive".into(),
                    shape: (0..n_modes).map(|r| -0.7 + 0.2 * r as f64).collect(),
                },
            ],
        });
        t
    }

    #[test]
    fn receptance_is_the_sum_of_modal_receptances_and_its_derivative_is_exact() {
        let m = ResidualModes::from_table(&table(3), 3).unwrap();
        let w = 250.0;
        let g = m.receptance(0, 1, w);
        let by_hand: Complex64 = (0..3)
            .map(|r| {
                let wr = 600.0 * (r + 1) as f64;
                let s = (1.0 - 0.1 * r as f64) * (-0.7 + 0.2 * r as f64);
                s / Complex64::new(wr * wr - w * w, 2.0 * 0.02 * wr * w)
            })
            .sum();
        assert!((g - by_hand).norm() < 1e-15 * by_hand.norm());
        let (_, dg) = m.receptance_matrix(&[0, 1], w);
        let d = 1e-3;
        let fd = (m.receptance(0, 1, w + d) - m.receptance(0, 1, w - d)) / (2.0 * d);
        assert!(
            (dg[(0, 1)] - fd).norm() < 1e-6 * fd.norm(),
            "{} vs {fd}",
            dg[(0, 1)]
        );
    }

    #[test]
    fn bad_counts_and_missing_modes_are_named() {
        let e = ResidualModes::from_table(&table(3), 4)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("residual_modes = 4") && e.contains("1 to 3"),
            "{e}"
        );
        let mut t = table(3);
        t.linear_modes = None;
        let e = ResidualModes::from_table(&t, 1).unwrap_err().to_string();
        assert!(e.contains("no linear modes"), "{e}");
    }

    #[test]
    fn absurd_table_values_are_refused_not_stepped_into_nan() {
        for (z, w) in [
            (1e300, 600.0),
            (0.02, 1e300),
            (-0.1, 600.0),
            (f64::NAN, 600.0),
        ] {
            let mut t = table(1);
            let lm = t.linear_modes.as_mut().unwrap();
            lm.damping_ratio[0] = z;
            lm.omega_rad_s[0] = w;
            let e = ResidualModes::from_table(&t, 1).unwrap_err().to_string();
            assert!(e.contains("linear_modes."), "{e}");
        }
    }

    #[test]
    fn internal_resonances_are_found_at_integer_multiples() {
        let m = ResidualModes::from_table(&table(3), 3).unwrap();
        // modes at 600, 1200, 1800 rad/s; band 195..205: 3 x 200 = 600
        assert_eq!(
            m.internal_resonances(195.0, 205.0, 13, 0.0),
            vec![(0, 3), (1, 6), (2, 9)]
        );
        assert!(m.internal_resonances(195.0, 205.0, 2, 0.0).is_empty());
    }
}
