//! The published example models of NLvib (M. Krack, J. Gross, "Harmonic
//! Balance for Nonlinear Vibration Problems", Springer 2019; the `EXAMPLES`
//! folder of github.com/maltekrack/NLvib), built with this crate's elements:
//! the cases on which issue 22 found the nonlinear modal analysis failing, and
//! a single-DOF Jenkins oscillator with a closed-form describing function.
use crate::structure::beam::{BeamSpec, BoundaryCondition};
use crate::structure::{
    CubicSpring, ElasticDryFriction, RegularizedFriction, StructuralModel, StructureError,
    UnilateralSpring,
};
use nalgebra::{DMatrix, DVector};

/// Mass and stiffness of NLvib's `ChainOfOscillators(mi, di, ki)`: masses `mi`
/// in a chain, spring `ki[0]` from ground to mass 0, `ki[i]` between masses
/// `i-1` and `i`, `ki[n]` from the last mass to ground (the same for the
/// dashpots `di`), named points `q1`, `q2`, ... at every mass.
pub fn chain_of_oscillators(mi: &[f64], di: &[f64], ki: &[f64]) -> StructuralModel {
    let n = mi.len();
    assert!(
        ki.len() == n + 1 && di.len() == n + 1,
        "n + 1 springs, dashpots"
    );
    let band = |c: &[f64]| {
        let mut a = DMatrix::zeros(n, n);
        for i in 0..n {
            a[(i, i)] = c[i] + c[i + 1];
            if i + 1 < n {
                a[(i, i + 1)] = -c[i + 1];
                a[(i + 1, i)] = -c[i + 1];
            }
        }
        a
    };
    let mut model = StructuralModel::new(
        DMatrix::from_diagonal(&DVector::from_row_slice(mi)),
        band(ki),
    );
    model.damping = band(di);
    for i in 0..n {
        let e = unit(n, i);
        model
            .add_named_point(&format!("q{}", i + 1), e)
            .expect("distinct names");
    }
    model
}

fn unit(n: usize, i: usize) -> DVector<f64> {
    DVector::from_fn(n, |j, _| if i == j { 1.0 } else { 0.0 })
}

/// NLvib example 05 (`twoDOFoscillator_tanhDryFriction_NM`): masses 0.02 and
/// 1 kg, springs `[0, 40, 600]` N/m, no damping, a grounded `tanh` friction
/// element `f = mu N tanh(q1' / eps)` at mass 1 with `mu N = 5` N and `eps =
/// 0.05` m/s. NLvib continues mode 1 with `H = 21`, `2^10` AFT samples, from
/// `log10 a = -1.5` to `1`.
pub fn nlvib_tanh_friction_2dof() -> StructuralModel {
    let mut model = chain_of_oscillators(&[0.02, 1.0], &[0.0; 3], &[0.0, 40.0, 600.0]);
    let law = RegularizedFriction::new(5.0, 0.05).expect("valid parameters");
    model
        .add_nonlinear("tanh-friction", unit(2, 0), law)
        .expect("valid element");
    model
}

/// NLvib example 07 (`multiDOFoscillator_multipleNonlinearities`): three unit
/// masses, unit springs `[1, 1, 1, 1]`, dashpots `0.02 ki`, elastic dry
/// friction (`k_t = 20`, `mu N = 1`) grounded at mass 1 and between masses 1
/// and 2, unit cubic springs grounded at mass 2 and between masses 2 and 3, a
/// unilateral spring (unit stiffness, gap 0.25) grounded at mass 3.
pub fn nlvib_friction_contact_chain() -> Result<StructuralModel, StructureError> {
    let mut model = chain_of_oscillators(&[1.0; 3], &[0.02; 4], &[1.0; 4]);
    let v = |x: [f64; 3]| DVector::from_row_slice(&x);
    model.add_nonlinear(
        "friction-1",
        v([1.0, 0.0, 0.0]),
        ElasticDryFriction::new(20.0, 1.0)?,
    )?;
    model.add_nonlinear(
        "friction-2",
        v([-1.0, 1.0, 0.0]),
        ElasticDryFriction::new(20.0, 1.0)?,
    )?;
    model.add_nonlinear("cubic-1", v([0.0, 1.0, 0.0]), CubicSpring::new(1.0)?)?;
    model.add_nonlinear("cubic-2", v([0.0, -1.0, 1.0]), CubicSpring::new(1.0)?)?;
    model.add_nonlinear(
        "contact",
        v([0.0, 0.0, 1.0]),
        UnilateralSpring::new(1.0, 0.25)?,
    )?;
    Ok(model)
}

/// NLvib example 09 (`beam_cubicSpring_NM1`): a clamped-free steel beam
/// (l = 0.7 m, 14 x 14 mm, E = 2.05e11 Pa, rho = 7800 kg/m^3, 20 nodes: 38
/// DOFs) with a cubic spring `k3 = 6e9 N/m^3` at the tip translation (point
/// `tip`); NLvib continues mode 1 with `H = 5` from `log10 a = -5` to `-3`
/// (conservative). `damping_ratio > 0` adds stiffness-proportional damping
/// with that ratio on mode 1.
pub fn nlvib_cantilever_cubic(damping_ratio: f64) -> Result<StructuralModel, StructureError> {
    let spec = BeamSpec {
        length_m: 0.7,
        height_m: 0.014,
        width_m: 0.014,
        youngs_modulus_pa: 2.05e11,
        density_kg_m3: 7800.0,
        n_nodes: 20,
        boundary: BoundaryCondition::ClampedFree,
    };
    let mut beam = spec.assemble()?;
    beam.add_point("tip", 0.7)?;
    let tip = beam.model.point("tip")?.direction.clone();
    beam.model
        .add_nonlinear("cubic", tip, CubicSpring::new(6e9)?)?;
    if damping_ratio > 0.0 {
        crate::structure::damping::stiffness_proportional_damping(
            &mut beam.model,
            0,
            damping_ratio,
        )?;
    }
    Ok(beam.model)
}

/// A single-DOF Jenkins oscillator: mass `m`, linear spring `k`, dashpot `c`
/// and a grounded elastic dry friction element (`k_t`, slip force `F_s`);
/// point `x`.
pub fn jenkins_oscillator(
    m: f64,
    c: f64,
    k: f64,
    kt: f64,
    fs: f64,
) -> Result<StructuralModel, StructureError> {
    let mut model = chain_of_oscillators(&[m], &[c, 0.0], &[k, 0.0]);
    model.points[0].name = "x".into();
    model.add_nonlinear("jenkins", unit(1, 0), ElasticDryFriction::new(kt, fs)?)?;
    Ok(model)
}

/// The describing function (first harmonic) of a Jenkins element (`k_t`,
/// `F_s`) under `u = x cos(theta)`: `f_1 = c cos + s sin` with
/// `(c, s)` returned [N]. Closed form (Krack & Gross 2019, Sec. 2.3): stick
/// (`x <= F_s/k_t`) `c = k_t x`, `s = 0`; else with
/// `cos(theta*) = 1 - 2 F_s / (k_t x)`:
/// `c = k_t x / pi (theta* - sin(2 theta*) / 2)`,
/// `s = -4 F_s / pi (1 - F_s / (k_t x))` (dissipation `4 F_s (x - F_s/k_t)`
/// per cycle, `pi x |s|`).
pub fn jenkins_describing_function(kt: f64, fs: f64, x: f64) -> (f64, f64) {
    let xs = fs / kt;
    if x <= xs {
        return (kt * x, 0.0);
    }
    let th = (1.0 - 2.0 * xs / x).acos();
    let c = kt * x / std::f64::consts::PI * (th - 0.5 * (2.0 * th).sin());
    let s = -4.0 * fs / std::f64::consts::PI * (1.0 - xs / x);
    (c, s)
}
