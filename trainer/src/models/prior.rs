//! The prior mean: a polynomial in the normalized inputs, with the GP modelling what it misses.
//!
//! Why a polynomial mean, and why the physics basis by default: on rate-table data the bulk of ω(T,
//! V) — the scale factor, its temperature coefficients, the cubic of the sine response — is a
//! low-order polynomial. Left to the GP (a constant mean), that ±80 °/s signal is carried by
//! weights of 1e5 that cancel to 1e-5 relative; in the firmware's f32 they cost degrees per second
//! (docs/paper.md, "Measured for the firmware"). With the basis {1, t, t²} × {1, v, v³} (bias and
//! scale factor quadratic in temperature, the sine response's cubic with them) the weights stay
//! small and f32 carries the model to a few µ°/s, at a leave-one-out error close to the constant
//! mean's (`trainer/benches/f32_study` measures both).
//!
//! The basis coefficients are not fixed beforehand: the GP marginalizes them (Rasmussen & Williams
//! §2.7, vague prior), so they are estimated by generalized least squares with the GP's covariance
//! and the hyperparameters maximize the restricted likelihood ([`crate::models::gp::exact`]).
//! Ordinary least squares gives the starting point and the output scale. The constant basis stays
//! the paper's fixed mean.

use std::fmt;
use std::str::FromStr;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Which monomials make up the prior mean. Inputs 0 and 1 are temperature and gyro output.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(into = "String")]
pub enum MeanBasis {
    /// A constant, the data's mean, fixed rather than marginalized: exactly the paper's model.
    Constant,
    /// {1, t, t²} × {1, v, v³} over temperature t and output v (a model's default).
    #[default]
    Physics,
    /// One of physics, poly1 and poly2, chosen on the training points by a command before it
    /// fits ([`crate::analysis::basis`]; the commands' default). A fit refuses it unchosen.
    Auto,
    /// All monomials of total degree ≤ N over every input.
    Poly(u8),
}

impl fmt::Display for MeanBasis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Constant => write!(f, "constant"),
            Self::Physics => write!(f, "physics"),
            Self::Auto => write!(f, "auto"),
            Self::Poly(n) => write!(f, "poly{n}"),
        }
    }
}

impl From<MeanBasis> for String {
    fn from(b: MeanBasis) -> Self {
        b.to_string()
    }
}

impl FromStr for MeanBasis {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "constant" => Ok(Self::Constant),
            "physics" => Ok(Self::Physics),
            "auto" => Ok(Self::Auto),
            _ => s
                .strip_prefix("poly")
                .and_then(|n| n.parse::<u8>().ok())
                .filter(|n| *n <= 5)
                .map(Self::Poly)
                .ok_or_else(|| {
                    format!("'{s}': expected auto, constant, physics or polyN with N in 0..=5")
                }),
        }
    }
}

impl MeanBasis {
    /// This basis, or physics where it is [`Self::Auto`]: what a command that compares methods
    /// on one basis (`reproduce`, `loo` of a method other than the GP) fits.
    pub fn or_physics(self) -> Self {
        if self == Self::Auto {
            Self::Physics
        } else {
            self
        }
    }

    /// Exponent vectors over `d` inputs, constant first, then in increasing degree. With fewer
    /// than two inputs the physics basis reduces to {1, t, t²}.
    pub fn exponents(self, d: usize) -> Vec<Vec<u8>> {
        match self {
            Self::Constant => vec![vec![0; d]],
            Self::Poly(n) => monomials(d, n),
            Self::Physics | Self::Auto => {
                let v_powers: &[u8] = if d >= 2 { &[0, 1, 3] } else { &[0] };
                let mut out = Vec::new();
                for &j in v_powers {
                    for i in 0..3u8 {
                        let mut e = vec![0u8; d];
                        if let Some(t) = e.first_mut() {
                            *t = i;
                        }
                        if let Some(v) = e.get_mut(1) {
                            *v = j;
                        }
                        if d > 0 {
                            out.push(e);
                        }
                    }
                }
                out.sort_by_key(|e| e.iter().map(|&k| u32::from(k)).sum::<u32>());
                out.dedup();
                out
            }
        }
    }
}

/// All exponent vectors over `d` inputs with total degree ≤ `degree`, in graded order.
fn monomials(d: usize, degree: u8) -> Vec<Vec<u8>> {
    let mut out = vec![vec![0u8; d]];
    for total in 1..=degree {
        let mut stack = vec![(Vec::<u8>::new(), total)];
        while let Some((prefix, left)) = stack.pop() {
            if prefix.len() + 1 == d {
                let mut e = prefix;
                e.push(left);
                out.push(e);
                continue;
            }
            for k in (0..=left).rev() {
                let mut e = prefix.clone();
                e.push(k);
                stack.push((e, left - k));
            }
        }
    }
    out
}

/// The design matrix: one column per monomial, one row per sample of normalized `x`.
pub fn design(x: &DMatrix<f64>, exponents: &[Vec<u8>]) -> DMatrix<f64> {
    DMatrix::from_fn(x.nrows(), exponents.len(), |i, j| {
        monomial(&exponents[j], x.row(i).iter().copied())
    })
}

fn monomial(e: &[u8], z: impl Iterator<Item = f64>) -> f64 {
    e.iter()
        .zip(z)
        .map(|(&k, v)| v.powi(i32::from(k)))
        .product()
}

/// A polynomial mean over normalized inputs, in output units.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct PolyPrior {
    /// Exponents of each monomial, one entry per input.
    pub exponents: Vec<Vec<u8>>,
    /// Coefficient of each monomial.
    pub coefficients: Vec<f64>,
    /// Monomials of the basis left out on these inputs, and why.
    pub dropped: Vec<Dropped>,
}

/// A monomial of the requested basis that the fitted prior leaves out.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Dropped {
    /// The monomial, as `t^i·v^j·x2^k…` over the inputs (temperature, output, further inputs).
    pub monomial: String,
    /// Why it was left out.
    pub reason: DropReason,
}

/// Why a monomial is left out of the prior mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum DropReason {
    /// Fewer than two samples per coefficient.
    TooFewSamples,
    /// On these inputs it is a combination of the monomials before it (an input with fewer
    /// distinct values than the basis' degree in it: a voltage at ±1 only makes v³ = v).
    Dependent,
}

impl fmt::Display for DropReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::TooFewSamples => "fewer than two samples per coefficient",
            Self::Dependent => "each a combination of the ones before it on these inputs",
        })
    }
}

/// A monomial's name over inputs named t, v, x2, x3, ….
fn name(e: &[u8]) -> String {
    let parts: Vec<String> = e
        .iter()
        .enumerate()
        .filter(|&(_, &k)| k > 0)
        .map(|(i, &k)| {
            let input = match i {
                0 => "t".to_owned(),
                1 => "v".to_owned(),
                _ => format!("x{i}"),
            };
            if k == 1 {
                input
            } else {
                format!("{input}^{k}")
            }
        })
        .collect();
    if parts.is_empty() {
        "1".to_owned()
    } else {
        parts.join("·")
    }
}

/// A column within this fraction of its norm of the span of the columns before it is dependent.
/// Exact dependence leaves rounding (1e-15); near dependence that strong would give coefficients
/// ~1e6 times the output that cancel, which the firmware's f32 (6e-8) cannot carry. Two soaked
/// plateaus under t² (sensor scatter of 0.01 °C) stay near 1e-3 and are kept.
const DEPENDENCE: f64 = 1e-6;

/// Indices of the columns of `a` that are not dependent on the ones kept before them (modified
/// Gram–Schmidt, in order, so the low-degree monomials are the ones kept).
fn independent_columns(a: &DMatrix<f64>) -> Vec<usize> {
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut keep = Vec::new();
    for (j, col) in a.column_iter().enumerate() {
        let norm = col.norm();
        let mut r = col.into_owned();
        for q in &basis {
            let c = q.dot(&r);
            r.axpy(-c, q, 1.0);
        }
        let rest = r.norm();
        if norm > 0.0 && rest > DEPENDENCE * norm {
            basis.push(r / rest);
            keep.push(j);
        }
    }
    keep
}

impl PolyPrior {
    /// Ordinary least squares of `basis` on `y`. Monomials dependent on the ones before them on
    /// these inputs are dropped ([`DropReason`]), so the design has full rank, then the rest from
    /// the top until there are at least twice as many samples as coefficients. The dependent ones
    /// span nothing the kept ones do not on the data: the fit there is the same.
    pub fn fit(x: &DMatrix<f64>, y: &DVector<f64>, basis: MeanBasis) -> Self {
        let exponents = basis.exponents(x.ncols());
        let keep = independent_columns(&design(x, &exponents));
        let room = (x.nrows() / 2).max(1);
        let mut dropped: Vec<Dropped> = Vec::new();
        let mut kept = Vec::new();
        for (j, e) in exponents.into_iter().enumerate() {
            let reason = if !keep.contains(&j) {
                DropReason::Dependent
            } else if kept.len() >= room {
                DropReason::TooFewSamples
            } else {
                kept.push(e);
                continue;
            };
            dropped.push(Dropped {
                monomial: name(&e),
                reason,
            });
        }
        let a = design(x, &kept);
        let coefficients = a
            .svd(true, true)
            .solve(y, 1e-12)
            .map(|c| c.iter().copied().collect())
            .unwrap_or_else(|_| vec![0.0; kept.len()]);
        Self {
            exponents: kept,
            coefficients,
            dropped,
        }
    }

    /// The mean at one normalized sample.
    pub fn eval(&self, z: &[f64]) -> f64 {
        self.exponents
            .iter()
            .zip(&self.coefficients)
            .map(|(e, c)| c * monomial(e, z.iter().copied()))
            .sum()
    }

    /// The mean at every row of normalized `x`.
    pub fn eval_all(&self, x: &DMatrix<f64>) -> DVector<f64> {
        &design(x, &self.exponents) * DVector::from_column_slice(&self.coefficients)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bases_have_the_documented_monomials() {
        assert_eq!(monomials(2, 3).len(), 10);
        assert_eq!(monomials(3, 2).len(), 10);
        assert!(monomials(2, 3).iter().all(|e| e.iter().sum::<u8>() <= 3));
        let phys = MeanBasis::Physics.exponents(2);
        assert_eq!(phys.len(), 9);
        assert_eq!(phys[0], vec![0, 0]);
        for e in [
            [1, 0],
            [0, 1],
            [2, 0],
            [1, 1],
            [2, 1],
            [0, 3],
            [1, 3],
            [2, 3],
        ] {
            assert!(phys.contains(&e.to_vec()), "{e:?}");
        }
        assert_eq!(MeanBasis::Physics.exponents(3)[1], vec![1, 0, 0]);
        assert_eq!(MeanBasis::Constant.exponents(2), vec![vec![0, 0]]);
        for s in ["constant", "physics", "poly3"] {
            assert_eq!(s.parse::<MeanBasis>().unwrap().to_string(), s);
        }
        assert!("poly9".parse::<MeanBasis>().is_err());
        assert!("cubic".parse::<MeanBasis>().is_err());
    }

    #[test]
    fn monomials_dependent_on_these_inputs_are_dropped_and_named() {
        // A voltage at ±1 only: v³ = v, so the cube and its products go; a line in v fits exactly.
        let x = DMatrix::from_fn(40, 2, |i, j| match j {
            0 => (i % 8) as f64 / 4.0 - 1.0,
            _ => [-1.0, 1.0][i % 2],
        });
        let y = DVector::from_fn(40, |i, _| 0.3 + 2.0 * x[(i, 1)] - 0.5 * x[(i, 0)].powi(2));
        let p = PolyPrior::fit(&x, &y, MeanBasis::Physics);
        let names: Vec<&str> = p.dropped.iter().map(|d| d.monomial.as_str()).collect();
        assert_eq!(names, ["v^3", "t·v^3", "t^2·v^3"]);
        assert!(p.dropped.iter().all(|d| d.reason == DropReason::Dependent));
        assert_eq!(p.exponents.len(), 6);
        for (i, yi) in y.iter().enumerate() {
            assert!((p.eval(&[x[(i, 0)], x[(i, 1)]]) - yi).abs() < 1e-10);
        }
        // A constant input (normalized to zero) leaves only the other's monomials; few samples
        // drop the top of the basis first.
        let flat = DMatrix::from_fn(40, 2, |i, j| if j == 0 { 0.0 } else { x[(i, 0)] });
        let p = PolyPrior::fit(&flat, &y, MeanBasis::Physics);
        assert!(p.exponents.iter().all(|e| e[0] == 0), "{:?}", p.exponents);
        let few = PolyPrior::fit(
            &x.rows(0, 6).into_owned(),
            &y.rows(0, 6).into_owned(),
            MeanBasis::Physics,
        );
        assert_eq!(few.exponents.len() + few.dropped.len(), 9);
        assert!(
            few.dropped
                .iter()
                .any(|d| d.reason == DropReason::TooFewSamples)
        );
    }

    #[test]
    fn recovers_a_cubic_exactly() {
        let x = DMatrix::from_fn(30, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 / 5.0 - 1.0);
        let f = |t: f64, v: f64| 0.5 - t + 2.0 * v + 0.3 * t * v * v - 0.1 * v.powi(3);
        let y = DVector::from_fn(30, |i, _| f(x[(i, 0)], x[(i, 1)]));
        let p = PolyPrior::fit(&x, &y, MeanBasis::Poly(3));
        let all = p.eval_all(&x);
        for (i, yi) in y.iter().enumerate() {
            assert!((p.eval(&[x[(i, 0)], x[(i, 1)]]) - yi).abs() < 1e-10);
            assert!((all[i] - yi).abs() < 1e-10);
        }
    }
}
