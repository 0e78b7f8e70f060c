//! Euler-Bernoulli beam finite elements: cubic Hermite shape functions, consistent
//! mass, two DOFs per node (transverse displacement `w` [m], rotation `w'` [rad]).
//!
//! Node `i` sits at `x_i = i l / (n - 1)`, `i = 0..n`. Element matrices (element
//! length `le`, DOFs `[w_1, w'_1, w_2, w'_2]`):
//!
//! ```text
//! K_e = EI/le^3 [ 12   6le   -12   6le ;  6le 4le^2 -6le 2le^2 ; -12 -6le 12 -6le ;  6le 2le^2 -6le 4le^2 ]
//! M_e = rhoA le/420 [ 156 22le 54 -13le ; 22le 4le^2 13le -3le^2 ; 54 13le 156 -22le ; -13le -3le^2 -22le 4le^2 ]
//! ```
//!
//! with `I = w h^3 / 12` (`h` in the bending direction) and `A = w h`. Boundary
//! conditions remove the constrained DOFs (clamped: `w = w' = 0`; pinned: `w = 0`);
//! the remaining DOFs keep the node order, translation before rotation.
use super::{NamedPoint, Result, StructuralModel, StructureError};
use crate::benchmark;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Boundary conditions at the two ends `x = 0` and `x = l`. Serialised, parsed
/// ([`std::str::FromStr`]) and displayed in kebab-case: `clamped-free`,
/// `clamped-clamped`, `pinned-pinned`, `clamped-pinned`, `free-free`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoundaryCondition {
    /// Clamped at `x = 0`, free at `x = l` (the paper's cantilever).
    #[default]
    ClampedFree,
    /// Clamped at both ends.
    ClampedClamped,
    /// Pinned (simply supported) at both ends.
    PinnedPinned,
    /// Clamped at `x = 0`, pinned at `x = l`.
    ClampedPinned,
    /// Free at both ends (two rigid-body modes).
    FreeFree,
}

impl BoundaryCondition {
    /// All boundary conditions.
    pub const ALL: [BoundaryCondition; 5] = [
        BoundaryCondition::ClampedFree,
        BoundaryCondition::ClampedClamped,
        BoundaryCondition::PinnedPinned,
        BoundaryCondition::ClampedPinned,
        BoundaryCondition::FreeFree,
    ];

    /// The kebab-case name (`clamped-free`, ...).
    pub fn as_str(self) -> &'static str {
        use BoundaryCondition::*;
        match self {
            ClampedFree => "clamped-free",
            ClampedClamped => "clamped-clamped",
            PinnedPinned => "pinned-pinned",
            ClampedPinned => "clamped-pinned",
            FreeFree => "free-free",
        }
    }

    /// `(w, w')` constrained at `x = 0` and at `x = l`.
    fn constraints(self) -> ([bool; 2], [bool; 2]) {
        use BoundaryCondition::*;
        const CLAMPED: [bool; 2] = [true, true];
        const PINNED: [bool; 2] = [true, false];
        const FREE: [bool; 2] = [false, false];
        match self {
            ClampedFree => (CLAMPED, FREE),
            ClampedClamped => (CLAMPED, CLAMPED),
            PinnedPinned => (PINNED, PINNED),
            ClampedPinned => (CLAMPED, PINNED),
            FreeFree => (FREE, FREE),
        }
    }
}

impl std::fmt::Display for BoundaryCondition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for BoundaryCondition {
    type Err = StructureError;
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|b| b.as_str() == s)
            .ok_or_else(|| StructureError::UnknownBoundaryCondition {
                name: s.to_string(),
                expected: Self::ALL
                    .iter()
                    .map(|b| b.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }
}

/// Geometry, material and discretisation of a uniform rectangular beam
/// (serialisable; unknown keys are rejected, `boundary` defaults to clamped-free).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamSpec {
    /// Length `l` [m].
    pub length_m: f64,
    /// Height in the bending direction `h` [m].
    pub height_m: f64,
    /// Width `w` [m].
    pub width_m: f64,
    /// Young's modulus `E` [Pa].
    pub youngs_modulus_pa: f64,
    /// Density `rho` [kg/m^3].
    pub density_kg_m3: f64,
    /// Number of nodes including both ends (at least 2).
    pub n_nodes: usize,
    /// Boundary conditions.
    #[serde(default)]
    pub boundary: BoundaryCondition,
}

impl BeamSpec {
    /// The paper's beam (Section 5, [`crate::benchmark`]): clamped-free, 100 nodes,
    /// l = 0.53 m, h = 0.019 m, w = 0.014 m, E = 2.1e11 Pa, rho = 7800 kg/m^3.
    /// Its fundamental frequency is 356.2 rad/s (the paper prints 346 rad/s, which
    /// these printed parameters do not give).
    pub fn paper() -> Self {
        Self {
            length_m: benchmark::LENGTH_M,
            height_m: benchmark::HEIGHT_M,
            width_m: benchmark::WIDTH_M,
            youngs_modulus_pa: benchmark::YOUNGS_MODULUS_PA,
            density_kg_m3: benchmark::DENSITY_KG_M3,
            n_nodes: benchmark::N_NODES,
            boundary: BoundaryCondition::ClampedFree,
        }
    }

    /// Rejects non-positive or non-finite dimensions and material data and fewer than 2 nodes.
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("length_m", self.length_m),
            ("height_m", self.height_m),
            ("width_m", self.width_m),
            ("youngs_modulus_pa", self.youngs_modulus_pa),
            ("density_kg_m3", self.density_kg_m3),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(StructureError::NonPositive { name, value });
            }
        }
        if self.n_nodes < 2 {
            return Err(StructureError::TooFewNodes {
                n_nodes: self.n_nodes,
                min: 2,
            });
        }
        Ok(())
    }

    /// Cross-section area `A = w h` [m^2].
    pub fn area_m2(&self) -> f64 {
        self.width_m * self.height_m
    }

    /// Second moment of area about the bending axis `I = w h^3 / 12` [m^4].
    pub fn second_moment_m4(&self) -> f64 {
        self.width_m * self.height_m.powi(3) / 12.0
    }

    /// Bending stiffness `EI` [N m^2].
    pub fn bending_stiffness_n_m2(&self) -> f64 {
        self.youngs_modulus_pa * self.second_moment_m4()
    }

    /// Mass per length `rho A` [kg/m].
    pub fn mass_per_length_kg_m(&self) -> f64 {
        self.density_kg_m3 * self.area_m2()
    }

    /// Total mass `rho A l` [kg].
    pub fn mass_kg(&self) -> f64 {
        self.mass_per_length_kg_m() * self.length_m
    }

    /// Element length `l / (n - 1)` [m].
    pub fn element_length_m(&self) -> f64 {
        self.length_m / (self.n_nodes - 1) as f64
    }

    /// Position of node `i`, `x_i = i l / (n - 1)` [m].
    pub fn node_x_m(&self, node: usize) -> f64 {
        node as f64 * self.element_length_m()
    }

    /// Analytic Euler-Bernoulli natural frequency for the eigenvalue `beta l`:
    /// `omega = (beta l)^2 sqrt(EI / (rho A l^4))` [rad/s].
    pub fn analytic_omega_rad_s(&self, beta_l: f64) -> f64 {
        beta_l
            * beta_l
            * (self.bending_stiffness_n_m2()
                / (self.mass_per_length_kg_m() * self.length_m.powi(4)))
            .sqrt()
    }

    /// Assembles mass and stiffness (no damping, no points, no nonlinear elements).
    pub fn assemble(&self) -> Result<Beam> {
        self.validate()?;
        let n = self.n_nodes;
        let le = self.element_length_m();
        let ei = self.bending_stiffness_n_m2();
        let rho_a = self.mass_per_length_kg_m();
        let ke = DMatrix::from_row_slice(
            4,
            4,
            &[
                12.0,
                6.0 * le,
                -12.0,
                6.0 * le, //
                6.0 * le,
                4.0 * le * le,
                -6.0 * le,
                2.0 * le * le, //
                -12.0,
                -6.0 * le,
                12.0,
                -6.0 * le, //
                6.0 * le,
                2.0 * le * le,
                -6.0 * le,
                4.0 * le * le,
            ],
        ) * (ei / le.powi(3));
        let me = DMatrix::from_row_slice(
            4,
            4,
            &[
                156.0,
                22.0 * le,
                54.0,
                -13.0 * le, //
                22.0 * le,
                4.0 * le * le,
                13.0 * le,
                -3.0 * le * le, //
                54.0,
                13.0 * le,
                156.0,
                -22.0 * le, //
                -13.0 * le,
                -3.0 * le * le,
                -22.0 * le,
                4.0 * le * le,
            ],
        ) * (rho_a * le / 420.0);

        // DOF numbering after removing the constrained ones.
        let (left, right) = self.boundary.constraints();
        let mut dof_map = vec![[None, None]; n];
        let mut ndof = 0;
        for (node, dofs) in dof_map.iter_mut().enumerate() {
            for (k, dof) in dofs.iter_mut().enumerate() {
                let fixed = (node == 0 && left[k]) || (node == n - 1 && right[k]);
                if !fixed {
                    *dof = Some(ndof);
                    ndof += 1;
                }
            }
        }
        let mut mass = DMatrix::zeros(ndof, ndof);
        let mut stiffness = DMatrix::zeros(ndof, ndof);
        for e in 0..n - 1 {
            let idx = [
                dof_map[e][0],
                dof_map[e][1],
                dof_map[e + 1][0],
                dof_map[e + 1][1],
            ];
            for (a, ia) in idx.iter().enumerate() {
                let Some(ia) = *ia else { continue };
                for (b, ib) in idx.iter().enumerate() {
                    let Some(ib) = *ib else { continue };
                    mass[(ia, ib)] += me[(a, b)];
                    stiffness[(ia, ib)] += ke[(a, b)];
                }
            }
        }
        Ok(Beam {
            spec: self.clone(),
            model: StructuralModel::new(mass, stiffness),
            dof_map,
        })
    }
}

/// An assembled beam: its specification, its structural model and the map from
/// nodes to generalized coordinates.
#[derive(Debug, Clone)]
pub struct Beam {
    pub spec: BeamSpec,
    pub model: StructuralModel,
    /// `dof_map[node] = [translation DOF, rotation DOF]`, `None` where constrained.
    dof_map: Vec<[Option<usize>; 2]>,
}

impl Beam {
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.spec.n_nodes
    }

    /// Position of node `node` [m].
    pub fn node_x_m(&self, node: usize) -> f64 {
        self.spec.node_x_m(node)
    }

    /// Generalized coordinate of the transverse displacement of `node`; `None` if the
    /// node does not exist or its translation is constrained.
    pub fn translation_dof(&self, node: usize) -> Option<usize> {
        self.dof_map.get(node).and_then(|d| d[0])
    }

    /// Generalized coordinate of the rotation of `node`; `None` if the node does not
    /// exist or its rotation is constrained.
    pub fn rotation_dof(&self, node: usize) -> Option<usize> {
        self.dof_map.get(node).and_then(|d| d[1])
    }

    /// The node at `x_m` [m]. A location between nodes is rejected (no snapping)
    /// with an error naming the two nearest nodes; tolerance `1e-9 l`.
    pub fn node_at(&self, x_m: f64) -> Result<usize> {
        let l = self.spec.length_m;
        let tol = 1e-9 * l;
        if !x_m.is_finite() || x_m < -tol || x_m > l + tol {
            return Err(StructureError::LocationOutsideBeam { x_m, length_m: l });
        }
        let le = self.spec.element_length_m();
        let s = (x_m / le).clamp(0.0, (self.n_nodes() - 1) as f64);
        let nearest = s.round() as usize;
        if (x_m - self.node_x_m(nearest)).abs() <= tol {
            return Ok(nearest);
        }
        let left = (s.floor() as usize).min(self.n_nodes() - 2);
        Err(StructureError::LocationBetweenNodes {
            x_m,
            left_node: left,
            left_x_m: self.node_x_m(left),
            right_node: left + 1,
            right_x_m: self.node_x_m(left + 1),
        })
    }

    /// Unit vector on the translation DOF of the node at `x_m` (see [`Beam::node_at`]).
    pub fn translation_vector(&self, name: &str, x_m: f64) -> Result<DVector<f64>> {
        let node = self.node_at(x_m)?;
        let dof = self
            .translation_dof(node)
            .ok_or_else(|| StructureError::ConstrainedDof {
                name: name.to_string(),
                node,
                x_m: self.node_x_m(node),
            })?;
        let mut e = DVector::zeros(self.model.ndof());
        e[dof] = 1.0;
        Ok(e)
    }

    /// Adds the named point `name` observing / loading the transverse displacement of
    /// the node at `x_m` (a [`NamedPoint`] with a unit vector on its translation DOF).
    pub fn add_point(&mut self, name: &str, x_m: f64) -> Result<&NamedPoint> {
        let e = self.translation_vector(name, x_m)?;
        self.model.add_named_point(name, e)?;
        Ok(self.model.points.last().expect("just added"))
    }

    /// Transverse displacement of every node for the generalized coordinates `q`
    /// (zero at constrained translations), e.g. to plot a mode shape.
    pub fn translation_profile(&self, q: &DVector<f64>) -> Vec<f64> {
        assert_eq!(q.len(), self.model.ndof(), "q has the wrong length");
        self.dof_map
            .iter()
            .map(|d| d[0].map_or(0.0, |i| q[i]))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(n_nodes: usize, boundary: BoundaryCondition) -> BeamSpec {
        BeamSpec {
            n_nodes,
            boundary,
            ..BeamSpec::paper()
        }
    }

    #[test]
    fn dof_counts_per_boundary_condition() {
        use BoundaryCondition::*;
        for (bc, removed) in [
            (ClampedFree, 2),
            (ClampedClamped, 4),
            (PinnedPinned, 2),
            (ClampedPinned, 3),
            (FreeFree, 0),
        ] {
            let b = spec(5, bc).assemble().unwrap();
            assert_eq!(b.model.ndof(), 10 - removed, "{bc:?}");
            b.model.validate().unwrap();
        }
        let b = spec(5, ClampedFree).assemble().unwrap();
        assert_eq!(b.translation_dof(0), None);
        assert_eq!(b.rotation_dof(0), None);
        assert_eq!(b.translation_dof(4), Some(6));
        assert_eq!(b.rotation_dof(4), Some(7));
        assert_eq!(b.translation_dof(5), None);
    }

    #[test]
    fn single_free_free_element_matches_textbook_matrices() {
        let s = spec(2, BoundaryCondition::FreeFree);
        let b = s.assemble().unwrap();
        let l = s.length_m;
        let ei = s.bending_stiffness_n_m2();
        let m = s.mass_kg();
        assert!((b.model.stiffness[(0, 0)] - 12.0 * ei / l.powi(3)).abs() < 1e-9 * ei / l.powi(3));
        assert!((b.model.stiffness[(1, 3)] - 2.0 * ei / l).abs() < 1e-9 * ei / l);
        assert!((b.model.mass[(0, 2)] - 54.0 * m / 420.0).abs() < 1e-12);
        assert!((b.model.mass[(1, 2)] - 13.0 * m * l / 420.0).abs() < 1e-12);
        // rigid translation and rotation produce no elastic force
        let trans = DVector::from_vec(vec![1.0, 0.0, 1.0, 0.0]);
        let rot = DVector::from_vec(vec![0.0, 1.0, l, 1.0]);
        assert!((&b.model.stiffness * trans).amax() < 1e-6);
        assert!((&b.model.stiffness * rot).amax() < 1e-6);
    }

    #[test]
    fn total_mass_and_first_moment_of_free_free_beam() {
        let s = spec(17, BoundaryCondition::FreeFree);
        let b = s.assemble().unwrap();
        // rigid translation: r^T M r = rho A l
        let r = DVector::from_fn(b.model.ndof(), |i, _| if i % 2 == 0 { 1.0 } else { 0.0 });
        let m = r.dot(&(&b.model.mass * &r));
        assert!(
            (m - s.mass_kg()).abs() < 1e-12 * s.mass_kg(),
            "{m} vs {}",
            s.mass_kg()
        );
        // rigid rotation about x = 0: w = x, w' = 1 -> r^T M theta = rho A l^2 / 2
        let th = DVector::from_fn(b.model.ndof(), |i, _| {
            if i % 2 == 0 {
                s.node_x_m(i / 2)
            } else {
                1.0
            }
        });
        let s1 = r.dot(&(&b.model.mass * &th));
        assert!((s1 - s.mass_kg() * s.length_m / 2.0).abs() < 1e-12 * s.mass_kg());
    }

    #[test]
    fn node_lookup_exact_between_and_outside() {
        let b = BeamSpec::paper().assemble().unwrap();
        let l = b.spec.length_m;
        assert_eq!(b.node_at(l).unwrap(), 99);
        assert_eq!(b.node_at(l / 3.0).unwrap(), 33);
        assert_eq!(b.node_at(2.0 * l / 3.0).unwrap(), 66);
        assert_eq!(b.node_at(0.0).unwrap(), 0);
        match b.node_at(0.1) {
            Err(StructureError::LocationBetweenNodes {
                left_node,
                right_node,
                left_x_m,
                right_x_m,
                x_m,
            }) => {
                assert_eq!((left_node, right_node), (18, 19));
                assert!(left_x_m < x_m && x_m < right_x_m);
            }
            other => panic!("{other:?}"),
        }
        let msg = b.node_at(0.1).unwrap_err().to_string();
        assert!(
            msg.contains("0.1 m") && msg.contains("node 18") && msg.contains("node 19"),
            "{msg}"
        );
        assert!(matches!(
            b.node_at(0.6),
            Err(StructureError::LocationOutsideBeam { .. })
        ));
        assert!(matches!(
            b.node_at(-1e-3),
            Err(StructureError::LocationOutsideBeam { .. })
        ));
        assert!(matches!(
            b.node_at(f64::NAN),
            Err(StructureError::LocationOutsideBeam { .. })
        ));
    }

    #[test]
    fn points_on_translation_dofs() {
        let mut b = BeamSpec::paper().assemble().unwrap();
        let l = b.spec.length_m;
        b.add_point("tip", l).unwrap();
        let tip = b.model.point("tip").unwrap();
        let dof = b.translation_dof(99).unwrap();
        assert_eq!(tip.direction[dof], 1.0);
        assert_eq!(tip.direction.sum(), 1.0);
        assert!(matches!(
            b.add_point("clamp", 0.0),
            Err(StructureError::ConstrainedDof { node: 0, .. })
        ));
        assert!(matches!(
            b.add_point("tip", l),
            Err(StructureError::DuplicateName { .. })
        ));
    }

    #[test]
    fn spec_serialises_and_rejects_unknown_keys() {
        let s = BeamSpec {
            boundary: BoundaryCondition::PinnedPinned,
            ..BeamSpec::paper()
        };
        let json = serde_json::to_string(&s).unwrap();
        assert!(json.contains("\"pinned-pinned\""), "{json}");
        assert_eq!(serde_json::from_str::<BeamSpec>(&json).unwrap(), s);
        let no_bc = r#"{"length_m":1,"height_m":0.01,"width_m":0.01,"youngs_modulus_pa":2e11,"density_kg_m3":7800,"n_nodes":5}"#;
        assert_eq!(
            serde_json::from_str::<BeamSpec>(no_bc).unwrap().boundary,
            BoundaryCondition::ClampedFree
        );
        let typo = no_bc.replace("n_nodes", "nodes");
        let err = serde_json::from_str::<BeamSpec>(&typo)
            .unwrap_err()
            .to_string();
        assert!(err.contains("nodes"), "{err}");
    }

    #[test]
    fn boundary_condition_names_round_trip() {
        for b in BoundaryCondition::ALL {
            assert_eq!(b.to_string().parse::<BoundaryCondition>().unwrap(), b);
        }
        let err = "clamped_free"
            .parse::<BoundaryCondition>()
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("clamped_free") && err.contains("clamped-free, clamped-clamped"),
            "{err}"
        );
    }

    #[test]
    fn bad_specs_are_rejected_naming_the_input() {
        let cases: Vec<(BeamSpec, &str)> = vec![
            (
                BeamSpec {
                    length_m: 0.0,
                    ..BeamSpec::paper()
                },
                "length_m",
            ),
            (
                BeamSpec {
                    height_m: -0.01,
                    ..BeamSpec::paper()
                },
                "height_m",
            ),
            (
                BeamSpec {
                    width_m: f64::NAN,
                    ..BeamSpec::paper()
                },
                "width_m",
            ),
            (
                BeamSpec {
                    youngs_modulus_pa: 0.0,
                    ..BeamSpec::paper()
                },
                "youngs_modulus_pa",
            ),
            (
                BeamSpec {
                    density_kg_m3: -7800.0,
                    ..BeamSpec::paper()
                },
                "density_kg_m3",
            ),
        ];
        for (s, name) in cases {
            match s.assemble() {
                Err(StructureError::NonPositive { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        assert!(matches!(
            BeamSpec {
                n_nodes: 1,
                ..BeamSpec::paper()
            }
            .assemble(),
            Err(StructureError::TooFewNodes { n_nodes: 1, min: 2 })
        ));
    }
}
