//! The iterative coupling of [`Master`] (implicit, with rollback; the
//! algorithm in the module docs of [`super`]): one interface evaluation, the
//! residual, the quasi-Newton iteration with Broyden's update, and its
//! Jacobian by finite differences or, column by column, from the FMI 3.0
//! units' directional derivatives.
use nalgebra::{DMatrix, DVector};

use super::{Link, Master, MasterError, Unit};

/// Which units the iterative master asks for directional derivatives
/// (`fmi3GetDirectionalDerivative`) of their connected outputs with respect
/// to their connected inputs: those that provide them (FMI 3.0 with
/// `providesDirectionalDerivatives`) and have both; the columns of the other
/// units' inputs are built by finite differences. `None` when no unit is
/// asked (all by finite differences).
pub(super) fn directional_units(us: &[Unit], links: &[Link]) -> Option<Vec<bool>> {
    let ask: Vec<bool> = us
        .iter()
        .enumerate()
        .map(|(ui, u)| {
            u.inst.version() == crate::import::Version::Fmi3
                && u.fmu.md.co_simulation.provides_directional_derivative
                && links.iter().any(|l| l.src == ui)
                && links.iter().any(|l| l.dst == ui)
        })
        .collect();
    ask.iter().any(|&a| a).then_some(ask)
}

impl Master {
    /// One interface evaluation: restore, step every unit with inputs linear
    /// from `y` to `guess`, return `G(guess)` in `self.y_new`.
    fn evaluate(
        &mut self,
        t: f64,
        h: f64,
        guess: &DVector<f64>,
        restore: bool,
    ) -> Result<(), MasterError> {
        if restore {
            for u in &mut self.units {
                u.inst.restore_state()?;
            }
        }
        for c in 0..self.links.len() {
            let l = &self.links[c];
            if l.interp {
                self.units[l.dst].inst.set_real(&[l.dst_vr], &[self.y[c]])?;
                self.set_slope(c, (guess[c] - self.y[c]) / h)?;
            } else {
                self.units[l.dst].inst.set_real(&[l.dst_vr], &[guess[c]])?;
            }
        }
        for u in &mut self.units {
            u.inst.do_step(t, h)?;
        }
        self.stats.do_steps += self.units.len();
        self.stats.evaluations += 1;
        for u in 0..self.units.len() {
            self.read_outputs(u)?;
            for j in 0..self.ports[u].out_links.len() {
                self.y_new[self.ports[u].out_links[j]] = self.buf[j];
            }
        }
        Ok(())
    }

    fn residual(&self, guess: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            guess.len(),
            (0..guess.len()).map(|c| self.y_new[c] - guess[c]),
        )
    }

    /// Relative size of a residual: max over connections of
    /// `|r_c| / max(scale_c, |Y_c|)` (absolute below 1e-300).
    fn rel_norm(&self, r: &DVector<f64>, guess: &DVector<f64>) -> f64 {
        r.iter()
            .enumerate()
            .map(|(c, v)| v.abs() / self.scale[c].max(guess[c].abs()).max(1e-300))
            .fold(0.0, f64::max)
    }

    /// Finite-difference Jacobian `dR/dY` around `guess` (whose residual is `r0`).
    fn fd_jacobian(
        &mut self,
        t: f64,
        h: f64,
        guess: &DVector<f64>,
        r0: &DVector<f64>,
    ) -> Result<DMatrix<f64>, MasterError> {
        let nc = guess.len();
        let mut j = DMatrix::zeros(nc, nc);
        self.fd_columns(t, h, guess, r0, &mut j, |_| true)?;
        self.stats.jacobian_builds += 1;
        Ok(j)
    }

    /// The columns `c` of `J` for which `which(c)` holds, by forward
    /// differences (one evaluation each).
    fn fd_columns(
        &mut self,
        t: f64,
        h: f64,
        guess: &DVector<f64>,
        r0: &DVector<f64>,
        j: &mut DMatrix<f64>,
        which: impl Fn(usize) -> bool,
    ) -> Result<(), MasterError> {
        for c in (0..guess.len()).filter(|&c| which(c)) {
            // relative perturbation; absolute 1e-9 while the connection has carried nothing yet
            let mag = self.scale[c].max(guess[c].abs()).max(self.y_new[c].abs());
            let d = if mag > 0.0 { 1e-7 * mag } else { 1e-9 };
            let mut g = guess.clone();
            g[c] += d;
            self.evaluate(t, h, &g, true)?;
            let r = self.residual(&g);
            j.set_column(c, &((r - r0) / d));
        }
        Ok(())
    }

    /// `J = dR/dY` with the columns of the inputs of the units in `ask`
    /// from their directional derivatives at the current point (after an
    /// evaluation) and the other columns by finite differences. Column `d`
    /// (the input of link `d`, of unit `u`) has `-1` on the diagonal and,
    /// in the rows of `u`'s outputs, their derivatives with respect to that
    /// input over the step: the direct feedthrough `D` (the shaker's `dF/dx =
    /// -k_s`) plus the states' response over the step, of order `h`, which
    /// the directional derivatives do not give and Broyden's update then
    /// corrects. A unit without feedthrough (the structure: only its states
    /// respond, `~ h^2 / m`, which closes the loop through `k_s`) gets its
    /// columns by differences. A stalled iteration rebuilds all columns by
    /// finite differences.
    fn directional_jacobian(
        &mut self,
        ask: &[bool],
        (t, h, guess, r0): (f64, f64, &DVector<f64>, &DVector<f64>),
    ) -> Result<DMatrix<f64>, MasterError> {
        let nc = self.links.len();
        let mut j = -DMatrix::<f64>::identity(nc, nc);
        for (ui, unit) in self.units.iter_mut().enumerate() {
            if !ask[ui] {
                continue;
            }
            let outs: Vec<usize> = (0..nc).filter(|&c| self.links[c].src == ui).collect();
            let ins: Vec<usize> = (0..nc).filter(|&d| self.links[d].dst == ui).collect();
            let unknowns: Vec<u32> = outs.iter().map(|&c| self.links[c].src_vr).collect();
            let knowns: Vec<u32> = ins.iter().map(|&d| self.links[d].dst_vr).collect();
            let mut seed = vec![0.0; ins.len()];
            let mut sens = vec![0.0; outs.len()];
            for (k, &d) in ins.iter().enumerate() {
                seed.fill(0.0);
                seed[k] = 1.0;
                unit.inst
                    .directional_derivative(&unknowns, &knowns, &seed, &mut sens)?;
                for (i, &c) in outs.iter().enumerate() {
                    j[(c, d)] += sens[i];
                }
            }
        }
        let asked: Vec<bool> = self.links.iter().map(|l| ask[l.dst]).collect();
        self.fd_columns(t, h, guess, r0, &mut j, |c| !asked[c])?;
        self.stats.directional_jacobians += 1;
        Ok(j)
    }

    pub(super) fn iterate(&mut self, t: f64, h: f64) -> Result<(), MasterError> {
        let nc = self.links.len();
        for u in &mut self.units {
            u.inst.save_state()?;
        }
        // Initial guess: extrapolation along the slopes.
        let mut guess = DVector::from_iterator(nc, (0..nc).map(|c| self.y[c] + h * self.dy[c]));
        self.evaluate(t, h, &guess, false)?;
        let mut r = self.residual(&guess);
        let mut rebuilt = false;
        // the directional-derivative Jacobian is tried once per step, first
        let mut directional_tried = false;
        let mut it = 0;
        loop {
            let rn = self.rel_norm(&r, &guess);
            if rn <= self.opts.iteration_rtol || nc == 0 {
                return Ok(());
            }
            if it >= self.opts.iteration_max {
                if rebuilt {
                    return Err(MasterError::NoConvergence {
                        time_s: t,
                        residual: rn,
                        iterations: it,
                    });
                }
                self.jac = None;
                it = 0;
            }
            if self.jac.is_none() {
                let j = match self.directional.clone() {
                    Some(ask) if !directional_tried => {
                        directional_tried = true;
                        self.directional_jacobian(&ask, (t, h, &guess, &r))?
                    }
                    _ => {
                        rebuilt = true;
                        self.fd_jacobian(t, h, &guess, &r)?
                    }
                };
                self.jac = Some(j);
            }
            let j = self.jac.as_ref().expect("built above");
            let Some(dx) = j.clone().lu().solve(&(-&r)) else {
                self.jac = None;
                if rebuilt {
                    return Err(MasterError::NoConvergence {
                        time_s: t,
                        residual: rn,
                        iterations: it,
                    });
                }
                continue;
            };
            guess += &dx;
            self.evaluate(t, h, &guess, true)?;
            let r_new = self.residual(&guess);
            // Broyden's good update: J += (dR - J dx) dx^T / (dx^T dx)
            let dd = dx.dot(&dx);
            if dd > 0.0 {
                let j = self.jac.as_mut().expect("present");
                let u = (&r_new - &r) - &*j * &dx;
                *j += u * dx.transpose() / dd;
            }
            r = r_new;
            it += 1;
        }
    }
}
