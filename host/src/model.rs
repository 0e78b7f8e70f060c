//! Scenario -> physical model: the beam (Craig-Bampton reduced or full, built by
//! `nlmode::structure::paper_structure`) or the user's matrices (read and built
//! by `nlmode::structure::matrices`), the shakers as generic linear
//! attachments, the sweep. Thin mapping onto `nlmode`.
use crate::scenario::{
    AttachmentOutput, AttachmentType, ExciterSpec, MatricesStructureSpec, Reduction, Scenario,
    StingerKind, StructureSpec,
};
use anyhow::{Context, Result};
use nlmode::attachment::{ArmatureDamping, LinearAttachment, ShakerParams, Stinger};
use nlmode::excitation::LinearSweep;
use nlmode::structure::{
    modal_analysis, paper_structure, BeamSpec, PaperStructureOptions, StructuralModel,
};
use nlmode::Complex64;

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
    /// Every linear attachment: the exciters' shakers first (one per
    /// `[[exciter]]`, in order), then the `[[attachment]]`s.
    pub attachments: Vec<LinearAttachment>,
    /// Complex input amplitudes of each attachment per unit of the sweep
    /// amplitude (`u_hat = sweep amplitude * inputs[a]`): for exciter `i`
    /// `voltage_v / [excitation] voltage_v * e^{i phase_rad}` (exactly 1 by
    /// default), for an `lti` attachment 1, none for the passive ones.
    pub inputs: Vec<Vec<Complex64>>,
    /// The outputs the attachments declare ([`AttachmentSpec::outputs`]), each
    /// with the index of its attachment in `attachments`.
    pub outputs: Vec<(usize, AttachmentOutput)>,
    /// Name of each exciter (`exciter[i].name`).
    pub exciter_names: Vec<String>,
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
    /// Stage timings and memory estimate of the sparse Craig-Bampton reduction
    /// of a large matrices structure (printed by `host run`), `None` otherwise.
    pub structure_timings: Option<nlmode::structure::sparse::StageTimings>,
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

/// A matrices error with the scenario key it concerns (`structure.point[2].dof`).
fn matrices_error(
    st: &MatricesStructureSpec,
    e: nlmode::structure::MatricesError,
) -> anyhow::Error {
    use nlmode::structure::MatricesError;
    let k = match &e {
        MatricesError::DofOutOfRange { name, .. } => {
            let i = st.point.iter().position(|p| &p.name == name).unwrap_or(0);
            format!("structure.point[{i}].dof")
        }
        MatricesError::DuplicatePoint { .. } => "structure.point".into(),
        MatricesError::UnknownPoint { key, .. } | MatricesError::InvalidParameter { key, .. } => {
            format!("structure.{key}")
        }
        MatricesError::Structure(nlmode::structure::StructureError::MemoryLimit { .. }) => {
            "structure.memory_limit_gb".into()
        }
        MatricesError::Structure(_) => "structure".into(),
        MatricesError::TooLargeForDense { .. } => "structure.reduction".into(),
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
    // the input's fault (a file or matrix, a key) is a ScenarioError (the
    // Python package raises nlmode.ScenarioError for it); a failed
    // computation of a valid model is not
    let computation = matches!(
        &e,
        MatricesError::Structure(s)
            if !matches!(s, nlmode::structure::StructureError::MemoryLimit { .. })
    );
    if computation {
        return anyhow::anyhow!("{k}: {e}");
    }
    anyhow::Error::new(crate::scenario::ScenarioError {
        key: k,
        message: e.to_string(),
        line: None,
    })
}

/// Each point's row: `dof`, or its node and direction in the `labels` of
/// labelled matrix files.
fn point_dofs(
    st: &MatricesStructureSpec,
    labels: Option<&[feio::Label]>,
) -> Result<Vec<(String, usize)>> {
    let mut points: Vec<(String, usize)> = Vec::with_capacity(st.point.len());
    for (i, p) in st.point.iter().enumerate() {
        let dof = match (p.dof, p.node, p.direction) {
            (Some(d), _, _) => d,
            (None, Some(node), Some(dir)) => {
                let Some(labels) = labels else {
                    anyhow::bail!(
                        "structure.point[{i}].node: node {node} needs a labelled matrix file \
                     (Abaqus' node, dof, node, dof, value); {} has no labels: give dof",
                        st.mass_mtx.display()
                    );
                };
                match labels.binary_search(&(node, dir.0)) {
                    Ok(d) => d,
                    Err(_) => {
                        let nodes = labels.iter().filter(|l| l.0 == node).count();
                        let what = if nodes == 0 {
                            format!(
                            "node {node} is not in the matrix files ({} .. {} of {} labelled DOFs)",
                            labels.first().map_or(0, |l| l.0),
                            labels.last().map_or(0, |l| l.0),
                            labels.len()
                        )
                        } else {
                            let dirs: Vec<u8> =
                                labels.iter().filter(|l| l.0 == node).map(|l| l.1).collect();
                            format!(
                            "node {node} has no direction {} ({}) in the matrix files; its DOFs are {dirs:?}",
                            dir.0,
                            dir.name()
                        )
                        };
                        anyhow::bail!(
                            "structure.point[{i}].node: {what} ({})",
                            st.mass_mtx.display()
                        );
                    }
                }
            }
            _ => {
                anyhow::bail!("structure.point[{i}].dof: missing: give dof, or node and direction")
            }
        };
        points.push((p.name.clone(), dof));
    }
    Ok(points)
}

/// The default Craig-Bampton masters: the nonlinear point and every exciter,
/// element and attachment point, one per DOF (`dof`: a point's row).
fn default_masters(
    sc: &Scenario,
    st: &MatricesStructureSpec,
    dof: &dyn Fn(&str) -> Option<usize>,
) -> Vec<String> {
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
        .chain(elements.iter())
        .chain(
            sc.attachment
                .iter()
                .flat_map(|a| a.point.iter().chain(a.points.iter().flatten())),
        );
    for p in used {
        if m.iter().all(|q| dof(q) != dof(p)) {
            m.push(p.clone());
        }
    }
    m
}

/// The matrices of `files` (role, path) read in `format`: each unlabelled
/// file to its sparse matrix as soon as it is read (its triplets freed), a
/// matrix given in memory (the Python package) converted from its shared
/// entries, a labelled file's triplets kept to be renumbered onto the union
/// of the labels (`(sparse, triplets)`, one of the two per file).
#[allow(clippy::type_complexity)]
fn read_matrices(
    st: &MatricesStructureSpec,
    files: &[(nlmode::structure::MatrixRole, &std::path::PathBuf)],
    format: feio::Format,
) -> Result<(
    Vec<Option<nlmode::structure::sparse::SparseMatrix>>,
    Vec<feio::Triplets>,
)> {
    use nlmode::structure::matrices::{read_matrix_triplets, sparse_from_feio};
    use rayon::prelude::*;
    let key = |e| matrices_error(st, e);
    // the files at once (each parse is itself parallel in chunks, but the
    // conversion to compressed columns is not): the errors in file order
    let one =
        |(k, (role, path)): (usize, &(nlmode::structure::MatrixRole, &std::path::PathBuf))| {
            if let Some(t) = st.in_memory.as_ref().and_then(|m| m.get(k)) {
                let s = sparse_from_feio(*role, path, t).map_err(key)?;
                return Ok((Some(s), feio::Triplets::default()));
            }
            let t = read_matrix_triplets(*role, path, format).map_err(key)?;
            if t.labels.is_none() {
                let s = sparse_from_feio(*role, path, &t).map_err(key)?;
                Ok((Some(s), feio::Triplets::default()))
            } else {
                Ok((None, t))
            }
        };
    let each: Vec<Result<_>> = files.par_iter().enumerate().map(one).collect();
    let mut read = Vec::with_capacity(files.len());
    let mut sparse = Vec::with_capacity(files.len());
    for r in each {
        let (s, t) = r?;
        sparse.push(s);
        read.push(t);
    }
    Ok((sparse, read))
}

/// The matrices structure of the scenario (paths already resolved), built by
/// `nlmode::structure::matrix_structure`. Errors name the scenario key (and
/// file, line).
pub fn build_matrices_structure(
    sc: &Scenario,
    st: &MatricesStructureSpec,
) -> Result<nlmode::structure::MatrixStructure> {
    // sparse from the files to the reduction (dense only for reduction = "none"
    // or a small model, nlmode::structure::matrices::SPARSE_MIN_DOF)
    use nlmode::structure::{
        matrices::{matrix_structure_sparse_with, sparse_from_feio},
        MatricesError, MatrixDamping, MatrixRole, MatrixStructureOptions,
    };
    let key = |e: MatricesError| matrices_error(st, e);
    // the files in their format (feio), then nlmode's checked sparse matrices
    let format = st.matrix_format.feio();
    let mut files = vec![
        (MatrixRole::Mass, &st.mass_mtx),
        (MatrixRole::Stiffness, &st.stiffness_mtx),
    ];
    if let Some(p) = &st.damping_mtx {
        files.push((MatrixRole::Damping, p));
    }
    let read_start = crate::stages::StageClock::now();
    let (mut sparse, mut read) = read_matrices(st, &files, format)?;
    // labelled files (Abaqus' labels format) share one numbering: the union of
    // their (node, dof) labels, ascending
    let labels: Option<Vec<feio::Label>> = if read.iter().any(|t| t.labels.is_some()) {
        if let Some(k) = sparse.iter().position(|s| s.is_some()) {
            let l = read.iter().position(|t| t.labels.is_some()).unwrap_or(0);
            anyhow::bail!(
                "structure.{}: {} carries no node labels, but {} {} does: give all matrices \
                 in one labelled format (Abaqus' node, dof, node, dof, value)",
                files[k].0.key(),
                files[k].1.display(),
                files[l].0.key(),
                files[l].1.display()
            );
        }
        let mut all: Vec<feio::Label> = read
            .iter()
            .flat_map(|t| t.labels.iter().flatten().copied())
            .collect();
        all.sort_unstable();
        all.dedup();
        for t in read.iter_mut() {
            // every label is in the union
            let _ = t.relabel(&all);
        }
        Some(all)
    } else {
        None
    };
    let mut sparse_of = |k: usize| match sparse[k].take() {
        Some(a) => Ok(a),
        None => {
            let t = std::mem::take(&mut read[k]);
            sparse_from_feio(files[k].0, files[k].1, &t).map_err(key)
        }
    };
    let mass = sparse_of(0)?;
    let stiffness = sparse_of(1)?;
    let damping_matrix = match &st.damping_mtx {
        Some(_) => Some(sparse_of(2)?),
        None => None,
    };
    let read_stage = read_start.sample("read");
    let damping = match (damping_matrix, st.rayleigh, st.damping_ratio) {
        (Some(c), _, _) => MatrixDamping::Matrix(c),
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
    let points = point_dofs(st, labels.as_deref())?;
    let dof = |name: &str| points.iter().find(|p| p.0 == name).map(|p| p.1);
    let cubic_spring = st
        .nonlinear_point
        .as_ref()
        .map(|p| (p.clone(), st.k3_n_per_m3));
    let masters = match &st.cb_masters {
        Some(m) => m.clone(),
        None => default_masters(sc, st, &dof),
    };
    let opts = MatrixStructureOptions {
        mass,
        mass_path: st.mass_mtx.clone(),
        stiffness,
        stiffness_path: st.stiffness_mtx.clone(),
        damping,
        damping_path: st.damping_mtx.clone(),
        points: points.clone(),
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
    let log = crate::stages::StageLog::default();
    let sparse = nlmode::structure::sparse::SparseOptions {
        memory_limit_bytes: st.memory_limit_bytes(),
        ordering: st.ordering,
        progress: Some(log.progress()),
        ..Default::default()
    };
    let mut ms = matrix_structure_sparse_with(&opts, &sparse).map_err(key)?;
    if let Some(t) = ms.timings.as_mut() {
        t.read_s = read_stage.wall_s;
        t.stages = std::iter::once(read_stage).chain(log.take()).collect();
    }
    if let Some(full) = ms.full.as_mut() {
        add_nonlinearities(sc, full)?;
    }
    add_nonlinearities(sc, &mut ms.model)?;
    Ok(ms)
}

/// `Z22` of `eq:fc1` is singular at an undamped fixed-interface pole `s = i
/// Omega` (no damping in the attachment with its interface held): refused when
/// that `Omega` lies in the sweep band, naming the key.
fn undamped_pole_in_band(
    att: &LinearAttachment,
    key: &str,
    sc: &Scenario,
    omega0: f64,
) -> Result<()> {
    let e = &sc.excitation;
    let (a, b) = (
        e.eta_start.min(e.eta_end) * omega0,
        e.eta_start.max(e.eta_end) * omega0,
    );
    // a fixed attachment with a static mode has no pole computation here; the
    // validity checks report that, the band is then checked per frequency by eq:fc1
    let Ok(poles) = att.fixed_interface_poles() else {
        return Ok(());
    };
    for p in poles {
        let w = p.im.abs();
        if p.re.abs() <= 1e-9 * p.norm() && w >= a && w <= b {
            anyhow::bail!(
                "{key}: Z_22 is singular at Omega = {w:.4} rad/s inside the sweep band [{a:.2}, {b:.2}] rad/s (undamped fixed-interface resonance of '{}'; eq:fc1 needs Z_22 regular): add damping or move it out of the band",
                att.name
            );
        }
    }
    Ok(())
}

impl Setup {
    /// The complex input amplitudes `u_hat` of every attachment at the sweep's
    /// amplitude (`inputs[a]` times it).
    pub fn input_amplitudes(&self) -> Vec<nalgebra::DVector<Complex64>> {
        self.inputs
            .iter()
            .map(|u| {
                nalgebra::DVector::from_iterator(
                    u.len(),
                    u.iter().map(|f| f * self.sweep.amplitude),
                )
            })
            .collect()
    }

    /// `imposed-force` replaces every exciter by the force it applied (taken
    /// at its point from `nlmode`, `reference` or a CSV file, see
    /// docs/scenario.md) and keeps the other attachments as impedances.
    /// Refused for more exciters than the model takes
    /// ([`nlmode::reduced::MAX_IMPOSED`]) and for an attachment at an exciter's
    /// point (the force measured there would already contain it).
    pub fn check_imposed_force(&self) -> Result<()> {
        let max = nlmode::reduced::MAX_IMPOSED;
        if self.shakers.len() > max {
            anyhow::bail!(
                "imposed-force: the model takes at most {max} prescribed forces, one per exciter; this scenario has {} exciters (remove `imposed-force` from run.methods)",
                self.shakers.len()
            );
        }
        for (i, drive) in self.exciter_points.iter().enumerate() {
            if let Some(a) = self.attachments[self.shakers.len()..]
                .iter()
                .find(|a| a.interface_points.contains(drive))
            {
                anyhow::bail!(
                    "imposed-force: attachment '{}' sits at the point '{drive}' of exciter '{}', where the prescribed force is measured with every attachment there: move it, or remove `imposed-force` from run.methods",
                    a.name,
                    self.exciter_names[i]
                );
            }
        }
        Ok(())
    }

    /// `cosim` co-simulates exactly one structure FMU and one shaker FMU: refused
    /// (with the reason) for several exciters or any `[[attachment]]`.
    pub fn check_cosim(&self) -> Result<()> {
        let extra = self.attachments.len() - self.shakers.len();
        if self.shakers.len() != 1 || extra != 0 {
            anyhow::bail!(
                "cosim: the co-simulation couples one structure FMU to exactly one shaker FMU; this scenario has {} exciters and {extra} [[attachment]] tables (remove `cosim` from run.methods, or keep one exciter and no attachment)",
                self.shakers.len()
            );
        }
        let u = self.inputs[0][0];
        if u != Complex64::new(1.0, 0.0) {
            anyhow::bail!(
                "cosim: the shaker FMU is driven by the sweep voltage itself; exciter[0].voltage_v and phase_rad must be left at their defaults (input factor {u})"
            );
        }
        Ok(())
    }

    pub fn new(sc: &Scenario) -> Result<Self> {
        let mut timings = None;
        let (model, omega0, full_ndof, mode_index, pts, d0) = match &sc.structure {
            StructureSpec::Beam(beam) => {
                let l = beam.length_m;
                let mut pts = Vec::new();
                for i in 0..sc.exciter.len() {
                    let x = sc.exciter_location_m(i)?;
                    pts.push((point_name(x, l), x));
                }
                let mut extra = Vec::new();
                for (i, a) in sc.attachment.iter().enumerate() {
                    if a.kind != AttachmentType::Lti {
                        let x = sc.attachment_location_m(i)?;
                        extra.push((point_name(x, l), x));
                    }
                }
                // The standard points of the paper, so that one modal table serves both locations.
                for (n, x) in [("l3", l / 3.0), ("2l3", 2.0 * l / 3.0)] {
                    if pts.iter().all(|(p, _)| p != n) && beam.n_nodes % 3 == 1 {
                        pts.push((n.into(), x));
                    }
                }
                let all: Vec<(String, f64)> = pts.iter().chain(&extra).cloned().collect();
                let (model, omega0, full_ndof) = build_structure(sc, &all)?;
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
                let n = ms.full_ndof;
                timings = ms.timings.clone();
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
        // `[nma] mode`: the followed mode counted from the lowest elastic one
        let mode_index = mode_index + sc.nma.mode - 1;
        let (omega0, d0) = if sc.nma.mode == 1 {
            (omega0, d0)
        } else {
            followed_mode(&model, mode_index, sc.nma.mode)?
        };
        let mut setup = Self::assemble(sc, model, omega0, full_ndof, mode_index, &pts, d0)?;
        setup.structure_timings = timings;
        Ok(setup)
    }

    /// Refuses a scenario without exciters for what drives the structure
    /// through them (`host run`, `host frf`; only `host nma` runs without).
    pub fn check_driven(&self) -> Result<()> {
        if self.shakers.is_empty() {
            anyhow::bail!(
                "exciter: the scenario has no [[exciter]] table; everything but `host nma` drives the structure through its exciters: add one with point = \"name\""
            );
        }
        Ok(())
    }

    /// This setup's structure (model, `omega0`, points, followed mode) with
    /// the exciters, response point and excitation of `sc`: for a scenario that
    /// differs from the one this setup was built from only outside
    /// `[structure]` and the exciter locations (a study's samples share one
    /// structure and its modal table this way).
    pub fn with_scenario(&self, sc: &Scenario) -> Result<Self> {
        let mut setup = Self::assemble(
            sc,
            self.model.clone(),
            self.omega0_rad_s,
            self.full_ndof,
            self.mode_index,
            &self.exciter_points,
            self.d0,
        )?;
        setup.structure_timings = self.structure_timings.clone();
        Ok(setup)
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
        let v0 = sc.excitation.voltage_v;
        let mut inputs: Vec<Vec<Complex64>> = sc
            .exciter
            .iter()
            .map(|ex| {
                let ratio = match ex.voltage_v {
                    Some(v) if v != v0 => {
                        anyhow::ensure!(
                            v0 > 0.0,
                            "exciter voltages: [excitation] voltage_v = 0 cannot carry exciter voltages (the sweep amplitude scales them)"
                        );
                        v / v0
                    }
                    _ => 1.0,
                };
                // exactly `ratio` (1 by default) without a phase
                Ok(vec![if ex.phase_rad == 0.0 {
                    Complex64::new(ratio, 0.0)
                } else {
                    Complex64::from_polar(ratio, ex.phase_rad)
                }])
            })
            .collect::<Result<_>>()?;
        let mut outputs = Vec::new();
        for (i, spec) in sc.attachment.iter().enumerate() {
            let point = match &sc.structure {
                StructureSpec::Beam(b) if spec.kind != AttachmentType::Lti => {
                    point_name(sc.attachment_location_m(i)?, b.length_m)
                }
                _ => spec.point.clone().unwrap_or_default(),
            };
            let att = spec.build(i, &point)?;
            undamped_pole_in_band(&att, &format!("attachment[{i}]"), sc, omega0)?;
            for o in spec.outputs() {
                outputs.push((attachments.len(), o));
            }
            inputs.push(vec![Complex64::new(1.0, 0.0); att.ninput()]);
            attachments.push(att);
        }
        let sweep = sweep_of(sc, omega0)?;
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
            inputs,
            outputs,
            exciter_names: sc.exciter.iter().map(|e| e.name.clone()).collect(),
            exciter_points,
            response_point,
            mode_index,
            sweep,
            d0,
            structure_timings: None,
            modal_masses,
        })
    }
}

/// `omega0` [rad/s] and `D0` (`phi^T C phi / (2 omega0)`, mass-normalised
/// `phi`) of mode `mode_index` of `model` (`[nma] mode` above 1). Errors name
/// `nma.mode` when the model has fewer modes.
fn followed_mode(model: &StructuralModel, mode_index: usize, mode: usize) -> Result<(f64, f64)> {
    let n = model.ndof();
    if mode_index >= n {
        anyhow::bail!(
            "nma.mode: mode {mode} does not exist: the model has {n} modes ({} elastic)",
            n + mode - 1 - mode_index
        );
    }
    let modes = modal_analysis(model, mode_index + 1).context("structure: modal analysis")?;
    let omega = modes.omega_rad_s[mode_index];
    let phi = modes.shape(mode_index);
    let d0 = (phi.transpose() * &model.damping * &phi)[(0, 0)] / (2.0 * omega);
    Ok((omega, d0))
}

/// The sweep of `sc`'s `[excitation]` on a structure of first natural
/// frequency `omega0` \[rad/s\] (the `sweep` of [`Setup::with_scenario`]).
pub fn sweep_of(sc: &Scenario, omega0: f64) -> Result<LinearSweep> {
    let e = &sc.excitation;
    LinearSweep::per_pseudo_period(
        omega0,
        e.eta_start,
        e.eta_end,
        e.rate_per_pseudo_period,
        e.voltage_v,
    )
    .context("excitation")
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
