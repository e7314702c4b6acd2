//! The ARD squared-exponential kernel (paper eq. 10), shared by the GP and LS-SVR.
//!
//! `k(x, x') = σ_f² · exp(−½ Σ_k (x_k − x'_k)² / ℓ_k²)` on normalized inputs, one length scale per
//! input (automatic relevance determination: an irrelevant input gets a long ℓ).

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Divides each input column by its length scale, so the kernel needs only squared distances.
pub fn scale_inputs(x: &DMatrix<f64>, length_scales: &[f64]) -> DMatrix<f64> {
    DMatrix::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)] / length_scales[j])
}

/// Squared distance between row `i` of `a` and row `j` of `b` (both already scaled).
fn sq_dist(a: &DMatrix<f64>, i: usize, b: &DMatrix<f64>, j: usize) -> f64 {
    (0..a.ncols())
        .map(|k| (a[(i, k)] - b[(j, k)]).powi(2))
        .sum()
}

/// The n×n kernel matrix of scaled inputs with unit signal variance: `exp(−½ r²)`.
pub fn gram(xs: &DMatrix<f64>) -> DMatrix<f64> {
    let mut k = gram_lower(xs);
    k.fill_upper_triangle_with_lower_triangle();
    k
}

/// The lower triangle of [`gram`] (the strict upper triangle is zero), for callers that read no
/// more: the exact GP's factorization and likelihood gradient. Mirroring is a transposing pass
/// over n² entries that they would not use.
///
/// Its n²/2 exponentials cost a quarter of an exact likelihood evaluation at n = 700–1,000, so the
/// columns are filled in parallel (contiguous, each entry computed alone: the same bits whatever
/// the threads).
pub fn gram_lower(xs: &DMatrix<f64>) -> DMatrix<f64> {
    let (n, d) = xs.shape();
    // Row-major copy: the distance loop then reads contiguous memory.
    let rows: Vec<f64> = (0..n)
        .flat_map(|i| (0..d).map(move |k| xs[(i, k)]))
        .collect();
    let mut k = DMatrix::zeros(n, n);
    if n == 0 {
        return k;
    }
    k.as_mut_slice()
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(j, column)| {
            column[j] = 1.0;
            let rj = &rows[j * d..(j + 1) * d];
            for (v, ri) in column[j + 1..]
                .iter_mut()
                .zip(rows[(j + 1) * d..].chunks_exact(d))
            {
                let r2: f64 = ri.iter().zip(rj).map(|(a, b)| (a - b) * (a - b)).sum();
                *v = (-0.5 * r2).exp();
            }
        });
    k
}

/// The m×n kernel matrix between scaled inputs `us` (m rows) and `xs` (n rows), unit signal
/// variance.
pub fn cross_matrix(us: &DMatrix<f64>, xs: &DMatrix<f64>) -> DMatrix<f64> {
    let d = us.ncols();
    let urows: Vec<f64> = (0..us.nrows())
        .flat_map(|i| (0..d).map(move |k| us[(i, k)]))
        .collect();
    let mut k = DMatrix::zeros(us.nrows(), xs.nrows());
    let mut x = vec![0.0; d];
    for (a, mut col) in k.column_iter_mut().enumerate() {
        for (j, v) in x.iter_mut().enumerate() {
            *v = xs[(a, j)];
        }
        for (ui, kv) in urows.chunks_exact(d).zip(col.iter_mut()) {
            let r2: f64 = ui.iter().zip(&x).map(|(p, q)| (p - q) * (p - q)).sum();
            *kv = (-0.5 * r2).exp();
        }
    }
    k
}

/// Kernel values between one normalized sample `z` and every row of `xs` (training inputs already
/// divided by `length_scales`), unit signal variance.
pub fn cross(xs: &DMatrix<f64>, z: &[f64], length_scales: &[f64]) -> DVector<f64> {
    let scaled: Vec<f64> = z.iter().zip(length_scales).map(|(v, l)| v / l).collect();
    let one = DMatrix::from_row_slice(1, scaled.len(), &scaled);
    DVector::from_fn(xs.nrows(), |i, _| (-0.5 * sq_dist(xs, i, &one, 0)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gram_matrix_is_the_kernel_at_every_pair() {
        let xs = DMatrix::from_fn(37, 3, |i, j| ((i * 5 + j * 7) % 11) as f64 / 4.0 - 1.2);
        let k = gram(&xs);
        for i in 0..37 {
            for j in 0..37 {
                let r2: f64 = (0..3).map(|c| (xs[(i, c)] - xs[(j, c)]).powi(2)).sum();
                assert_eq!(k[(i, j)], (-0.5 * r2).exp(), "({i}, {j})");
            }
        }
        assert_eq!(gram(&DMatrix::zeros(0, 2)).shape(), (0, 0));
    }
}
