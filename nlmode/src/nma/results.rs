//! The nonlinear-mode branch: points, folds, internal resonances, and its
//! conversion to a modal table.
use super::continuation::StopReason;
use super::errors::NmaWarning;
use crate::table::{
    ModalTable, PointShape, TableDiscontinuity, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION,
};
use crate::Complex64;

/// One converged point of the nonlinear-mode branch.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint {
    /// Modal amplitude `a` [sqrt(kg) m].
    pub amplitude: f64,
    /// Modal frequency `omega` [rad/s].
    pub omega_rad_s: f64,
    /// Modal damping ratio `D` [-].
    pub damping_ratio: f64,
    pub newton_iterations: usize,
    /// Share of the fundamental harmonic in the kinetic energy of the
    /// oscillation, `|phi_1|_M^2 / sum_n n^2 |phi_n|_M^2` (1 for a harmonic
    /// motion; drops where energy localizes in higher harmonics along loops).
    pub fundamental_energy_share: f64,
    /// Kinetic-energy share of every harmonic `n = 0..=H` (summed over the
    /// modes; `[0]` is 0, `[1]` is [`Self::fundamental_energy_share`]).
    pub harmonic_energy_shares: Vec<f64>,
    /// The largest energy component other than the continued mode's
    /// fundamental: where the energy goes along an internal-resonance loop.
    pub secondary: EnergyComponent,
    /// `points[p][n]`: harmonic `phi_n` (`n = 0..=H`) at stored named point `p`
    /// [m / (sqrt(kg) m)], so the point moves as `Re(a sum_n phi_n e^{i n psi})`.
    pub points: Vec<Vec<Complex64>>,
    /// `coordinates[i][n]`: harmonic `phi_n` of generalized coordinate `i` (if stored).
    pub coordinates: Vec<Vec<Complex64>>,
}

/// Direction of the amplitude at a fold of the branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldKind {
    /// `a` stops increasing (the start of a loop).
    AmplitudeMaximum,
    /// `a` stops decreasing.
    AmplitudeMinimum,
}

/// One (harmonic, linear mode) component of the oscillation and its share of
/// the kinetic energy, `n^2 |Psi_{n,k}|^2 / sum_{n,k} n^2 |Psi_{n,k}|^2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyComponent {
    pub harmonic: usize,
    /// 0-based linear mode index (the paper's "mode 2" is index 1).
    pub mode_index: usize,
    pub share: f64,
}

/// An internal resonance `1:n` of the continued mode with another mode: the
/// `n`-th harmonic of the motion meets that mode's frequency, `n omega ~
/// omega_k(a)`, and takes over the energy along a loop of the backbone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InternalResonance {
    /// Harmonic order `n` (ratio `1:n`).
    pub harmonic: usize,
    /// 0-based index of the participating linear mode.
    pub mode_index: usize,
    /// Largest energy share of that component along the loop.
    pub max_share: f64,
    /// Smallest fundamental energy share along the loop.
    pub min_fundamental_share: f64,
    /// `omega` at the loop's amplitude minimum [rad/s].
    pub omega_rad_s: f64,
}

impl std::fmt::Display for InternalResonance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "1:{} with mode {} (n omega = {:.2} rad/s, {:.0} % of the energy in that component, fundamental share down to {:.1e})",
            self.harmonic,
            self.mode_index + 1,
            self.harmonic as f64 * self.omega_rad_s,
            100.0 * self.max_share,
            self.min_fundamental_share
        )
    }
}

/// A turning point of `a` along the branch (loops from internal resonances).
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// Index of the branch point nearest to the fold.
    pub index: usize,
    pub kind: FoldKind,
    pub amplitude: f64,
    pub omega_rad_s: f64,
    /// For an [`FoldKind::AmplitudeMaximum`]: the internal resonance of the
    /// loop that starts there, identified from the harmonic energy
    /// distribution between it and the next amplitude minimum.
    pub internal_resonance: Option<InternalResonance>,
}

/// Full nonlinear-mode branch including loops/folds.
#[derive(Debug, Clone, PartialEq)]
pub struct NmaResult {
    pub harmonics: usize,
    pub samples: usize,
    pub mode_index: usize,
    pub conservative: bool,
    /// Linear natural frequency of the continued mode [rad/s].
    pub linear_omega_rad_s: f64,
    /// Linear modal damping ratio of the continued mode (0 if conservative).
    pub linear_damping_ratio: f64,
    /// Names of the stored points (order of [`BranchPoint::points`]).
    pub point_names: Vec<String>,
    pub branch: Vec<BranchPoint>,
    pub folds: Vec<Fold>,
    /// Total Newton iterations (including the start point and rejected steps).
    pub newton_iterations: usize,
    /// Rejected continuation steps (failed or jumped correctors).
    pub rejected_steps: usize,
    /// Why the continuation stopped (`None` if it failed).
    pub stop: Option<StopReason>,
    pub warnings: Vec<NmaWarning>,
}

/// Which part of the branch goes into a [`ModalTable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TablePolicy {
    /// The primary branch up to the first turning point of `a` (default).
    #[default]
    PrimaryBranch,
    /// All points whose `a` exceeds every earlier one: steps over loops and
    /// continues on the branch beyond them (a jump in the table at each loop).
    SkipLoops,
}

impl NmaResult {
    pub fn n_points(&self) -> usize {
        self.branch.len()
    }

    /// Index of a stored named point.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.point_names.iter().position(|p| p == name)
    }

    /// `|q_{point,1}| = a |phi_1(point)|` [m] along the branch, e.g. `|q_tip,1|`
    /// of the paper's backbone figure.
    pub fn point_fundamental_amplitude(&self, name: &str) -> Option<Vec<f64>> {
        let p = self.point_index(name)?;
        Some(
            self.branch
                .iter()
                .map(|b| b.amplitude * b.points[p][1].norm())
                .collect(),
        )
    }

    /// First fold of the amplitude (where the default table is truncated).
    pub fn first_fold(&self) -> Option<&Fold> {
        self.folds.first()
    }

    /// Indices of the branch points that go into the table under `policy`.
    /// The primary branch also ends before a stepped-over loop
    /// ([`NmaResult::branch_discontinuity`]), at the last point before it.
    pub fn table_indices(&self, policy: TablePolicy) -> (Vec<usize>, Option<f64>) {
        let mut idx = Vec::new();
        let mut amax = f64::NEG_INFINITY;
        let mut truncated = None;
        let jump = match policy {
            TablePolicy::PrimaryBranch => self.discontinuity_index(),
            TablePolicy::SkipLoops => None,
        };
        for (i, b) in self.branch.iter().enumerate() {
            if Some(i) == jump {
                truncated = Some(amax);
                break;
            }
            if b.amplitude > amax {
                idx.push(i);
                amax = b.amplitude;
            } else {
                match policy {
                    TablePolicy::PrimaryBranch => {
                        truncated = Some(amax);
                        break;
                    }
                    TablePolicy::SkipLoops => {
                        truncated.get_or_insert(amax);
                    }
                }
            }
        }
        (idx, truncated)
    }

    /// Index of the first point of the primary branch (before its first fold)
    /// reached by a jump: a step whose `omega` change exceeds
    /// [`JUMP_SLOPE_RATIO`] times the change the previous interval's slope
    /// predicts (and 1e-3 relative) while its higher-harmonic energy share
    /// `1 - fundamental share` grows [`JUMP_SLOPE_RATIO`]-fold to above 1e-3:
    /// the continuation stepped over an internal-resonance loop. Both are
    /// required: either alone also marks the onset of slip of a friction
    /// element (a kink of `omega(a)`, harmonics from zero), which is no jump.
    /// Jumps this misses are caught by the refinement ([`super::refine::JUMP_WIDTH`]).
    fn discontinuity_index(&self) -> Option<usize> {
        let b = &self.branch;
        for i in 2..b.len() {
            if b[i].amplitude <= b[i - 1].amplitude || b[i - 1].amplitude <= b[i - 2].amplitude {
                return None; // the first fold: the primary branch ends anyway
            }
            let slope = (b[i - 1].omega_rad_s - b[i - 2].omega_rad_s)
                / (b[i - 1].amplitude - b[i - 2].amplitude);
            let predicted = slope * (b[i].amplitude - b[i - 1].amplitude);
            let actual = b[i].omega_rad_s - b[i - 1].omega_rad_s;
            let omega_jump =
                actual.abs() > JUMP_SLOPE_RATIO * predicted.abs() + 1e-3 * b[i].omega_rad_s;
            let (h0, h1) = (
                1.0 - b[i - 1].fundamental_energy_share,
                1.0 - b[i].fundamental_energy_share,
            );
            let share_jump = h1 > 1e-3 && h1 > JUMP_SLOPE_RATIO * h0;
            if omega_jump && share_jump {
                return Some(i);
            }
        }
        None
    }

    /// The stepped-over loop that ends the primary branch's table, if any
    /// ([`NmaResult::table_indices`]).
    pub fn branch_discontinuity(&self, policy: TablePolicy) -> Option<TableDiscontinuity> {
        if policy != TablePolicy::PrimaryBranch {
            return None;
        }
        let i = self.discontinuity_index()?;
        let (p, q) = (&self.branch[i - 1], &self.branch[i]);
        Some(TableDiscontinuity {
            amplitude: p.amplitude,
            amplitude_after: q.amplitude,
            omega_jump_rel: (q.omega_rad_s / p.omega_rad_s - 1.0).abs(),
            reason: format!(
                "a continuation step of the primary branch changed omega by {:.2e} rad/s where the local slope predicts {:.2e}, and the higher-harmonic energy share jumped from {:.2e} to {:.2e}: a stepped-over internal-resonance loop; lower the step size (ds, dsmax) to trace it",
                q.omega_rad_s - p.omega_rad_s,
                {
                    let r = &self.branch[i - 2];
                    (p.omega_rad_s - r.omega_rad_s) / (p.amplitude - r.amplitude)
                        * (q.amplitude - p.amplitude)
                },
                1.0 - p.fundamental_energy_share,
                1.0 - q.fundamental_energy_share
            ),
        })
    }

    /// The modal table (`a` strictly increasing) with the shape harmonics at
    /// every stored point and of all generalized coordinates (if stored).
    pub fn to_table(&self, policy: TablePolicy) -> ModalTable {
        let (idx, truncated) = self.table_indices(policy);
        let pts: Vec<&BranchPoint> = idx.iter().map(|&i| &self.branch[i]).collect();
        self.table_of(&pts, truncated, policy)
    }

    /// The table of the points `pts` (strictly increasing `a`).
    pub(super) fn table_of(
        &self,
        pts: &[&BranchPoint],
        truncated: Option<f64>,
        policy: TablePolicy,
    ) -> ModalTable {
        let shape = |name: String, get: &dyn Fn(&BranchPoint) -> &Vec<Complex64>| PointShape {
            name,
            re: pts
                .iter()
                .map(|b| get(b).iter().map(|c| c.re).collect())
                .collect(),
            im: pts
                .iter()
                .map(|b| get(b).iter().map(|c| c.im).collect())
                .collect(),
        };
        let points = (0..self.point_names.len())
            .map(|p| shape(self.point_names[p].clone(), &|b: &BranchPoint| &b.points[p]))
            .collect();
        let ncoord = self
            .branch
            .first()
            .map(|b| b.coordinates.len())
            .unwrap_or(0);
        let coordinates = (0..ncoord)
            .map(|i| shape(format!("q{i}"), &|b: &BranchPoint| &b.coordinates[i]))
            .collect();
        let mut description = format!(
            "EPMC nonlinear mode {} (0-based) by Harmonic Balance, H = {}, {} AFT samples, {}; linear omega = {} rad/s, D = {}; {} of {} branch points",
            self.mode_index,
            self.harmonics,
            self.samples,
            if self.conservative { "conservative" } else { "damped" },
            self.linear_omega_rad_s,
            self.linear_damping_ratio,
            pts.len(),
            self.branch.len()
        );
        if let Some(a) = truncated {
            description += &match policy {
                TablePolicy::PrimaryBranch => {
                    format!("; primary branch truncated at the first fold of a = {a:e}")
                }
                TablePolicy::SkipLoops => format!("; loops skipped, first fold at a = {a:e}"),
            };
        }
        ModalTable {
            format: MODAL_TABLE_FORMAT.to_string(),
            version: MODAL_TABLE_VERSION,
            description,
            harmonics: self.harmonics,
            amplitude: pts.iter().map(|b| b.amplitude).collect(),
            omega_rad_s: pts.iter().map(|b| b.omega_rad_s).collect(),
            damping_ratio: pts.iter().map(|b| b.damping_ratio).collect(),
            points,
            coordinates,
            truncated_at_fold: truncated,
            accuracy: None,
            linear_modes: None,
        }
    }
}

/// Ratio of the `omega` step to the one the previous slope predicts above which
/// a step of the primary branch counts as a jump
/// ([`NmaResult::branch_discontinuity`]).
pub const JUMP_SLOPE_RATIO: f64 = 10.0;
