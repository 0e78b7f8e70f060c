//! The common case of a sweep compiled once per sweep: one attachment port
//! with one interface point (the paper's shaker) and no imposed force. The
//! slow flow's right-hand side is then straight-line code (no loops over
//! ports, points or imposed forces: about half the instructions of the
//! general [`ReducedModel::rhs`]), with every floating-point operation of
//! the general path in the same order on the same operands, so the numbers
//! are bit-identical.
use super::fast::cubic;
use super::{ReducedError, ReducedModel};
use num_complex::Complex64;

/// The channels and the table point of the one interface point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SinglePoint {
    /// Channel of `Z_G` (1 x 1); `T_G u_hat` is the next one.
    pub z: usize,
    /// Table point of the interface point.
    pub pt: usize,
}

impl ReducedModel {
    /// The single interface point of the model, if it has one port with one
    /// point and no imposed force.
    pub(crate) fn single_point(&self) -> Option<SinglePoint> {
        match &self.ports[..] {
            [port] if port.points.len() == 1 && self.imposed.is_empty() => Some(SinglePoint {
                z: port.offset,
                pt: port.points[0],
            }),
            _ => None,
        }
    }

    /// [`Self::rhs`] for a [`SinglePoint`] model, its channels the cubics
    /// `c` of the sweep's tabulation at local coordinate `tc` (the numbers
    /// of [`super::sweep::OmegaCache::eval`]). The same operations in the
    /// same order as the general path: `gather_at`, `terms_with` with one
    /// term, then the slow flow.
    #[inline(always)]
    pub(crate) fn rhs_single(
        &self,
        sp: SinglePoint,
        y: &[f64; 2],
        omega: f64,
        c: &[[Complex64; 4]],
        tc: f64,
    ) -> Result<[f64; 2], ReducedError> {
        let amp = Complex64::new(y[0], y[1]);
        let a = (y[0] * y[0] + y[1] * y[1]).sqrt();
        let loc = self.fast.locate(a)?;
        let mut w = self.fast.value(loc, 0);
        let damping = self.fast.value(loc, 1);
        let fe = self.frequency_error;
        if fe.eps != 0.0 || fe.offset_rad_s != 0.0 {
            w = self.detuned_omega(w, a)?;
        }
        let ph = self.fast.shape(loc, sp.pt);
        let (z_g, t_g) = match &c[sp.z..sp.z + 2] {
            [z, t] => (cubic(z, tc), cubic(t, tc)),
            _ => unreachable!(),
        };
        let zero = Complex64::new(0.0, 0.0);
        // terms_with's sums, each from zero as there
        let mut zr = zero;
        zr += z_g * ph;
        let mut za = zero;
        za += ph.conj() * zr;
        let mut fm = zero;
        fm += ph.conj() * t_g;
        let k = Complex64::new(w * w - omega * omega, 2.0 * damping * w * omega) + za;
        let z = fm - k * amp;
        let s = 0.5 / omega;
        Ok([z.im * s, -z.re * s])
    }
}
