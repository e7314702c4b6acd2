//! The prior mean: a least-squares polynomial in the normalized inputs, fitted before the GP.
//!
//! Why: the GP then models only what the polynomial misses. On rate-table data the bulk of
//! ω(T, V) — the scale factor, its temperature coefficient, the cubic of the sine response — is a
//! low-order polynomial; leaving it to the GP makes the GP part large, which costs extrapolation
//! (the GP falls back to its prior mean away from data, e.g. near zero rate between ±1 °/s) and f32
//! precision in firmware (large weights α that cancel). All monomials of total degree ≤ `degree`
//! are used; degree 0 is a constant mean, the default. Measured on paper-protocol units (README,
//! "Choosing the prior mean"): higher degrees give the GP a smaller, better-conditioned residual,
//! but their leave-one-out error varies from unit to unit (up to 30× worse on one), while the
//! constant mean was never beaten by more than a few percent.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// A fitted polynomial mean over normalized inputs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolyPrior {
    /// Exponents of each monomial, one entry per input.
    pub exponents: Vec<Vec<u8>>,
    /// Coefficient of each monomial.
    pub coefficients: Vec<f64>,
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

fn design(x: &DMatrix<f64>, exponents: &[Vec<u8>]) -> DMatrix<f64> {
    DMatrix::from_fn(x.nrows(), exponents.len(), |i, j| {
        exponents[j]
            .iter()
            .enumerate()
            .map(|(k, &e)| x[(i, k)].powi(i32::from(e)))
            .product()
    })
}

impl PolyPrior {
    /// Fits all monomials of total degree ≤ `degree` to `y` by least squares (SVD, so a
    /// rank-deficient design still gives the minimum-norm solution rather than garbage). The degree
    /// is lowered until there are at least twice as many samples as coefficients.
    pub fn fit(x: &DMatrix<f64>, y: &DVector<f64>, degree: u8) -> Self {
        let mut degree = degree;
        let mut exponents = monomials(x.ncols(), degree);
        while degree > 0 && 2 * exponents.len() > x.nrows() {
            degree -= 1;
            exponents = monomials(x.ncols(), degree);
        }
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
            .map(|(e, c)| {
                c * e
                    .iter()
                    .zip(z)
                    .map(|(&k, v)| v.powi(i32::from(k)))
                    .product::<f64>()
            })
            .sum()
    }

    /// The mean at every row of normalized `x`.
    pub fn eval_all(&self, x: &DMatrix<f64>) -> DVector<f64> {
        let row = |i: usize| x.row(i).iter().copied().collect::<Vec<_>>();
        DVector::from_fn(x.nrows(), |i, _| self.eval(&row(i)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monomial_count_is_binomial() {
        assert_eq!(monomials(2, 0).len(), 1);
        assert_eq!(monomials(2, 1).len(), 3);
        assert_eq!(monomials(2, 3).len(), 10);
        assert_eq!(monomials(3, 2).len(), 10);
        assert!(monomials(2, 3).iter().all(|e| e.iter().sum::<u8>() <= 3));
    }

    #[test]
    fn recovers_a_cubic_exactly() {
        let x = DMatrix::from_fn(30, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 / 5.0 - 1.0);
        let f = |t: f64, v: f64| 0.5 - t + 2.0 * v + 0.3 * t * v * v - 0.1 * v.powi(3);
        let y = DVector::from_fn(30, |i, _| f(x[(i, 0)], x[(i, 1)]));
        let p = PolyPrior::fit(&x, &y, 3);
        for (i, yi) in y.iter().enumerate() {
            assert!((p.eval(&[x[(i, 0)], x[(i, 1)]]) - yi).abs() < 1e-10);
        }
    }
}
