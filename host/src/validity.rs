//! The validity checks of `eq:NM` with attachments (the paper's Sections 3
//! and 6) and the remedy of each (issue 25, item 3): a quasi-steady
//! attachment that is not (`[slowflow] attachments = "dynamic"`), a mode the
//! attachments distort or another mode near a harmonic (`[slowflow]
//! residual_modes`).
use crate::model::Setup;
use nlmode::structure::modal_analysis;
use nlmode::Complex64;
use serde::Serialize;

/// The `[slowflow]` setting that addresses a fired validity check.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "remedy")]
pub enum Remedy {
    /// `[slowflow] attachments = "dynamic"`: the attachment's states carried
    /// (`"remedy": "dynamic"`, the spelling).
    #[serde(rename = "dynamic")]
    DynamicAttachments { attachment: String },
    /// `[slowflow] residual_modes`: the structure's other modes beside the
    /// nonlinear mode (`"remedy": "residual_modes"`).
    #[serde(rename = "residual_modes")]
    ResidualModes { check: String },
}

impl Remedy {
    /// The scenario setting, as the user writes it.
    pub fn setting(&self) -> &'static str {
        match self {
            Remedy::DynamicAttachments { .. } => "[slowflow] attachments = \"dynamic\"",
            Remedy::ResidualModes { .. } => "[slowflow] residual_modes",
        }
    }

    /// The name of the `nlmode` result run with it beside the plain one
    /// (`[slowflow] remedies = "run"`).
    pub fn result_name(&self) -> &'static str {
        match self {
            Remedy::DynamicAttachments { .. } => "nlmode-dynamic",
            Remedy::ResidualModes { .. } => "nlmode-residual-modes",
        }
    }
}

/// A remedy as `summary.json` lists it (`remedies`): what it addresses, the
/// setting, and the result it was run as (`[slowflow] remedies = "run"`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RemedyEntry {
    #[serde(flatten)]
    pub remedy: Remedy,
    pub setting: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub result: Option<&'static str>,
}

/// The fired checks' warnings and their remedies.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Validity {
    pub warnings: Vec<String>,
    pub remedies: Vec<Remedy>,
}

impl Validity {
    /// Drops the remedies already applied by the scenario's `[slowflow]`.
    pub fn without_applied(mut self, slowflow: &crate::scenario::SlowFlowSpec) -> Self {
        self.remedies.retain(|r| match r {
            Remedy::DynamicAttachments { .. } => {
                slowflow.attachments != nlmode::reduced::AttachmentStates::Dynamic
            }
            Remedy::ResidualModes { .. } => slowflow.residual_modes == 0,
        });
        self
    }

    /// The remedies once each (one `nlmode` run per kind), in the order found.
    pub fn distinct_kinds(&self) -> Vec<Remedy> {
        let mut out: Vec<Remedy> = Vec::new();
        for r in &self.remedies {
            if !out
                .iter()
                .any(|o| std::mem::discriminant(o) == std::mem::discriminant(r))
            {
                out.push(r.clone());
            }
        }
        out
    }
}

/// Separation factor of the quasi-steady check: every fixed-interface pole of
/// an attachment must lie at least this many modulation rates `1 / T_mod` away
/// from the band of excitation frequencies the sweep covers. The slow flow
/// evaluates `Z_G` at the instantaneous `Omega`; the envelope's modulation
/// spreads the excitation over about `Omega +- 1/T_mod`, over which `Z_G`
/// changes little only if its poles are well outside: with 5, a pole's
/// resonance term `1/(s - i Omega)` varies by at most 20 % over that spread.
pub const QUASI_STEADY_FACTOR: f64 = 5.0;
/// Largest damping ratio of an assembled mode counted in the internal-resonance
/// check: above it the mode's resonant amplification `1/(2D)` is below 2.5 and
/// it cannot take up energy through a harmonic.
pub const INTERNAL_RESONANCE_MAX_DAMPING: f64 = 0.2;
/// Relative floor of the internal-resonance window around `n omega_m`
/// (beside the half-power bandwidth of the other mode), see
/// [`Setup::validity_warnings`].
pub const INTERNAL_RESONANCE_WINDOW: f64 = 0.02;
/// MAC of the free and the attached mode below which the mode counts as
/// distorted: `1 - MAC` is the mass-weighted fraction of the attached shape
/// outside the free mode, which the projection `Z_A = phi^H Z_q phi` of
/// `eq:NM` neglects; at 0.9 that is 10 %, the order of the paper's mass ratios'
/// effect on the mode itself.
pub const MAC_THRESHOLD: f64 = 0.9;

impl Setup {
    /// The paper's validity checks of `eq:NM` with attachments (issue 11, item 4),
    /// as warning lines (empty when all hold):
    ///
    /// 1. **Quasi-steady attachments.** Each attachment's fixed-interface poles
    ///    `s` ([`LinearAttachment::fixed_interface_poles`]) against the sweep's
    ///    modulation time `T_mod = 2 D0 omega0 / |dOmega/dt|` (the time to cross
    ///    the mode's half-power band): warning if the distance of a pole from
    ///    the swept band, `min over Omega in the sweep of |s - i Omega|`, is below
    ///    `QUASI_STEADY_FACTOR / T_mod`.
    /// 2. **Internal resonance.** The assembly's linear natural frequencies
    ///    `omega_j = |s_j|` (oscillatory poles, damping ratio < 1) against
    ///    `n omega_m`, `n = 1..=harmonics` (`n = 1`: a close mode), counting
    ///    modes with damping ratio below [`INTERNAL_RESONANCE_MAX_DAMPING`], `omega_m` the
    ///    attached followed mode: window `n [omega_lo, omega_hi] +- max(2 D_j
    ///    omega_j, INTERNAL_RESONANCE_WINDOW n omega_m)`, `[omega_lo, omega_hi]`
    ///    the mode's frequency range (its linear value, widened by the modal
    ///    table's range when given). Warning when the assembly has more natural
    ///    frequencies in a window than the free structure (the attachment moved
    ///    one there, or added one).
    /// 3. **Mode-shape distortion.** Mass-weighted MAC of the free mode and the
    ///    structure part of the attached mode below [`MAC_THRESHOLD`].
    pub fn validity_warnings(
        &self,
        harmonics: usize,
        table_omega: Option<(f64, f64)>,
        attachments: nlmode::reduced::AttachmentStates,
    ) -> Vec<String> {
        self.validity(harmonics, table_omega, attachments).warnings
    }

    /// [`Self::validity_warnings`] with the remedy of each check that fired
    /// ([`Remedy`]; issue 25, item 3).
    pub fn validity(
        &self,
        harmonics: usize,
        table_omega: Option<(f64, f64)>,
        attachments: nlmode::reduced::AttachmentStates,
    ) -> Validity {
        let mut v = Validity::default();
        self.checks(harmonics, table_omega, attachments, &mut v);
        v
    }

    /// Check 1: every attachment's fixed-interface poles against the sweep.
    fn quasi_steady_checks(&self, v: &mut Validity) {
        let w = &mut v.warnings;
        let rate = self.sweep.signed_rate_rad_s2().abs();
        let t_mod = 2.0 * self.d0 * self.omega0_rad_s / rate;
        let (w_lo, w_hi) = (
            self.sweep.omega_start_rad_s.min(self.sweep.omega_end_rad_s),
            self.sweep.omega_start_rad_s.max(self.sweep.omega_end_rad_s),
        );
        let limit = QUASI_STEADY_FACTOR / t_mod;
        for att in &self.attachments {
            match att.fixed_interface_poles() {
                Ok(poles) => {
                    // distance of s from the segment i [w_lo, w_hi] of the imaginary axis
                    let dist = |s: &Complex64| {
                        let im = s.im.abs().clamp(w_lo, w_hi);
                        Complex64::new(s.re, s.im.abs() - im).norm()
                    };
                    if let Some(p) = poles
                        .iter()
                        .min_by(|a, b| dist(a).total_cmp(&dist(b)))
                        .filter(|p| dist(p) < limit)
                    {
                        w.push(format!(
                            "attachment '{}': fixed-interface pole {:.4e}{:+.4e}i rad/s lies {:.3e} rad/s from the swept band [{w_lo:.1}, {w_hi:.1}] rad/s, less than {QUASI_STEADY_FACTOR} / T_mod = {limit:.3e} rad/s (T_mod = 2 D0 omega0 / |dOmega/dt| = {t_mod:.3e} s): the quasi-steady attachment assumption of eq:NM is doubtful: carry the attachment's states with [slowflow] attachments = \"dynamic\" (together with [slowflow] rate_terms = true, which keeps the modulation's first-order terms; or sweep slower)",
                            att.name, p.re, p.im, dist(p)
                        ));
                        v.remedies.push(Remedy::DynamicAttachments {
                            attachment: att.name.clone(),
                        });
                    }
                }
                Err(e) => w.push(format!(
                    "attachment '{}': fixed-interface poles not computed: {e}",
                    att.name
                )),
            }
        }
    }

    fn checks(
        &self,
        harmonics: usize,
        table_omega: Option<(f64, f64)>,
        attachments: nlmode::reduced::AttachmentStates,
        v: &mut Validity,
    ) {
        if self.attachments.is_empty() {
            return;
        }
        // 1. quasi-steady (carried as states, a pole near the band is
        // followed in time: within 5 / T_mod is far inside the dynamic slow
        // flow's `fast_pole_factor * Omega_max`)
        if attachments == nlmode::reduced::AttachmentStates::QuasiSteady {
            self.quasi_steady_checks(v);
        }
        let w = &mut v.warnings;
        // 2./3. linear modes of the assembly
        let sys = match nlmode::reference::AssembledSystem::new(
            &self.model,
            &self.attachments,
            &self.response_point,
        ) {
            Ok(s) => s,
            Err(e) => {
                w.push(format!("assembly's linear modes not computed: {e}"));
                return;
            }
        };
        let j = self.mode_index;
        let nfree = self.model.ndof().min(60);
        let free = match modal_analysis(&self.model, nfree.max(j + 1)) {
            Ok(m) => m,
            Err(e) => {
                w.push(format!("free modes not computed: {e}"));
                return;
            }
        };
        let phi = free.shapes.column(j).map(|v| Complex64::new(v, 0.0));
        let m = self.model.mass.map(|v| Complex64::new(v, 0.0));
        let mac = |q: &nalgebra::DVector<Complex64>| {
            let mq = &m * q;
            let num = phi.dotc(&mq).norm_sqr();
            num / (phi.dotc(&(&m * &phi)).re * q.dotc(&mq).re)
        };
        // oscillatory poles (upper half plane), damping ratio < 1
        let poles: Vec<Complex64> = sys
            .linear_poles()
            .into_iter()
            .filter(|s| s.im > 0.0)
            .collect();
        let w0 = self.omega0_rad_s;
        let followed = poles
            .iter()
            .filter(|s| s.norm() > 0.5 * w0 && s.norm() < 1.5 * w0)
            .filter_map(|&s| sys.structure_mode_shape(s).map(|q| (s, mac(&q))))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((s_m, mac_m)) = followed else {
            w.push(format!(
                "no oscillatory mode of the assembly within [0.5, 1.5] omega0 = [{:.1}, {:.1}] rad/s: the attachments change the followed mode beyond the single-mode theory",
                0.5 * w0,
                1.5 * w0
            ));
            return;
        };
        let w_m = s_m.norm();
        if mac_m < MAC_THRESHOLD {
            w.push(format!(
                "the attachments distort the mode: MAC(free mode, attached mode at {w_m:.2} rad/s) = {mac_m:.4} < {MAC_THRESHOLD} (eq:NM projects the attachments on the free mode): add the structure's other modes with [slowflow] residual_modes"
            ));
            v.remedies.push(Remedy::ResidualModes {
                check: "mode-shape distortion".into(),
            });
        }
        let (lo, hi) = match table_omega {
            Some((a, b)) => (a.min(w_m), b.max(w_m)),
            None => (w_m, w_m),
        };
        // the free modes with their modal damping ratios phi^T C phi / (2 omega)
        // (mass-normalised shapes), so that both sides get the same window
        let free_modes: Vec<(f64, f64)> = (0..free.n_modes())
            .filter(|&k| k != j && free.omega_rad_s[k] > 0.0)
            .map(|k| {
                let phi_k = free.shapes.column(k);
                let wk = free.omega_rad_s[k];
                (wk, phi_k.dot(&(&self.model.damping * phi_k)) / (2.0 * wk))
            })
            .collect();
        for n in 1..=harmonics {
            let nf = n as f64;
            let inside = |wj: f64, dj: f64| {
                let b = (2.0 * dj * wj).max(INTERNAL_RESONANCE_WINDOW * nf * w_m);
                wj >= nf * lo - b && wj <= nf * hi + b
            };
            let assembled: Vec<Complex64> = poles
                .iter()
                .filter(|s| (**s - s_m).norm() > 1e-9 * w_m)
                .filter(|s| -s.re / s.norm() < INTERNAL_RESONANCE_MAX_DAMPING)
                .filter(|s| inside(s.norm(), -s.re / s.norm()))
                .copied()
                .collect();
            let nfree_in = free_modes
                .iter()
                .filter(|&&(wf, df)| df < INTERNAL_RESONANCE_MAX_DAMPING && inside(wf, df))
                .count();
            if assembled.len() > nfree_in {
                let list: Vec<String> = assembled
                    .iter()
                    .map(|s| format!("{:.2} rad/s (D = {:.3})", s.norm(), -s.re / s.norm()))
                    .collect();
                w.push(format!(
                    "internal resonance 1:{n}: the assembly has natural frequencies {} within n [{lo:.2}, {hi:.2}] rad/s (+- max(2 D omega, {INTERNAL_RESONANCE_WINDOW} n omega_m)) of {n} x the followed mode ({w_m:.2} rad/s), the free structure {nfree_in}: eq:NM assumes no other mode interacts; [slowflow] residual_modes carries the other modes' linear response to the attachments' forces, an exchange through the nonlinear element needs a second nonlinear mode",
                    list.join(", ")
                ));
                v.remedies.push(Remedy::ResidualModes {
                    check: format!("internal resonance 1:{n}"),
                });
            }
        }
    }
}
