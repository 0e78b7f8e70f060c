//! Harmonic Balance residuals in modal coordinates and their condensed
//! (Schur-complement) linear solver.
//!
//! The generalized coordinates are expanded in all mass-normalized linear modes
//! of the underlying undamped structure, `q = Phi eta` (`Phi^T M Phi = I`,
//! `Phi^T K Phi = diag(omega_k^2)`); this is exact (no truncation). The
//! Fourier coefficients of `eta` are stored harmonic-component major,
//! `X[h n + k]` = coefficient `h` (layout of [`super::hb::cos_index`]) of mode `k`.
//!
//! **EPMC** (`eq:EPMC`, `M q'' - 2 D omega M q' + C q' + K q + f_nl(q, q') = 0`)
//! with `q = a Psi`: per harmonic `n` and mode `k`, with `A = omega_k^2 - (n omega)^2`
//! and `B = n omega (C_m - 2 D omega I)` (`C_m = Phi^T C Phi`),
//!
//! ```text
//! R_c = A Psi_c + B Psi_s + (1/a) W F_c(a W^T Psi),
//! R_s = -B Psi_c + A Psi_s + (1/a) W F_s(a W^T Psi),
//! ```
//!
//! (the complex form `(K - (n omega)^2 M + i n omega (C - 2 D omega M)) q_n + f_n = 0`),
//! closed by the amplitude normalization `Psi_1^H Psi_1 = 1`, i.e.
//! `a = sqrt(q_1^H M q_1)` (Section 3.1), and the phase normalization
//! `Im(Psi_{1,j}) = 0` on the continued mode `j`. Unknowns
//! `X = [Psi; omega; D; log10 a]`; `log10 a` is the continuation parameter.
//! Here `W = Phi^T [w_1 ... w_E]` holds the nonlinear elements' directions.
//!
//! **Forced response** `M q'' + C q' + K q + f_nl = f cos(Omega t)` with
//! unknowns `X = [eta; Omega]`.
//!
//! **Condensation.** The linear part is block diagonal (2x2 per mode and
//! harmonic when `C_m` is diagonal, e.g. Rayleigh damping); the nonlinear part
//! is `P G P^T` with `P = I (x) W`. Newton systems bordered with the extra
//! unknowns and rows are solved by eliminating all well-conditioned modal
//! blocks (`|A + iB|` not small) and keeping explicitly the nonlinear
//! coordinates `z = G P^T y` (`E (2H+1)` of them), the near-resonant modal
//! blocks (always the continued mode's fundamental, plus any `n omega ~ omega_k`
//! internal resonance) and the bordered unknowns. The dense system left has
//! size `E(2H+1) + #near-resonant + #border`, independent of the model size;
//! forming it costs `O(n H (E^2 + #border))`. Non-diagonal modal damping falls
//! back to a dense solve of the full system.
use super::hb::{cos_index, sin_index, Aft};
use super::hb_jacobian::HbJacobian;
use super::modal_basis::ModalBasis;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::LN_10;
use std::sync::Arc;

/// Most Rayleigh-quotient iterations of [`EpmcResidual::linearised_guess`].
pub const LINEARISED_GUESS_ITERATIONS: usize = 50;

/// Most modes for which [`EpmcResidual::linearised_guess`] solves the dense
/// complex eigenproblem (`O(n^3)` per iteration); above, the undamped linear
/// mode is the start.
pub const LINEARISED_GUESS_MAX_MODES: usize = 400;

/// Linear harmonic rows `Lambda(omega, D) X` (unscaled) and their derivatives
/// w.r.t. `omega` and `D`.
fn linear_rows(
    basis: &ModalBasis,
    harmonics: usize,
    omega: f64,
    d: f64,
    x: &[f64],
) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
    let n = basis.n_modes();
    let m = n * (2 * harmonics + 1);
    let mut r = DVector::zeros(m);
    let mut dr_dom = DVector::zeros(m);
    let mut dr_dd = DVector::zeros(m);
    for k in 0..n {
        r[k] = basis.omega2[k] * x[k];
    }
    let mut bs = vec![0.0; n];
    let mut bc = vec![0.0; n];
    let mut cs = vec![0.0; n];
    let mut cc = vec![0.0; n];
    for nn in 1..=harmonics {
        let nf = nn as f64;
        let (hc, hs) = (cos_index(nn), sin_index(nn));
        let xc = &x[hc * n..(hc + 1) * n];
        let xs = &x[hs * n..(hs + 1) * n];
        basis.apply_b(nf, omega, d, xs, &mut bs);
        basis.apply_b(nf, omega, d, xc, &mut bc);
        // d B / d omega = n (C_m - 4 D omega I): apply via B(omega, 2D) / omega
        basis.apply_b(nf, omega, 2.0 * d, xs, &mut cs);
        basis.apply_b(nf, omega, 2.0 * d, xc, &mut cc);
        for k in 0..n {
            let a = basis.omega2[k] - (nf * omega).powi(2);
            let da = -2.0 * nf * nf * omega;
            r[hc * n + k] = a * xc[k] + bs[k];
            r[hs * n + k] = -bc[k] + a * xs[k];
            dr_dom[hc * n + k] = da * xc[k] + cs[k] / omega;
            dr_dom[hs * n + k] = -cc[k] / omega + da * xs[k];
            dr_dd[hc * n + k] = -2.0 * nf * omega * omega * xs[k];
            dr_dd[hs * n + k] = 2.0 * nf * omega * omega * xc[k];
        }
    }
    (r, dr_dom, dr_dd)
}

/// How the EPMC unknowns are normalised and which amplitude is the
/// continuation parameter (last unknown `X = [Psi; omega; D; log10 A]`,
/// `q = A Psi` in modal coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Normalisation {
    /// `A = a = sqrt(q_1^H M q_1)` (paper Section 3.1): `Psi_1^H Psi_1 = 1` and
    /// phase `Im(Psi_{1,j}) = 0` on the continued mode `j` (default). Along an
    /// internal-resonance loop the fundamental passes near zero, so `Psi`
    /// diverges and `log10 a -> -inf`: this form cannot pass loops.
    #[default]
    Fundamental,
    /// `A^2 = sum_{n>=1} n^2 q_n^H M q_n` (the kinetic-energy norm over all
    /// harmonics, `2 T_mean / omega^2`): `sum_n n^2 Psi_n^H Psi_n = 1` and phase
    /// `sum_n n s_{n,j} = 0` (the continued mode's modal velocity vanishes at
    /// `t = 0`), neither of which rests on the fundamental. All unknowns stay
    /// finite along loops; the paper's `a = A |Psi_1|` and `phi_n = Psi_n /
    /// |Psi_1|` are computed after each solve
    /// ([`EpmcResidual::to_fundamental`]).
    HarmonicEnergy,
}

/// [`EpmcResidual`]'s unknowns, split (see [`EpmcResidual::unknowns`]).
struct Unknowns<'x> {
    n: usize,
    nh: usize,
    m: usize,
    omega: f64,
    d: f64,
    amp: f64,
    psi: &'x [f64],
}

/// The EPMC residual (`eq:EPMC`) in modal Harmonic Balance form; unknowns
/// `X = [Psi; omega; D; log10 A]` (see module doc and [`Normalisation`]).
#[derive(Debug, Clone)]
pub struct EpmcResidual {
    basis: Arc<ModalBasis>,
    aft: Aft,
    mode: usize,
    row_scale: Arc<DVector<f64>>,
    normalisation: Normalisation,
}

impl EpmcResidual {
    /// Residual for the nonlinear mode continuing linear mode `mode` (0-based).
    pub fn new(basis: Arc<ModalBasis>, harmonics: usize, samples: usize, mode: usize) -> Self {
        assert!(harmonics >= 1, "EPMC needs at least one harmonic");
        assert!(mode < basis.n_modes());
        let row_scale = Arc::new(basis.row_scale(harmonics, basis.omega(mode)));
        Self {
            aft: Aft::new(harmonics, samples),
            basis,
            mode,
            row_scale,
            normalisation: Normalisation::Fundamental,
        }
    }

    /// The same residual with another normalisation.
    pub fn with_normalisation(mut self, normalisation: Normalisation) -> Self {
        self.normalisation = normalisation;
        self
    }

    /// The continued linear mode (0-based).
    pub fn mode(&self) -> usize {
        self.mode
    }

    pub fn normalisation(&self) -> Normalisation {
        self.normalisation
    }

    /// A solution `x` in the [`Normalisation::Fundamental`] form
    /// `[Psi; omega; D; log10 a]`: `a = A |Psi_1|`, `Psi_n` divided by `|Psi_1|`
    /// and shifted in time (`Psi_n e^{i n theta}`) so that `Im(Psi_{1,j}) = 0`,
    /// `Re(Psi_{1,j}) >= 0`. Identity for the fundamental normalisation.
    pub fn to_fundamental(&self, x: &DVector<f64>) -> DVector<f64> {
        if self.normalisation == Normalisation::Fundamental {
            return x.clone();
        }
        let n = self.basis.n_modes();
        let m = self.n_coeffs();
        let (ic, is) = (cos_index(1) * n, sin_index(1) * n);
        let p1 = (0..n)
            .map(|k| x[ic + k].powi(2) + x[is + k].powi(2))
            .sum::<f64>()
            .sqrt();
        // q_1j = c - i s; rotate by theta = -arg(q_1j)
        let theta = -(-x[is + self.mode]).atan2(x[ic + self.mode]);
        let mut y = x.clone();
        for nn in 0..=self.harmonics() {
            let (sn, cs) = ((nn as f64) * theta).sin_cos();
            for k in 0..n {
                let ck = x[cos_index(nn) * n + k];
                if nn == 0 {
                    y[k] = ck / p1;
                    continue;
                }
                let sk = x[sin_index(nn) * n + k];
                y[cos_index(nn) * n + k] = (ck * cs + sk * sn) / p1;
                y[sin_index(nn) * n + k] = (sk * cs - ck * sn) / p1;
            }
        }
        y[m + 2] = x[m + 2] + p1.log10();
        y
    }

    /// Kinetic-energy shares `n^2 Psi_{n,k}^2 / sum` of every harmonic `n`
    /// (index `n`, `0..=H`) and mode `k` (index `k`): `shares[n][k]`.
    pub fn harmonic_energy_shares(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        let n = self.basis.n_modes();
        let mut e: Vec<Vec<f64>> = (0..=self.harmonics())
            .map(|nn| {
                (0..n)
                    .map(|k| {
                        if nn == 0 {
                            0.0
                        } else {
                            (nn * nn) as f64
                                * (x[cos_index(nn) * n + k].powi(2)
                                    + x[sin_index(nn) * n + k].powi(2))
                        }
                    })
                    .collect()
            })
            .collect();
        let total: f64 = e.iter().flatten().sum();
        for v in e.iter_mut().flatten() {
            *v /= total;
        }
        e
    }

    pub fn basis(&self) -> &ModalBasis {
        &self.basis
    }

    pub fn harmonics(&self) -> usize {
        self.aft.harmonics()
    }

    /// Number of modal Fourier coefficients `m = n (2H+1)`.
    pub fn n_coeffs(&self) -> usize {
        self.basis.n_modes() * self.aft.n_coeffs()
    }

    /// The linear mode as start vector at `log10 a`.
    pub fn linear_guess(&self, log10_a: f64) -> DVector<f64> {
        let m = self.n_coeffs();
        let n = self.basis.n_modes();
        let mut x = DVector::zeros(m + 3);
        x[cos_index(1) * n + self.mode] = 1.0;
        x[m] = self.basis.omega(self.mode);
        x[m + 1] = self.basis.damping_ratio(self.mode);
        x[m + 2] = log10_a;
        x
    }

    /// The start vector at `log10 a` from the linear mode of the system
    /// linearised at rest: every element's tangent `(df/du, df/dv)` at
    /// `u = v = 0` ([`NonlinearLaw::eval`]; for a Jenkins element its stick
    /// stiffness `k_t`, for `tanh` friction the damper `F_s / v_r`) added to
    /// `K` and `C`. The EPMC of a linear system is the nonlinear eigenproblem
    /// `(K_l + i omega C_l - s M) psi = 0`, `s = omega^2 (1 + 2 i D)`, solved by
    /// Rayleigh-quotient inverse iteration in modal coordinates from the
    /// continued mode (at most [`LINEARISED_GUESS_ITERATIONS`] iterations); for
    /// a damper-like element the start is thus the complex mode. Falls back to
    /// [`Self::linear_guess`] where all tangents vanish (then identical, e.g.
    /// cubic springs), for more than [`LINEARISED_GUESS_MAX_MODES`] modes, or
    /// if the iteration fails.
    pub fn linearised_guess(&self, log10_a: f64) -> DVector<f64> {
        use num_complex::Complex64 as C64;
        let basis = &*self.basis;
        let n = basis.n_modes();
        let tangents: Vec<(f64, f64)> = basis
            .laws
            .iter()
            .map(|l| {
                let (_, k, c) = l.eval(0.0, 0.0);
                (k, c)
            })
            .collect();
        let finite = tangents.iter().all(|t| t.0.is_finite() && t.1.is_finite());
        if !finite || tangents.iter().all(|t| *t == (0.0, 0.0)) || n > LINEARISED_GUESS_MAX_MODES {
            return self.linear_guess(log10_a);
        }
        let mut kl = DMatrix::from_diagonal(&basis.omega2);
        let mut cl = basis.cm.clone();
        for (e, &(k, c)) in tangents.iter().enumerate() {
            let we = basis.w.column(e);
            kl += (we * we.transpose()) * k;
            cl += (we * we.transpose()) * c;
        }
        let j = self.mode;
        let mut psi =
            DVector::<C64>::from_fn(n, |k, _| C64::new(if k == j { 1.0 } else { 0.0 }, 0.0));
        let mut s = C64::new(basis.omega2[j], 0.0);
        let mut converged = false;
        for _ in 0..LINEARISED_GUESS_ITERATIONS {
            let omega = s.re.max(0.0).sqrt();
            let b = DMatrix::<C64>::from_fn(n, n, |r, c| C64::new(kl[(r, c)], omega * cl[(r, c)]));
            let mut a = b.clone();
            for k in 0..n {
                a[(k, k)] -= s;
            }
            let next = match a.lu().solve(&psi) {
                Some(y) if y.iter().all(|v| v.re.is_finite() && v.im.is_finite()) => y,
                // `s` is an eigenvalue to machine precision
                _ => {
                    converged = true;
                    break;
                }
            };
            let norm = next.norm();
            if norm.is_nan() || norm <= 0.0 {
                break;
            }
            psi = next / C64::new(norm, 0.0);
            let s_new = psi.dotc(&(&b * &psi));
            let done = (s_new - s).norm() <= 1e-13 * s_new.norm();
            s = s_new;
            if done {
                converged = true;
                break;
            }
        }
        if !converged || s.re.is_nan() || s.re <= 0.0 || psi[j].norm() == 0.0 {
            return self.linear_guess(log10_a);
        }
        // unit norm, psi_j real and positive
        let rot = psi[j].conj() / psi[j].norm();
        let psi = psi.map(|v| v * rot / C64::new(psi.norm(), 0.0));
        let m = self.n_coeffs();
        let mut x = DVector::zeros(m + 3);
        for k in 0..n {
            x[cos_index(1) * n + k] = psi[k].re;
            x[sin_index(1) * n + k] = -psi[k].im;
        }
        x[sin_index(1) * n + j] = 0.0;
        x[m] = s.re.sqrt();
        x[m + 1] = s.im / (2.0 * s.re);
        x[m + 2] = log10_a;
        x
    }

    /// `|Psi_1|^2 / sum_n n^2 |Psi_n|^2` (modal coordinates are mass-normalized).
    pub fn fundamental_energy_share(&self, x: &DVector<f64>) -> f64 {
        let n = self.basis.n_modes();
        let mut e1 = 0.0;
        let mut total = 0.0;
        for nn in 1..=self.harmonics() {
            let en: f64 = (cos_index(nn) * n..(sin_index(nn) + 1) * n)
                .map(|i| x[i] * x[i])
                .sum();
            if nn == 1 {
                e1 = en;
            }
            total += (nn * nn) as f64 * en;
        }
        e1 / total
    }

    /// Complex harmonics `phi_n`, `n = 0..=H`, of the generalized coordinates
    /// (`q = Re(a sum phi_n e^{i n omega t})`), from a solution `x`.
    pub fn shape_harmonics(
        &self,
        x: &DVector<f64>,
    ) -> Vec<nalgebra::DVector<num_complex::Complex64>> {
        let n = self.basis.n_modes();
        (0..=self.harmonics())
            .map(|nn| {
                let c = DVector::from_column_slice(
                    &x.as_slice()[cos_index(nn) * n..(cos_index(nn) + 1) * n],
                );
                let pc = &self.basis.phi * c;
                if nn == 0 {
                    pc.map(|v| num_complex::Complex64::new(v, 0.0))
                } else {
                    let s = DVector::from_column_slice(
                        &x.as_slice()[sin_index(nn) * n..(sin_index(nn) + 1) * n],
                    );
                    let ps = &self.basis.phi * s;
                    DVector::from_fn(n, |i, _| num_complex::Complex64::new(pc[i], -ps[i]))
                }
            })
            .collect()
    }

    /// Complex harmonics `e^T phi_n` of an observation direction `e` (physical).
    pub fn observe(&self, x: &DVector<f64>, e_modal: &DVector<f64>) -> Vec<num_complex::Complex64> {
        observe_harmonics(self.harmonics(), x, e_modal)
    }
}

/// Complex harmonics `e_modal^T psi_n`, `n = 0..=harmonics`, of the modal
/// harmonic coefficients at the start of `x` (cosine/sine blocks of
/// `n_modes = e_modal.len()` entries; `q_n = c_n - i s_n`).
fn observe_harmonics(
    harmonics: usize,
    x: &DVector<f64>,
    e_modal: &DVector<f64>,
) -> Vec<num_complex::Complex64> {
    let n = e_modal.len();
    let dot = |block: usize| -> f64 { (0..n).map(|k| e_modal[k] * x[block * n + k]).sum() };
    (0..=harmonics)
        .map(|nn| {
            if nn == 0 {
                num_complex::Complex64::new(dot(cos_index(0)), 0.0)
            } else {
                num_complex::Complex64::new(dot(cos_index(nn)), -dot(sin_index(nn)))
            }
        })
        .collect()
}

impl EpmcResidual {
    /// The unknowns `x = [psi (n modes x nh coefficients), omega, D, log10 a]`
    /// split into their parts (`a` = 10^lg), for the residual and its Jacobian.
    fn unknowns<'x>(&self, x: &'x DVector<f64>) -> Unknowns<'x> {
        let n = self.basis.n_modes();
        let nh = self.aft.n_coeffs();
        let m = n * nh;
        Unknowns {
            n,
            nh,
            m,
            omega: x[m],
            d: x[m + 1],
            amp: 10f64.powf(x[m + 2]),
            psi: &x.as_slice()[..m],
        }
    }

    /// The amplitude and phase rows of [`Normalisation`] into `res[m..m + 2]`
    /// and, if given, their derivatives into `border_rows` (`2 x (m + 3)`).
    fn normalisation_rows(
        &self,
        psi: &[f64],
        res: &mut DVector<f64>,
        mut border_rows: Option<&mut DMatrix<f64>>,
    ) {
        let n = self.basis.n_modes();
        let m = psi.len();
        match self.normalisation {
            Normalisation::Fundamental => {
                let (ic, is) = (cos_index(1) * n, sin_index(1) * n);
                res[m] = psi[is + self.mode];
                res[m + 1] = (0..n)
                    .map(|k| psi[ic + k].powi(2) + psi[is + k].powi(2))
                    .sum::<f64>()
                    - 1.0;
                if let Some(br) = border_rows.as_deref_mut() {
                    br[(0, is + self.mode)] = 1.0;
                    for k in 0..n {
                        br[(1, ic + k)] = 2.0 * psi[ic + k];
                        br[(1, is + k)] = 2.0 * psi[is + k];
                    }
                }
            }
            Normalisation::HarmonicEnergy => {
                let mut norm = -1.0;
                for nn in 1..=self.harmonics() {
                    let (w, nf) = (((nn * nn) as f64), nn as f64);
                    let (ic, is) = (cos_index(nn) * n, sin_index(nn) * n);
                    res[m] += nf * psi[is + self.mode];
                    if let Some(br) = border_rows.as_deref_mut() {
                        br[(0, is + self.mode)] = nf;
                    }
                    for k in 0..n {
                        norm += w * (psi[ic + k].powi(2) + psi[is + k].powi(2));
                        if let Some(br) = border_rows.as_deref_mut() {
                            br[(1, ic + k)] = 2.0 * w * psi[ic + k];
                            br[(1, is + k)] = 2.0 * w * psi[is + k];
                        }
                    }
                }
                res[m + 1] = norm;
            }
        }
    }
}

impl super::continuation::Residual for EpmcResidual {
    type Jacobian = HbJacobian;

    fn n_unknowns(&self) -> usize {
        self.n_coeffs() + 3
    }

    /// The residual of [`Self::eval`] without the AFT Jacobians.
    fn residual(&self, x: &DVector<f64>) -> DVector<f64> {
        let basis = &*self.basis;
        let Unknowns {
            n,
            nh,
            m,
            omega,
            d,
            amp,
            psi,
        } = self.unknowns(x);
        let (mut r, _, _) = linear_rows(basis, self.harmonics(), omega, d, psi);
        let u = basis.element_coeffs(psi, nh, amp);
        for (e, ue) in u.iter().enumerate() {
            let force = self.aft.force(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            for h in 0..nh {
                let fh = force[h] / amp;
                for k in 0..n {
                    r[h * n + k] += we[k] * fh;
                }
            }
        }
        let mut res = DVector::zeros(m + 2);
        for i in 0..m {
            res[i] = r[i] / self.row_scale[i];
        }
        self.normalisation_rows(psi, &mut res, None);
        res
    }

    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, HbJacobian) {
        let basis = &*self.basis;
        let Unknowns {
            n,
            nh,
            m,
            omega,
            d,
            amp,
            psi,
        } = self.unknowns(x);
        let (mut r, mut dr_dom, dr_dd) = linear_rows(basis, self.harmonics(), omega, d, psi);
        let mut dr_dlg = DVector::zeros(m);
        let u = basis.element_coeffs(psi, nh, amp);
        let mut g = Vec::with_capacity(u.len());
        for (e, ue) in u.iter().enumerate() {
            let out = self.aft.eval(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            let gu_minus_f = &out.jac_u * ue - &out.force;
            for h in 0..nh {
                let (fh, fwh, glh) = (
                    out.force[h] / amp,
                    out.jac_omega[h] / amp,
                    LN_10 * gu_minus_f[h] / amp,
                );
                for k in 0..n {
                    r[h * n + k] += we[k] * fh;
                    dr_dom[h * n + k] += we[k] * fwh;
                    dr_dlg[h * n + k] += we[k] * glh;
                }
            }
            g.push(out.jac_u);
        }
        let mut res = DVector::zeros(m + 2);
        for i in 0..m {
            res[i] = r[i] / self.row_scale[i];
        }
        let mut border_cols = DMatrix::zeros(m, 3);
        border_cols.set_column(0, &dr_dom);
        border_cols.set_column(1, &dr_dd);
        border_cols.set_column(2, &dr_dlg);
        let mut border_rows = DMatrix::zeros(2, m + 3);
        self.normalisation_rows(psi, &mut res, Some(&mut border_rows));
        let jac = HbJacobian {
            basis: self.basis.clone(),
            harmonics: self.harmonics(),
            omega,
            d,
            g,
            row_scale: self.row_scale.clone(),
            border_cols,
            border_rows,
            explicit: vec![(self.mode, 1)],
        };
        (res, jac)
    }
}

/// Harmonic Balance residual of the forced response
/// `M q'' + C q' + K q + f_nl(q, q') = f cos(Omega t)`; unknowns
/// `X = [eta; Omega]` (modal Fourier coefficients, excitation frequency
/// [rad/s] as continuation parameter).
#[derive(Debug, Clone)]
pub struct ForcedResidual {
    basis: Arc<ModalBasis>,
    aft: Aft,
    force_modal: DVector<f64>,
    row_scale: Arc<DVector<f64>>,
}

impl ForcedResidual {
    /// `force` [N] in generalized coordinates (length `n`); `omega_ref` sets the
    /// row scaling (any frequency of the range of interest).
    pub fn new(
        basis: Arc<ModalBasis>,
        harmonics: usize,
        samples: usize,
        force: &DVector<f64>,
        omega_ref: f64,
    ) -> Self {
        assert_eq!(force.len(), basis.n_modes());
        let force_modal = basis.phi.transpose() * force;
        let row_scale = Arc::new(basis.row_scale(harmonics, omega_ref));
        Self {
            aft: Aft::new(harmonics, samples),
            basis,
            force_modal,
            row_scale,
        }
    }

    pub fn n_coeffs(&self) -> usize {
        self.basis.n_modes() * self.aft.n_coeffs()
    }

    /// Linear (harmonic-1, nonlinearity ignored) response at `omega` as start vector.
    pub fn linear_guess(&self, omega: f64) -> DVector<f64> {
        let n = self.basis.n_modes();
        let m = self.n_coeffs();
        let mut x = DVector::zeros(m + 1);
        for k in 0..n {
            let a = self.basis.omega2[k] - omega * omega;
            let b = omega * self.basis.cm[(k, k)];
            let det = a * a + b * b;
            // [[a, b], [-b, a]] (c, s) = (f, 0)
            x[cos_index(1) * n + k] = a * self.force_modal[k] / det;
            x[sin_index(1) * n + k] = b * self.force_modal[k] / det;
        }
        x[m] = omega;
        x
    }

    /// Complex harmonics `e^T q_n` [m] of a physical observation direction `e`.
    pub fn observe(&self, x: &DVector<f64>, e: &DVector<f64>) -> Vec<num_complex::Complex64> {
        observe_harmonics(self.aft.harmonics(), x, &(self.basis.phi.transpose() * e))
    }
}

impl super::continuation::Residual for ForcedResidual {
    type Jacobian = HbJacobian;

    fn n_unknowns(&self) -> usize {
        self.n_coeffs() + 1
    }

    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, HbJacobian) {
        let basis = &*self.basis;
        let n = basis.n_modes();
        let nh = self.aft.n_coeffs();
        let m = n * nh;
        let omega = x[m];
        let eta = &x.as_slice()[..m];
        let (mut r, mut dr_dom, _) = linear_rows(basis, self.aft.harmonics(), omega, 0.0, eta);
        for k in 0..n {
            r[cos_index(1) * n + k] -= self.force_modal[k];
        }
        let u = basis.element_coeffs(eta, nh, 1.0);
        let mut g = Vec::with_capacity(u.len());
        for (e, ue) in u.iter().enumerate() {
            let out = self.aft.eval(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            for h in 0..nh {
                for k in 0..n {
                    r[h * n + k] += we[k] * out.force[h];
                    dr_dom[h * n + k] += we[k] * out.jac_omega[h];
                }
            }
            g.push(out.jac_u);
        }
        let res = r.component_div(&self.row_scale);
        let jac = HbJacobian {
            basis: self.basis.clone(),
            harmonics: self.aft.harmonics(),
            omega,
            d: 0.0,
            g,
            row_scale: self.row_scale.clone(),
            border_cols: DMatrix::from_column_slice(m, 1, dr_dom.as_slice()),
            border_rows: DMatrix::zeros(0, m + 1),
            explicit: vec![],
        };
        (res, jac)
    }
}
