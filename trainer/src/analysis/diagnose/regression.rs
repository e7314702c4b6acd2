//! The least squares every hypothesis is fitted with: a constant (an intercept, or one per plateau
//! of a soaked table) and the cause's regressors.

use nalgebra::{DMatrix, DVector};

use crate::data::points::plateaus;

/// A cause's regressor at each parameter of its grid (one absent regressor for `none`).
pub type Candidates = Vec<(f32, Option<Vec<f64>>)>;

/// A soaked table's plateaus as the blocks see them: the plateau temperatures and each block's
/// piecewise-linear interpolation weights between them.
pub struct Plateaus {
    pub(super) knots: Vec<f64>,
    pub(super) weights: Vec<[(usize, f64); 2]>,
}

/// The constant part of a regression on the residual. An intercept; or, for a design with a
/// heating/cooling state over a soaked table, a piecewise-linear function of temperature over
/// the table's plateaus: the table was soaked in one state per temperature, whichever way the
/// chamber reached it, and the static GP absorbed that state's offset there, so the stream's
/// residual carries minus that offset wherever its state differs
/// ([`crate::analysis::extend::fit`] takes it out of the points the same way). Neighbouring
/// plateau constants are tied by a weak penalty, so a plateau the blocks do not visit takes its
/// neighbours' value.
#[derive(Clone, Copy)]
pub enum Constant<'a> {
    /// One intercept.
    Intercept,
    /// One constant per plateau.
    Plateaus(&'a Plateaus),
}

impl<'a> Constant<'a> {
    /// The constant of a design, with or without a heating/cooling state, over `plateaus` (a
    /// soaked table's, if any).
    pub(super) fn of(plateaus: Option<&'a Plateaus>, with_state: bool) -> Self {
        match plateaus {
            Some(p) if with_state => Self::Plateaus(p),
            _ => Self::Intercept,
        }
    }

    /// Columns the constant takes.
    pub(crate) fn columns(self) -> usize {
        match self {
            Self::Intercept => 1,
            Self::Plateaus(p) => p.knots.len(),
        }
    }

    /// The constant's value at block `i` under coefficients `beta`.
    pub(super) fn at(self, beta: &[f64], i: usize) -> f64 {
        match self {
            Self::Intercept => beta[0],
            Self::Plateaus(p) => p.weights[i].iter().map(|&(j, w)| w * beta[j]).sum(),
        }
    }
}

/// Weight of a difference between neighbouring plateau constants against one 60 s block's
/// residual: weak, so that it only decides constants the blocks do not visit.
pub(super) const PENALTY_WEIGHT: f64 = 1.0;

/// Least squares of y on [constant, x₁ … x_k] over the blocks `idx`: the coefficients (the
/// constant's first) and the SSE over those blocks. SVD, so a regressor that is constant or
/// repeats another costs nothing.
pub(crate) fn ols(
    constant: Constant<'_>,
    xs: &[&[f64]],
    y: &[f64],
    idx: &[usize],
) -> (Vec<f64>, f64) {
    let c = constant.columns();
    let k = c + xs.len();
    let m = idx.len();
    let penalties = c - 1;
    let mut a = DMatrix::zeros(m + penalties, k);
    let mut b = DVector::zeros(m + penalties);
    for (r, &i) in idx.iter().enumerate() {
        match constant {
            Constant::Intercept => a[(r, 0)] = 1.0,
            Constant::Plateaus(p) => {
                for &(j, w) in &p.weights[i] {
                    a[(r, j)] += w;
                }
            }
        }
        for (j, x) in xs.iter().enumerate() {
            a[(r, c + j)] = x[i];
        }
        b[r] = y[i];
    }
    for j in 0..penalties {
        a[(m + j, j)] = PENALTY_WEIGHT;
        a[(m + j, j + 1)] = -PENALTY_WEIGHT;
    }
    let beta = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(k));
    let sse = (&b - &a * &beta).rows(0, m).norm_squared();
    (beta.iter().copied().collect(), sse)
}

/// Prediction of [`ols`] coefficients at block `i`.
pub(super) fn predict(constant: Constant<'_>, beta: &[f64], xs: &[&[f64]], i: usize) -> f64 {
    constant.at(beta, i)
        + xs.iter()
            .zip(&beta[constant.columns()..])
            .map(|(x, b)| b * x[i])
            .sum::<f64>()
}

/// Mean temperature of each of the points' plateaus, ascending.
pub(super) fn plateau_temperatures(temps: &[f64]) -> Vec<f64> {
    let id = plateaus(temps);
    let count = id.iter().max().map_or(0, |m| m + 1);
    let mut sum = vec![(0.0, 0usize); count];
    for (&p, &t) in id.iter().zip(temps) {
        sum[p].0 += t;
        sum[p].1 += 1;
    }
    sum.into_iter().map(|(s, n)| s / n as f64).collect()
}

/// Piecewise-linear interpolation weights of `t` on ascending `knots` (held constant beyond the
/// ends): two (index, weight) pairs summing to one.
pub(crate) fn hat_weights(knots: &[f64], t: f64) -> [(usize, f64); 2] {
    let last = knots.len() - 1;
    let j = knots.partition_point(|&k| k <= t);
    if j == 0 {
        [(0, 1.0), (0, 0.0)]
    } else if j > last {
        [(last, 1.0), (last, 0.0)]
    } else {
        let w = (t - knots[j - 1]) / (knots[j] - knots[j - 1]);
        [(j - 1, 1.0 - w), (j, w)]
    }
}
