//! Co-simulation master for FMI 2.0 and FMI 3.0 Co-Simulation FMUs (mixed
//! freely: `fmi2-import` drives both through one `Instance`) connected by a
//! list of scalar Real (`Float64`) connections `unit.output -> unit.input`.
//!
//! ## Notation
//! Macro step `h` from `t_n` to `t_{n+1} = t0 + (n+1) h` (time is counted, not
//! summed). Every connection `c` carries the value `y_c` of its source output.
//!
//! ## Exchange at communication points
//! After every step the master reads outputs and sets inputs unit by unit in
//! the *exchange order*: a unit whose outputs depend directly on an input
//! (`<ModelStructure>`, direct feedthrough) comes after the units feeding
//! that input. With the two FMUs of this repository, the structure (no
//! feedthrough: `x`, `v` are states) comes first and the shaker (its `F =
//! k_s (q_a - x)` depends directly on `x`) second, so `F(t_{n+1})` is read
//! after `x(t_{n+1})` was set, and the exchanged values are consistent at
//! every communication point whatever the algorithm.
//!
//! ## Algorithms
//! * **Jacobi**: every unit steps from the values at `t_n`; with
//!   extrapolation, each input also gets its first derivative through
//!   `fmi2SetRealInputDerivatives` (when the receiving FMU declares
//!   `canInterpolateInputs`) taken from the source's
//!   `fmi2GetRealOutputDerivatives` (when `maxOutputDerivativeOrder >= 1`) or
//!   else a backward difference.
//! * **Gauss-Seidel**: units step one after the other in the Gauss-Seidel
//!   order; an input whose source has already stepped gets the exact linear
//!   interpolation between `y_c(t_n)` and `y_c(t_{n+1})` (derivative
//!   `(y_c(t_{n+1}) - y_c(t_n))/h`, or the new value held when the receiver
//!   cannot interpolate); other inputs are extrapolated as in Jacobi.
//!   Default order = exchange order, i.e. **structure first, then shaker**: the
//!   shaker is linear time-invariant and integrated exactly for inputs linear
//!   in time, so giving it the structure's actual displacement over the step
//!   makes its stinger force exact up to the linear interpolation of `x`;
//!   the other order would evaluate the stiff stinger (`k_s = 2.6e7 N/m`) on an
//!   extrapolated `x`, whose error `k_s (x_extrapolated - x)` is then fed to the
//!   structure during the step. `CosimParams::shaker_first` selects the other
//!   order to measure this.
//! * **Iterative** (implicit coupling with rollback): all units save their
//!   state (`fmi2GetFMUstate`); the unknowns are the connection values at the
//!   end of the step, `Y`; one evaluation restores the states, steps every
//!   unit with inputs linear from `y(t_n)` to `Y` and reads `G(Y)`, the
//!   outputs at `t_{n+1}`. The interface residual `R(Y) = G(Y) - Y` is driven
//!   to zero by a quasi-Newton iteration `Y <- Y - J^{-1} R` whose Jacobian
//!   `J = dR/dY` is built on the first step by finite differences (and again
//!   whenever the iteration stalls; with
//!   [`MasterOptions::directional_derivatives`] the columns of the inputs of
//!   FMI 3.0 units that provide `fmi3GetDirectionalDerivative` come from
//!   their direct feedthrough instead) and kept up to date by Broyden's ("good")
//!   rank-one update; it carries over from step to step, so a converged step
//!   usually costs two evaluations.
use std::time::Instant;

use nalgebra::DMatrix;

use crate::import::{Causality, Fmu, FmuError, Instance, SchemaError, VarType};

mod iterative;
use iterative::directional_units;

/// Co-simulation master algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Algorithm {
    Jacobi,
    GaussSeidel,
    Iterative,
}

impl std::str::FromStr for Algorithm {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "jacobi" => Ok(Algorithm::Jacobi),
            "gauss-seidel" => Ok(Algorithm::GaussSeidel),
            "iterative" => Ok(Algorithm::Iterative),
            other => Err(format!("unknown co-simulation algorithm '{other}', expected jacobi, gauss-seidel or iterative")),
        }
    }
}

/// Most macro steps one run may take (at about 1 us per step of the paper's
/// pair, a quarter of an hour): a longer run is [`MasterError::Steps`] before
/// anything is allocated or stepped.
pub const MAX_MACRO_STEPS: u64 = 1_000_000_000;

/// Number of macro steps of `macro_step_s` from `start_time_s` until the first
/// communication point at or after `stop_time_s`, checked: finite times,
/// at most [`MAX_MACRO_STEPS`], and a step that advances the time at both ends
/// (`1e300 + 1e-5 == 1e300`).
pub fn macro_steps(
    start_time_s: f64,
    stop_time_s: f64,
    macro_step_s: f64,
) -> Result<u64, MasterError> {
    let err = |reason: String| MasterError::Steps {
        start_time_s,
        stop_time_s,
        macro_step_s,
        reason,
    };
    if !(macro_step_s.is_finite() && macro_step_s > 0.0) {
        return Err(MasterError::BadStep(macro_step_s));
    }
    if !(start_time_s.is_finite() && stop_time_s.is_finite()) {
        return Err(err("both times must be finite".into()));
    }
    let n = ((stop_time_s - start_time_s) / macro_step_s - 1e-9)
        .ceil()
        .max(0.0);
    if n.is_nan() || n > MAX_MACRO_STEPS as f64 {
        return Err(err(format!(
            "{n:e} macro steps, more than the limit of {MAX_MACRO_STEPS:e} (shorten the run or enlarge the step)"
        )));
    }
    for t in [start_time_s, stop_time_s] {
        if t + macro_step_s == t {
            return Err(err(format!(
                "the step is below the resolution of the time {t:e} s (time would not advance)"
            )));
        }
    }
    Ok(n as u64)
}

/// Errors of the master; FMU failures keep the FMU's own error.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    #[error(transparent)]
    Fmu(#[from] FmuError),
    #[error("connection '{0}': expected 'unit.variable'")]
    BadEndpoint(String),
    #[error("connection '{endpoint}': no unit named '{unit}' (units: {available})")]
    UnknownUnit {
        endpoint: String,
        unit: String,
        available: String,
    },
    #[error("connection {from} -> {to}: {reason}")]
    BadConnection {
        from: String,
        to: String,
        reason: String,
    },
    #[error("input '{0}' is driven by more than one connection")]
    DoubleInput(String),
    #[error("macro step must be positive and finite, got {0} s")]
    BadStep(f64),
    /// The run from `start_time_s` to `stop_time_s` at `macro_step_s` needs
    /// more than [`MAX_MACRO_STEPS`] steps, or the step is lost in rounding at
    /// the start time.
    #[error("start_time_s = {start_time_s:e} s to stop_time_s = {stop_time_s:e} s at macro_step_s = {macro_step_s:e} s: {reason}")]
    Steps {
        start_time_s: f64,
        stop_time_s: f64,
        macro_step_s: f64,
        reason: String,
    },
    #[error("unit '{unit}' does not support {what}, which the {algorithm:?} algorithm needs")]
    Unsupported {
        unit: String,
        what: &'static str,
        algorithm: Algorithm,
    },
    #[error("iterative coupling did not converge at t = {time_s} s: interface residual {residual:e} (relative) after {iterations} iterations")]
    NoConvergence {
        time_s: f64,
        residual: f64,
        iterations: usize,
    },
    #[error("parameter {unit}.{name}: {reason}")]
    BadParameter {
        unit: String,
        name: String,
        reason: String,
    },
}

/// Value of a parameter set by name.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// Options of the master.
#[derive(Debug, Clone)]
pub struct MasterOptions {
    pub algorithm: Algorithm,
    /// Macro step `h` [s].
    pub macro_step_s: f64,
    /// Give inputs first derivatives (extrapolation / interpolation) where the
    /// receiving FMU can interpolate inputs.
    pub extrapolate: bool,
    /// Gauss-Seidel order as unit indices (default: the exchange order).
    pub order: Option<Vec<usize>>,
    /// Relative tolerance of the iterative coupling (per connection, relative
    /// to the largest magnitude the connection has carried so far).
    pub iteration_rtol: f64,
    pub iteration_max: usize,
    /// Iterative coupling: build the Jacobian's columns of the inputs of
    /// units that provide directional derivatives from them, the others by
    /// finite differences (off: all by finite differences, the default).
    /// The directional derivatives are the instantaneous partials; the
    /// iteration needs those of the step map, which add the states'
    /// response over the step: on the paper's stiff pair (stinger `k_s =
    /// 2.6e7 N/m`, macro step 1e-5 s) the shaker's `dF/dx = -k_s` misses the
    /// dependence of the end-of-step force on the velocity input it
    /// extrapolates with (`~ k_s h`), and the iteration needs 3.6
    /// evaluations per step against 2.0 with the finite-difference
    /// Jacobian; it pays where finite differences are costly (many
    /// connections) and the feedthrough dominates.
    pub directional_derivatives: bool,
}

impl Default for MasterOptions {
    fn default() -> Self {
        Self {
            algorithm: Algorithm::GaussSeidel,
            macro_step_s: 1e-5,
            extrapolate: true,
            order: None,
            iteration_rtol: 1e-6,
            iteration_max: 20,
            directional_derivatives: false,
        }
    }
}

/// One co-simulation unit: an FMU and its instance. (Field order: the
/// instance is dropped before the unpacked folder.)
pub struct Unit {
    pub name: String,
    pub inst: Instance,
    pub fmu: Fmu,
}

struct Link {
    src: usize,
    src_vr: u32,
    dst: usize,
    dst_vr: u32,
    /// The receiver accepts input derivatives.
    interp: bool,
    /// The source provides output derivatives.
    src_der: bool,
}

/// Per-unit index lists for batched get/set without allocation.
#[derive(Default)]
struct Ports {
    out_vrs: Vec<u32>,
    out_links: Vec<usize>,
    der_vrs: Vec<u32>,
    der_links: Vec<usize>,
    in_links: Vec<usize>,
}

/// Counters of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MasterStats {
    pub steps: usize,
    /// Unit step evaluations (every `fmi2DoStep` call, rollbacks included).
    pub do_steps: usize,
    /// Iterative coupling: interface evaluations and Jacobian rebuilds by
    /// finite differences.
    pub evaluations: usize,
    pub jacobian_builds: usize,
    /// Iterative coupling: Jacobians built from the units' directional
    /// derivatives (no extra evaluation).
    pub directional_jacobians: usize,
}

/// The master over a set of units and connections.
pub struct Master {
    pub units: Vec<Unit>,
    links: Vec<Link>,
    ports: Vec<Ports>,
    exchange: Vec<usize>,
    gs_order: Vec<usize>,
    opts: MasterOptions,
    t0: f64,
    n: u64,
    /// Connection values at the last communication point, the one before, and scratch.
    y: Vec<f64>,
    y_prev: Vec<f64>,
    dy: Vec<f64>,
    y_new: Vec<f64>,
    scale: Vec<f64>,
    have_prev: bool,
    buf: Vec<f64>,
    orders: Vec<i32>,
    jac: Option<DMatrix<f64>>,
    /// Iterative coupling: the units asked for directional derivatives when
    /// a Jacobian is built (`None`: finite differences only).
    directional: Option<Vec<bool>>,
    stepped: Vec<bool>,
    pub stats: MasterStats,
}

fn split_endpoint(s: &str) -> Result<(&str, &str), MasterError> {
    s.split_once('.')
        .filter(|(u, v)| !u.is_empty() && !v.is_empty())
        .ok_or_else(|| MasterError::BadEndpoint(s.into()))
}

/// The connections resolved to links between the units' variables (checked:
/// Real output to Real input of another unit, each input fed once), and
/// `feeds[b]`: the units feeding an input of `b` that some output of `b`
/// depends on directly.
fn resolve_links(
    us: &[Unit],
    connections: &[(String, String)],
) -> Result<(Vec<Link>, Vec<Vec<usize>>), MasterError> {
    let names = || {
        us.iter()
            .map(|u| u.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let find = |ep: &str| -> Result<(usize, usize), MasterError> {
        let (u, v) = split_endpoint(ep)?;
        let ui = us
            .iter()
            .position(|x| x.name == u)
            .ok_or_else(|| MasterError::UnknownUnit {
                endpoint: ep.into(),
                unit: u.into(),
                available: names(),
            })?;
        let vi = us[ui]
            .fmu
            .md
            .variables
            .iter()
            .position(|x| x.name == v)
            .ok_or_else(|| {
                MasterError::Fmu(FmuError::Schema(SchemaError::UnknownVariable {
                    model: us[ui].fmu.md.model_name.clone(),
                    name: v.into(),
                }))
            })?;
        Ok((ui, vi))
    };
    let mut links = Vec::new();
    let mut ins: Vec<(usize, usize)> = Vec::new();
    // feeds[b] contains a if a -> b feeds an input that some output of b depends on directly
    let mut feeds = vec![Vec::<usize>::new(); us.len()];
    for (from, to) in connections {
        let (su, sv) = find(from)?;
        let (du, dv) = find(to)?;
        let bad = |reason: String| MasterError::BadConnection {
            from: from.clone(),
            to: to.clone(),
            reason,
        };
        let s = &us[su].fmu.md.variables[sv];
        let d = &us[du].fmu.md.variables[dv];
        if s.ty != VarType::Real || d.ty != VarType::Real {
            return Err(bad("only Real variables can be connected".into()));
        }
        if s.causality != Causality::Output {
            return Err(bad(format!(
                "source has causality {:?}, expected output",
                s.causality
            )));
        }
        if d.causality != Causality::Input {
            return Err(bad(format!(
                "target has causality {:?}, expected input",
                d.causality
            )));
        }
        if su == du {
            return Err(bad("a unit cannot feed itself".into()));
        }
        if ins.contains(&(du, dv)) {
            return Err(MasterError::DoubleInput(to.clone()));
        }
        ins.push((du, dv));
        let md = &us[du].fmu.md;
        if md
            .outputs
            .iter()
            .any(|o| md.output_depends_on(o.index - 1, dv))
            && !feeds[du].contains(&su)
        {
            feeds[du].push(su);
        }
        links.push(Link {
            src: su,
            src_vr: s.value_reference,
            dst: du,
            dst_vr: d.value_reference,
            interp: us[du].fmu.md.co_simulation.can_interpolate_inputs,
            src_der: us[su].fmu.md.co_simulation.max_output_derivative_order >= 1,
        });
    }
    Ok((links, feeds))
}

/// Exchange order: Kahn's topological sort on direct feedthrough (`feeds`
/// of [`resolve_links`]), stable in the given unit order; units in an
/// algebraic loop keep their order.
fn exchange_order(feeds: &[Vec<usize>]) -> Vec<usize> {
    let n = feeds.len();
    let mut exchange = Vec::new();
    let mut placed = vec![false; n];
    while exchange.len() < n {
        let next = (0..n)
            .find(|&b| !placed[b] && feeds[b].iter().all(|&a| placed[a] || a == b))
            .or_else(|| (0..n).find(|&b| !placed[b]))
            .expect("an unplaced unit");
        placed[next] = true;
        exchange.push(next);
    }
    exchange
}

/// Each unit's outputs, output derivatives and inputs by link.
fn ports_of(links: &[Link], n: usize) -> Vec<Ports> {
    let mut ports: Vec<Ports> = (0..n).map(|_| Ports::default()).collect();
    for (c, l) in links.iter().enumerate() {
        ports[l.src].out_vrs.push(l.src_vr);
        ports[l.src].out_links.push(c);
        if l.src_der {
            ports[l.src].der_vrs.push(l.src_vr);
            ports[l.src].der_links.push(c);
        }
        ports[l.dst].in_links.push(c);
    }
    ports
}

impl Master {
    /// Instantiate every FMU (`units`: name and loaded FMU) and resolve the
    /// connections (`from`, `to` as `unit.variable`).
    pub fn new(
        units: Vec<(String, Fmu)>,
        connections: &[(String, String)],
        opts: MasterOptions,
    ) -> Result<Self, MasterError> {
        if !(opts.macro_step_s.is_finite() && opts.macro_step_s > 0.0) {
            return Err(MasterError::BadStep(opts.macro_step_s));
        }
        let mut us = Vec::new();
        for (name, fmu) in units {
            let inst = fmu.instantiate(&name, true)?;
            us.push(Unit { name, inst, fmu });
        }
        let (links, feeds) = resolve_links(&us, connections)?;
        let exchange = exchange_order(&feeds);
        let gs_order = match &opts.order {
            Some(o) => {
                let mut s = o.clone();
                s.sort_unstable();
                assert!(
                    s == (0..us.len()).collect::<Vec<_>>(),
                    "order must be a permutation of the unit indices"
                );
                o.clone()
            }
            None => exchange.clone(),
        };
        let ports = ports_of(&links, us.len());
        if opts.algorithm == Algorithm::Iterative {
            for u in &us {
                if !u.fmu.md.co_simulation.can_get_and_set_fmu_state {
                    return Err(MasterError::Unsupported {
                        unit: u.name.clone(),
                        what: "fmi2GetFMUstate/fmi2SetFMUstate",
                        algorithm: opts.algorithm,
                    });
                }
            }
        }
        let directional = directional_units(&us, &links).filter(|_| opts.directional_derivatives);
        let nc = links.len();
        let nunits = us.len();
        let nmax = links.len().max(1);
        Ok(Master {
            units: us,
            links,
            ports,
            exchange,
            gs_order,
            opts,
            t0: 0.0,
            n: 0,
            y: vec![0.0; nc],
            y_prev: vec![0.0; nc],
            dy: vec![0.0; nc],
            y_new: vec![0.0; nc],
            scale: vec![0.0; nc],
            have_prev: false,
            buf: vec![0.0; nmax],
            orders: vec![1; nmax],
            jac: None,
            directional,
            stepped: vec![false; nunits],
            stats: MasterStats::default(),
        })
    }

    pub fn unit_index(&self, name: &str) -> Option<usize> {
        self.units.iter().position(|u| u.name == name)
    }

    /// The exchange order (unit indices).
    pub fn exchange_order(&self) -> &[usize] {
        &self.exchange
    }

    /// Set a parameter (or input start value) by name before [`initialize`](Self::initialize).
    pub fn set_parameter(
        &mut self,
        unit: usize,
        name: &str,
        value: &ParamValue,
    ) -> Result<(), MasterError> {
        let u = &mut self.units[unit];
        let v = u.fmu.md.variable(name).map_err(FmuError::from)?;
        let bad = |reason: String| MasterError::BadParameter {
            unit: u.name.clone(),
            name: name.into(),
            reason,
        };
        let vr = [v.value_reference];
        match (value, v.ty) {
            (ParamValue::Real(x), VarType::Real) => u.inst.set_real(&vr, &[*x])?,
            (ParamValue::Integer(x), VarType::Integer | VarType::Enumeration) => {
                u.inst.set_integer(&vr, &[*x])?
            }
            (ParamValue::Boolean(x), VarType::Boolean) => u.inst.set_boolean(&vr, &[*x])?,
            (ParamValue::String(x), VarType::String) => u.inst.set_string(&vr, &[x.as_str()])?,
            (val, ty) => {
                return Err(bad(format!(
                    "value {val:?} does not fit the variable's type {ty:?}"
                )))
            }
        }
        Ok(())
    }

    /// `fmi2SetupExperiment`, initialization mode, and the first exchange at `t0`.
    pub fn initialize(&mut self, t0: f64, stop: Option<f64>) -> Result<(), MasterError> {
        self.t0 = t0;
        self.n = 0;
        for u in &mut self.units {
            u.inst.setup_experiment(t0, stop, None)?;
            u.inst.enter_initialization_mode()?;
        }
        for u in &mut self.units {
            u.inst.exit_initialization_mode()?;
        }
        self.exchange_all()?;
        self.read_derivatives()?;
        self.y_prev.copy_from_slice(&self.y);
        self.have_prev = false;
        Ok(())
    }

    /// Current communication time [s].
    pub fn time(&self) -> f64 {
        self.t0 + self.n as f64 * self.opts.macro_step_s
    }

    /// Read outputs and set inputs in the exchange order (values into `self.y`).
    fn exchange_all(&mut self) -> Result<(), MasterError> {
        for k in 0..self.exchange.len() {
            let u = self.exchange[k];
            self.read_outputs(u)?;
            for j in 0..self.ports[u].out_links.len() {
                let c = self.ports[u].out_links[j];
                self.y[c] = self.buf[j];
                let l = &self.links[c];
                self.units[l.dst]
                    .inst
                    .set_real(&[l.dst_vr], &[self.buf[j]])?;
            }
        }
        for c in 0..self.y.len() {
            self.scale[c] = self.scale[c].max(self.y[c].abs());
        }
        Ok(())
    }

    /// Outputs of unit `u` that feed connections into `self.buf[..]`.
    #[inline]
    fn read_outputs(&mut self, u: usize) -> Result<(), MasterError> {
        let p = &self.ports[u];
        let n = p.out_vrs.len();
        if n > 0 {
            self.units[u]
                .inst
                .get_real(&p.out_vrs, &mut self.buf[..n])?;
        }
        Ok(())
    }

    /// Extrapolation slopes `self.dy` at the current communication point.
    fn read_derivatives(&mut self) -> Result<(), MasterError> {
        let h = self.opts.macro_step_s;
        for c in 0..self.links.len() {
            self.dy[c] = if self.have_prev {
                (self.y[c] - self.y_prev[c]) / h
            } else {
                0.0
            };
        }
        for u in 0..self.units.len() {
            let p = &self.ports[u];
            let n = p.der_vrs.len();
            if n > 0 {
                self.units[u].inst.get_real_output_derivatives(
                    &p.der_vrs,
                    &self.orders[..n],
                    &mut self.buf[..n],
                )?;
                for j in 0..n {
                    self.dy[self.ports[u].der_links[j]] = self.buf[j];
                }
            }
        }
        Ok(())
    }

    /// Set the first derivative `d` of the input of connection `c` (if the receiver interpolates).
    #[inline]
    fn set_slope(&mut self, c: usize, d: f64) -> Result<(), MasterError> {
        let l = &self.links[c];
        if l.interp {
            self.units[l.dst]
                .inst
                .set_real_input_derivatives(&[l.dst_vr], &[1], &[d])?;
        }
        Ok(())
    }

    /// One macro step from the current time.
    pub fn step(&mut self) -> Result<(), MasterError> {
        let h = self.opts.macro_step_s;
        let t = self.time();
        match self.opts.algorithm {
            Algorithm::Jacobi => {
                if self.opts.extrapolate {
                    for c in 0..self.links.len() {
                        self.set_slope(c, self.dy[c])?;
                    }
                }
                for u in &mut self.units {
                    u.inst.do_step(t, h)?;
                }
                self.stats.do_steps += self.units.len();
            }
            Algorithm::GaussSeidel => {
                self.stepped.iter_mut().for_each(|s| *s = false);
                for k in 0..self.gs_order.len() {
                    let u = self.gs_order[k];
                    for j in 0..self.ports[u].in_links.len() {
                        let c = self.ports[u].in_links[j];
                        let src = self.links[c].src;
                        if self.stepped[src] {
                            if self.links[c].interp {
                                self.set_slope(c, (self.y_new[c] - self.y[c]) / h)?;
                            } else {
                                let l = &self.links[c];
                                self.units[l.dst]
                                    .inst
                                    .set_real(&[l.dst_vr], &[self.y_new[c]])?;
                            }
                        } else if self.opts.extrapolate {
                            self.set_slope(c, self.dy[c])?;
                        }
                    }
                    self.units[u].inst.do_step(t, h)?;
                    self.stats.do_steps += 1;
                    self.read_outputs(u)?;
                    for j in 0..self.ports[u].out_links.len() {
                        self.y_new[self.ports[u].out_links[j]] = self.buf[j];
                    }
                    self.stepped[u] = true;
                }
            }
            Algorithm::Iterative => self.iterate(t, h)?,
        }
        self.n += 1;
        self.y_prev.copy_from_slice(&self.y);
        self.have_prev = true;
        self.exchange_all()?;
        if self.opts.extrapolate || self.opts.algorithm == Algorithm::Iterative {
            self.read_derivatives()?;
        }
        self.stats.steps += 1;
        Ok(())
    }

    /// Read Real variables of a unit.
    #[inline]
    pub fn get_real(
        &mut self,
        unit: usize,
        vrs: &[u32],
        out: &mut [f64],
    ) -> Result<(), MasterError> {
        self.units[unit].inst.get_real(vrs, out)?;
        Ok(())
    }
}

/// A recorded run: named columns and how it ended.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    pub time_s: Vec<f64>,
    /// (`unit.variable`, samples)
    pub columns: Vec<(String, Vec<f64>)>,
    /// Set when an FMU failed: the time and the error (with the FMU's log).
    pub stopped: Option<(f64, String)>,
    pub stats: MasterStats,
    pub wall_time_s: f64,
}

impl Recording {
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// Run the initialized master to `t_end`, recording `record` (`unit.variable`,
/// Real) every `every` macro steps (and at the start). An FMU failure stops
/// the run and is reported in [`Recording::stopped`], with the samples up to
/// the last good communication point.
pub fn run(
    m: &mut Master,
    t_end: f64,
    record: &[String],
    every: usize,
    progress: &mut dyn FnMut(f64),
) -> Result<Recording, MasterError> {
    let wall = Instant::now();
    let mut probes: Vec<(usize, u32)> = Vec::new();
    for r in record {
        let (u, v) = split_endpoint(r)?;
        let ui = m.unit_index(u).ok_or_else(|| MasterError::UnknownUnit {
            endpoint: r.clone(),
            unit: u.into(),
            available: m
                .units
                .iter()
                .map(|u| u.name.clone())
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        let var = m.units[ui].fmu.md.variable(v).map_err(FmuError::from)?;
        if var.ty != VarType::Real {
            return Err(MasterError::BadConnection {
                from: r.clone(),
                to: "recording".into(),
                reason: "only Real variables are recorded".into(),
            });
        }
        probes.push((ui, var.value_reference));
    }
    // group probes per unit for batched reads
    let mut groups: Vec<(usize, Vec<u32>, Vec<usize>)> = Vec::new();
    for (k, &(u, vr)) in probes.iter().enumerate() {
        match groups.iter_mut().find(|g| g.0 == u) {
            Some(g) => {
                g.1.push(vr);
                g.2.push(k);
            }
            None => groups.push((u, vec![vr], vec![k])),
        }
    }
    let n_steps = macro_steps(m.time(), t_end, m.opts.macro_step_s)?;
    let every = every.max(1) as u64;
    // reserve for the whole run, but not more than a few MB up front
    let cap = (n_steps / every + 2).min(1 << 18) as usize;
    let mut rec = Recording {
        time_s: Vec::with_capacity(cap),
        columns: record
            .iter()
            .map(|n| (n.clone(), Vec::with_capacity(cap)))
            .collect(),
        ..Default::default()
    };
    let mut buf = vec![0.0; probes.len()];
    let sample =
        |m: &mut Master, rec: &mut Recording, buf: &mut [f64]| -> Result<(), MasterError> {
            for (u, vrs, ks) in &groups {
                let mut tmp = [0.0f64; 32];
                if vrs.len() <= 32 {
                    m.get_real(*u, vrs, &mut tmp[..vrs.len()])?;
                    for (j, &k) in ks.iter().enumerate() {
                        buf[k] = tmp[j];
                    }
                } else {
                    let mut v = vec![0.0; vrs.len()];
                    m.get_real(*u, vrs, &mut v)?;
                    for (j, &k) in ks.iter().enumerate() {
                        buf[k] = v[j];
                    }
                }
            }
            rec.time_s.push(m.time());
            for (k, (_, col)) in rec.columns.iter_mut().enumerate() {
                col.push(buf[k]);
            }
            Ok(())
        };
    sample(m, &mut rec, &mut buf)?;
    let report = (n_steps / 200).max(1);
    for k in 1..=n_steps {
        if let Err(e) = m.step() {
            rec.stopped = Some((m.time(), e.to_string()));
            break;
        }
        if k % every == 0 || k == n_steps {
            if let Err(e) = sample(m, &mut rec, &mut buf) {
                rec.stopped = Some((m.time(), e.to_string()));
                break;
            }
        }
        if k % report == 0 {
            progress(m.time());
        }
    }
    rec.stats = m.stats.clone();
    rec.wall_time_s = wall.elapsed().as_secs_f64();
    Ok(rec)
}

/// A generic co-simulation: any FMI 2.0 CS FMUs, a connection list and
/// parameters, as a scenario can give them.
#[derive(Debug, Clone)]
pub struct GenericSpec {
    /// (unit name, `.fmu` path)
    pub units: Vec<(String, std::path::PathBuf)>,
    /// (`unit.output`, `unit.input`)
    pub connections: Vec<(String, String)>,
    /// (`unit.variable`, value), set before initialization.
    pub parameters: Vec<(String, ParamValue)>,
    pub options: MasterOptions,
    pub start_time_s: f64,
    pub stop_time_s: f64,
    /// Variables to record (`unit.variable`, Real).
    pub record: Vec<String>,
    /// Record every this many macro steps.
    pub record_every: usize,
}

/// Load, connect, parameterize, initialize and run a [`GenericSpec`].
pub fn run_generic(
    spec: &GenericSpec,
    progress: &mut dyn FnMut(f64),
) -> Result<Recording, MasterError> {
    let mut units = Vec::new();
    for (name, path) in &spec.units {
        units.push((name.clone(), Fmu::load(path)?));
    }
    let mut m = Master::new(units, &spec.connections, spec.options.clone())?;
    for (ep, v) in &spec.parameters {
        let (u, name) = split_endpoint(ep)?;
        let ui = m.unit_index(u).ok_or_else(|| MasterError::UnknownUnit {
            endpoint: ep.clone(),
            unit: u.into(),
            available: spec
                .units
                .iter()
                .map(|u| u.0.clone())
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        m.set_parameter(ui, name, v)?;
    }
    let h = spec.options.macro_step_s;
    let n = macro_steps(spec.start_time_s, spec.stop_time_s, h)? as f64;
    m.initialize(spec.start_time_s, Some(spec.start_time_s + n * h))?;
    run(
        &mut m,
        spec.stop_time_s,
        &spec.record,
        spec.record_every,
        progress,
    )
}
