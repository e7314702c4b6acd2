//! The ARD squared-exponential kernel (paper eq. 10), shared by the GP and LS-SVR.
//!
//! `k(x, x') = σ_f² · exp(−½ Σ_k (x_k − x'_k)² / ℓ_k²)` on normalized inputs, one length scale per
//! input (automatic relevance determination: an irrelevant input gets a long ℓ).

use multiversion::multiversion;
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
/// Its n²/2 exponentials are a large share of an exact likelihood evaluation, so the columns are
/// filled in parallel (contiguous, each entry computed alone: the same bits whatever the
/// threads).
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
                *v = ri.iter().zip(rj).map(|(a, b)| (a - b) * (a - b)).sum();
            }
            kernel_of_squared_distances(&mut column[j + 1..]);
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
            *kv = ui.iter().zip(&x).map(|(p, q)| (p - q) * (p - q)).sum();
        }
        kernel_of_squared_distances(col.as_mut_slice());
    }
    k
}

/// Kernel values between one normalized sample `z` and every row of `xs` (training inputs already
/// divided by `length_scales`), unit signal variance.
pub fn cross(xs: &DMatrix<f64>, z: &[f64], length_scales: &[f64]) -> DVector<f64> {
    let scaled: Vec<f64> = z.iter().zip(length_scales).map(|(v, l)| v / l).collect();
    let one = DMatrix::from_row_slice(1, scaled.len(), &scaled);
    let mut k = DVector::from_fn(xs.nrows(), |i, _| sq_dist(xs, i, &one, 0));
    kernel_of_squared_distances(k.as_mut_slice());
    k
}

/// Replaces every squared distance r² by the unit-variance kernel exp(−½ r²), in place.
///
/// Why by hand: the C library's `exp` computes one value per call, and these n²/2 exponentials are
/// a share of every exact likelihood. This form has no branch and no table,
/// so the loop is vectorized (four lanes where the CPU has AVX2, chosen at run time by
/// `multiversion`; two with the baseline SSE2), and it gives the same bits on every path (no
/// fused multiply-add). The method is the textbook one: e^x = 2^k e^r with k = round(x / ln 2),
/// r reduced in two parts (Cody–Waite) to |r| ≤ ln 2 / 2, and e^r by its Taylor series to r¹³
/// (the next term is below 10⁻¹⁷). It is within one ulp of the C library's `exp` over the whole
/// range (tested). An r² beyond 1,416 gives e^−708 ≈ 3e−308 instead of a subnormal or zero,
/// which no covariance can tell apart. A NaN stays NaN.
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn kernel_of_squared_distances(values: &mut [f64]) {
    for v in values {
        *v = exp_nonpositive(-0.5 * *v);
    }
}

/// e^x for x ≤ 0 ([`kernel_of_squared_distances`]): plain arithmetic and bit operations only,
/// so that a loop over it vectorizes.
#[inline(always)]
fn exp_nonpositive(x: f64) -> f64 {
    /// 1.5 · 2⁵²: adding it rounds a value below 2⁵¹ to an integer held in the low bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    /// ln 2 in two parts (fdlibm's, by their bits): the first ends in 21 zero bits, so k · LN2_HI
    /// is exact for |k| < 2²¹; the second is the rest.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    /// 1/j! for j = 13 down to 2.
    const INVERSE_FACTORIALS: [f64; 12] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        1.0 / 2.0,
    ];
    let x = if x < -708.0 { -708.0 } else { x };
    let shifted = x * std::f64::consts::LOG2_E + SHIFT;
    let k = shifted - SHIFT;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let mut p = INVERSE_FACTORIALS[0];
    for c in &INVERSE_FACTORIALS[1..] {
        p = p * r + c;
    }
    let e_r = (p * r + 1.0) * r + 1.0;
    // k sits in the low bits of `shifted`; 2^k is k + 1023 in the exponent field.
    let k_bits = shifted.to_bits().wrapping_sub(SHIFT.to_bits());
    e_r * f64::from_bits(k_bits.wrapping_add(1023) << 52)
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
                let mut r2 = [(0..3).map(|c| (xs[(i, c)] - xs[(j, c)]).powi(2)).sum()];
                kernel_of_squared_distances(&mut r2);
                assert_eq!(k[(i, j)], r2[0], "({i}, {j})");
            }
        }
        assert_eq!(gram(&DMatrix::zeros(0, 2)).shape(), (0, 0));
    }

    /// Distance in units in the last place between two positive finite doubles.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn the_kernels_exponential_is_within_one_ulp_of_exp_over_its_whole_range() {
        // A fine grid over e^−708…e^0 (every reduction interval holds hundreds of points), the
        // ends, and points next to the interval boundaries k·ln 2 / 2 where r is largest.
        let mut xs: Vec<f64> = (0..=2_000_000).map(|i| -708.0 * i as f64 / 2e6).collect();
        xs.extend((0..1_021).flat_map(|k| {
            let b = -(k as f64 + 0.5) * std::f64::consts::LN_2;
            [b, b.next_up(), b.next_down()]
        }));
        xs.extend([-0.0, -1e-300, -1e-17, -1e-9, -707.999_999]);
        // One call over all of them: the vector lanes and the scalar remainder.
        let mut k: Vec<f64> = xs.iter().map(|x| -2.0 * x).collect();
        kernel_of_squared_distances(&mut k);
        let (u, x) = xs
            .iter()
            .zip(&k)
            .map(|(x, v)| (ulps(*v, x.exp()), *x))
            .max_by_key(|w| w.0)
            .unwrap_or((0, 0.0));
        assert!(u <= 1, "{u} ulp at x = {x}");
        let mut edge = [0.0, 1e6, f64::NAN];
        kernel_of_squared_distances(&mut edge);
        assert_eq!(edge[0], 1.0);
        assert!(ulps(edge[1], (-708.0f64).exp()) <= 2);
        assert!(edge[2].is_nan());
    }
}
