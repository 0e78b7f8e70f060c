//! The paper's benchmark structure (Section 5): a clamped-free Euler-Bernoulli beam
//! (l = 0.53 m, h = 0.019 m, w = 0.014 m, E = 2.1e11 Pa, rho = 7800 kg/m^3, 100
//! nodes) with a cubic spring `k3 = 6e9 N/m^3` at the tip translation,
//! stiffness-proportional damping with `D0 = 0.4 %` on mode 1 (calibrated on the full
//! model) and a Craig-Bampton reduction with the tip translation as master and 10
//! fixed-interface modes.
//!
//! With the printed parameters the lowest linear natural frequency is
//! `omega0 = 356.2 rad/s` (`1.8751^2 sqrt(EI / (rho A l^4))`); the paper prints
//! `omega0 = 346 rad/s`. We follow the printed parameters.
use super::craig_bampton::craig_bampton;
use super::damping::stiffness_proportional_damping_from_modes;
use super::modal::modal_analysis;
use super::{Beam, BeamSpec, CubicSpring, Result, StructuralModel, StructureError};
use crate::benchmark;
use nalgebra::{DMatrix, DVector};

/// Name of the tip point (`x = l`).
pub const TIP: &str = "tip";
/// Name of the point at `x = l/3`.
pub const L3: &str = "l3";
/// Name of the point at `x = 2l/3`.
pub const TWO_L3: &str = "2l3";
/// Name of the cubic spring element.
pub const CUBIC_SPRING: &str = "cubic_spring";

/// Options of [`paper_structure`]; `Default` is the paper. Serialisable: missing keys
/// take the paper's values, unknown keys are rejected; `points` is a list of
/// `[name, x_m]` pairs. The host's beam scenarios are built through these options
/// (geometry, material, nodes and boundary in `beam`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PaperStructureOptions {
    /// Geometry, material, number of nodes and boundary conditions of the beam
    /// ([`BeamSpec::paper`]: 100 nodes, clamped-free).
    pub beam: BeamSpec,
    /// Cubic spring at the tip `k3` [N/m^3] (6e9; 0 gives the linear beam, without
    /// a nonlinear element).
    pub k3_n_per_m3: f64,
    /// Damping ratio of mode 1 for stiffness-proportional damping (0.004).
    pub d0: f64,
    /// Fixed-interface modes of the Craig-Bampton reduction (`Some(10)`); `None`
    /// keeps the unreduced model.
    pub cb_modes: Option<usize>,
    /// Named points `(name, x [m])` on node translations, in this order: `tip` (l),
    /// `l3` (l/3), `2l3` (2l/3).
    pub points: Vec<(String, f64)>,
}

impl Default for PaperStructureOptions {
    fn default() -> Self {
        let l = benchmark::LENGTH_M;
        Self {
            beam: BeamSpec::paper(),
            k3_n_per_m3: benchmark::K3_N_PER_M3,
            d0: benchmark::D0,
            cb_modes: Some(benchmark::CB_MODES),
            points: vec![
                (TIP.into(), l),
                (L3.into(), l / 3.0),
                (TWO_L3.into(), 2.0 * l / 3.0),
            ],
        }
    }
}

/// The paper's structure: the model to simulate (Craig-Bampton reduced or full),
/// the full beam and `q_full = transform q`.
#[derive(Debug, Clone)]
pub struct PaperStructure {
    /// The structural model of `eq:component1` used downstream (reduced unless
    /// `cb_modes = None`); same points and nonlinear elements as `beam.model`.
    pub model: StructuralModel,
    /// The full beam, with damping, cubic spring and points.
    pub beam: Beam,
    /// `n_full x model.ndof()`, `q_full = transform q` (identity when unreduced).
    pub transform: DMatrix<f64>,
    /// Stiffness-proportional coefficient `beta` [s], `C = beta K`.
    pub damping_beta_s: f64,
    /// Lowest linear natural frequency of the full model `omega0` [rad/s].
    pub omega0_rad_s: f64,
    /// Natural frequencies of the fixed-interface modes (empty when unreduced) [rad/s].
    pub interface_omega_rad_s: Vec<f64>,
}

impl PaperStructure {
    /// Full-model coordinates from the model's coordinates.
    pub fn recover(&self, q: &DVector<f64>) -> DVector<f64> {
        assert_eq!(q.len(), self.transform.ncols(), "q has the wrong length");
        &self.transform * q
    }
}

/// Builds the paper's structure (see the module docs).
pub fn paper_structure(opts: &PaperStructureOptions) -> Result<PaperStructure> {
    if !opts.k3_n_per_m3.is_finite() {
        return Err(StructureError::InvalidParameter {
            name: "k3_n_per_m3",
            value: opts.k3_n_per_m3,
            expected: "a finite number",
        });
    }
    let mut beam = opts.beam.assemble()?;
    let l = beam.spec.length_m;
    let tip_node = beam.n_nodes() - 1;
    // The tip translation carries the cubic spring and is the Craig-Bampton master.
    let tip_dof = beam
        .translation_dof(tip_node)
        .ok_or_else(|| StructureError::ConstrainedDof {
            name: TIP.into(),
            node: tip_node,
            x_m: l,
        })?;
    for (name, x) in &opts.points {
        beam.add_point(name, *x)?;
    }
    if opts.k3_n_per_m3 != 0.0 {
        let e_tip = beam.translation_vector(CUBIC_SPRING, l)?;
        beam.model
            .add_nonlinear(CUBIC_SPRING, e_tip, CubicSpring::new(opts.k3_n_per_m3)?)?;
    }
    let modes = modal_analysis(&beam.model, 1)?;
    let omega0_rad_s = modes.omega_rad_s[0];
    let damping_beta_s =
        stiffness_proportional_damping_from_modes(&mut beam.model, &modes, 0, opts.d0)?;
    let (model, transform, interface_omega_rad_s) = match opts.cb_modes {
        Some(n_modes) => {
            let cb = craig_bampton(&beam.model, &[tip_dof], n_modes)?;
            (cb.reduced, cb.transform, cb.interface_omega_rad_s)
        }
        None => {
            let n = beam.model.ndof();
            (beam.model.clone(), DMatrix::identity(n, n), Vec::new())
        }
    };
    Ok(PaperStructure {
        model,
        beam,
        transform,
        damping_beta_s,
        omega0_rad_s,
        interface_omega_rad_s,
    })
}
