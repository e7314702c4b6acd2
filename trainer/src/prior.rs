//! The prior mean: a polynomial in the normalized inputs, with the GP modelling what it misses.
//!
//! Why a polynomial mean, and why the physics basis by default: on rate-table data the bulk of
//! ω(T, V) — the scale factor, its temperature coefficients, the cubic of the sine response — is a
//! low-order polynomial. Left to the GP (a constant mean), that ±80 °/s signal is carried by weights
//! of 1e5 that cancel to 1e-5 relative; in the firmware's f32 they cost degrees per second
//! (README, "Measured for the firmware"). With the basis {1, t, t²} × {1, v, v³} (bias and scale
//! factor quadratic in temperature, the sine response's cubic with them) the weights stay below
//! 10 °/s and f32 carries the model to 4e-6 °/s, at a leave-one-out error within 0.95–1.2× of the
//! constant mean (f32 study, `trainer/benches/f32_study`).
//!
//! The basis coefficients are not fixed beforehand: the GP marginalizes them (Rasmussen & Williams
//! §2.7, vague prior), so they are estimated by generalized least squares with the GP's covariance
//! and the hyperparameters maximize the restricted likelihood (gp.rs). Ordinary least squares
//! gives the starting point and the output scale. The constant basis stays the paper's fixed mean.

use std::fmt;
use std::str::FromStr;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Which monomials make up the prior mean. Inputs 0 and 1 are temperature and gyro output.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(into = "String")]
pub enum MeanBasis {
    /// A constant, the data's mean, fixed rather than marginalized: exactly the paper's model.
    Constant,
    /// {1, t, t²} × {1, v, v³} over temperature t and output v (the default).
    #[default]
    Physics,
    /// All monomials of total degree ≤ N over every input.
    Poly(u8),
}

impl fmt::Display for MeanBasis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Constant => write!(f, "constant"),
            Self::Physics => write!(f, "physics"),
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
            _ => s
                .strip_prefix("poly")
                .and_then(|n| n.parse::<u8>().ok())
                .filter(|n| *n <= 5)
                .map(Self::Poly)
                .ok_or_else(|| {
                    format!("'{s}': expected constant, physics or polyN with N in 0..=5")
                }),
        }
    }
}

impl MeanBasis {
    /// Exponent vectors over `d` inputs, constant first, then in increasing degree. With fewer
    /// than two inputs the physics basis reduces to {1, t, t²}.
    pub fn exponents(self, d: usize) -> Vec<Vec<u8>> {
        match self {
            Self::Constant => vec![vec![0; d]],
            Self::Poly(n) => monomials(d, n),
            Self::Physics => {
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
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolyPrior {
    /// Exponents of each monomial, one entry per input.
    pub exponents: Vec<Vec<u8>>,
    /// Coefficient of each monomial.
    pub coefficients: Vec<f64>,
}

impl PolyPrior {
    /// Ordinary least squares of `basis` on `y` (SVD, so a rank-deficient design still gives the
    /// minimum-norm solution). Monomials are dropped from the top until there are at least twice
    /// as many samples as coefficients.
    pub fn fit(x: &DMatrix<f64>, y: &DVector<f64>, basis: MeanBasis) -> Self {
        let mut exponents = basis.exponents(x.ncols());
        exponents.truncate((x.nrows() / 2).max(1));
        let a = design(x, &exponents);
        let coefficients = a
            .svd(true, true)
            .solve(y, 1e-12)
            .map(|c| c.iter().copied().collect())
            .unwrap_or_else(|_| vec![0.0; exponents.len()]);
        Self {
            exponents,
            coefficients,
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
