//! Attachment states in the slow flow (`[slowflow] attachments = "dynamic"`):
//! the modulation equations extended by the attachments' states, as the
//! paper suggests where the quasi-steady assumption fails (Section 3, "one
//! has to apply Complexification-Averaging to the attachment model, too").
//!
//! # Derivation
//!
//! In the primal coordinates of `eq:primal` (`x = L1 q + L2 x_r`) with the
//! interface displacements `u_G = E^T q` and `P = pinv(B2)` (so `L1 = P E^T`,
//! [`crate::attachment`]), `eq:component2` projected on `L2` and the force
//! it exerts on the structure read (`eq:assemblyT1`-`eq:assemblyT2`)
//!
//! ```text
//! L2^T sum_k A_k d^k/dt^k (P u_G + L2 x_r) = L2^T f_ex2,
//! F_G = -P^T sum_k A_k d^k/dt^k (P u_G + L2 x_r) + P^T f_ex2,        c1 = E F_G.
//! ```
//!
//! Complexification as for the structure (`eq:ansatz`):
//! `u_G = Re(U e^{i Phi})`, `x_r = Re(X e^{i Phi})`, `f_ex2 = Re(B_u u_hat e^{i Phi})`
//! with `Phi' = Omega` and `U`, `X` slowly varying. Then
//! `d^k/dt^k (X e^{i Phi}) = e^{i Phi} (i Omega + d/dt)^k X` (terms in `Omega'`
//! dropped, as in `eq:NM`), and to first order in the slow derivatives
//!
//! ```text
//! sum_k A_k (i Omega + d/dt)^k X = Z(Omega) X + Z_s(Omega) X' + O(X''),
//! Z_s = dZ/d(i Omega) = sum_k k (i Omega)^(k-1) A_k,
//! ```
//!
//! exact for a first-order attachment (`k <= 1`, e.g. an electrical circuit).
//! Averaging (the fundamental harmonic) gives, with the blocks of
//! [`crate::attachment::AveragedBlocks`] (`Z_mn` of `eq:assemblyF1`,
//! `B22 = L2^T Z_s L2`):
//!
//! ```text
//! (1)  B22 X' + Z22 X = B_u2 u_hat - Z_2G U,
//! (2)  F_G = -(Z_GG U + Z_G2 X) + B_uG u_hat,
//! (3)  2 i Omega A' + (omega^2 - Omega^2 + 2 i D omega Omega) A
//!          = phi^H f_ex1 + sum_att phi_G^H F_G,          U = phi_G A,
//! ```
//!
//! (3) being `eq:NMpre` with the coupling force (2). The terms with the rate
//! of the interface displacement (`Z_s` acting on `U'`) and `Z_G2,s X'` in
//! (2) are dropped: they are of the order of what `eq:NM` itself neglects on
//! the structure side (the modulation of the attachment's force through its
//! frequency dependence, `dZ_A/dOmega A'`); keeping them would change
//! `eq:NM` even for an attachment without internal states (a rigid mass
//! would add `m |phi_G|^2` to the unit modal mass of the `A'` term). The
//! model adds exactly the attachment's own internal dynamics, `B22 X'`.
//!
//! **Reduction to `eq:NM`.** At `X' = 0`, (1) gives
//! `X = Z22^{-1} (B_u2 u_hat - Z_2G U)`; in (2) that is `eq:fc1`
//! (`F_G = -Z_G U + T_G u_hat`) and (3) becomes `eq:NM`: the steady states
//! of the two models are the same. In a transient, the homogeneous part of
//! (1), `X' = -B22^{-1} Z22 X`, has the eigenvalues `mu_j`; since
//! `Z(Omega - i mu) ~ Z + mu Z_s`, `mu_j + i Omega` approximates a
//! fixed-interface pole `s_j` of the attachment near the band (exactly for a
//! first-order attachment). For a pole far from the band `X` follows its
//! quasi-steady value with a lag `~ X_qs' / |mu_j|`; through a coupling
//! stiffness that grows with the pole (a stiff spring to a dashpot or a
//! mass) the lag's force tends to a finite rate term (`-c U'` of the
//! dashpot, `-2 i Omega m U'` of the mass), of the order `eq:NM` itself
//! neglects (`dZ_A/dOmega A'`, relative `~ 1/(Omega T_mod)`). So a far pole
//! gives `eq:NM` plus such a term (tested: the difference to that model falls
//! like `1/|mu|`); keeping it quasi-steady (below) drops it consistently with
//! `eq:NM`, and a model whose attachment poles all lie far from the band *is*
//! `eq:NM` (bit for bit: the sweep runs the quasi-steady kernel).
//!
//! **Fast and slow parts.** In the basis `X = T y` of the eigenvectors of
//! `B22^{-1} Z22` at the band centre `Omega_c`, a component whose pole
//! `mu_j + i Omega_c` lies farther than `fast_pole_factor * Omega_max` from the
//! swept band `i [Omega_min, Omega_max]` is kept in quasi-steady state
//! (`y_f' = 0`, eliminated exactly by a Schur complement): its lag is of the
//! order of the slow flow's own averaging error, and carrying it would make
//! the integration stiff (the paper shaker's electrical pole `R/L = 2.1e4
//! 1/s`). Only the slow components `y_s` are states. With
//! `N = T^{-1} B22^{-1} Z22 T`, `K = T^{-1} B22^{-1} Z_2G`,
//! `h = T^{-1} B22^{-1} B_u2 u_hat`, `W = Z_G2 T`, and `X_* = N_ff^{-1} [N_fs, K_f, h_f]`:
//!
//! ```text
//! y_s' = -P1 y_s - P2 U + p,     P1 = N_ss - N_sf X_N,  P2 = K_s - N_sf X_K,  p = h_s - N_sf X_h,
//! F_G  = -Q1 U - Q2 y_s + q,     Q1 = Z_GG - W_f X_K,   Q2 = W_s - W_f X_N,   q = B_uG u_hat - W_f X_h.
//! ```
//!
//! With no slow component, `Q1 = Z_G` and `q = T_G u_hat` (`eq:fc1`): a model
//! whose attachments have no pole near the band is `eq:NM` exactly, and the
//! sweep then runs the quasi-steady kernel itself. The blocks are functions
//! of `Omega` only and are tabulated along the sweep like `Z_G`
//! ([`super::sweep`], cubic Hermite to `channel_tol`).
//!
//! # Exact poles of a second-order internal block
//!
//! `B22 = dZ22/d(i Omega)` makes `mu_j + i Omega` the fixed-interface pole
//! only to first order in the distance `Omega - omega_j`: for a mass on a
//! spring, `mu = -Z22/B22 = -(k - Omega^2 m + i Omega c)/(c + 2 i Omega m)`
//! gives the beat `(omega_t^2 - Omega^2)/(2 Omega)` instead of `omega_t -
//! Omega`, 7.5 % off at `Omega = 1.18 omega_t`, 18 % at `0.73 omega_t`. A
//! lightly damped attachment that beats while the sweep passes is then
//! followed with the wrong beat. For a second-order internal block,
//! `Z22(lambda) = M lambda^2 + C lambda + K` with `lambda = i Omega` and a
//! regular `M`, the right solvent `X = V S V^{-1}` of its positive-frequency
//! eigenpairs (`S` the poles with `Im s_j > 0`, `V` their eigenvectors,
//! `M X^2 + C X + K = 0`) factorises it exactly:
//!
//! ```text
//! Z22(lambda) = (lambda M + M X + C) (lambda I - X),
//! ```
//!
//! so with `B22 -> lambda M + M X + C` the states' own matrix is
//! `B22^{-1} Z22 = i Omega I - X`: the carried poles are the attachment's
//! poles `s_j` at every `Omega`, and the negative-frequency poles, far from
//! the band, are in quasi-steady state. This is the pole-residue form of
//! the attachment (for one degree of freedom `B22 = m (i Omega - conj(s))`,
//! equal to `c + 2 i Omega m` at `Omega = omega_t`); the steady states
//! (`X' = 0`) are unchanged. Used where `Z22` is exactly quadratic with a
//! regular `M_22` and every selected pole has `Im s_j > 0` (underdamped);
//! otherwise (the paper shaker's coil current has no second derivative, an
//! overdamped mode) `B22 = dZ22/d(i Omega)` as above.
//!
//! # Residual modes
//!
//! With residual modes ([`super::residual`]) the interface displacement is
//! `U + G F_G`, the residual receptance `G(Omega)` coupling all attachments:
//! their blocks are stacked (block diagonal over the attachments, the
//! merged port's rows in turn) and, with `S = (I + Q1 G)^{-1}`,
//!
//! ```text
//! F_G = -S Q1 U - S Q2 y_s + S q,
//! y_s' = -(P1 - P2 G S Q2) y_s - P2 (I - G S Q1) U + (p - P2 G S q),
//! ```
//!
//! (`F_G = -Q1 (U + G F_G) - Q2 y_s + q` solved for `F_G`, then put in the
//! states' equation). Without carried states this is the quasi-steady
//! `Z_G -> S Z_G`, `T_G -> S T_G` of [`super::residual`]; the steady states
//! are that model's (tested).
//!
//! # Scope
//!
//! Every attachment given by its coefficient matrices
//! ([`crate::attachment::LinearAttachment`]) with a regular `B22` in the band
//! (its internal states all have dynamics: a state without a derivative, a
//! purely algebraic one, is not covered). An attachment known only by its
//! frequency response has no states to carry: refused with a message.
//! Starting from rest, the attachment states start at zero (the exciter
//! switched on at `t = 0`), as in the full-order `reference`.
use super::sweep::{emit, stop_status, OmegaCache};
use super::{Port, ResidualModes, MAX_PHI, SWEEP_BATCH};
use super::{ReducedError, ReducedModel, SlowFlowOptions, SweepRun, SweepSink, SweepStatus};
use crate::attachment::{AveragedBlocks, Condenser};
use crate::dopri::{integrate, Controller, ErrorScale, Tolerances};
use crate::excitation::LinearSweep;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

mod solvent;
use solvent::Solvent;

/// How the attachments enter the slow flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AttachmentStates {
    /// In quasi-steady state: condensed into `Z_A` and the imposed modal force
    /// (`eq:fc1`, `eq:NM`; the paper's model).
    #[default]
    QuasiSteady,
    /// Their internal states carried as slowly varying complex amplitudes
    /// beside `A` (module docs).
    Dynamic,
}

/// Default of [`SlowFlowOptions::fast_pole_factor`]: an attachment mode whose
/// pole lies farther than the band's top frequency from the band is kept in
/// quasi-steady state.
pub const FAST_POLE_FACTOR: f64 = 1.0;

/// Condition number of the basis `T` above which the eigenvectors are not
/// used and every internal state of the attachment is carried as it is.
const BASIS_CONDITION_LIMIT: f64 = 1e8;

type CMat = DMatrix<Complex64>;

/// One attachment's internal states within a [`StatePort`]: its fixed-
/// interface modes `x_r = T y` with the slow (carried) components first.
#[derive(Debug, Clone)]
struct PartStates {
    name: String,
    condenser: Condenser,
    /// The exact-pole `B22` of a second-order internal block (module docs).
    solvent: Option<Solvent>,
    /// Input amplitudes per unit of the sweep amplitude.
    input: Vec<Complex64>,
    t: CMat,
    t_inv: CMat,
    /// Slow (carried) components.
    ns: usize,
    ncon: usize,
}

/// A port's blocks of the carried slow flow (module docs):
/// `y' = -P1 y - P2 U + p`, `F_G = -Q1 U - Q2 y + q`.
struct Blocks {
    p1: CMat,
    p2: CMat,
    p: DVector<Complex64>,
    q1: CMat,
    q2: CMat,
    q: DVector<Complex64>,
}

/// A port of a [`ReducedModel`] whose attachments' slow internal states are
/// carried: one attachment, or (with residual modes) the merged port of all
/// attachments seen through the residual receptance `G` (module docs,
/// "Residual modes").
#[derive(Debug, Clone)]
pub(crate) struct StatePort {
    /// Index in [`ReducedModel::ports`].
    port: usize,
    /// The port's attachments in the order of its rows.
    parts: Vec<PartStates>,
    /// The residual modes and the table point of each row of the merged port.
    residual: Option<(Arc<ResidualModes>, Vec<usize>)>,
    /// Slow (carried) components, all parts.
    pub(crate) ns: usize,
    ncon: usize,
    /// Offset of the port's interface shapes among the gathered shapes.
    phi_offset: usize,
    /// Offset of the port's slow states among the complex states after `A`.
    pub(crate) state_offset: usize,
    /// Offset of the port's extra channels (`P1`, `P2`, `p`, `Q2`) after the
    /// model's `nch` standard channels.
    extra_offset: usize,
}

impl PartStates {
    /// The attachment of `port` with its fixed-interface modes split into
    /// slow ones (pole within `factor * hi` of the band `i [lo, hi]`) and
    /// fast ones (module docs).
    fn new(port: &Port, (lo, hi): (f64, f64), factor: f64) -> Result<Self, ReducedError> {
        let ncon = port.ncon();
        let name = port.model.name().to_string();
        let refuse = |why: String| ReducedError::AttachmentStates {
            attachment: name.clone(),
            why,
        };
        let Some(condenser) = port.model.condenser() else {
            return Err(refuse(
                "it is given as a frequency response only, without a state model; use attachments = \"quasi-steady\"".into(),
            ));
        };
        let nr = condenser.internal_states();
        let mut part = PartStates {
            name: name.clone(),
            condenser: condenser.clone(),
            solvent: Solvent::of(condenser.internal_coefficients()),
            input: port.input.clone(),
            t: CMat::identity(nr, nr),
            t_inv: CMat::identity(nr, nr),
            ns: 0,
            ncon,
        };
        if nr == 0 {
            return Ok(part);
        }
        let wc = 0.5 * (lo + hi);
        let b = part.averaged_blocks(wc);
        let binv = b.b_22.clone().try_inverse().ok_or_else(|| {
            refuse(format!(
                "B22 = dZ22/d(i Omega) is singular at Omega = {wc} rad/s: an internal state has no dynamics of its own (algebraic), which the averaged model does not cover"
            ))
        })?;
        let n0 = &binv * &b.z_22;
        let (mu, v) = complex_eigen(&n0).ok_or_else(|| {
            refuse(format!(
                "the eigenvalues of B22^-1 Z22 at Omega = {wc} rad/s did not converge"
            ))
        })?;
        // distance of the pole mu + i Omega_c from the band i [lo, hi]
        let dist = |m: &Complex64| {
            let s = m + Complex64::new(0.0, wc);
            let im = s.im.abs().clamp(lo, hi);
            Complex64::new(s.re, s.im.abs() - im).norm()
        };
        let mut order: Vec<usize> = (0..nr).collect();
        order.sort_by(|&i, &j| dist(&mu[i]).total_cmp(&dist(&mu[j])));
        let ns = order
            .iter()
            .filter(|&&j| dist(&mu[j]) < factor * hi)
            .count();
        if ns == 0 {
            return Ok(part);
        }
        let t = CMat::from_fn(nr, nr, |i, k| v[(i, order[k])]);
        (part.t, part.t_inv, part.ns) = match t.clone().try_inverse() {
            Some(ti) if t.norm() * ti.norm() < BASIS_CONDITION_LIMIT => (t, ti, ns),
            // defective or nearly so: carry every internal state as it is
            _ => (CMat::identity(nr, nr), CMat::identity(nr, nr), nr),
        };
        Ok(part)
    }

    /// The part's [`Blocks`] at `Omega` for the sweep amplitude `amplitude`,
    /// the fast components eliminated (module docs).
    fn blocks(&self, omega: f64, amplitude: f64) -> Result<Blocks, ReducedError> {
        let b = self.averaged_blocks(omega);
        let singular = |what: &str| ReducedError::AttachmentStates {
            attachment: self.name.clone(),
            why: format!("{what} is singular at Omega = {omega} rad/s"),
        };
        let u = DVector::from_iterator(self.input.len(), self.input.iter().map(|u| u * amplitude));
        let g_q = &b.bu_g * &u;
        let nr = self.t.nrows();
        if nr == 0 {
            let (c, z) = (self.ncon, |r, c| CMat::zeros(r, c));
            return Ok(Blocks {
                p1: z(0, 0),
                p2: z(0, c),
                p: DVector::zeros(0),
                q1: b.z_gg,
                q2: z(c, 0),
                q: g_q,
            });
        }
        let binv = b
            .b_22
            .clone()
            .try_inverse()
            .ok_or_else(|| singular("B22 = dZ22/d(i Omega)"))?;
        let left = &self.t_inv * &binv;
        let n = &left * &b.z_22 * &self.t;
        let k = &left * &b.z_2g;
        let h = &left * (&b.bu_2 * &u);
        let w = &b.z_g2 * &self.t;
        let s = self.ns;
        let f = nr - s;
        let mut out = Blocks {
            p1: n.view((0, 0), (s, s)).into_owned(),
            p2: k.rows(0, s).into_owned(),
            p: h.rows(0, s).into_owned(),
            q1: b.z_gg.clone(),
            q2: w.columns(0, s).into_owned(),
            q: g_q,
        };
        if f > 0 {
            let nff_inv = n
                .view((s, s), (f, f))
                .into_owned()
                .try_inverse()
                .ok_or_else(|| singular("the fast block of B22^-1 Z22"))?;
            let x_n = &nff_inv * n.view((s, 0), (f, s));
            let x_k = &nff_inv * k.rows(s, f);
            let x_h = &nff_inv * h.rows(s, f);
            let n_sf = n.view((0, s), (s, f));
            let w_f = w.columns(s, f);
            out.p1 -= n_sf * &x_n;
            out.p2 -= n_sf * &x_k;
            out.p -= n_sf * &x_h;
            out.q1 -= w_f * &x_k;
            out.q2 -= w_f * &x_n;
            out.q -= w_f * &x_h;
        }
        Ok(out)
    }
}

impl PartStates {
    /// The condenser's blocks at `Omega`, `B22` the exact-pole one where it
    /// applies (module docs).
    fn averaged_blocks(&self, omega: f64) -> AveragedBlocks {
        let mut b = self.condenser.averaged_blocks(omega);
        if let Some(s) = &self.solvent {
            b.b_22 = s.b22(omega);
        }
        b
    }
}

impl Blocks {
    /// The parts' blocks side by side (block diagonal; `nc` rows, `ns`
    /// states in all).
    fn stacked(parts: &[Blocks], nc: usize, ns: usize) -> Blocks {
        let mut out = Blocks {
            p1: CMat::zeros(ns, ns),
            p2: CMat::zeros(ns, nc),
            p: DVector::zeros(ns),
            q1: CMat::zeros(nc, nc),
            q2: CMat::zeros(nc, ns),
            q: DVector::zeros(nc),
        };
        let (mut r, mut s) = (0, 0);
        for b in parts {
            let (c, k) = (b.q1.nrows(), b.p1.nrows());
            out.p1.view_mut((s, s), (k, k)).copy_from(&b.p1);
            out.p2.view_mut((s, r), (k, c)).copy_from(&b.p2);
            out.p.rows_mut(s, k).copy_from(&b.p);
            out.q1.view_mut((r, r), (c, c)).copy_from(&b.q1);
            out.q2.view_mut((r, s), (c, k)).copy_from(&b.q2);
            out.q.rows_mut(r, c).copy_from(&b.q);
            r += c;
            s += k;
        }
        out
    }

    /// The blocks with the interface displacement `U + G F_G` (the residual
    /// modes' receptance `g` at the rows' points; module docs):
    /// `S = (I + Q1 G)^-1`, `Q1 -> S Q1`, `Q2 -> S Q2`, `q -> S q`,
    /// `P1 -> P1 - P2 G S Q2`, `P2 -> P2 (I - G S Q1)`, `p -> p - P2 G S q`.
    fn through_residual(self, g: &CMat) -> Option<Blocks> {
        let nc = g.nrows();
        let s = (CMat::identity(nc, nc) + &self.q1 * g).try_inverse()?;
        let (q1, q2, q) = (&s * &self.q1, &s * &self.q2, &s * &self.q);
        let p2g = &self.p2 * g;
        Some(Blocks {
            p1: &self.p1 - &p2g * &q2,
            p2: &self.p2 - &p2g * &q1,
            p: &self.p - &p2g * &q,
            q1,
            q2,
            q,
        })
    }
}

impl StatePort {
    /// The ports of `model` whose attachments have internal states with a
    /// pole within `factor * hi` of the band `i [lo, hi]` (module docs);
    /// empty if none. With residual modes the merged port is one
    /// [`StatePort`] over all attachments.
    pub(crate) fn select(
        model: &ReducedModel,
        lo: f64,
        hi: f64,
        factor: f64,
    ) -> Result<Vec<StatePort>, ReducedError> {
        let mut out = Vec::new();
        let (mut phi_offset, mut state_offset, mut extra_offset) = (0, 0, model.nch);
        // (model port, its attachments, the residual coupling)
        let groups: Vec<(usize, &[Port], _)> = match &model.residual {
            Some(res) if !model.ports.is_empty() => {
                let points = model.ports[0].points.clone();
                vec![(0, &res.ports[..], Some((res.modes.clone(), points)))]
            }
            _ => (0..model.ports.len())
                .map(|i| (i, std::slice::from_ref(&model.ports[i]), None))
                .collect(),
        };
        for (index, ports, residual) in groups {
            let parts = ports
                .iter()
                .map(|p| PartStates::new(p, (lo, hi), factor))
                .collect::<Result<Vec<_>, _>>()?;
            let ncon: usize = parts.iter().map(|p| p.ncon).sum();
            let ns: usize = parts.iter().map(|p| p.ns).sum();
            phi_offset += ncon;
            if ns == 0 {
                continue;
            }
            let sp = StatePort {
                port: index,
                parts,
                residual,
                ns,
                ncon,
                phi_offset: phi_offset - ncon,
                state_offset,
                extra_offset,
            };
            state_offset += ns;
            extra_offset += sp.nextra();
            out.push(sp);
        }
        Ok(out)
    }

    /// Number of extra channels: `P1` (`ns x ns`), `P2` (`ns x ncon`), `p`
    /// (`ns`), `Q2` (`ncon x ns`), each row major.
    pub(crate) fn nextra(&self) -> usize {
        let (s, c) = (self.ns, self.ncon);
        s * s + s * c + s + c * s
    }

    /// `Q1`, `q` into the port's standard channels (in place of `Z_G`,
    /// `T_G u_hat`) and `P1`, `P2`, `p`, `Q2` into the extra channels, at
    /// `Omega` for the input amplitudes `u_hat` (module docs).
    pub(crate) fn fill(
        &self,
        model: &ReducedModel,
        omega: f64,
        amplitude: f64,
        out: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        let port = &model.ports[self.port];
        let parts = self
            .parts
            .iter()
            .map(|p| p.blocks(omega, amplitude))
            .collect::<Result<Vec<_>, _>>()?;
        let blocks = match (&self.residual, parts.len()) {
            (None, 1) => parts.into_iter().next().expect("one part"),
            (None, _) => Blocks::stacked(&parts, self.ncon, self.ns),
            (Some((modes, points)), _) => {
                let (g, _) = modes.receptance_matrix(points, omega);
                Blocks::stacked(&parts, self.ncon, self.ns)
                    .through_residual(&g)
                    .ok_or_else(|| ReducedError::AttachmentStates {
                        attachment: port.model.name().into(),
                        why: format!(
                            "I + Q1 G is singular at Omega = {omega} rad/s (the attachments resonate on the residual modes alone)"
                        ),
                    })?
            }
        };
        let Blocks {
            p1,
            p2,
            p,
            q1,
            q2,
            q,
        } = blocks;
        let (s, c) = (self.ns, self.ncon);
        let o = port.offset;
        for r in 0..c {
            for j in 0..c {
                out[o + r * c + j] = q1[(r, j)];
            }
            out[o + c * c + r] = q[r];
        }
        let mut e = self.extra_offset;
        let mut put = |rows: usize, cols: usize, m: &[Complex64]| {
            // nalgebra's storage is column major: written row major here
            for r in 0..rows {
                for j in 0..cols {
                    out[e] = m[r + j * rows];
                    e += 1;
                }
            }
        };
        put(s, s, p1.as_slice());
        put(s, c, p2.as_slice());
        put(s, 1, p.as_slice());
        put(c, s, q2.as_slice());
        Ok(())
    }

    /// The carried states' rates `y_s' = -P1 y_s - P2 U + p` into `dy`, and the
    /// port's force channel `q` replaced by `q - Q2 y_s` (so that the standard
    /// channels give `F_G = -Q1 U + (q - Q2 y_s)`), for the modal amplitude
    /// `amp` and the gathered shapes `phi`.
    #[inline]
    pub(crate) fn apply(
        &self,
        model: &ReducedModel,
        ch: &mut [Complex64],
        phi: &[Complex64],
        amp: Complex64,
        y: &[Complex64],
        dy: Option<&mut [Complex64]>,
    ) {
        let (s, c) = (self.ns, self.ncon);
        let e = self.extra_offset;
        let (p1, rest) = ch[e..].split_at(s * s);
        let (p2, rest) = rest.split_at(s * c);
        let (p, rest) = rest.split_at(s);
        let q2 = &rest[..c * s];
        let u = &phi[self.phi_offset..self.phi_offset + c];
        if let Some(dy) = dy {
            for i in 0..s {
                let mut r = p[i];
                for j in 0..s {
                    r -= p1[i * s + j] * y[j];
                }
                for j in 0..c {
                    r -= p2[i * c + j] * u[j] * amp;
                }
                dy[i] = r;
            }
        }
        let mut corr = [Complex64::new(0.0, 0.0); MAX_PHI];
        for (r, cr) in corr.iter_mut().enumerate().take(c) {
            for j in 0..s {
                *cr += q2[r * s + j] * y[j];
            }
        }
        let o = model.ports[self.port].offset + c * c;
        for (r, cr) in corr.iter().enumerate().take(c) {
            ch[o + r] -= cr;
        }
    }
}

/// Eigenvalues and right eigenvectors (columns) of a small complex matrix
/// (faer's complex EVD).
fn complex_eigen(m: &CMat) -> Option<(Vec<Complex64>, CMat)> {
    let n = m.nrows();
    let a = faer::Mat::<Complex64>::from_fn(n, n, |i, j| m[(i, j)]);
    let evd = a.eigen().ok()?;
    let sv = evd.S().column_vector();
    let s = (0..n).map(|i| sv[i]).collect();
    let u = evd.U();
    Some((s, CMat::from_fn(n, n, |i, j| u[(i, j)])))
}

/// The complex states after `A` in the real state vector (`[Re A, Im A, Re y, Im y, ...]`).
fn complex_states(y: &[f64], out: &mut Vec<Complex64>) {
    out.clear();
    out.extend(y[2..].chunks_exact(2).map(|c| Complex64::new(c[0], c[1])));
}

/// The sweep of [`ReducedModel::simulate_sweep_into`] with the slow states
/// of `ports` carried (module docs): same output, same statuses.
pub(crate) fn simulate(
    model: &ReducedModel,
    ports: &[StatePort],
    sweep: &LinearSweep,
    opts: &SlowFlowOptions,
    a0: Complex64,
    sink: &mut dyn SweepSink,
) -> Result<SweepRun, ReducedError> {
    let (lo, hi) = {
        let (s, e) = (sweep.omega_start_rad_s, sweep.omega_end_rad_s);
        (s.min(e), s.max(e))
    };
    let nch = model.nch;
    let ntot = nch + ports.iter().map(StatePort::nextra).sum::<usize>();
    let ns: usize = ports.iter().map(|p| p.ns).sum();
    let cache = tabulate_channels(model, ports, sweep.amplitude, (lo, hi), opts, ntot)?;
    let duration = sweep.duration_s();
    let scale = carried_state_scales(model, ports, &cache, (lo, hi), ns, ntot)?;
    let tol = sweep_tolerances(model, opts, &scale, duration);
    let mut ch = vec![Complex64::new(0.0, 0.0); ntot];
    let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
    let mut ys: Vec<Complex64> = Vec::with_capacity(ns);
    let mut dys = vec![Complex64::new(0.0, 0.0); ns];
    let mut dch = vec![Complex64::new(0.0, 0.0); if opts.rate_terms { ntot } else { 0 }];
    let rhs = |t: f64, y: &DVector<f64>, dy: &mut DVector<f64>| -> Result<(), ReducedError> {
        let w = sweep.omega_rad_s(t);
        if opts.rate_terms {
            cache.eval_with_derivative(w, &mut ch, &mut dch);
        } else {
            cache.eval(w, &mut ch);
        }
        let fi = model.imposed_at(w)?;
        let amp = Complex64::new(y[0], y[1]);
        let a = (y[0] * y[0] + y[1] * y[1]).sqrt();
        let props = model.gather(a, &mut phi)?;
        complex_states(y.as_slice(), &mut ys);
        for p in ports {
            let r = p.state_offset..p.state_offset + p.ns;
            p.apply(model, &mut ch, &phi, amp, &ys[r.clone()], Some(&mut dys[r]));
        }
        let (k, fm, _) = model.terms_with(&props, &phi, w, &ch[..nch], &fi);
        let z = fm - k * amp;
        if opts.rate_terms {
            // the rate terms of the condensed feedthrough Q1 (the carried
            // states' own rates are in dys); super::rate
            let wdot = sweep.omega_rate_rad_s2(t);
            let a = amp.norm();
            let d = model.first_order_rate(&props, &phi, a, w, wdot, &dch[..nch], z, amp)?;
            dy[0] = d.re;
            dy[1] = d.im;
        } else {
            let s = 0.5 / w;
            dy[0] = z.im * s;
            dy[1] = -z.re * s;
        }
        for (j, d) in dys.iter().enumerate() {
            dy[2 + 2 * j] = d.re;
            dy[3 + 2 * j] = d.im;
        }
        Ok(())
    };
    let n = opts.output_samples;
    let dt = duration / (n - 1) as f64;
    let sample_t = |j: usize| if j + 1 == n { duration } else { j as f64 * dt };
    let mut y0 = DVector::zeros(2 + 2 * ns);
    y0[0] = a0.re;
    y0[1] = a0.im;
    let mut batch = StateBatch {
        ts: Vec::with_capacity(SWEEP_BATCH),
        states: Vec::with_capacity(SWEEP_BATCH),
        emitted: 0,
    };
    let mut next = 0usize;
    let mut last_state = (0.0, y0.clone());
    let mut yt = y0.clone();
    let (stats, stop) = integrate(rhs, 0.0, y0.clone(), duration, &tol, |d, _| {
        let t1 = d.t0 + d.h;
        while next < n && sample_t(next) <= t1 * (1.0 + 1e-14) {
            let t = sample_t(next).max(d.t0);
            d.eval_into(t, &mut yt);
            batch.ts.push(t);
            batch.states.push(yt.clone());
            next += 1;
            if batch.ts.len() == SWEEP_BATCH {
                batch.flush(model, ports, sweep, &cache, sink, opts.rate_terms)?;
            }
        }
        d.eval_into(t1, &mut last_state.1);
        last_state.0 = t1;
        Ok(())
    });
    if batch.emitted == 0 && batch.ts.is_empty() {
        batch.ts.push(0.0);
        batch.states.push(y0);
    }
    let status = match stop {
        None => SweepStatus::Completed,
        Some(stop) => {
            let (t_stop, y) = &last_state;
            let a_stop = Complex64::new(y[0], y[1]).norm();
            let status = stop_status(stop, *t_stop, sweep.omega_rad_s(*t_stop), a_stop)?;
            if batch.ts.last().map(|t| t < t_stop).unwrap_or(true) {
                batch.ts.push(*t_stop);
                batch.states.push(y.clone());
            }
            status
        }
    };
    batch.flush(model, ports, sweep, &cache, sink, opts.rate_terms)?;
    Ok(SweepRun {
        status,
        stats,
        channel_nodes: cache.len(),
        samples: batch.emitted,
    })
}

/// The channels of the model and the ports' blocks over the band `(lo, hi)`
/// [rad/s] at the sweep's `amplitude`, tabulated in `Omega` to
/// `opts.channel_tol` (Hermite, slopes by central differences).
fn tabulate_channels(
    model: &ReducedModel,
    ports: &[StatePort],
    amplitude: f64,
    (lo, hi): (f64, f64),
    opts: &SlowFlowOptions,
    ntot: usize,
) -> Result<OmegaCache, ReducedError> {
    let nch = model.nch;
    let fill = |w: f64, v: &mut [Complex64]| -> Result<(), ReducedError> {
        model.fill_channels(w, amplitude, &mut v[..nch])?;
        for p in ports {
            p.fill(model, w, amplitude, v)?;
        }
        Ok(())
    };
    // the blocks are rational in Omega: central differences (1e-5 Omega) for
    // the Hermite slopes; the tabulation checks the values at every midpoint
    let fill_d = |w: f64, v: &mut [Complex64], d: &mut [Complex64]| -> Result<(), ReducedError> {
        let dw = 1e-5 * w;
        fill(w, v)?;
        let mut vm = vec![Complex64::new(0.0, 0.0); ntot];
        fill(w + dw, d)?;
        fill(w - dw, &mut vm)?;
        for (d, m) in d.iter_mut().zip(&vm) {
            *d = (*d - m) / (2.0 * dw);
        }
        Ok(())
    };
    OmegaCache::tabulate(ntot, lo, hi, opts.channel_tol, fill, fill_d)
}

/// The size of each carried state: its largest quasi-steady value at the
/// band's ends and middle, at rest and at the table's largest amplitude
/// (the scale of its absolute tolerance).
fn carried_state_scales(
    model: &ReducedModel,
    ports: &[StatePort],
    cache: &OmegaCache,
    (lo, hi): (f64, f64),
    ns: usize,
    ntot: usize,
) -> Result<Vec<f64>, ReducedError> {
    let mut scale = vec![0.0f64; ns];
    let mut ch = vec![Complex64::new(0.0, 0.0); ntot];
    let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
    model.gather(model.a_scale, &mut phi)?;
    for w in [lo, 0.5 * (lo + hi), hi] {
        cache.eval(w, &mut ch);
        for amp in [0.0, model.a_scale] {
            for p in ports {
                let ys = p.quasi_steady(&ch, &phi, Complex64::new(amp, 0.0))?;
                for (j, y) in ys.iter().enumerate() {
                    let k = p.state_offset + j;
                    scale[k] = scale[k].max(y.norm());
                }
            }
        }
    }
    Ok(scale)
}

/// The integration tolerances of the sweep (`duration` [s]): absolute ones
/// for `A` against the table's largest amplitude, for each carried state
/// against its `scale` ([`carried_state_scales`], 1 where zero).
fn sweep_tolerances(
    model: &ReducedModel,
    opts: &SlowFlowOptions,
    scale: &[f64],
    duration: f64,
) -> Tolerances<DVector<f64>> {
    let ns = scale.len();
    // absolute tolerances: A against the table's largest amplitude, each
    // carried state against its quasi-steady size over the band
    let atol_a = opts.atol_rel * model.a_scale;
    let mut atol = DVector::from_element(2 + 2 * ns, atol_a);
    for (k, s) in scale.iter().enumerate() {
        let a = opts.atol_rel * if *s > 0.0 { *s } else { 1.0 };
        atol[2 + 2 * k] = a;
        atol[3 + 2 * k] = a;
    }
    Tolerances {
        rtol: opts.rtol,
        atol,
        controller: Controller::Pi,
        scale: ErrorScale::Local,
        h_max: opts.max_step_fraction * duration,
        h_min: 1e-12 * duration,
        max_steps: 10_000_000,
        h0: None,
    }
}

impl StatePort {
    /// The quasi-steady value of the carried states, `P1^{-1} (p - P2 U)`, at
    /// the channels `ch` and the modal amplitude `amp` (tolerance scales).
    fn quasi_steady(
        &self,
        ch: &[Complex64],
        phi: &[Complex64],
        amp: Complex64,
    ) -> Result<Vec<Complex64>, ReducedError> {
        let (s, c) = (self.ns, self.ncon);
        let e = self.extra_offset;
        let p1 = CMat::from_row_slice(s, s, &ch[e..e + s * s]);
        let p2 = CMat::from_row_slice(s, c, &ch[e + s * s..e + s * s + s * c]);
        let p = DVector::from_column_slice(&ch[e + s * s + s * c..e + s * s + s * c + s]);
        let u = DVector::from_iterator(
            c,
            phi[self.phi_offset..self.phi_offset + c]
                .iter()
                .map(|f| f * amp),
        );
        let y = p1
            .lu()
            .solve(&(p - p2 * u))
            .unwrap_or_else(|| DVector::zeros(s));
        Ok(y.iter().copied().collect())
    }
}

/// The sampled states not yet handed to the sink.
struct StateBatch {
    ts: Vec<f64>,
    states: Vec<DVector<f64>>,
    emitted: usize,
}

impl StateBatch {
    /// The output quantities of the pending states (the standard channels
    /// with each port's force channel including its carried states), to the
    /// sink.
    fn flush(
        &mut self,
        model: &ReducedModel,
        ports: &[StatePort],
        sweep: &LinearSweep,
        cache: &OmegaCache,
        sink: &mut dyn SweepSink,
        rate_terms: bool,
    ) -> Result<(), ReducedError> {
        if self.ts.is_empty() {
            return Ok(());
        }
        let nch = model.nch;
        let w: Vec<f64> = self.ts.iter().map(|&t| sweep.omega_rad_s(t)).collect();
        let mut channels = Vec::with_capacity(nch * w.len());
        let mut amps = Vec::with_capacity(w.len());
        let mut ch = vec![Complex64::new(0.0, 0.0); cache.nch()];
        let mut dch = vec![Complex64::new(0.0, 0.0); if rate_terms { cache.nch() } else { 0 }];
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let mut ys = Vec::new();
        for ((&wi, &ti), y) in w.iter().zip(&self.ts).zip(&self.states) {
            if rate_terms {
                cache.eval_with_derivative(wi, &mut ch, &mut dch);
            } else {
                cache.eval(wi, &mut ch);
            }
            let amp = Complex64::new(y[0], y[1]);
            let props = model.gather(amp.norm(), &mut phi)?;
            complex_states(y.as_slice(), &mut ys);
            for p in ports {
                let r = p.state_offset..p.state_offset + p.ns;
                p.apply(model, &mut ch, &phi, amp, &ys[r], None);
            }
            if rate_terms {
                // the slow flow's A' at the sample, its rate force reported
                let fi = model.imposed_at(wi)?;
                let (k, fm, _) = model.terms_with(&props, &phi, wi, &ch[..nch], &fi);
                let wdot = sweep.omega_rate_rad_s2(ti);
                let rate = model.first_order_rate(
                    &props,
                    &phi,
                    amp.norm(),
                    wi,
                    wdot,
                    &dch[..nch],
                    fm - k * amp,
                    amp,
                )?;
                model.subtract_rate_forces(&mut ch[..nch], &dch[..nch], &phi, rate);
            }
            channels.extend_from_slice(&ch[..nch]);
            amps.push(amp);
        }
        emit(model, &self.ts, &w, &amps, &channels, sink)?;
        self.emitted += self.ts.len();
        self.ts.clear();
        self.states.clear();
        Ok(())
    }
}
