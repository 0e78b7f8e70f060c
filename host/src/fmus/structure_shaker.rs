//! The `cosim` method's pairing: the structure FMU and the shaker FMU of this
//! repository (DESIGN.md section 5) co-simulated over a sine sweep by the
//! generic master of the `cosim` crate.
//!
//! The units, connections (`structure.x -> shaker.x`, `structure.v ->
//! shaker.v`, `shaker.F -> structure.F`) and recorded variables are a
//! co-simulation file like any user's (`docs/cosim.md`),
//! `structure_shaker.toml` beside this file ([`PAIRING`]); the parameters
//! come from the scenario ([`parameters`]). The shaker generates the sweep
//! voltage itself (`u_hat`, `Omega_start`, `Omega_end`, `Omega_rate`); the
//! excitation phase for the envelope is the integral of its `Omega` output.
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use nlmode::attachment::{ShakerParams, Stinger};
use nlmode::envelope::Envelope;
use nlmode::excitation::LinearSweep;
use nlmode::reference::envelope::fundamental_amplitudes;

use cosim::import::Fmu;
use cosim::master::{
    run, Algorithm, GenericSpec, Master, MasterError, MasterOptions, MasterStats, ParamValue,
};

/// The pairing as a co-simulation file (`docs/cosim.md`): units, connections,
/// recorded variables. Its master settings are placeholders: [`CosimParams`]
/// sets them.
pub const PAIRING: &str = include_str!("structure_shaker.toml");

/// [`PAIRING`], read by the `cosim` crate's reader of co-simulation files.
pub fn pairing() -> GenericSpec {
    cosim::spec::parse_spec(PAIRING, Path::new("structure_shaker.toml"))
        .expect("the embedded pairing is a valid co-simulation file")
}

/// Everything `run_cosim` needs besides the two FMU files.
#[derive(Debug, Clone)]
pub struct CosimParams {
    pub algorithm: Algorithm,
    pub macro_step_s: f64,
    /// Input extrapolation / interpolation through input derivatives.
    pub extrapolate: bool,
    /// Gauss-Seidel: step the shaker before the structure (default: structure first).
    pub shaker_first: bool,
    pub shaker: ShakerParams,
    /// The sweep the shaker FMU generates (its internal source):
    /// `u = amplitude cos(Phi)`, `dPhi/dt = Omega`, `Omega` linear from start to
    /// end at `|dOmega/dt| = rate_rad_s2` (0: fixed sine at `omega_start_rad_s`).
    pub sweep: LinearSweep,
    /// Drive point name in the modal table (`2l3`, `l3`).
    pub drive_point: String,
    /// Modal table file; `None`: the one in the structure FMU's `resources/`.
    pub modal_table: Option<PathBuf>,
    /// Relative natural-frequency error of the structure FMU.
    pub frequency_error: f64,
    /// The structure FMU's `residual_modes` (0: not set, the FMU's default).
    pub residual_modes: usize,
    /// The structure FMU's `harmonic_force_projection` (false: not set, the
    /// FMU's default).
    pub harmonic_force_projection: bool,
    /// End time [s]; `None`: the sweep duration.
    pub stop_time_s: Option<f64>,
    /// Sample interval of the time series [s], rounded to a multiple of the
    /// macro step; 0: about 1/64 of the shortest excitation period.
    pub output_interval_s: f64,
    pub iteration_rtol: f64,
    pub iteration_max: usize,
}

impl CosimParams {
    /// Defaults for a shaker and sweep: Gauss-Seidel, structure first,
    /// extrapolation on, `h = 1e-5 s`, drive point `2l3`.
    pub fn new(shaker: ShakerParams, sweep: LinearSweep) -> Self {
        Self {
            algorithm: Algorithm::GaussSeidel,
            macro_step_s: 1e-5,
            extrapolate: true,
            shaker_first: false,
            shaker,
            sweep,
            drive_point: "2l3".into(),
            modal_table: None,
            frequency_error: 0.0,
            residual_modes: 0,
            harmonic_force_projection: false,
            stop_time_s: None,
            output_interval_s: 0.0,
            iteration_rtol: 1e-6,
            iteration_max: 20,
        }
    }

    /// Duration of the run [s].
    pub fn duration_s(&self) -> f64 {
        self.stop_time_s.unwrap_or_else(|| {
            let s = &self.sweep;
            if s.rate_rad_s2 > 0.0 {
                (s.omega_end_rad_s - s.omega_start_rad_s).abs() / s.rate_rad_s2
            } else {
                f64::NAN
            }
        })
    }
}

/// Result of `run_cosim`.
#[derive(Debug, Clone, Default)]
pub struct CosimOutput {
    pub time_s: Vec<f64>,
    /// Instantaneous excitation frequency `Omega` (shaker output) [rad/s].
    pub omega_rad_s: Vec<f64>,
    pub x_tip_m: Vec<f64>,
    /// Drive-point displacement [m].
    pub x_m: Vec<f64>,
    /// Stinger force on the structure [N].
    pub force_n: Vec<f64>,
    pub voltage_v: Vec<f64>,
    pub current_a: Vec<f64>,
    /// Fundamental harmonics against the excitation frequency (with the drive-point amplitude).
    pub envelope: Envelope,
    /// Set when an FMU failed mid-run: the time [s] and the error with the FMU's log.
    pub stopped: Option<(f64, String)>,
    pub stats: MasterStats,
    pub wall_time_s: f64,
}

/// Errors before the run starts (after that, failures end up in `CosimOutput::stopped`).
#[derive(Debug, thiserror::Error)]
pub enum CosimError {
    #[error("{what} FMU {path}: {source}")]
    Load {
        what: &'static str,
        path: PathBuf,
        source: Box<cosim::import::FmuError>,
    },
    #[error(transparent)]
    Master(#[from] MasterError),
    #[error("the shaker FMU needs an elastic stinger (its force is k_s (q_a - x)); a rigid stinger is not co-simulated")]
    RigidStinger,
    #[error("run duration must be positive and finite, got {0} s (give stop_time_s for a fixed-frequency run)")]
    BadDuration(f64),
}

/// The connections of [`PAIRING`]: `structure.x -> shaker.x`, `structure.v
/// -> shaker.v`, `shaker.F -> structure.F`.
pub fn connections() -> Vec<(String, String)> {
    pairing().connections
}

/// The FMU parameters (`unit.variable`, value) of `p`: shaker constants,
/// the internal sweep, the structure's frequency error, drive point and
/// modal table.
pub fn parameters(p: &CosimParams) -> Result<Vec<(String, ParamValue)>, CosimError> {
    let ks = match p.shaker.stinger {
        Stinger::Elastic { stiffness_n_per_m } => stiffness_n_per_m,
        Stinger::Rigid => return Err(CosimError::RigidStinger),
    };
    let s = &p.shaker;
    let mut v: Vec<(String, ParamValue)> = [
        ("L", s.inductance_h),
        ("R", s.resistance_ohm),
        ("G", s.force_constant_n_per_a),
        ("m_a", s.armature_mass_kg),
        ("k_a", s.armature_stiffness_n_per_m),
        ("D_a", s.damping_ratio()),
        ("k_s", ks),
        ("u_hat", p.sweep.amplitude),
        ("Omega_start", p.sweep.omega_start_rad_s),
        ("Omega_end", p.sweep.omega_end_rad_s),
        ("Omega_rate", p.sweep.rate_rad_s2),
    ]
    .iter()
    .map(|(n, x)| (format!("shaker.{n}"), ParamValue::Real(*x)))
    .collect();
    v.push((
        "shaker.use_external_voltage".into(),
        ParamValue::Boolean(false),
    ));
    v.push((
        "structure.frequency_error".into(),
        ParamValue::Real(p.frequency_error),
    ));
    v.push((
        "structure.drive_point".into(),
        ParamValue::String(p.drive_point.clone()),
    ));
    if p.residual_modes > 0 {
        v.push((
            "structure.residual_modes".into(),
            ParamValue::Integer(i32::try_from(p.residual_modes).unwrap_or(i32::MAX)),
        ));
    }
    if p.harmonic_force_projection {
        v.push((
            "structure.harmonic_force_projection".into(),
            ParamValue::Boolean(true),
        ));
    }
    if let Some(t) = &p.modal_table {
        v.push((
            "structure.modal_table".into(),
            ParamValue::String(t.to_string_lossy().into_owned()),
        ));
    }
    Ok(v)
}

/// Write the coupled system of `p` as an SSP 1.0 archive (see [`cosim::ssp`]).
/// A modal table given as a file path is referenced by that path.
pub fn export_ssp(
    out: &Path,
    structure_fmu: &Path,
    shaker_fmu: &Path,
    p: &CosimParams,
) -> Result<(), cosim::ssp::SspError> {
    let params = parameters(p).map_err(|e| cosim::ssp::SspError::BadUnit(e.to_string()))?;
    cosim::ssp::write_ssp(
        out,
        "structure-shaker",
        &[
            ("structure".into(), structure_fmu.into()),
            ("shaker".into(), shaker_fmu.into()),
        ],
        &connections(),
        &params,
        p.duration_s(),
    )
}

/// Build the master for the two FMUs with the parameters set, initialized at t = 0.
pub fn build_master(
    structure_fmu: &Path,
    shaker_fmu: &Path,
    p: &CosimParams,
) -> Result<Master, CosimError> {
    parameters(p)?;
    let st = Fmu::load(structure_fmu).map_err(|source| CosimError::Load {
        what: "structure",
        path: structure_fmu.into(),
        source: Box::new(source),
    })?;
    let sh = Fmu::load(shaker_fmu).map_err(|source| CosimError::Load {
        what: "shaker",
        path: shaker_fmu.into(),
        source: Box::new(source),
    })?;
    let conns = connections();
    let opts = MasterOptions {
        algorithm: p.algorithm,
        macro_step_s: p.macro_step_s,
        extrapolate: p.extrapolate,
        order: if p.shaker_first {
            Some(vec![1, 0])
        } else {
            Some(vec![0, 1])
        },
        iteration_rtol: p.iteration_rtol,
        iteration_max: p.iteration_max,
        directional_derivatives: false,
    };
    let mut m = Master::new(
        vec![("structure".into(), st), ("shaker".into(), sh)],
        &conns,
        opts,
    )?;
    for (ep, v) in parameters(p)? {
        let (u, name) = ep.split_once('.').expect("unit.variable");
        m.set_parameter(if u == "structure" { 0 } else { 1 }, name, &v)?;
    }
    let dur = p.duration_s();
    if !(dur.is_finite() && dur > 0.0) {
        return Err(CosimError::BadDuration(dur));
    }
    // the run ends at the first communication point at or after `dur`
    let n = (cosim::master::macro_steps(0.0, dur, p.macro_step_s)? as f64).max(1.0);
    m.initialize(0.0, Some(n * p.macro_step_s))?;
    Ok(m)
}

/// Co-simulate the structure and shaker FMUs over the sweep of `p`.
/// `progress` receives the simulated time [s] now and then.
pub fn run_cosim(
    structure_fmu: &Path,
    shaker_fmu: &Path,
    p: &CosimParams,
    progress: &mut dyn FnMut(f64),
) -> Result<CosimOutput, CosimError> {
    let mut m = build_master(structure_fmu, shaker_fmu, p)?;
    let dur = p.duration_s();
    let h = p.macro_step_s;
    let w_max = p.sweep.omega_start_rad_s.max(p.sweep.omega_end_rad_s);
    let dt_out = if p.output_interval_s > 0.0 {
        p.output_interval_s
    } else {
        2.0 * PI / w_max / 64.0
    };
    let every = ((dt_out / h).round() as usize).max(1);
    // shaker.Omega, structure.x_tip, structure.x, shaker.F, shaker.u, shaker.I
    let names = pairing().record;
    let rec = run(&mut m, dur, &names, every, progress)?;
    let col = |k: usize| rec.columns[k].1.clone();
    let mut out = CosimOutput {
        time_s: rec.time_s.clone(),
        omega_rad_s: col(0),
        x_tip_m: col(1),
        x_m: col(2),
        force_n: col(3),
        voltage_v: col(4),
        current_a: col(5),
        stopped: rec.stopped.clone(),
        stats: rec.stats.clone(),
        wall_time_s: rec.wall_time_s,
        ..Default::default()
    };
    out.envelope = envelope_of(&out);
    Ok(out)
}

/// Phase `Phi(t_k) = int_0^t Omega dt` from samples of `Omega` (trapezoidal
/// rule, exact for the linear sweep of the shaker FMU).
pub fn phase_from_omega(t: &[f64], omega: &[f64]) -> Vec<f64> {
    let mut phi = Vec::with_capacity(t.len());
    let mut p = 0.0;
    for k in 0..t.len() {
        if k > 0 {
            p += 0.5 * (omega[k] + omega[k - 1]) * (t[k] - t[k - 1]);
        }
        phi.push(p);
    }
    phi
}

/// The envelope of a co-simulated time series: the sliding one-period
/// Fourier projection on the excitation phase of `nlmode::reference`
/// (the same extractor as the `reference` method), with window centres
/// every eighth of an excitation period.
pub fn envelope_of(o: &CosimOutput) -> Envelope {
    let phi = phase_from_omega(&o.time_s, &o.omega_rad_s);
    let mut centers = Vec::new();
    let mut next = 0.0;
    for (k, &p) in phi.iter().enumerate() {
        if p >= next {
            centers.push(k);
            next = p + PI / 4.0;
        }
    }
    let amps = |x: &[f64]| fundamental_amplitudes(&phi, x, &centers, 1.0);
    let (f, tip, x) = (amps(&o.force_n), amps(&o.x_tip_m), amps(&o.x_m));
    let mut e = Envelope {
        drive_amplitude_m: Some(Vec::new()),
        ..Default::default()
    };
    let mut drive = Vec::new();
    for (j, &c) in centers.iter().enumerate() {
        if let (Some(f), Some(tip), Some(x)) = (f[j], tip[j], x[j]) {
            e.omega_rad_s.push(o.omega_rad_s[c]);
            e.force_amplitude_n.push(f);
            e.tip_amplitude_m.push(tip);
            drive.push(x);
        }
    }
    e.drive_amplitude_m = Some(drive);
    e
}

#[cfg(test)]
#[path = "structure_shaker_tests.rs"]
mod tests;
