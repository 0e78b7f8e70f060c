//! The design of a study: which parameter values each sample gets.
//!
//! - `grid`: every parameter lists its `values`; the samples are the full
//!   factorial, the last parameter varying fastest.
//! - `random`: each parameter has a distribution; sample `i` draws its
//!   parameters in order from one ChaCha8 stream seeded by `seed` (the same
//!   study gives the same samples on every machine and thread count).
//! - `lhs`: Latin hypercube: for each parameter the `samples` equiprobable
//!   strata are permuted at random (same stream), sample `i` takes a uniform
//!   point of its stratum and maps it through the distribution's inverse CDF.
//!
//! Distributions: `uniform` (`low`, `high`), `normal` (`mean`, `std`),
//! `lognormal` (`mean`, `std` of `ln x`), `truncated-normal` (`mean`, `std`,
//! `low`, `high`: the normal restricted to `[low, high]`).
use super::StudyError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::Distribution as _;
use serde::{Deserialize, Serialize};

/// How the samples are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DesignKind {
    Grid,
    Random,
    Lhs,
}

/// One `[[parameter]]` of STUDY.toml as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// Dotted scenario key (`excitation.voltage_v`, `exciter.0.location`).
    pub key: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distribution: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub low: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub high: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
    /// Grid designs: the values (numbers; integers stay integers in the scenario).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<toml::Value>>,
}

/// A validated distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    Uniform {
        low: f64,
        high: f64,
    },
    Normal {
        mean: f64,
        std: f64,
    },
    LogNormal {
        mean: f64,
        std: f64,
    },
    TruncatedNormal {
        mean: f64,
        std: f64,
        low: f64,
        high: f64,
    },
}

impl Distribution {
    /// The distribution a parameter names, its numbers checked (the error names the key).
    // `!(mass > 1e-12)` on purpose: a NaN mass is refused too
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn from_spec(p: &ParameterSpec) -> Result<Self, StudyError> {
        let bad = |message: String| StudyError::Parameter {
            key: p.key.clone(),
            message,
        };
        let name = p
            .distribution
            .as_deref()
            .ok_or_else(|| bad("random and lhs designs need a `distribution`".into()))?;
        if p.values.is_some() {
            return Err(bad("`values` belongs to grid designs".into()));
        }
        let need = |v: Option<f64>, what: &str| -> Result<f64, StudyError> {
            match v {
                Some(x) if x.is_finite() => Ok(x),
                Some(x) => Err(bad(format!("{what} = {x} is not finite"))),
                None => Err(bad(format!("distribution \"{name}\" needs `{what}`"))),
            }
        };
        let unused = |v: Option<f64>, what: &str| -> Result<(), StudyError> {
            match v {
                Some(_) => Err(bad(format!(
                    "distribution \"{name}\" has no `{what}` (uniform: low, high; normal and \
                     lognormal: mean, std; truncated-normal: mean, std, low, high)"
                ))),
                None => Ok(()),
            }
        };
        let std_ok = |s: f64| -> Result<f64, StudyError> {
            if s > 0.0 {
                Ok(s)
            } else {
                Err(bad(format!("std = {s} must be positive")))
            }
        };
        let interval = |low: f64, high: f64| -> Result<(), StudyError> {
            if low < high {
                Ok(())
            } else {
                Err(bad(format!("low = {low} must be below high = {high}")))
            }
        };
        let d = match name {
            "uniform" => {
                unused(p.mean, "mean")?;
                unused(p.std, "std")?;
                let (low, high) = (need(p.low, "low")?, need(p.high, "high")?);
                interval(low, high)?;
                Distribution::Uniform { low, high }
            }
            "normal" | "lognormal" => {
                unused(p.low, "low")?;
                unused(p.high, "high")?;
                let mean = need(p.mean, "mean")?;
                let std = std_ok(need(p.std, "std")?)?;
                if name == "normal" {
                    Distribution::Normal { mean, std }
                } else {
                    Distribution::LogNormal { mean, std }
                }
            }
            "truncated-normal" => {
                let mean = need(p.mean, "mean")?;
                let std = std_ok(need(p.std, "std")?)?;
                let (low, high) = (need(p.low, "low")?, need(p.high, "high")?);
                interval(low, high)?;
                let mass = normal_cdf((high - mean) / std) - normal_cdf((low - mean) / std);
                if !(mass > 1e-12) {
                    return Err(bad(format!(
                        "[low, high] = [{low}, {high}] holds a probability of {mass:e} of \
                         normal(mean = {mean}, std = {std}): nothing to sample"
                    )));
                }
                Distribution::TruncatedNormal {
                    mean,
                    std,
                    low,
                    high,
                }
            }
            other => {
                return Err(bad(format!(
                    "unknown distribution \"{other}\" (uniform | normal | lognormal | truncated-normal)"
                )))
            }
        };
        Ok(d)
    }

    /// Inverse CDF at `u in (0, 1)`.
    pub fn quantile(&self, u: f64) -> f64 {
        match *self {
            Distribution::Uniform { low, high } => low + (high - low) * u,
            Distribution::Normal { mean, std } => mean + std * normal_quantile(u),
            Distribution::LogNormal { mean, std } => (mean + std * normal_quantile(u)).exp(),
            Distribution::TruncatedNormal {
                mean,
                std,
                low,
                high,
            } => {
                let (a, b) = (
                    normal_cdf((low - mean) / std),
                    normal_cdf((high - mean) / std),
                );
                (mean + std * normal_quantile(a + (b - a) * u)).clamp(low, high)
            }
        }
    }

    /// One random draw (rand_distr's samplers; the truncated normal by its
    /// inverse CDF, which needs no rejection loop far in a tail).
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        match *self {
            Distribution::Uniform { low, high } => {
                rand_distr::Uniform::new(low, high).map_or(low, |d| d.sample(rng))
            }
            Distribution::Normal { mean, std } => {
                rand_distr::Normal::new(mean, std).map_or(mean, |d| d.sample(rng))
            }
            Distribution::LogNormal { mean, std } => {
                rand_distr::LogNormal::new(mean, std).map_or(mean.exp(), |d| d.sample(rng))
            }
            Distribution::TruncatedNormal { .. } => self.quantile(open_unit(rng)),
        }
    }
}

/// A uniform number in the open interval (0, 1).
fn open_unit(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(rand_distr::Open01)
}

/// Standard normal CDF `Phi(x) = erfc(-x / sqrt 2) / 2`.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// Standard normal quantile `Phi^-1(u)`: Acklam's rational approximation
/// (relative error 1.2e-9) polished by one Halley step on [`normal_cdf`] to
/// full double accuracy. Hand-written: no light crate has it (statrs brings
/// a second `rand`).
pub fn normal_quantile(u: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    if u <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if u >= 1.0 {
        return f64::INFINITY;
    }
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    let p_low = 0.02425;
    let x = if u < p_low {
        tail((-2.0 * u.ln()).sqrt())
    } else if u > 1.0 - p_low {
        -tail((-2.0 * (1.0 - u).ln()).sqrt())
    } else {
        let q = u - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    };
    // Halley step: e = Phi(x) - u, x -= e / (phi(x) + x e / 2)
    let e = normal_cdf(x) - u;
    let pdf = (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let step = e / pdf;
    x - step / (1.0 + 0.5 * x * step)
}

/// Most samples a study takes (each sample's row and design values are held in
/// memory: about 100 bytes per parameter and sample).
pub const MAX_SAMPLES: usize = 10_000_000;

/// The parameter values of every sample: `values[sample][parameter]`.
pub fn samples(
    kind: DesignKind,
    params: &[ParameterSpec],
    samples: Option<usize>,
    seed: u64,
) -> Result<Vec<Vec<toml::Value>>, StudyError> {
    match kind {
        DesignKind::Grid => grid(params, samples),
        DesignKind::Random | DesignKind::Lhs => {
            let n = samples.ok_or_else(|| StudyError::Study {
                key: "samples".into(),
                message: "random and lhs designs need `samples`".into(),
            })?;
            if !(1..=MAX_SAMPLES).contains(&n) {
                return Err(StudyError::Study {
                    key: "samples".into(),
                    message: format!("expected 1 ..= {MAX_SAMPLES}, got {n}"),
                });
            }
            let dists = params
                .iter()
                .map(Distribution::from_spec)
                .collect::<Result<Vec<_>, _>>()?;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let x: Vec<Vec<f64>> = if kind == DesignKind::Random {
                (0..n)
                    .map(|_| dists.iter().map(|d| d.draw(&mut rng)).collect())
                    .collect()
            } else {
                lhs(&dists, n, &mut rng)
            };
            Ok(x.into_iter()
                .map(|row| row.into_iter().map(toml::Value::Float).collect())
                .collect())
        }
    }
}

fn grid(
    params: &[ParameterSpec],
    samples: Option<usize>,
) -> Result<Vec<Vec<toml::Value>>, StudyError> {
    let mut axes = Vec::new();
    for p in params {
        let bad = |message: &str| StudyError::Parameter {
            key: p.key.clone(),
            message: message.into(),
        };
        if p.distribution.is_some()
            || p.low.is_some()
            || p.high.is_some()
            || p.mean.is_some()
            || p.std.is_some()
        {
            return Err(bad("grid designs take `values` only (distribution, low, high, mean, std belong to random and lhs designs)"));
        }
        let v = p
            .values
            .as_ref()
            .ok_or_else(|| bad("grid designs need `values = [...]`"))?;
        if v.is_empty() {
            return Err(bad("`values` is empty"));
        }
        for x in v {
            match x {
                toml::Value::Float(f) if f.is_finite() => {}
                toml::Value::Integer(_) => {}
                other => {
                    return Err(bad(&format!(
                        "`values` holds {other}: expected finite numbers"
                    )))
                }
            }
        }
        axes.push(v.clone());
    }
    let total = axes
        .iter()
        .try_fold(1usize, |t, a| t.checked_mul(a.len()))
        .filter(|t| *t <= MAX_SAMPLES)
        .ok_or_else(|| StudyError::Study {
            key: "parameter".into(),
            message: format!(
                "the grid (the product of the values' lengths) has more than {MAX_SAMPLES} samples"
            ),
        })?;
    if let Some(n) = samples {
        if n != total {
            return Err(StudyError::Study {
                key: "samples".into(),
                message: format!("a grid has {total} samples (the product of the values' lengths), not {n}: leave `samples` out"),
            });
        }
    }
    let mut out = Vec::with_capacity(total);
    for i in 0..total {
        let mut rest = i;
        let mut row = vec![toml::Value::Integer(0); axes.len()];
        for (j, axis) in axes.iter().enumerate().rev() {
            row[j] = axis[rest % axis.len()].clone();
            rest /= axis.len();
        }
        out.push(row);
    }
    Ok(out)
}

/// Latin hypercube: per parameter a random permutation of the strata, then a
/// uniform point in each.
fn lhs(dists: &[Distribution], n: usize, rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
    use rand::seq::SliceRandom;
    let mut cols = Vec::with_capacity(dists.len());
    for d in dists {
        let mut strata: Vec<usize> = (0..n).collect();
        strata.shuffle(rng);
        let col: Vec<f64> = strata
            .iter()
            .map(|&k| d.quantile((k as f64 + open_unit(rng)) / n as f64))
            .collect();
        cols.push(col);
    }
    (0..n)
        .map(|i| cols.iter().map(|c| c[i]).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantile_inverts_the_cdf() {
        for &u in &[
            1e-12,
            1e-6,
            0.001,
            0.02,
            0.1,
            0.3,
            0.5,
            0.7,
            0.97,
            0.999,
            1.0 - 1e-9,
        ] {
            let x = normal_quantile(u);
            let back = normal_cdf(x);
            assert!(
                (back - u).abs() <= 4e-16_f64.max(1e-13 * u),
                "{u}: {x} -> {back}"
            );
        }
        assert!(normal_quantile(0.5).abs() < 1e-15);
        assert!((normal_quantile(0.975) - 1.959963984540054).abs() < 1e-13);
    }

    fn param(
        key: &str,
        dist: &str,
        low: Option<f64>,
        high: Option<f64>,
        mean: Option<f64>,
        std: Option<f64>,
    ) -> ParameterSpec {
        ParameterSpec {
            key: key.into(),
            distribution: Some(dist.into()),
            low,
            high,
            mean,
            std,
            values: None,
        }
    }

    #[test]
    fn lhs_puts_one_sample_in_each_stratum() {
        let p = [
            param("a", "uniform", Some(1.0), Some(3.0), None, None),
            param(
                "b",
                "truncated-normal",
                Some(-1.0),
                Some(2.0),
                Some(0.0),
                Some(1.0),
            ),
        ];
        // a sample count sized from input is bounded before anything is allocated
        assert!(samples(DesignKind::Lhs, &p, Some(100_000_000_000), 7).is_err());
        assert!(samples(DesignKind::Lhs, &p, Some(0), 7).is_err());
        let x = samples(DesignKind::Lhs, &p, Some(50), 7).unwrap();
        let mut strata: Vec<usize> = x
            .iter()
            .map(|r| ((r[0].as_float().unwrap() - 1.0) / 2.0 * 50.0) as usize)
            .collect();
        strata.sort();
        assert_eq!(strata, (0..50).collect::<Vec<_>>());
        assert!(x
            .iter()
            .all(|r| (-1.0..=2.0).contains(&r[1].as_float().unwrap())));
        assert_eq!(x, samples(DesignKind::Lhs, &p, Some(50), 7).unwrap());
        assert_ne!(x, samples(DesignKind::Lhs, &p, Some(50), 8).unwrap());
    }

    #[test]
    fn bad_distributions_name_the_key() {
        for (p, want) in [
            (
                param("k", "uniform", Some(2.0), Some(1.0), None, None),
                "below",
            ),
            (
                param("k", "normal", None, None, Some(1.0), Some(0.0)),
                "std",
            ),
            (
                param("k", "normal", Some(1.0), None, Some(1.0), Some(1.0)),
                "no `low`",
            ),
            (
                param("k", "weibull", None, None, None, None),
                "unknown distribution",
            ),
            (
                param(
                    "k",
                    "truncated-normal",
                    Some(50.0),
                    Some(60.0),
                    Some(0.0),
                    Some(1.0),
                ),
                "probability",
            ),
        ] {
            let e = Distribution::from_spec(&p).unwrap_err().to_string();
            assert!(e.contains("k") && e.contains(want), "{e}");
        }
    }
}
