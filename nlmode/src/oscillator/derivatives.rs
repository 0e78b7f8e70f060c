//! Derivatives of the oscillator for Model Exchange and extrapolating
//! masters: the Jacobian of the normal form's right-hand side, the outputs'
//! derivatives with respect to the state, and the outputs' rates along the
//! flow.
use super::{projection, ModalOscillator, OscillatorError, OscillatorState, PointResponse};
use crate::table::TableLocation;

impl ModalOscillator {
    /// Jacobian of [`Self::state_rate`] at the current state under the force
    /// `c_n` [N]: rows `eta'`, `u'`, columns `eta`, `u`, `c`; the exact
    /// derivative of the normal form's right-hand side
    /// `eta' = w u`, `u' = -w eta - 2 D w u + |phi_ex| c / w`
    /// with `w = (1 + eps) omega(a)`, `D(a)`, `phi_ex(a)` the PCHIP cubics of
    /// the table ([`TableInterpolator::slopes_at`],
    /// [`TableInterpolator::shape_slope_at`]) and `a = hypot(eta, u)`,
    /// `da/deta = eta/a`, `da/du = u/a`. Below the first tabulated amplitude
    /// (in particular at `a = 0`, where `hypot` has no derivative) the
    /// properties are held, their amplitude derivatives are 0 and the
    /// Jacobian is the linear oscillator's.
    ///
    /// With the force on every harmonic ([`Self::with_harmonic_force_projection`])
    /// and `a > 0`: the column of `c` exactly (the right-hand side is affine
    /// in `c`), the state columns by central differences of the right-hand
    /// side with the step and the one-sided rule at the table's end of
    /// [`Self::output_state_jacobian`] (about 1e-10 relative).
    pub fn jacobian(&self, c_n: f64) -> Result<[[f64; 3]; 2], OscillatorError> {
        let s = self.state;
        let a = s.amplitude();
        let loc = self.locate(a, s.time_s)?;
        if self.harmonic_projection && a > 0.0 {
            return self.jacobian_projected(c_n, &loc);
        }
        let (w, d, phi) = self.properties_at(&loc);
        let p = phi.norm();
        let (domega, dd) = self.interp.slopes_at(&loc);
        let dw = self.frequency_factor * domega;
        let dphi = self.interp.shape_slope_at(self.drive, 1, &loc);
        // d|phi|/da = Re(conj(phi) phi')/|phi|
        let dp = if p > 0.0 {
            (phi.conj() * dphi).re / p
        } else {
            0.0
        };
        let (a_eta, a_u) = if a > 0.0 {
            (s.eta / a, s.u / a)
        } else {
            (0.0, 0.0)
        };
        // d(eta')/da and d(u')/da at fixed (eta, u, c)
        let de_da = dw * s.u;
        let du_da = -dw * s.eta - 2.0 * (dd * w + d * dw) * s.u + c_n * (dp / w - p * dw / (w * w));
        Ok([
            [de_da * a_eta, w + de_da * a_u, 0.0],
            [-w + du_da * a_eta, -2.0 * d * w + du_da * a_u, p / w],
        ])
    }

    /// [`Self::jacobian`] with the force on every harmonic, at `a > 0` located at `loc`.
    fn jacobian_projected(
        &self,
        c_n: f64,
        loc: &TableLocation,
    ) -> Result<[[f64; 3]; 2], OscillatorError> {
        let s = self.state;
        let a = s.amplitude();
        let (w, _, phi_ex) = self.properties_at(loc);
        let (fe, fu) = projection::harmonic_forcing(
            &self.interp,
            self.drive,
            loc,
            (s.eta, s.u),
            a,
            1.0,
            w,
            phi_ex,
        );
        let h = 6e-6 * a.max(1e-3 * self.a_max);
        let rhs = |eta: f64, u: f64| self.rhs(eta, u, c_n, s.time_s);
        // the column of state component k (0: eta, 1: u)
        let column = |k: usize| -> Result<[f64; 2], OscillatorError> {
            let (de, du) = if k == 0 { (1.0, 0.0) } else { (0.0, 1.0) };
            if a + h <= self.a_max {
                let p = rhs(s.eta + h * de, s.u + h * du)?;
                let m = rhs(s.eta - h * de, s.u - h * du)?;
                return Ok([(p.0 - m.0) / (2.0 * h), (p.1 - m.1) / (2.0 * h)]);
            }
            // towards the origin: sg = -1 for a positive component
            let comp = if k == 0 { s.eta } else { s.u };
            let sg = if comp >= 0.0 { -1.0 } else { 1.0 };
            let f0 = rhs(s.eta, s.u)?;
            let f1 = rhs(s.eta + sg * h * de, s.u + sg * h * du)?;
            let f2 = rhs(s.eta + 2.0 * sg * h * de, s.u + 2.0 * sg * h * du)?;
            Ok([
                sg * (-3.0 * f0.0 + 4.0 * f1.0 - f2.0) / (2.0 * h),
                sg * (-3.0 * f0.1 + 4.0 * f1.1 - f2.1) / (2.0 * h),
            ])
        };
        let (d_eta, d_u) = (column(0)?, column(1)?);
        let j = [[d_eta[0], d_u[0], fe], [d_eta[1], d_u[1], fu]];
        Ok(j)
    }

    /// Derivatives of the outputs with respect to the state: for each of
    /// `points`, `[[dx/deta, dx/du], [dv/deta, dv/du]]` of
    /// [`Self::point_response`] written into `out`, and
    /// `[[da/deta, da/du], [domega/deta, domega/du]]` returned.
    ///
    /// `a` and `omega` exactly (`da/deta = eta/a`, `da/du = u/a`, 0 at `a = 0`,
    /// the symmetric value at the kink of `hypot`; `domega = (1 + eps)
    /// omega'(a) da`). `x`, `v` by a central difference of the synthesis in
    /// each state component with the step `h = 6e-6 max(a, 1e-3 a_max)`: the
    /// synthesis is a smooth function of `(eta, u)` on the scale `a` (the PCHIP
    /// cubics are C1, the phasor `z/a` turns on the scale `a`), so the
    /// truncation error `h^2 f'''/6` is about `(h/a)^2 ~ 4e-11` relative and
    /// the round-off `1e-16 a/h` about `2e-11` (a step of about
    /// `eps_mach^(1/3) a` balances the two). Where `a + h` would leave the
    /// table the one-sided second-order difference
    /// `(3 f(x) - 4 f(x - h) + f(x - 2h))/(2h)` towards the origin is used.
    /// The residual modes do not depend on `(eta, u)`.
    pub fn output_state_jacobian(
        &self,
        points: &[usize],
        out: &mut [[[f64; 2]; 2]],
    ) -> Result<[[f64; 2]; 2], OscillatorError> {
        assert_eq!(points.len(), out.len());
        let s = self.state;
        let a = s.amplitude();
        let loc = self.locate(a, s.time_s)?;
        let (domega, _) = self.interp.slopes_at(&loc);
        let dw = self.frequency_factor * domega;
        let (a_eta, a_u) = if a > 0.0 {
            (s.eta / a, s.u / a)
        } else {
            (0.0, 0.0)
        };
        if !points.is_empty() {
            let h = 6e-6 * a.max(1e-3 * self.a_max);
            let zero = PointResponse {
                x_m: 0.0,
                v_m_s: 0.0,
            };
            let mut r = vec![zero; 3 * points.len()];
            let (r0, rest) = r.split_at_mut(points.len());
            let (r1, r2) = rest.split_at_mut(points.len());
            for j in 0..2 {
                let comp = if j == 0 { s.eta } else { s.u };
                let dir = |k: f64| OscillatorState {
                    time_s: s.time_s,
                    eta: s.eta + if j == 0 { k } else { 0.0 },
                    u: s.u + if j == 1 { k } else { 0.0 },
                };
                if a + h <= self.a_max {
                    self.synthesize(&dir(h), points, r1)?;
                    self.synthesize(&dir(-h), points, r2)?;
                    for (o, (p, m)) in out.iter_mut().zip(r1.iter().zip(r2.iter())) {
                        o[0][j] = (p.x_m - m.x_m) / (2.0 * h);
                        o[1][j] = (p.v_m_s - m.v_m_s) / (2.0 * h);
                    }
                } else {
                    // towards the origin: sg = -1 for a positive component
                    let sg = if comp >= 0.0 { -1.0 } else { 1.0 };
                    self.synthesize(&s, points, r0)?;
                    self.synthesize(&dir(sg * h), points, r1)?;
                    self.synthesize(&dir(2.0 * sg * h), points, r2)?;
                    for (o, ((f0, f1), f2)) in
                        out.iter_mut().zip(r0.iter().zip(r1.iter()).zip(r2.iter()))
                    {
                        o[0][j] = sg * (-3.0 * f0.x_m + 4.0 * f1.x_m - f2.x_m) / (2.0 * h);
                        o[1][j] = sg * (-3.0 * f0.v_m_s + 4.0 * f1.v_m_s - f2.v_m_s) / (2.0 * h);
                    }
                }
            }
        }
        Ok([[a_eta, a_u], [dw * a_eta, dw * a_u]])
    }

    /// Time derivatives `(dx/dt, dv/dt)` of [`Self::point_response`] along the
    /// oscillator's flow under the force `c_n` [N] (for extrapolating masters).
    /// Central difference along the flow with the time increment
    /// `1e-5 / omega(a)`: truncation error ~1e-10 relative, round-off ~1e-11.
    pub fn point_response_rate(
        &self,
        point: usize,
        c_n: f64,
    ) -> Result<PointResponse, OscillatorError> {
        let mut out = [PointResponse {
            x_m: 0.0,
            v_m_s: 0.0,
        }];
        self.output_rates(&[point], c_n, &mut out)?;
        Ok(out[0])
    }

    /// `(da/dt, d omega/dt)` along the flow under the force `c_n` [N].
    pub fn modal_rate(&self, c_n: f64) -> Result<(f64, f64), OscillatorError> {
        self.output_rates(&[], c_n, &mut [])
    }

    /// All output rates at once (the FMU's output-derivative path): the rates
    /// [`Self::point_response_rate`] of several points written into `out`, and
    /// [`Self::modal_rate`] returned, with one state rate, one table look-up
    /// at the state and one synthesis of all points per side of the central
    /// difference. Equal to the single-quantity functions bit for bit.
    pub fn output_rates(
        &self,
        points: &[usize],
        c_n: f64,
        out: &mut [PointResponse],
    ) -> Result<(f64, f64), OscillatorError> {
        assert_eq!(points.len(), out.len());
        let s = self.state;
        let a = s.amplitude();
        let loc = self.locate(a, s.time_s)?;
        let (w, d, phi_ex) = self.properties_at(&loc);
        // the normal form's right-hand side, as `rhs`
        let (de, du) = if self.harmonic_projection && a > 0.0 {
            self.rhs_projected(&loc, (s.eta, s.u), a, c_n)
        } else {
            (
                w * s.u,
                -w * s.eta - 2.0 * d * w * s.u + phi_ex.norm() * c_n / w,
            )
        };
        if !points.is_empty() {
            let eps = 1e-5 / w;
            let plus = OscillatorState {
                time_s: s.time_s,
                eta: s.eta + eps * de,
                u: s.u + eps * du,
            };
            let minus = OscillatorState {
                time_s: s.time_s,
                eta: s.eta - eps * de,
                u: s.u - eps * du,
            };
            // two points (drive and tip) on the stack, more on the heap
            let mut stack = [PointResponse {
                x_m: 0.0,
                v_m_s: 0.0,
            }; 4];
            let mut heap = Vec::new();
            let both: &mut [PointResponse] = if 2 * points.len() <= stack.len() {
                &mut stack[..2 * points.len()]
            } else {
                heap.resize(
                    2 * points.len(),
                    PointResponse {
                        x_m: 0.0,
                        v_m_s: 0.0,
                    },
                );
                &mut heap
            };
            let (p, m) = both.split_at_mut(points.len());
            self.synthesize(&plus, points, p)?;
            self.synthesize(&minus, points, m)?;
            for ((o, p), m) in out.iter_mut().zip(p.iter()).zip(m.iter()) {
                *o = PointResponse {
                    x_m: (p.x_m - m.x_m) / (2.0 * eps),
                    v_m_s: (p.v_m_s - m.v_m_s) / (2.0 * eps),
                };
            }
            // the residual modes' part cancels in the difference: exactly
            if let Some(res) = &self.residual {
                for (o, &k) in out.iter_mut().zip(points) {
                    let (dx, dv) = res.response_rate(&self.residual_state, k, c_n);
                    o.x_m += dx;
                    o.v_m_s += dv;
                }
            }
        }
        if a == 0.0 {
            return Ok((0.0, 0.0));
        }
        let a_dot = (s.eta * de + s.u * du) / a;
        Ok((
            a_dot,
            self.frequency_factor * self.interp.eval_at(&loc).domega_da * a_dot,
        ))
    }
}
