//! Scenario -> physical model: the beam (Craig-Bampton reduced or full, built by
//! `nlmode::structure::paper_structure`) or the user's matrices (read and built
//! by `nlmode::structure::matrices`), the shakers as generic linear
//! attachments, the sweep. Thin mapping onto `nlmode`.
use crate::scenario::{
    ExciterSpec, MatricesStructureSpec, Reduction, Scenario, StingerKind, StructureSpec,
};
use anyhow::{Context, Result};
use nlmode::attachment::{ArmatureDamping, LinearAttachment, ShakerParams, Stinger};
use nlmode::excitation::LinearSweep;
use nlmode::structure::{
    modal_analysis, paper_structure, BeamSpec, PaperStructureOptions, StructuralModel,
};

/// Name of the tip point of a beam.
pub const TIP: &str = nlmode::structure::paper::TIP;

/// Everything the methods need, built once per run.
pub struct Setup {
    /// The structural model the methods use (reduced unless `reduction = "none"`).
    pub model: StructuralModel,
    /// Linear natural frequency of mode 1 of the full model [rad/s].
    pub omega0_rad_s: f64,
    /// Degrees of freedom of the full FE model.
    pub full_ndof: usize,
    pub shakers: Vec<ShakerParams>,
    pub attachments: Vec<LinearAttachment>,
    /// Structure point of each exciter.
    pub exciter_points: Vec<String>,
    /// The point whose displacement is `tip_amplitude_m` (`[output] response_point`).
    pub response_point: String,
    /// 0-based index of the linear mode the single-mode methods follow (the lowest
    /// elastic mode: the number of rigid-body modes, 0 for the beam).
    pub mode_index: usize,
    pub sweep: LinearSweep,
    /// Linear modal damping ratio of the followed mode, `D0` (beam: the scenario's
    /// `damping_ratio`; matrices: `phi^T C phi / (2 omega0)` of the full model).
    pub d0: f64,
    /// Modal mass `1/phi(x)^2` of mode 1 at each exciter [kg] and the mass ratio `m_a/m_mod`.
    pub modal_masses: Vec<(f64, f64)>,
}

/// Point name of a location: `tip`, `l3`, `2l3` or `x<metres>`.
pub fn point_name(x_m: f64, length_m: f64) -> String {
    let near = |a: f64| (x_m - a).abs() <= 1e-9 * length_m;
    if near(length_m) {
        TIP.into()
    } else if near(length_m / 3.0) {
        "l3".into()
    } else if near(2.0 * length_m / 3.0) {
        "2l3".into()
    } else {
        format!("x{x_m:.6}")
    }
}

pub fn shaker_params(ex: &ExciterSpec) -> ShakerParams {
    ShakerParams {
        inductance_h: ex.inductance_h,
        resistance_ohm: ex.resistance_ohm,
        force_constant_n_per_a: ex.force_constant_n_per_a,
        armature_mass_kg: ex.armature_mass_kg,
        armature_stiffness_n_per_m: ex.armature_stiffness_n_per_m,
        armature_damping: match (ex.armature_damping_ratio, ex.armature_damping_n_s_per_m) {
            (_, Some(d)) => ArmatureDamping::Viscous(d),
            (Some(r), None) => ArmatureDamping::Ratio(r),
            (None, None) => ArmatureDamping::Ratio(nlmode::benchmark::SHAKER_DA),
        },
        stinger: match ex.stinger {
            StingerKind::Rigid => Stinger::Rigid,
            StingerKind::Elastic => Stinger::Elastic {
                stiffness_n_per_m: ex.stinger_stiffness_n_per_m,
            },
        },
    }
}

/// The structure of the scenario with the points `tip` and `extra_points` (name,
/// x), by `nlmode`'s paper set-up: the model to simulate, `omega0` of the full
/// model [rad/s] and the full model's DOF count.
pub fn build_structure(
    sc: &Scenario,
    extra_points: &[(String, f64)],
) -> Result<(StructuralModel, f64, usize)> {
    let st = sc
        .structure
        .beam()
        .context("build_structure: the structure is not a beam")?;
    let mut points = vec![(TIP.to_string(), st.length_m)];
    for (name, x) in extra_points {
        if points.iter().all(|(p, _)| p != name) {
            points.push((name.clone(), *x));
        }
    }
    let opts = PaperStructureOptions {
        beam: BeamSpec {
            length_m: st.length_m,
            height_m: st.height_m,
            width_m: st.width_m,
            youngs_modulus_pa: st.youngs_modulus_pa,
            density_kg_m3: st.density_kg_m3,
            n_nodes: st.n_nodes,
            boundary: st.boundary,
        },
        k3_n_per_m3: st.k3_n_per_m3,
        d0: st.damping_ratio,
        cb_modes: match st.reduction {
            Reduction::CraigBampton => Some(st.cb_modes),
            Reduction::None => None,
        },
        points,
    };
    let ps = paper_structure(&opts).with_context(|| {
        format!(
            "structure (boundary {:?}, points {:?})",
            st.boundary, opts.points
        )
    })?;
    if sc.nonlinearity.is_empty() {
        return Ok((ps.model, ps.omega0_rad_s, ps.beam.model.ndof()));
    }
    // [[nonlinearity]] on the full beam; the Craig-Bampton masters are the tip
    // and every element point
    let mut full = ps.beam.model.clone();
    add_nonlinearities(sc, &mut full)?;
    let model = match st.reduction {
        Reduction::CraigBampton => {
            let dof = |p: &str| -> Result<usize> {
                Ok(full
                    .point(p)
                    .map_err(|e| anyhow::anyhow!("{e}"))?
                    .direction
                    .iamax())
            };
            let mut masters = vec![dof(TIP)?];
            for nl in &sc.nonlinearity {
                for p in nl.point_names() {
                    let d = dof(&p)?;
                    if !masters.contains(&d) {
                        masters.push(d);
                    }
                }
            }
            nlmode::structure::craig_bampton(&full, &masters, st.cb_modes)
                .context("structure: Craig-Bampton reduction with the nonlinearity points")?
                .reduced
        }
        Reduction::None => full,
    };
    Ok((model, ps.omega0_rad_s, ps.beam.model.ndof()))
}

/// Adds the scenario's `[[nonlinearity]]` elements to `model`, with directions
/// from the model's own named points (`e` grounded, `e_a - e_b` relative; on a
/// Craig-Bampton model whose masters include the points this equals projecting
/// the full model's element). Errors name the key (`nonlinearity[0].point`).
pub fn add_nonlinearities(sc: &Scenario, model: &mut StructuralModel) -> Result<()> {
    for (i, nl) in sc.nonlinearity.iter().enumerate() {
        let law = nl.law(i)?;
        let names = nl.point_names();
        let mut dirs = Vec::new();
        for (j, p) in names.iter().enumerate() {
            let key = match nl.point {
                Some(_) => format!("nonlinearity[{i}].point"),
                None => format!("nonlinearity[{i}].points[{j}]"),
            };
            let available: Vec<&str> = model.points.iter().map(|q| q.name.as_str()).collect();
            let e = model.point(p).map_err(|_| {
                anyhow::anyhow!(
                    "{key}: unknown point '{p}'; the structure's points are {available:?}"
                )
            })?;
            dirs.push(e.direction.clone());
        }
        let w = match dirs.as_slice() {
            [a] => a.clone(),
            [a, b] => a - b,
            _ => anyhow::bail!("nonlinearity[{i}].points: expected one or two points"),
        };
        model
            .add_nonlinear_shared(&nl.element_name(i), w, law)
            .map_err(|e| anyhow::anyhow!("nonlinearity[{i}].name: {e}"))?;
    }
    Ok(())
}

/// The matrices structure of the scenario (paths already resolved), built by
/// `nlmode::structure::matrix_structure`. Errors name the scenario key (and
/// file, line).
pub fn build_matrices_structure(
    sc: &Scenario,
    st: &MatricesStructureSpec,
) -> Result<nlmode::structure::MatrixStructure> {
    use nlmode::structure::{
        matrix_structure, read_matrix_market, MatricesError, MatrixDamping, MatrixRole,
        MatrixStructureOptions,
    };
    let key = |e: MatricesError| -> anyhow::Error {
        let k = match &e {
            MatricesError::DofOutOfRange { name, .. } => {
                let i = st.point.iter().position(|p| &p.name == name).unwrap_or(0);
                format!("structure.point[{i}].dof")
            }
            MatricesError::DuplicatePoint { .. } => "structure.point".into(),
            MatricesError::UnknownPoint { key, .. }
            | MatricesError::InvalidParameter { key, .. } => {
                format!("structure.{key}")
            }
            MatricesError::Structure(_) => "structure".into(),
            MatricesError::MassNotPositiveDefinite { .. } => "structure.mass_mtx".into(),
            MatricesError::StiffnessIndefinite { .. } | MatricesError::RigidBodyModes { .. } => {
                "structure.stiffness_mtx".into()
            }
            MatricesError::Io { role, .. }
            | MatricesError::Malformed { role, .. }
            | MatricesError::NotSquare { role, .. }
            | MatricesError::SizeMismatch { role, .. }
            | MatricesError::NonFinite { role, .. }
            | MatricesError::NotSymmetric { role, .. }
            | MatricesError::BadDiagonal { role, .. } => format!("structure.{}", role.key()),
        };
        anyhow::anyhow!("{k}: {e}")
    };
    let mass = read_matrix_market(MatrixRole::Mass, &st.mass_mtx).map_err(key)?;
    let stiffness = read_matrix_market(MatrixRole::Stiffness, &st.stiffness_mtx).map_err(key)?;
    let damping = match (&st.damping_mtx, st.rayleigh, st.damping_ratio) {
        (Some(p), _, _) => {
            MatrixDamping::Matrix(read_matrix_market(MatrixRole::Damping, p).map_err(key)?)
        }
        (None, Some([alpha_per_s, beta_s]), _) => MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        },
        (None, None, Some(ratio)) => MatrixDamping::StiffnessProportional {
            ratio,
            mode_index: st.damping_mode.unwrap_or(1) - 1,
        },
        (None, None, None) => anyhow::bail!("structure.damping_mtx: missing damping"),
    };
    let points: Vec<(String, usize)> = st.point.iter().map(|p| (p.name.clone(), p.dof)).collect();
    let dof = |name: &str| st.point.iter().find(|p| p.name == name).map(|p| p.dof);
    let cubic_spring = st
        .nonlinear_point
        .as_ref()
        .map(|p| (p.clone(), st.k3_n_per_m3));
    // Default masters: the nonlinear point and every exciter point, one per DOF.
    let masters = match &st.cb_masters {
        Some(m) => m.clone(),
        None => {
            let mut m: Vec<String> = Vec::new();
            let elements: Vec<String> = sc
                .nonlinearity
                .iter()
                .flat_map(|nl| nl.point_names())
                .collect();
            let used = st
                .nonlinear_point
                .iter()
                .filter(|_| st.k3_n_per_m3 != 0.0)
                .chain(sc.exciter.iter().filter_map(|e| e.point.as_ref()))
                .chain(elements.iter());
            for p in used {
                if m.iter().all(|q| dof(q) != dof(p)) {
                    m.push(p.clone());
                }
            }
            m
        }
    };
    let opts = MatrixStructureOptions {
        mass,
        mass_path: st.mass_mtx.clone(),
        stiffness,
        stiffness_path: st.stiffness_mtx.clone(),
        damping,
        damping_path: st.damping_mtx.clone(),
        points,
        cubic_spring,
        craig_bampton: match st.reduction {
            Reduction::CraigBampton => Some((masters, st.cb_modes)),
            Reduction::None => None,
        },
        allow_rigid_body_modes: st.allow_rigid_body_modes,
    };
    if let (Some(m), Reduction::CraigBampton) = (&st.cb_masters, st.reduction) {
        for (i, nl) in sc.nonlinearity.iter().enumerate() {
            for p in nl.point_names() {
                if m.iter().all(|q| dof(q) != dof(&p)) {
                    anyhow::bail!(
                        "structure.cb_masters: must include the DOF of point '{p}' of nonlinearity[{i}] (masters {m:?})"
                    );
                }
            }
        }
    }
    let mut ms = matrix_structure(&opts).map_err(key)?;
    add_nonlinearities(sc, &mut ms.full)?;
    add_nonlinearities(sc, &mut ms.model)?;
    Ok(ms)
}

impl Setup {
    pub fn new(sc: &Scenario) -> Result<Self> {
        let (model, omega0, full_ndof, mode_index, pts, d0) = match &sc.structure {
            StructureSpec::Beam(beam) => {
                let l = beam.length_m;
                let mut pts = Vec::new();
                for i in 0..sc.exciter.len() {
                    let x = sc.exciter_location_m(i)?;
                    pts.push((point_name(x, l), x));
                }
                // The standard points of the paper, so that one modal table serves both locations.
                for (n, x) in [("l3", l / 3.0), ("2l3", 2.0 * l / 3.0)] {
                    if pts.iter().all(|(p, _)| p != n) && beam.n_nodes % 3 == 1 {
                        pts.push((n.into(), x));
                    }
                }
                let (model, omega0, full_ndof) = build_structure(sc, &pts)?;
                let names: Vec<String> = pts.into_iter().map(|(n, _)| n).collect();
                (model, omega0, full_ndof, 0, names, beam.damping_ratio)
            }
            StructureSpec::Matrices(m) => {
                let ms = build_matrices_structure(sc, m)?;
                let names = sc
                    .exciter
                    .iter()
                    .map(|e| e.point.clone().context("exciter point"))
                    .collect::<Result<Vec<_>>>()?;
                let n = ms.full.ndof();
                (
                    ms.model,
                    ms.omega0_rad_s,
                    n,
                    ms.rigid_body_modes,
                    names,
                    ms.damping_ratio,
                )
            }
        };
        Self::assemble(sc, model, omega0, full_ndof, mode_index, &pts, d0)
    }

    /// This setup's structure (model, `omega0`, points, followed mode) with
    /// the exciters, response point and excitation of `sc`: for a scenario that
    /// differs from the one this setup was built from only outside
    /// `[structure]` and the exciter locations (a study's samples share one
    /// structure and its modal table this way).
    pub fn with_scenario(&self, sc: &Scenario) -> Result<Self> {
        Self::assemble(
            sc,
            self.model.clone(),
            self.omega0_rad_s,
            self.full_ndof,
            self.mode_index,
            &self.exciter_points,
            self.d0,
        )
    }

    /// The exciters (`pts[i]`: the structure point of exciter `i`), the
    /// response point and the sweep of `sc` on a built structure.
    fn assemble(
        sc: &Scenario,
        model: StructuralModel,
        omega0: f64,
        full_ndof: usize,
        mode_index: usize,
        pts: &[String],
        d0: f64,
    ) -> Result<Self> {
        let response_point = sc.response_point();
        model
            .point(&response_point)
            .map_err(|e| anyhow::anyhow!("output.response_point: {e}"))?;
        let mut shakers = Vec::new();
        let mut attachments = Vec::new();
        let mut exciter_points = Vec::new();
        for (i, ex) in sc.exciter.iter().enumerate() {
            let p = shaker_params(ex);
            p.validate().with_context(|| format!("exciter[{i}]"))?;
            let point = pts[i].clone();
            attachments.push(
                LinearAttachment::shaker(&ex.name, &p, &point)
                    .with_context(|| format!("exciter[{i}]"))?,
            );
            shakers.push(p);
            exciter_points.push(point);
        }
        let e = &sc.excitation;
        let sweep = LinearSweep::per_pseudo_period(
            omega0,
            e.eta_start,
            e.eta_end,
            e.rate_per_pseudo_period,
            e.voltage_v,
        )
        .context("excitation")?;
        let modes = modal_analysis(&model, mode_index + 1).context("structure: modal analysis")?;
        let modal_masses = exciter_points
            .iter()
            .zip(&shakers)
            .map(|(p, s)| {
                let m = modes.modal_mass_kg(mode_index, &model.point(p)?.direction);
                Ok((m, s.armature_mass_kg / m))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            model,
            omega0_rad_s: omega0,
            full_ndof,
            shakers,
            attachments,
            exciter_points,
            response_point,
            mode_index,
            sweep,
            d0,
            modal_masses,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_setup_matches_the_paper() {
        let s = Setup::new(&Scenario::default_scenario()).unwrap();
        assert!((s.omega0_rad_s - 356.2).abs() < 0.4, "{}", s.omega0_rad_s);
        assert_eq!(s.model.ndof(), 11);
        assert_eq!(s.exciter_points, vec!["2l3".to_string()]);
        let mm = &s.modal_masses;
        assert!((mm[0].0 - 0.92).abs() < 0.03, "{:?}", mm);
        assert!((mm[0].1 - 0.047).abs() < 0.002, "{:?}", mm);
        assert!((s.sweep.omega_end_rad_s / s.omega0_rad_s - 1.8).abs() < 1e-12);
    }

    #[test]
    fn between_nodes_is_rejected_with_the_location() {
        let sc = Scenario::parse("[[exciter]]\nlocation_m = 0.2\n").unwrap();
        let e = Setup::new(&sc).err().unwrap();
        let msg = format!("{e:#}");
        assert!(msg.contains("0.2") && msg.contains("between"), "{msg}");
    }
}
