//! A solid FE test model: a cantilever plate of 8-node hexahedral elements
//! (trilinear, full `2 x 2 x 2` Gauss integration, consistent mass, isotropic
//! linear elasticity), clamped on its face `x = 0`. It is the large-model test
//! problem of the sparse Craig-Bampton path ([`super::matrices::matrix_structure_sparse`]):
//! the tests compare the sparse path with the dense one on a small plate, the
//! scale benchmark (`nlmode/examples/hex_plate.rs`, `docs/performance.md`)
//! writes it as Matrix Market files of 10^5 to 10^6 DOFs.
//!
//! Element (edges `a x b x c` along `x, y, z`, natural coordinates
//! `xi, eta, zeta` in `[-1, 1]`): local node `l = 4 i + 2 j + k` at the corner
//! `(i a, j b, k c)`, `N_l = (1 + s_i xi)(1 + s_j eta)(1 + s_k zeta) / 8`,
//! `s = 2 i - 1`;
//!
//! ```text
//! K_e = sum_g B^T D B det J,   M_e = rho sum_g N^T N det J,   det J = a b c / 8,
//! ```
//!
//! with the strains `(e_xx, e_yy, e_zz, g_xy, g_yz, g_zx) = B u_e` and Lame's
//! `D` (`lambda = E nu / ((1 + nu)(1 - 2 nu))`, `mu = E / (2 (1 + nu))`). The
//! Gauss rule integrates `M_e` exactly and `K_e` of a box exactly for the
//! trilinear field.
//!
//! Plate DOFs: node `(ix, iy, iz)`, `ix = 1..=nx` (the nodes `ix = 0` are
//! clamped), numbered `((ix - 1) (ny + 1) + iy) (nz + 1) + iz`, three
//! translations `u_x, u_y, u_z` per node ([`HexPlate::dof`]).
use super::sparse::SparseMatrix;
use super::{Result, StructureError};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};

/// Element matrices of the 24 DOFs `(u_x, u_y, u_z)` of the local nodes `0..8`.
pub type ElementMatrix = [[f64; 24]; 24];

/// Material of the solid: Young's modulus [Pa], Poisson's ratio, density [kg/m^3].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elastic {
    pub youngs_modulus_pa: f64,
    pub poisson_ratio: f64,
    pub density_kg_m3: f64,
}

impl Elastic {
    /// Structural steel: `E = 2.1e11 Pa`, `nu = 0.3`, `rho = 7800 kg/m^3`.
    pub fn steel() -> Self {
        Self {
            youngs_modulus_pa: 2.1e11,
            poisson_ratio: 0.3,
            density_kg_m3: 7800.0,
        }
    }

    /// The isotropic `6 x 6` elasticity matrix (engineering shear strains).
    pub fn d_matrix(&self) -> [[f64; 6]; 6] {
        let (e, nu) = (self.youngs_modulus_pa, self.poisson_ratio);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        let mut d = [[0.0; 6]; 6];
        for (i, row) in d.iter_mut().enumerate().take(3) {
            for (j, v) in row.iter_mut().enumerate().take(3) {
                *v = lambda + if i == j { 2.0 * mu } else { 0.0 };
            }
        }
        for (i, row) in d.iter_mut().enumerate().skip(3) {
            row[i] = mu;
        }
        d
    }
}

/// Stiffness and mass matrices of a box element with the edges `a, b, c` [m]
/// (module docs).
pub fn hex8_matrices(edges_m: [f64; 3], mat: &Elastic) -> (ElementMatrix, ElementMatrix) {
    let [a, b, c] = edges_m;
    let d = mat.d_matrix();
    let det_j = a * b * c / 8.0;
    let g = 1.0 / 3f64.sqrt();
    let mut ke = [[0.0; 24]; 24];
    let mut me = [[0.0; 24]; 24];
    for gp in 0..8 {
        let xi = [(gp >> 2) & 1, (gp >> 1) & 1, gp & 1].map(|s| if s == 1 { g } else { -g });
        // shape functions and their x, y, z derivatives at the Gauss point
        let mut n = [0.0; 8];
        let mut dn = [[0.0; 3]; 8];
        for l in 0..8 {
            let s = [(l >> 2) & 1, (l >> 1) & 1, l & 1].map(|v| 2.0 * v as f64 - 1.0);
            let f = [0, 1, 2].map(|q| 1.0 + s[q] * xi[q]);
            n[l] = f[0] * f[1] * f[2] / 8.0;
            dn[l] = [
                s[0] * f[1] * f[2] / 8.0 * 2.0 / a,
                f[0] * s[1] * f[2] / 8.0 * 2.0 / b,
                f[0] * f[1] * s[2] / 8.0 * 2.0 / c,
            ];
        }
        let mut bm = [[0.0; 24]; 6];
        for l in 0..8 {
            let [nx, ny, nz] = dn[l];
            bm[0][3 * l] = nx;
            bm[1][3 * l + 1] = ny;
            bm[2][3 * l + 2] = nz;
            bm[3][3 * l] = ny;
            bm[3][3 * l + 1] = nx;
            bm[4][3 * l + 1] = nz;
            bm[4][3 * l + 2] = ny;
            bm[5][3 * l] = nz;
            bm[5][3 * l + 2] = nx;
        }
        // D B (6 x 24), then B^T (D B)
        let mut db = [[0.0; 24]; 6];
        for i in 0..6 {
            for j in 0..24 {
                db[i][j] = (0..6).map(|k| d[i][k] * bm[k][j]).sum();
            }
        }
        for i in 0..24 {
            for j in 0..24 {
                ke[i][j] += (0..6).map(|k| bm[k][i] * db[k][j]).sum::<f64>() * det_j;
            }
        }
        for l in 0..8 {
            for m in 0..8 {
                let v = mat.density_kg_m3 * n[l] * n[m] * det_j;
                for q in 0..3 {
                    me[3 * l + q][3 * m + q] += v;
                }
            }
        }
    }
    (ke, me)
}

/// A cantilever plate `length x width x thickness` [m] of `nx x ny x nz` box
/// elements, clamped at `x = 0` (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HexPlate {
    pub length_m: f64,
    pub width_m: f64,
    pub thickness_m: f64,
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
    pub material: Elastic,
}

/// Largest number of elements along one edge of [`HexPlate`] (bounds the sizes).
pub const MAX_ELEMENTS_PER_EDGE: usize = 100_000;

impl HexPlate {
    /// The benchmark plate of `docs/performance.md`: steel, `0.5 x 0.25 x 0.01`
    /// m, 3 elements through the thickness, `nx = 2 ny`, `ny` chosen so that the
    /// model has about `target_dofs` DOFs (`3 nx (ny + 1) (nz + 1)`).
    pub fn benchmark(target_dofs: usize) -> Self {
        let ny = ((target_dofs as f64 / 24.0).sqrt().round() as usize).max(1);
        Self {
            length_m: 0.5,
            width_m: 0.25,
            thickness_m: 0.01,
            nx: 2 * ny,
            ny,
            nz: 3,
            material: Elastic::steel(),
        }
    }

    /// Number of DOFs: `3 nx (ny + 1) (nz + 1)`.
    pub fn ndof(&self) -> usize {
        3 * self.nx * (self.ny + 1) * (self.nz + 1)
    }

    /// The DOF of the translation `dir` (0 = x, 1 = y, 2 = z) of node
    /// `(ix, iy, iz)`; `None` on the clamped face `ix = 0` or outside the plate.
    pub fn dof(&self, ix: usize, iy: usize, iz: usize, dir: usize) -> Option<usize> {
        (ix >= 1 && ix <= self.nx && iy <= self.ny && iz <= self.nz && dir < 3)
            .then(|| 3 * (((ix - 1) * (self.ny + 1) + iy) * (self.nz + 1) + iz) + dir)
    }

    fn check(&self) -> Result<()> {
        for (name, v) in [
            ("length_m", self.length_m),
            ("width_m", self.width_m),
            ("thickness_m", self.thickness_m),
            ("youngs_modulus_pa", self.material.youngs_modulus_pa),
            ("density_kg_m3", self.material.density_kg_m3),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(StructureError::NonPositive { name, value: v });
            }
        }
        let nu = self.material.poisson_ratio;
        if !(nu > -1.0 && nu < 0.5) {
            return Err(StructureError::InvalidParameter {
                name: "poisson_ratio",
                value: nu,
                expected: "-1 < nu < 0.5",
            });
        }
        for (name, v) in [("nx", self.nx), ("ny", self.ny), ("nz", self.nz)] {
            if v == 0 || v > MAX_ELEMENTS_PER_EDGE {
                return Err(StructureError::InvalidParameter {
                    name,
                    value: v as f64,
                    expected: "between 1 and 100000 elements",
                });
            }
        }
        Ok(())
    }

    /// The assembled mass [kg] and stiffness [N/m] matrices (both triangles
    /// stored, rows ascending in each column).
    pub fn assemble(&self) -> Result<(SparseMatrix, SparseMatrix)> {
        self.check()?;
        let edges = [
            self.length_m / self.nx as f64,
            self.width_m / self.ny as f64,
            self.thickness_m / self.nz as f64,
        ];
        let (ke, me) = hex8_matrices(edges, &self.material);
        let n = self.ndof();
        let (mut col_ptr, mut rows) = (Vec::with_capacity(n + 1), Vec::new());
        let (mut kv, mut mv) = (Vec::new(), Vec::new());
        col_ptr.push(0usize);
        let size = [self.nx, self.ny, self.nz];
        for ix in 1..=self.nx {
            for iy in 0..=self.ny {
                for iz in 0..=self.nz {
                    let a = [ix, iy, iz];
                    let nbrs = self.neighbours(a);
                    for d in 0..3 {
                        for &b in &nbrs {
                            for e in 0..3 {
                                let (mut k, mut m) = (0.0, 0.0);
                                for_shared_elements(a, b, size, |la, lb| {
                                    k += ke[3 * lb + e][3 * la + d];
                                    m += me[3 * lb + e][3 * la + d];
                                });
                                let row = self.dof(b[0], b[1], b[2], e).expect("a free node");
                                rows.push(row);
                                kv.push(k);
                                mv.push(m);
                            }
                        }
                        col_ptr.push(rows.len());
                    }
                }
            }
        }
        let sym = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
        Ok((
            SparseColMat::new(sym.clone(), mv),
            SparseColMat::new(sym, kv),
        ))
    }

    /// The free nodes sharing an element with node `a` (itself included), in
    /// ascending DOF order.
    fn neighbours(&self, a: [usize; 3]) -> Vec<[usize; 3]> {
        let mut out = Vec::with_capacity(27);
        let size = [self.nx, self.ny, self.nz];
        for dx in -1i64..=1 {
            for dy in -1i64..=1 {
                for dz in -1i64..=1 {
                    let b = [dx, dy, dz]
                        .iter()
                        .zip(a)
                        .map(|(o, v)| v as i64 + o)
                        .collect::<Vec<_>>();
                    if b[0] >= 1 && (0..3).all(|q| b[q] >= 0 && b[q] <= size[q] as i64) {
                        out.push([b[0] as usize, b[1] as usize, b[2] as usize]);
                    }
                }
            }
        }
        out
    }
}

/// Calls `f(local a, local b)` for every element (of the `size` grid) that
/// contains both nodes `a` and `b`.
fn for_shared_elements(
    a: [usize; 3],
    b: [usize; 3],
    size: [usize; 3],
    mut f: impl FnMut(usize, usize),
) {
    // element lower corners e with e <= min(a, b) and max(a, b) <= e + 1
    let lo = |q: usize| a[q].max(b[q]).saturating_sub(1);
    let hi = |q: usize| a[q].min(b[q]).min(size[q] - 1);
    for ex in lo(0)..=hi(0) {
        for ey in lo(1)..=hi(1) {
            for ez in lo(2)..=hi(2) {
                let local = |p: [usize; 3]| 4 * (p[0] - ex) + 2 * (p[1] - ey) + (p[2] - ez);
                f(local(a), local(b));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::sparse::{asymmetry, sparse_modal};

    const EDGES: [f64; 3] = [0.03, 0.02, 0.01];

    /// `u^T A u` of an element matrix and a nodal field `u(x, y, z)`.
    fn energy(a: &ElementMatrix, u: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
        let mut v = [0.0; 24];
        for l in 0..8 {
            let x = [(l >> 2) & 1, (l >> 1) & 1, l & 1];
            let p = [0, 1, 2].map(|q| x[q] as f64 * EDGES[q]);
            v[3 * l..3 * l + 3].copy_from_slice(&u(p));
        }
        (0..24)
            .map(|i| (0..24).map(|j| v[i] * a[i][j] * v[j]).sum::<f64>())
            .sum()
    }

    /// Exact element properties: rigid-body motions free of strain energy,
    /// uniform strains with the energy `eps^T D eps V`, the mass of a
    /// translation `rho V` and of a linear field `rho int x^2 dV`.
    #[test]
    fn element_matrices_are_exact_for_rigid_and_linear_fields() {
        let mat = Elastic::steel();
        let (ke, me) = hex8_matrices(EDGES, &mat);
        let vol = EDGES.iter().product::<f64>();
        let d = mat.d_matrix();
        let kmax = ke.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        for (i, row) in ke.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - ke[j][i]).abs() <= 1e-12 * kmax, "K_e symmetric");
            }
        }
        // rigid translations and rotations: K_e u = 0 (energy at rounding level)
        let scale = kmax * 1e-2f64.powi(2);
        for u in [
            (|_| [1.0, 0.0, 0.0]) as fn([f64; 3]) -> [f64; 3],
            |_| [0.0, 0.0, 1.0],
            |p| [-p[1], p[0], 0.0],
            |p| [0.0, -p[2], p[1]],
            |p| [p[2], 0.0, -p[0]],
        ] {
            assert!(energy(&ke, u).abs() < 1e-9 * scale);
        }
        // uniaxial strain e_xx = 1e-3: (lambda + 2 mu) e^2 V; shear g_xy: mu g^2 V
        let e = 1e-3;
        let want = d[0][0] * e * e * vol;
        let got = energy(&ke, |p| [e * p[0], 0.0, 0.0]);
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        let want = d[3][3] * e * e * vol;
        let got = energy(&ke, |p| [e * p[1], 0.0, 0.0]);
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        // volumetric strain: sum of D's 3x3 block e^2 V
        let want = (0..3).flat_map(|i| (0..3).map(move |j| (i, j)));
        let want: f64 = want.map(|(i, j)| d[i][j]).sum::<f64>() * e * e * vol;
        let got = energy(&ke, |p| [e * p[0], e * p[1], e * p[2]]);
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        let rho = mat.density_kg_m3;
        let got = energy(&me, |_| [0.0, 1.0, 0.0]);
        assert!((got - rho * vol).abs() < 1e-14 * rho * vol);
        let want = rho * EDGES[1] * EDGES[2] * EDGES[0].powi(3) / 3.0;
        let got = energy(&me, |p| [p[0], 0.0, 0.0]);
        assert!((got - want).abs() < 1e-13 * want, "{got} vs {want}");
    }

    /// The assembled plate: symmetric, numbered as [`HexPlate::dof`], and a
    /// slender one's first bending frequency near Euler-Bernoulli's
    /// `1.875^2 sqrt(E I / (rho A L^4))` (the trilinear element in bending is
    /// stiffer by shear locking: +20 % at this mesh, within +25 %).
    #[test]
    fn slender_plate_bends_like_a_cantilever_beam() {
        let p = HexPlate {
            length_m: 0.4,
            width_m: 0.01,
            thickness_m: 0.01,
            nx: 40,
            ny: 1,
            nz: 2,
            material: Elastic::steel(),
        };
        let (m, k) = p.assemble().unwrap();
        assert_eq!(m.nrows(), p.ndof());
        assert_eq!(p.ndof(), 3 * 40 * 2 * 3);
        assert_eq!(p.dof(1, 0, 0, 0), Some(0));
        assert_eq!(p.dof(40, 1, 2, 2), Some(p.ndof() - 1));
        assert_eq!(p.dof(0, 0, 0, 0), None);
        for a in [&k, &m] {
            let (asym, scale) = asymmetry(a);
            assert!(asym <= 1e-14 * scale, "{asym:e}");
        }
        let (w, _) = sparse_modal(&m, &k, 2, "n").unwrap();
        let mat = p.material;
        let (a, i) = (
            p.width_m * p.thickness_m,
            p.width_m * p.thickness_m.powi(3) / 12.0,
        );
        let beam = 1.875104f64.powi(2)
            * (mat.youngs_modulus_pa * i / (mat.density_kg_m3 * a * p.length_m.powi(4))).sqrt();
        // square section: the two bending modes coincide up to the mesh's asymmetry
        let r = w[0] / beam;
        assert!(r > 1.0 && r < 1.25, "omega1 = {} vs beam {beam}: {r}", w[0]);
        assert!(p.assemble().is_ok());
        let bad = HexPlate { nx: 0, ..p };
        assert!(matches!(
            bad.assemble(),
            Err(StructureError::InvalidParameter { name: "nx", .. })
        ));
    }
}
