//! Modal-table I/O, validation and interpolation.
//!
//! The table ([`ModalTable`], format `nlmode-modal-table` version 1, JSON) holds
//! the nonlinear mode along the amplitude `a`: `omega(a)`, `D(a)` and the harmonics
//! `phi_n(a)` of the deflection shape at named points (paper Section 3.1,
//! `eq:fourier`, `eq:ansatz`). Both the host's `nlmode` path and the structure FMU
//! read it; it can also come from an experimental nonlinear modal analysis.
//!
//! Interpolation in `a` is piecewise cubic Hermite with monotonicity-preserving
//! slopes (PCHIP, Fritsch-Carlson with the harmonic-mean slope rule), as the
//! paper recommends ("Piecewise cubic Hermite interpolation ... very good
//! results"). Written here rather than taken from a crate because it is a few
//! lines, must be allocation-free on the hot path of the slow-flow integration,
//! and no maintained Rust crate offers PCHIP with precomputed slopes.
//!
//! Range policy: below the first tabulated amplitude the properties are held at
//! their first values (the linear limit `a -> 0`); above the last one
//! [`TableInterpolator::eval`] returns [`TableError::AboveRange`] so that callers
//! report it instead of extrapolating silently.
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Identifier written into every modal-table file.
pub const MODAL_TABLE_FORMAT: &str = "nlmode-modal-table";
/// Current modal-table format version.
pub const MODAL_TABLE_VERSION: u32 = 1;

mod linear_modes;
pub use linear_modes::{LinearModeShape, LinearModes, MAX_LINEAR_MODES};

/// The harmonics of the mode shape at one named physical point along the branch:
/// `phi_n(a)` for `n = 0..=H`, so that the point's displacement is
/// `u(t) = Re( a sum_n phi_n(a) e^{i n psi} )` (`eq:ansatz`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointShape {
    pub name: String,
    /// `re[j][n]`: real part of `phi_n` at amplitude `amplitude[j]` [m / (sqrt(kg) m)].
    pub re: Vec<Vec<f64>>,
    /// `im[j][n]`: imaginary part of `phi_n`.
    pub im: Vec<Vec<f64>>,
}

/// A nonlinear modal table (file format `nlmode-modal-table`, version 1; JSON).
///
/// Modal amplitude `a = sqrt(q1^H M q1)` (paper Section 3.1), so the fundamental
/// harmonic of the shape is mass-normalized. `amplitude` is strictly increasing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalTable {
    pub format: String,
    pub version: u32,
    /// Free text: model, harmonics, how the table was made.
    pub description: String,
    /// Harmonic truncation order `H` of the stored shapes.
    pub harmonics: usize,
    /// Modal amplitude `a` [sqrt(kg) m], strictly increasing.
    pub amplitude: Vec<f64>,
    /// Modal frequency `omega(a)` [rad/s].
    pub omega_rad_s: Vec<f64>,
    /// Modal damping ratio `D(a)` [-].
    pub damping_ratio: Vec<f64>,
    /// Shape harmonics at named physical points (`tip`, exciter locations, DOFs).
    pub points: Vec<PointShape>,
    /// Shape harmonics of all generalized (reduced) coordinates, if stored;
    /// `coordinates[i]` is coordinate `i` (named `q<i>`).
    #[serde(default)]
    pub coordinates: Vec<PointShape>,
    /// Amplitude at which the primary branch was truncated (first fold of `a`),
    /// if any [sqrt(kg) m].
    #[serde(default)]
    pub truncated_at_fold: Option<f64>,
    /// Measured interpolation accuracy of the table (set by
    /// [`crate::nma::NmaResult::refined_table`]; `None` for unrefined or measured tables
    /// and for files written before this field existed).
    #[serde(default)]
    pub accuracy: Option<TableAccuracy>,
    /// The underlying linear structure's other modes at the table's points,
    /// for residual modes (`[slowflow] residual_modes`,
    /// [`crate::reduced::ResidualModes`]); absent in measured tables and in
    /// files written before this field existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_modes: Option<LinearModes>,
}

/// Interpolation accuracy of a refined [`ModalTable`]: the largest PCHIP
/// errors against fresh Harmonic Balance solves at the midpoints of all table
/// intervals, and the targets of the refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableAccuracy {
    /// Largest relative error of `omega` [-].
    pub omega_rel: f64,
    /// Largest relative error of `D` [-] (against `max(|D|, 1e-10)`).
    pub damping_rel: f64,
    /// Largest error of the point shapes relative to each point's largest harmonic [-].
    pub shape_rel: f64,
    /// Target for `omega_rel`.
    pub target_omega_rel: f64,
    /// Target for `damping_rel` and `shape_rel`.
    pub target_rel: f64,
    /// Midpoint HB solves made (including those that led to insertions; a
    /// re-check of an interval after a neighbour's insertion reuses its solve).
    pub checks: usize,
    /// `true` if the point cap stopped the refinement before all targets were met.
    pub capped: bool,
    /// Set if the table ends before the first fold `a_f` of a truncated
    /// primary branch: its last amplitude is `(1 - fold_margin) a_f` [-].
    #[serde(default)]
    pub fold_margin: Option<f64>,
    /// Where the worst `omega` error occurs (interval midpoint `a` [sqrt(kg) m]);
    /// set (and written) only where the target is missed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega_worst_amplitude: Option<f64>,
    /// Where the worst `D` error occurs; set only where the target is missed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping_worst_amplitude: Option<f64>,
    /// Where the worst shape error occurs; set only where the target is missed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape_worst_amplitude: Option<f64>,
    /// Set if the table ends at a discontinuity of the branch (a stepped-over
    /// internal-resonance loop) instead of following it: the table stops before
    /// it, so interpolation never crosses it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub discontinuity: Option<TableDiscontinuity>,
    /// Largest kinetic-energy share of the highest harmonic `H` along the
    /// table, set only where it exceeds [`HIGHEST_HARMONIC_SHARE_WARNING`]
    /// (the truncation may be too low). Not written to the file (the paper
    /// beam's H = 7 table reaches 1.5e-3 at a = 3.92e-3, above the sweeps'
    /// range, and its file must stay as it was): [`Self::warnings`] reports it.
    #[serde(default, skip_serializing)]
    pub highest_harmonic_share: Option<f64>,
    /// Amplitude at which [`Self::highest_harmonic_share`] occurs (not written).
    #[serde(default, skip_serializing)]
    pub highest_harmonic_share_amplitude: Option<f64>,
    /// Smallest table amplitude from which the highest harmonic's share
    /// exceeds [`HIGHEST_HARMONIC_SHARE_WARNING`] (not written): below it the
    /// truncation is not in question.
    #[serde(default, skip_serializing)]
    pub highest_harmonic_share_from_amplitude: Option<f64>,
}

/// Kinetic-energy share of the highest harmonic `H` above which the harmonic
/// truncation is flagged: the `H`-th harmonic then carries a displacement of
/// `sqrt(1e-4) / H = 1 % / H` of the fundamental or more, more than the default
/// table targets (1e-4 relative) tolerate for the neglected `H+1`-th harmonic,
/// which is of the same order.
pub const HIGHEST_HARMONIC_SHARE_WARNING: f64 = 1e-4;

/// A discontinuity of the computed branch that ended a table
/// ([`TableAccuracy::discontinuity`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableDiscontinuity {
    /// Amplitude of the last point before the jump [sqrt(kg) m].
    pub amplitude: f64,
    /// Amplitude of the first point after it [sqrt(kg) m].
    pub amplitude_after: f64,
    /// Relative jump of `omega` across it [-].
    pub omega_jump_rel: f64,
    /// How it was found.
    pub reason: String,
}

impl TableAccuracy {
    /// Human-readable warnings: missed targets with the worst value and the
    /// amplitude where it occurs, a discontinuity that ended the table, a
    /// harmonic truncation that may be too low. Empty when all is well.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let miss = |name: &str, value: f64, target: f64, at: Option<f64>| {
            at.map(|a| {
                format!(
                    "modal table: {name} interpolation error {value:.2e} exceeds the target {target:.1e} (worst at a = {a:.4e}); raise the refinement's max_points or lower the amplitude range"
                )
            })
        };
        w.extend(miss(
            "omega",
            self.omega_rel,
            self.target_omega_rel,
            self.omega_worst_amplitude,
        ));
        w.extend(miss(
            "damping ratio",
            self.damping_rel,
            self.target_rel,
            self.damping_worst_amplitude,
        ));
        w.extend(miss(
            "shape",
            self.shape_rel,
            self.target_rel,
            self.shape_worst_amplitude,
        ));
        if let Some(d) = &self.discontinuity {
            w.push(format!(
                "modal table: ends at a = {:.4e} before a discontinuity of the branch (omega jumps by {:.2e} relative up to a = {:.4e}: {}); the table is not interpolated across it",
                d.amplitude, d.omega_jump_rel, d.amplitude_after, d.reason
            ));
        }
        if let (Some(s), Some(a)) = (
            self.highest_harmonic_share,
            self.highest_harmonic_share_amplitude,
        ) {
            let from = self
                .highest_harmonic_share_from_amplitude
                .map(|f| format!("from a = {f:.4e} on, "))
                .unwrap_or_default();
            w.push(format!(
                "modal table: the highest harmonic carries more than {HIGHEST_HARMONIC_SHARE_WARNING:.0e} of the kinetic energy {from}up to {s:.2e} at a = {a:.4e}; where a response reaches these amplitudes, raise [nma] harmonics"
            ));
        }
        w
    }
}

/// Errors of modal tables; each names the field or value at fault.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    #[error("modal table: format is '{0}', expected '{MODAL_TABLE_FORMAT}'")]
    Format(String),
    #[error("modal table: version {0} is not supported (this build reads version {MODAL_TABLE_VERSION})")]
    Version(u32),
    #[error("modal table: need at least 2 amplitude points, got {0}")]
    TooFewPoints(usize),
    #[error("modal table: field '{field}' has {got} entries, expected {expected}")]
    Length {
        field: String,
        got: usize,
        expected: usize,
    },
    #[error("modal table: amplitude must be positive and strictly increasing; amplitude[{index}] = {value} after {previous}")]
    NotIncreasing {
        index: usize,
        value: f64,
        previous: f64,
    },
    #[error(
        "modal table: field '{field}' entry {index} is {value}, expected a finite{positive} number"
    )]
    BadValue {
        field: String,
        index: usize,
        value: f64,
        positive: &'static str,
    },
    #[error("modal table: no point named '{name}' (available: {available})")]
    UnknownPoint { name: String, available: String },
    #[error("modal amplitude a = {a:.6e} lies above the table's range (max {max:.6e}); the single-nonlinear-mode model is not defined there")]
    AboveRange { a: f64, max: f64 },
    #[error("modal amplitude a = {0} is not a finite non-negative number")]
    BadAmplitude(f64),
    #[error("modal table '{path}': {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("modal table '{path}': invalid JSON: {source}")]
    Json {
        path: String,
        source: serde_json::Error,
    },
}

impl ModalTable {
    /// A table of a linear mode: constant `omega0`, `D0` and fundamental shape
    /// `phi` at the given points over `[a_min, a_max]` (used by the linear
    /// variants and by tests).
    pub fn linear(
        omega0_rad_s: f64,
        damping_ratio: f64,
        points: &[(&str, Complex64)],
        a_min: f64,
        a_max: f64,
    ) -> Self {
        let n = 2;
        let amplitude = vec![a_min, a_max];
        let points = points
            .iter()
            .map(|(name, phi)| PointShape {
                name: name.to_string(),
                re: vec![vec![0.0, phi.re]; n],
                im: vec![vec![0.0, phi.im]; n],
            })
            .collect();
        ModalTable {
            format: MODAL_TABLE_FORMAT.into(),
            version: MODAL_TABLE_VERSION,
            description: format!(
                "linear mode: omega0 = {omega0_rad_s} rad/s, D0 = {damping_ratio}"
            ),
            harmonics: 1,
            amplitude,
            omega_rad_s: vec![omega0_rad_s; n],
            damping_ratio: vec![damping_ratio; n],
            points,
            coordinates: Vec::new(),
            truncated_at_fold: None,
            accuracy: None,
            linear_modes: None,
        }
    }

    /// Check format, version, lengths, monotonicity and finiteness.
    pub fn validate(&self) -> Result<(), TableError> {
        if self.format != MODAL_TABLE_FORMAT {
            return Err(TableError::Format(self.format.clone()));
        }
        if self.version != MODAL_TABLE_VERSION {
            return Err(TableError::Version(self.version));
        }
        let n = self.amplitude.len();
        if n < 2 {
            return Err(TableError::TooFewPoints(n));
        }
        let len = |field: &str, got: usize, expected: usize| {
            if got != expected {
                Err(TableError::Length {
                    field: field.into(),
                    got,
                    expected,
                })
            } else {
                Ok(())
            }
        };
        len("omega_rad_s", self.omega_rad_s.len(), n)?;
        len("damping_ratio", self.damping_ratio.len(), n)?;
        for (j, &a) in self.amplitude.iter().enumerate() {
            let prev = if j == 0 { 0.0 } else { self.amplitude[j - 1] };
            if !a.is_finite() || a <= prev {
                return Err(TableError::NotIncreasing {
                    index: j,
                    value: a,
                    previous: prev,
                });
            }
        }
        for (j, &w) in self.omega_rad_s.iter().enumerate() {
            if !(w.is_finite() && w > 0.0) {
                return Err(TableError::BadValue {
                    field: "omega_rad_s".into(),
                    index: j,
                    value: w,
                    positive: " positive",
                });
            }
        }
        for (j, &d) in self.damping_ratio.iter().enumerate() {
            if !d.is_finite() {
                return Err(TableError::BadValue {
                    field: "damping_ratio".into(),
                    index: j,
                    value: d,
                    positive: "",
                });
            }
        }
        for p in self.points.iter().chain(self.coordinates.iter()) {
            len(&format!("points[{}].re", p.name), p.re.len(), n)?;
            len(&format!("points[{}].im", p.name), p.im.len(), n)?;
            for (j, (re, im)) in p.re.iter().zip(&p.im).enumerate() {
                len(
                    &format!("points[{}].re[{j}]", p.name),
                    re.len(),
                    self.harmonics + 1,
                )?;
                len(
                    &format!("points[{}].im[{j}]", p.name),
                    im.len(),
                    self.harmonics + 1,
                )?;
                if let Some(v) = re.iter().chain(im).find(|v| !v.is_finite()) {
                    return Err(TableError::BadValue {
                        field: format!("points[{}]", p.name),
                        index: j,
                        value: *v,
                        positive: "",
                    });
                }
            }
        }
        if let Some(lm) = &self.linear_modes {
            lm.validate(&self.points)?;
        }
        Ok(())
    }

    /// Parse and validate a table from JSON text.
    pub fn from_json(text: &str) -> Result<Self, serde_json::Error> {
        serde_json::from_str(text)
    }

    /// Serialize to pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("modal table serializes")
    }

    /// Read and validate a table file.
    pub fn read(path: &Path) -> Result<Self, TableError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| TableError::Io {
            path: p.clone(),
            source,
        })?;
        let table =
            Self::from_json(&text).map_err(|source| TableError::Json { path: p, source })?;
        table.validate()?;
        Ok(table)
    }

    /// Write the table as JSON.
    pub fn write(&self, path: &Path) -> Result<(), TableError> {
        std::fs::write(path, self.to_json()).map_err(|source| TableError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Index of the named point.
    pub fn point_index(&self, name: &str) -> Result<usize, TableError> {
        self.points
            .iter()
            .position(|p| p.name == name)
            .ok_or_else(|| TableError::UnknownPoint {
                name: name.into(),
                available: self
                    .points
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Build the PCHIP interpolator (validates the table first).
    pub fn interpolator(&self) -> Result<TableInterpolator, TableError> {
        self.validate()?;
        TableInterpolator::new(self)
    }
}

/// One monotone piecewise-cubic Hermite interpolant on the table's grid.
#[derive(Debug, Clone)]
struct Pchip {
    y: Vec<f64>,
    d: Vec<f64>,
}

impl Pchip {
    fn new(x: &[f64], y: &[f64]) -> Self {
        let n = x.len();
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let delta: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
        let mut d = vec![0.0; n];
        if n == 2 {
            d[0] = delta[0];
            d[1] = delta[0];
            return Self { y: y.to_vec(), d };
        }
        for k in 1..n - 1 {
            if delta[k - 1] * delta[k] > 0.0 {
                // weighted harmonic mean (Fritsch-Butland / scipy's pchip)
                let w1 = 2.0 * h[k] + h[k - 1];
                let w2 = h[k] + 2.0 * h[k - 1];
                d[k] = (w1 + w2) / (w1 / delta[k - 1] + w2 / delta[k]);
            }
        }
        let end = |h0: f64, h1: f64, d0: f64, d1: f64| {
            let mut s = ((2.0 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
            if s.signum() != d0.signum() {
                s = 0.0;
            } else if d0.signum() != d1.signum() && s.abs() > 3.0 * d0.abs() {
                s = 3.0 * d0;
            }
            s
        };
        d[0] = end(h[0], h[1], delta[0], delta[1]);
        d[n - 1] = end(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
        Self { y: y.to_vec(), d }
    }

    /// Power-form coefficients of segment `k` (width `h`) in its local
    /// coordinate `t in [0, 1]`: the same cubic as [`Self::eval`], written
    /// `c0 + t (c1 + t (c2 + t c3))` with `c0` the node value exactly.
    fn power_form(&self, k: usize, h: f64) -> [f64; 4] {
        let (y0, y1) = (self.y[k], self.y[k + 1]);
        let (m0, m1) = (h * self.d[k], h * self.d[k + 1]);
        [
            y0,
            m0,
            3.0 * (y1 - y0) - 2.0 * m0 - m1,
            2.0 * (y0 - y1) + m0 + m1,
        ]
    }

    /// Value on a located segment with the precomputed Hermite weights; the
    /// same arithmetic, in the same order, as the value of [`Self::eval`].
    #[inline]
    fn value_at(&self, s: &Segment) -> f64 {
        let k = s.k;
        s.w[0] * self.y[k] + s.w[1] * self.d[k] + s.w[2] * self.y[k + 1] + s.w[3] * self.d[k + 1]
    }

    /// Value and derivative on segment `k` at local coordinate `t in [0, 1]`.
    #[inline]
    fn eval(&self, k: usize, t: f64, h: f64) -> (f64, f64) {
        let (y0, y1, d0, d1) = (self.y[k], self.y[k + 1], self.d[k], self.d[k + 1]);
        let t2 = t * t;
        let [h00, h10, h01, h11] = hermite_basis(t);
        let v = h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1;
        let dv = ((6.0 * t2 - 6.0 * t) * y0
            + (3.0 * t2 - 4.0 * t + 1.0) * h * d0
            + (-6.0 * t2 + 6.0 * t) * y1
            + (3.0 * t2 - 2.0 * t) * h * d1)
            / h;
        (v, dv)
    }
}

/// The cubic Hermite basis `h00, h10, h01, h11` at `t in [0, 1]`
/// (`p(t) = h00 y0 + h10 h d0 + h01 y1 + h11 h d1`).
#[inline]
fn hermite_basis(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        2.0 * t3 - 3.0 * t2 + 1.0,
        t3 - 2.0 * t2 + t,
        -2.0 * t3 + 3.0 * t2,
        t3 - t2,
    ]
}

/// A table segment with the cubic Hermite weights `h00, h10 h, h01, h11 h` of
/// one amplitude: found once ([`TableInterpolator::locate`]) and reused for
/// every interpolated quantity at that amplitude (the hot path of the
/// time-domain oscillator evaluates 60 or more interpolants per amplitude).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    k: usize,
    t: f64,
    h: f64,
    w: [f64; 4],
}

/// Where an amplitude lies in the table (from [`TableInterpolator::locate`]):
/// below the first node (properties held at their first values) or on one
/// segment with its interpolation weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableLocation(Option<Segment>);

/// Modal properties at one amplitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalProperties {
    /// `omega(a)` [rad/s].
    pub omega_rad_s: f64,
    /// `D(a)` [-].
    pub damping_ratio: f64,
    /// `d omega / d a`.
    pub domega_da: f64,
}

/// PCHIP interpolation of a [`ModalTable`] in the modal amplitude `a`.
#[derive(Debug, Clone)]
pub struct TableInterpolator {
    amplitude: Vec<f64>,
    omega: Pchip,
    damping: Pchip,
    /// per point, per harmonic: (re, im)
    shapes: Vec<Vec<(Pchip, Pchip)>>,
    point_names: Vec<String>,
    harmonics: usize,
}

impl TableInterpolator {
    fn new(table: &ModalTable) -> Result<Self, TableError> {
        let x = &table.amplitude;
        let shapes = table
            .points
            .iter()
            .map(|p| {
                (0..=table.harmonics)
                    .map(|n| {
                        let re: Vec<f64> = p.re.iter().map(|r| r[n]).collect();
                        let im: Vec<f64> = p.im.iter().map(|r| r[n]).collect();
                        (Pchip::new(x, &re), Pchip::new(x, &im))
                    })
                    .collect()
            })
            .collect();
        Ok(Self {
            amplitude: x.clone(),
            omega: Pchip::new(x, &table.omega_rad_s),
            damping: Pchip::new(x, &table.damping_ratio),
            shapes,
            point_names: table.points.iter().map(|p| p.name.clone()).collect(),
            harmonics: table.harmonics,
        })
    }

    /// Tabulated amplitude range `(a_min, a_max)`.
    pub fn amplitude_range(&self) -> (f64, f64) {
        (self.amplitude[0], *self.amplitude.last().unwrap())
    }

    /// Harmonic truncation order `H` of the shapes.
    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    /// Number of named points.
    pub(crate) fn point_count(&self) -> usize {
        self.shapes.len()
    }

    /// The tabulated amplitudes (the breakpoints of every interpolant).
    pub(crate) fn amplitudes(&self) -> &[f64] {
        &self.amplitude
    }

    /// The interpolants of `omega`, `D` and the fundamental shape (`Re`,
    /// `Im` at every point) in power form, per segment `k` the quantities
    /// `[omega, D, Re phi_1(p0), Im phi_1(p0), Re phi_1(p1), ...]` at
    /// `c[k * (2 + 2 npoints) + q]` (see [`Pchip::power_form`]): the same
    /// cubics for the slow flow's hot loop (`reduced::fast`).
    pub(crate) fn fundamental_power_form(&self) -> Vec<[f64; 4]> {
        let nq = 2 + 2 * self.shapes.len();
        let mut c = Vec::with_capacity((self.amplitude.len() - 1) * nq);
        for (k, w) in self.amplitude.windows(2).enumerate() {
            let h = w[1] - w[0];
            c.push(self.omega.power_form(k, h));
            c.push(self.damping.power_form(k, h));
            for point in &self.shapes {
                let (re, im) = &point[1];
                c.push(re.power_form(k, h));
                c.push(im.power_form(k, h));
            }
        }
        c
    }

    /// Index of a named point.
    pub fn point_index(&self, name: &str) -> Result<usize, TableError> {
        self.point_names
            .iter()
            .position(|p| p == name)
            .ok_or_else(|| TableError::UnknownPoint {
                name: name.into(),
                available: self.point_names.join(", "),
            })
    }

    /// Locate `a` in the table once for several interpolations
    /// ([`Self::eval_at`], [`Self::values_at`], [`Self::shape_at`], [`Self::shape_all_at`]):
    /// the results equal those of [`Self::eval`], [`Self::shape`] and
    /// [`Self::shape_all`] bit for bit. Errors as [`Self::eval`].
    #[inline]
    pub fn locate(&self, a: f64) -> Result<TableLocation, TableError> {
        if !(a.is_finite() && a >= 0.0) {
            return Err(TableError::BadAmplitude(a));
        }
        let (amin, amax) = self.amplitude_range();
        if a <= amin {
            return Ok(TableLocation(None));
        }
        if a > amax {
            return Err(TableError::AboveRange { a, max: amax });
        }
        let k = self
            .amplitude
            .partition_point(|&x| x < a)
            .saturating_sub(1)
            .min(self.amplitude.len() - 2);
        let h = self.amplitude[k + 1] - self.amplitude[k];
        let t = (a - self.amplitude[k]) / h;
        let [h00, h10, h01, h11] = hermite_basis(t);
        Ok(TableLocation(Some(Segment {
            k,
            t,
            h,
            w: [h00, h10 * h, h01, h11 * h],
        })))
    }

    /// `omega(a)`, `D(a)` and `d omega/d a` at a located amplitude.
    #[inline]
    pub fn eval_at(&self, loc: &TableLocation) -> ModalProperties {
        match &loc.0 {
            None => ModalProperties {
                omega_rad_s: self.omega.y[0],
                damping_ratio: self.damping.y[0],
                domega_da: 0.0,
            },
            Some(s) => {
                let (_, dw) = self.omega.eval(s.k, s.t, s.h);
                ModalProperties {
                    omega_rad_s: self.omega.value_at(s),
                    damping_ratio: self.damping.value_at(s),
                    domega_da: dw,
                }
            }
        }
    }

    /// The amplitude derivatives `(d omega/d a, d D/d a)` at a located
    /// amplitude: the exact derivatives of the PCHIP cubics of the located
    /// segment (below the first amplitude the properties are held, so 0).
    #[inline]
    pub fn slopes_at(&self, loc: &TableLocation) -> (f64, f64) {
        match &loc.0 {
            None => (0.0, 0.0),
            Some(s) => (
                self.omega.eval(s.k, s.t, s.h).1,
                self.damping.eval(s.k, s.t, s.h).1,
            ),
        }
    }

    /// `d phi_n / d a` of harmonic `n` of the shape at `point` at a located
    /// amplitude: the exact derivative of the PCHIP cubics of [`Self::shape_at`]
    /// (0 below the first amplitude, where the shape is held).
    #[inline]
    pub fn shape_slope_at(&self, point: usize, n: usize, loc: &TableLocation) -> Complex64 {
        let (re, im) = &self.shapes[point][n];
        match &loc.0 {
            None => Complex64::new(0.0, 0.0),
            Some(s) => Complex64::new(re.eval(s.k, s.t, s.h).1, im.eval(s.k, s.t, s.h).1),
        }
    }

    /// `(omega(a), D(a))` at a located amplitude (without the slope).
    #[inline]
    pub fn values_at(&self, loc: &TableLocation) -> (f64, f64) {
        match &loc.0 {
            None => (self.omega.y[0], self.damping.y[0]),
            Some(s) => (self.omega.value_at(s), self.damping.value_at(s)),
        }
    }

    /// Harmonic `n` of the shape at `point` at a located amplitude.
    #[inline]
    pub fn shape_at(&self, point: usize, n: usize, loc: &TableLocation) -> Complex64 {
        let (re, im) = &self.shapes[point][n];
        match &loc.0 {
            None => Complex64::new(re.y[0], im.y[0]),
            Some(s) => Complex64::new(re.value_at(s), im.value_at(s)),
        }
    }

    /// All harmonics `phi_0..phi_H` at `point` at a located amplitude, written
    /// into `out` (length `H+1`).
    #[inline]
    pub fn shape_all_at(&self, point: usize, loc: &TableLocation, out: &mut [Complex64]) {
        let shapes = &self.shapes[point];
        assert!(
            out.len() >= shapes.len(),
            "shape_all_at: out must hold H+1 harmonics"
        );
        match &loc.0 {
            None => {
                for (o, (re, im)) in out.iter_mut().zip(shapes) {
                    *o = Complex64::new(re.y[0], im.y[0]);
                }
            }
            Some(s) => {
                for (o, (re, im)) in out.iter_mut().zip(shapes) {
                    *o = Complex64::new(re.value_at(s), im.value_at(s));
                }
            }
        }
    }

    /// `omega(a)`, `D(a)` and `d omega/d a`.
    pub fn eval(&self, a: f64) -> Result<ModalProperties, TableError> {
        Ok(self.eval_at(&self.locate(a)?))
    }

    /// Harmonic `n` of the shape at point `point` (index from [`Self::point_index`]).
    pub fn shape(&self, point: usize, n: usize, a: f64) -> Result<Complex64, TableError> {
        Ok(self.shape_at(point, n, &self.locate(a)?))
    }

    /// All harmonics `phi_0..phi_H` at a point, written into `out` (length `H+1`).
    pub fn shape_all(&self, point: usize, a: f64, out: &mut [Complex64]) -> Result<(), TableError> {
        self.shape_all_at(point, &self.locate(a)?, out);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ModalTable {
        let a: Vec<f64> = (0..18).map(|j| 1e-4 * 1.35f64.powi(j)).collect();
        let omega: Vec<f64> = a
            .iter()
            .map(|&a| (356.2f64.powi(2) + 0.75 * 6e9 * 0.9 * a * a).sqrt())
            .collect();
        let damping: Vec<f64> = a
            .iter()
            .map(|&a| 0.004 * 356.2 / (356.2f64.powi(2) + 0.75 * 6e9 * 0.9 * a * a).sqrt())
            .collect();
        let re = a
            .iter()
            .map(|&a| vec![0.0, 1.05 + 10.0 * a, 0.01 * a])
            .collect();
        let im = a.iter().map(|&a| vec![0.0, -2.0 * a, 0.0]).collect();
        ModalTable {
            format: MODAL_TABLE_FORMAT.into(),
            version: MODAL_TABLE_VERSION,
            description: "test".into(),
            harmonics: 2,
            amplitude: a,
            omega_rad_s: omega,
            damping_ratio: damping,
            points: vec![PointShape {
                name: "tip".into(),
                re,
                im,
            }],
            coordinates: vec![],
            truncated_at_fold: Some(0.5),
            accuracy: None,
            linear_modes: None,
        }
    }

    #[test]
    fn round_trip_is_exact_and_nodes_are_interpolated_exactly() {
        let t = sample();
        let dir = std::env::temp_dir().join(format!("nlmode-table-{}.json", std::process::id()));
        t.write(&dir).unwrap();
        let back = ModalTable::read(&dir).unwrap();
        std::fs::remove_file(&dir).ok();
        assert_eq!(t, back);
        let ip = back.interpolator().unwrap();
        let tip = ip.point_index("tip").unwrap();
        for j in 0..t.amplitude.len() {
            let p = ip.eval(t.amplitude[j]).unwrap();
            assert_eq!(p.omega_rad_s, t.omega_rad_s[j]);
            assert_eq!(p.damping_ratio, t.damping_ratio[j]);
            let phi = ip.shape(tip, 1, t.amplitude[j]).unwrap();
            assert_eq!(
                phi,
                Complex64::new(t.points[0].re[j][1], t.points[0].im[j][1])
            );
        }
    }

    #[test]
    fn interpolation_is_monotone_between_nodes_and_accurate() {
        let t = sample();
        let ip = t.interpolator().unwrap();
        let (amin, amax) = ip.amplitude_range();
        let mut prev = 0.0;
        let mut maxerr: f64 = 0.0;
        for k in 0..=2000 {
            let a = amin + (amax - amin) * k as f64 / 2000.0;
            let p = ip.eval(a).unwrap();
            assert!(p.omega_rad_s >= prev, "not monotone at a = {a}");
            prev = p.omega_rad_s;
            let exact = (356.2f64.powi(2) + 0.75 * 6e9 * 0.9 * a * a).sqrt();
            maxerr = maxerr.max((p.omega_rad_s - exact).abs() / exact);
        }
        assert!(maxerr < 2e-3, "{maxerr}");
        // derivative consistent with finite differences
        let a = 0.3 * amax;
        let h = 1e-7 * amax;
        let fd =
            (ip.eval(a + h).unwrap().omega_rad_s - ip.eval(a - h).unwrap().omega_rad_s) / (2.0 * h);
        assert!((ip.eval(a).unwrap().domega_da - fd).abs() < 1e-5 * fd.abs());
    }

    #[test]
    fn monotone_data_with_a_kink_does_not_overshoot() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [0.0, 0.0, 1.0, 1.0, 1.0];
        let p = Pchip::new(&x, &y);
        for k in 0..4 {
            for s in 0..=50 {
                let (v, _) = p.eval(k, s as f64 / 50.0, 1.0);
                assert!((-1e-15..=1.0 + 1e-15).contains(&v), "{v}");
            }
        }
    }

    #[test]
    fn range_policy() {
        let t = sample();
        let ip = t.interpolator().unwrap();
        let (amin, amax) = ip.amplitude_range();
        assert_eq!(ip.eval(0.0).unwrap().omega_rad_s, t.omega_rad_s[0]);
        assert_eq!(ip.eval(0.5 * amin).unwrap().omega_rad_s, t.omega_rad_s[0]);
        assert!(matches!(
            ip.eval(1.01 * amax),
            Err(TableError::AboveRange { .. })
        ));
        assert!(matches!(
            ip.eval(f64::NAN),
            Err(TableError::BadAmplitude(_))
        ));
        assert!(matches!(
            ip.point_index("nope"),
            Err(TableError::UnknownPoint { .. })
        ));
    }

    #[test]
    fn validation_names_the_problem() {
        let mut t = sample();
        t.amplitude[3] = t.amplitude[2];
        assert!(matches!(
            t.validate(),
            Err(TableError::NotIncreasing { index: 3, .. })
        ));
        let mut t = sample();
        t.omega_rad_s.pop();
        assert!(matches!(t.validate(), Err(TableError::Length { .. })));
        let mut t = sample();
        t.points[0].re[2].pop();
        assert!(matches!(t.validate(), Err(TableError::Length { .. })));
        let mut t = sample();
        t.version = 9;
        assert!(matches!(t.validate(), Err(TableError::Version(9))));
    }

    #[test]
    fn linear_table_is_constant() {
        let t = ModalTable::linear(
            356.2,
            0.004,
            &[("tip", Complex64::new(1.4, 0.0))],
            1e-6,
            1.0,
        );
        let ip = t.interpolator().unwrap();
        let p = ip.eval(0.37).unwrap();
        assert_eq!(p.omega_rad_s, 356.2);
        assert_eq!(p.damping_ratio, 0.004);
        assert_eq!(ip.shape(0, 1, 0.37).unwrap(), Complex64::new(1.4, 0.0));
    }
}
