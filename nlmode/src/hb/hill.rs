//! Stability of a harmonic-balance solution by Hill's method.
//!
//! The perturbation of the periodic solution obeys the linearised assembled
//! system in its explicit first-order form (structure and every attachment
//! state, [`crate::reference::assembly::FirstOrderSystem`]),
//!
//! ```text
//! dz' = A dz + sum_e g_e (k_e(t) c_e^T + d_e(t) d_e^T) dz,
//! k_e(t) = df_e/du (u_e(t), v_e(t)),   d_e(t) = df_e/dv,
//! ```
//!
//! with `u_e(t)` the HB solution at element `e`. With the Floquet ansatz
//! `dz = e^{s t} sum_h Y_h phi_h(Omega t)` on the same `2H+1` real Fourier
//! functions as the HB, `s Y = Hill Y` with the real Hill matrix
//!
//! ```text
//! Hill = I (x) A - Omega (D (x) I) + sum_e T[k_e] (x) g_e c_e^T + T[d_e] (x) g_e d_e^T,
//! ```
//!
//! `D` the derivative of the Fourier functions and `T[k]` the harmonic
//! (Toeplitz) matrix of multiplication by `k(t)` - the AFT's `dF/dU` of the
//! law with only its `u`-derivative (respectively its `v`-derivative) kept, so
//! the same AFT and samples as the HB. For a hysteretic law the HB
//! Jacobian `dF/dU` itself is used for `T[k]` and `T[d] = 0`.
//!
//! **Sorting.** The Hill matrix has `nz (2H+1)` eigenvalues: each Floquet
//! exponent appears with copies shifted by `i k Omega`, and truncation adds
//! spurious ones near the ends of the harmonic range. The `nz` kept ones are
//! those with the smallest `|n_bar| + |Im s| / Omega`, where `n_bar = sum n
//! |Y_n|^2 / sum |Y_n|^2` is the energy centroid of the eigenvector over the
//! complex harmonics `n = -H..H` (the copy `s + i k Omega` has its centroid
//! shifted by `-k`, so the key is the same for every accurate copy, ties going
//! to the smaller centroid, i.e. the most periodic eigenvector), while a
//! spurious eigenvalue (an edge copy mixed by the truncation) has either a
//! centred eigenvector far from the real axis or a far centroid. Both terms
//! alone fail: the centroid keeps the spurious centred pairs of `H = 1`
//! Duffing middle branches, the imaginary part alone keeps spurious copies of
//! modes above `H Omega`. The solution is **stable** when every
//! kept exponent has `Re s < 0` (a margin of `1e-9` times the largest kept
//! `|s|` absorbs the eigensolver's rounding at a fold, where one exponent is
//! exactly zero).
use super::residual::HbResidual;
use crate::nma::hb::{cos_index, sin_index};
use crate::structure::NonlinearLaw;
use faer::Mat;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// The law with only `df/du` kept (as `df/du`): `dF/dU` of the AFT is `T[k]`.
#[derive(Debug)]
struct StiffnessPart<'a>(&'a dyn NonlinearLaw);
/// The law's `df/dv` reported as `df/du`: `dF/dU` of the AFT is `T[d]`.
#[derive(Debug)]
struct DampingPart<'a>(&'a dyn NonlinearLaw);

impl NonlinearLaw for StiffnessPart<'_> {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
        let (f, fu, _) = self.0.eval(u, v);
        (f, fu, 0.0)
    }
}

impl NonlinearLaw for DampingPart<'_> {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
        let (f, _, fv) = self.0.eval(u, v);
        (f, fv, 0.0)
    }
}

/// Floquet exponents of one solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Floquet {
    /// The kept exponents `s` \[1/s\] (`nz` of them).
    pub exponents: Vec<Complex64>,
    /// Largest real part of the kept exponents.
    pub max_re: f64,
    /// Largest real part among the kept exponents with a non-zero imaginary
    /// part (complex pairs; the Neimark-Sacker test function).
    pub max_re_complex: f64,
    /// Number of kept exponents with a non-zero imaginary part.
    pub n_complex: usize,
    pub stable: bool,
}

/// Per element, the harmonic operators `T[df/du]` and `T[df/dv]` (real
/// cos/sin basis, `(2H+1) x (2H+1)`) at `x`; for a hysteretic law the HB
/// Jacobian `dF/dU` and no `T[d]` (module docs).
pub(crate) fn element_operators(
    res: &HbResidual,
    x: &DVector<f64>,
) -> Vec<(DMatrix<f64>, Option<DMatrix<f64>>)> {
    let omega = x[x.len() - 1];
    res.element_coeffs(x)
        .iter()
        .zip(&res.sys.laws)
        .map(|(u, law)| {
            if law.hysteresis().is_some() {
                (res.aft.eval(law.as_ref(), u, omega).jac_u, None)
            } else {
                let tk = res.aft.eval(&StiffnessPart(law.as_ref()), u, omega).jac_u;
                let td = res.aft.eval(&DampingPart(law.as_ref()), u, omega).jac_u;
                (tk, Some(td))
            }
        })
        .collect()
}

/// The real Hill matrix at `x` (module docs).
pub(crate) fn hill_matrix(res: &HbResidual, x: &DVector<f64>, h: usize) -> Option<DMatrix<f64>> {
    let fo = res.sys.first_order.as_ref().ok()?;
    let nz = fo.a.nrows();
    let h = h.min(res.harmonics());
    let nh = 2 * h + 1;
    let omega = x[x.len() - 1];
    let ne = res.sys.n_elements();
    let mut hill = DMatrix::zeros(nz * nh, nz * nh);
    for b in 0..nh {
        hill.view_mut((b * nz, b * nz), (nz, nz)).copy_from(&fo.a);
    }
    for n in 1..=h {
        let (c, s) = (cos_index(n), sin_index(n));
        let w = n as f64 * omega;
        for i in 0..nz {
            hill[(c * nz + i, s * nz + i)] -= w;
            hill[(s * nz + i, c * nz + i)] += w;
        }
    }
    for (e, (tk, td)) in element_operators(res, x).into_iter().enumerate() {
        let g = fo.g.column(e);
        let gc = g * fo.proj.row(e);
        let gd = g * fo.proj.row(ne + e);
        for b in 0..nh {
            for b2 in 0..nh {
                let k = tk[(b, b2)];
                let d = td.as_ref().map_or(0.0, |t| t[(b, b2)]);
                if k == 0.0 && d == 0.0 {
                    continue;
                }
                let mut blk = hill.view_mut((b * nz, b2 * nz), (nz, nz));
                blk += &gc * k + &gd * d;
            }
        }
    }
    Some(hill)
}

/// Eigenvalues and right eigenvectors of the real matrix `m` (faer's real
/// EVD, sequential: the Hill matrices of a continuation are a few hundred
/// rows, where rayon's threads cost more than they save, 2.6x measured on
/// the paper beam at H = 7); the eigenvectors as columns.
pub(crate) fn real_eigen(m: &DMatrix<f64>) -> Option<(Vec<Complex64>, DMatrix<Complex64>)> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{evd_real, evd_scratch, ComputeEigenvectors};
    let n = m.nrows();
    let a = Mat::<f64>::from_fn(n, n, |i, j| m[(i, j)]);
    let par = faer::Par::Seq;
    let mut u = Mat::<f64>::zeros(n, n);
    let mut s_re = faer::diag::Diag::<f64>::zeros(n);
    let mut s_im = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    evd_real(
        a.as_ref(),
        s_re.as_mut(),
        s_im.as_mut(),
        None,
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .ok()?;
    // faer's real storage: a complex pair (k, k+1) holds the first
    // eigenvector's real and imaginary parts in columns k and k+1, the second
    // is its conjugate
    let mut s = vec![Complex64::new(0.0, 0.0); n];
    let mut v = DMatrix::<Complex64>::zeros(n, n);
    let mut k = 0;
    while k < n {
        if s_im[k] == 0.0 || k + 1 == n {
            s[k] = Complex64::new(s_re[k], s_im[k]);
            for i in 0..n {
                v[(i, k)] = Complex64::new(u[(i, k)], 0.0);
            }
            k += 1;
        } else {
            s[k] = Complex64::new(s_re[k], s_im[k]);
            s[k + 1] = s[k].conj();
            for i in 0..n {
                v[(i, k)] = Complex64::new(u[(i, k)], u[(i, k + 1)]);
                v[(i, k + 1)] = v[(i, k)].conj();
            }
            k += 2;
        }
    }
    Some((s, v))
}

/// Floquet exponents of the solution `x` (module docs), `None` if the
/// eigenvalue problem failed or the assembly has no first-order form.
pub(crate) fn floquet(
    res: &HbResidual,
    x: &DVector<f64>,
    h: usize,
    method: super::HillMethod,
) -> Option<Floquet> {
    if method == super::HillMethod::Condensed {
        if let Some(f) = res
            .sys
            .modal
            .as_ref()
            .and_then(|m| super::hill_band::floquet_band(res, m, x, h))
        {
            return Some(f);
        }
    }
    floquet_full(res, x, h)
}

/// [`floquet`] from every eigenvalue of the full Hill matrix.
fn floquet_full(res: &HbResidual, x: &DVector<f64>, h: usize) -> Option<Floquet> {
    let hill = hill_matrix(res, x, h)?;
    let fo = res.sys.first_order.as_ref().ok()?;
    let nz = fo.a.nrows();
    let h = h.min(res.harmonics());
    let omega = x[x.len() - 1];
    let dim = hill.nrows();
    let (s, u) = real_eigen(&hill)?;
    let mut ranked: Vec<(f64, f64, Complex64)> = (0..dim)
        .map(|k| {
            let at = |i: usize| u[(i, k)];
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..nz {
                den += at(i).norm_sqr();
            }
            for n in 1..=h {
                let (c, sn) = (cos_index(n), sin_index(n));
                let (mut wp, mut wm) = (0.0, 0.0);
                for i in 0..nz {
                    let (yc, ys) = (at(c * nz + i), at(sn * nz + i));
                    let j = Complex64::i();
                    wp += (yc - j * ys).norm_sqr();
                    wm += (yc + j * ys).norm_sqr();
                }
                num += n as f64 * (wp - wm);
                den += wp + wm;
            }
            let lam = s[k];
            let centroid = num / den.max(f64::MIN_POSITIVE);
            (1.001 * centroid.abs() + lam.im.abs() / omega, centroid, lam)
        })
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let exponents = keep_one_per_family(&ranked, nz, h, omega);
    summarise(exponents, omega)
}

/// The Floquet summary of the kept exponents (`None` if there are none or
/// one is not finite).
pub(crate) fn summarise(exponents: Vec<Complex64>, omega: f64) -> Option<Floquet> {
    if exponents.is_empty()
        || exponents
            .iter()
            .any(|e| !(e.re.is_finite() && e.im.is_finite()))
    {
        return None;
    }
    let scale = exponents.iter().map(|e| e.norm()).fold(0.0, f64::max);
    let max_re = exponents
        .iter()
        .map(|e| e.re)
        .fold(f64::NEG_INFINITY, f64::max);
    let tol = 1e-9 * scale.max(omega);
    // a multiplier e^{sT} off the real axis: the band-folded imaginary part
    // is neither 0 (multiplier > 0) nor Omega/2 (multiplier < 0)
    let complex = || {
        exponents.iter().filter(|e| {
            let b = band(**e, omega).im.abs();
            b > tol && b < 0.5 * omega - tol
        })
    };
    let max_re_complex = complex().map(|e| e.re).fold(f64::NEG_INFINITY, f64::max);
    let n_complex = complex().count();
    Some(Floquet {
        stable: max_re <= 1e-9 * scale,
        exponents,
        max_re,
        max_re_complex,
        n_complex,
    })
}

/// The copy of `s` in the fundamental band: `s - i k Omega` with
/// `|Im| <= Omega/2`.
pub(crate) fn band(s: Complex64, omega: f64) -> Complex64 {
    let k = (s.im / omega).round();
    Complex64::new(s.re, s.im - k * omega)
}

/// The first `nz` exponents of `ranked` (key, energy centroid, eigenvalue;
/// best first) that are centred (`|n_bar| <= max(H/2, 1/2)`: an eigenvector
/// whose energy sits in the outer half of the harmonic range is a truncated
/// copy, inaccurate) and not a copy of one already kept. A copy `s + i k
/// Omega` (`0 < |k| <= 2H`, within the Hill matrix's harmonic range) of a
/// kept exponent has the same band copy up to the truncation error of the
/// less centred one (`1e-2 Omega` accepted: 0.3 % of Omega measured on the
/// paper beam at H = 3); two eigenvalues with the same raw imaginary part
/// (`k = 0`) are distinct exponents however close (a real pair near a fold).
fn keep_one_per_family(
    ranked: &[(f64, f64, Complex64)],
    nz: usize,
    h: usize,
    omega: f64,
) -> Vec<Complex64> {
    let max_centroid = (0.5 * h as f64).max(0.5);
    let mut kept: Vec<Complex64> = Vec::with_capacity(nz);
    for &(_, centroid, s) in ranked {
        if kept.len() == nz {
            break;
        }
        if centroid.abs() > max_centroid {
            continue;
        }
        let b = band(s, omega);
        let copy = |k: &Complex64| {
            let shift = ((s.im - k.im) / omega).round().abs();
            shift >= 1.0 && shift <= 2.0 * h as f64 && (band(*k, omega) - b).norm() < 1e-2 * omega
        };
        if !kept.iter().any(copy) {
            kept.push(s);
        }
    }
    kept
}
