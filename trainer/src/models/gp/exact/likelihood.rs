//! The restricted log marginal likelihood and its gradient, the gradient's trace terms computed
//! in column chunks in parallel.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::error::GpError;
use super::hyper::Hyperparameters;
use super::posterior::Posterior;
use crate::models::kernel;

/// Columns of the gradient's double sum given to one parallel task.
const GRADIENT_CHUNK: usize = 64;

/// (Restricted) log marginal likelihood and its gradient w.r.t. θ (paper eq. 11–12). θ has
/// ln σ_g last when `offsets` (each sample's group index) is not empty.
pub fn lml_and_gradient(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    h: &DMatrix<f64>,
    offsets: &[usize],
    theta: &[f64],
) -> Result<(f64, Vec<f64>), GpError> {
    let d = z.ncols();
    let hyper = Hyperparameters::from_log_of(theta, d);
    let xs = kernel::scale_inputs(z, &hyper.length_scales);
    let gram = kernel::gram_lower(&xs);
    let post = Posterior::from_gram(xs, &gram, y, h, hyper, offsets)?;
    let sf2 = post.hyper.signal_std.powi(2);
    let sn2 = post.hyper.noise_std.powi(2);
    let kinv = post.projected_inverse_lower();
    let n = y.len();
    let grouped = !post.offsets.is_empty();
    // W = ααᵀ − P; ∂K/∂ln ℓ_k = K_se ∘ (Δz_k/ℓ_k)², ∂K/∂ln σ_f = 2 K_se, ∂K/∂ln σ_n = 2 σ_n² I,
    // ∂K/∂ln σ_g = 2 σ_g² B (B_ij = 1 where i and j share a group).
    // Both W and ∂K are symmetric: the strict lower triangle counts twice, the diagonal once.
    // Column by column over contiguous slices, the columns spread over the cores: [ℓ…, σ_f, B].
    let columns = GradientColumns {
        n,
        kinv: kinv.as_slice(),
        gram: gram.as_slice(),
        alpha: post.alpha.as_slice(),
        xs: post.xs.as_slice(),
        offsets: &post.offsets,
        sf2,
    };
    // Fixed chunks summed in order: the same θ gives the same bits, however the work was shared.
    let partial: Vec<Vec<f64>> = (0..n.div_ceil(GRADIENT_CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut acc, mut column) = (vec![0.0; d + 2], vec![0.0; d + 2]);
            for j in c * GRADIENT_CHUNK..((c + 1) * GRADIENT_CHUNK).min(n) {
                columns.sums(j, &mut column);
                acc.iter_mut().zip(&column).for_each(|(a, v)| *a += v);
            }
            acc
        })
        .collect();
    let mut sums = vec![0.0; d + 2];
    for p in &partial {
        sums.iter_mut().zip(p).for_each(|(a, v)| *a += v);
    }
    let mut grad = vec![0.0; d + 2 + usize::from(grouped)];
    grad[..=d].copy_from_slice(&sums[..=d]);
    grad[d + 1] = sn2
        * (0..n)
            .map(|i| post.alpha[i].powi(2) - kinv[(i, i)])
            .sum::<f64>();
    if let Some(g) = post.hyper.offset_std.filter(|_| grouped) {
        grad[d + 2] = 2.0 * g * g * sums[d + 1];
    }
    Ok((post.log_marginal_likelihood, grad))
}

/// What one column of the likelihood gradient's double sum reads (all column-major, n rows).
struct GradientColumns<'a> {
    n: usize,
    /// Lower triangle of P.
    kinv: &'a [f64],
    /// Lower triangle of the unit-variance Gram matrix.
    gram: &'a [f64],
    alpha: &'a [f64],
    /// Scaled inputs.
    xs: &'a [f64],
    /// Each sample's group (empty without offsets).
    offsets: &'a [usize],
    sf2: f64,
}

/// Inputs whose length-scale sums one pass over a column carries ([`GradientColumns::sums`]).
const PASS_INPUTS: usize = 4;

impl GradientColumns<'_> {
    /// Column j's sums over i ≥ j (the diagonal halved) into `out`: [ℓ…, σ_f, B].
    fn sums(&self, j: usize, out: &mut [f64]) {
        let d = out.len() - 2;
        out.fill(0.0);
        for k0 in (0..d.max(1)).step_by(PASS_INPUTS) {
            let first = k0 == 0;
            match (d - k0).min(PASS_INPUTS) {
                0 => self.pass::<0>(j, k0, first, out),
                1 => self.pass::<1>(j, k0, first, out),
                2 => self.pass::<2>(j, k0, first, out),
                3 => self.pass::<3>(j, k0, first, out),
                _ => self.pass::<PASS_INPUTS>(j, k0, first, out),
            }
        }
    }

    /// One pass over column j for the length scales of inputs k0..k0 + D, and with `first` the
    /// σ_f and group sums. D is a constant so that the sums stay in registers (with a count
    /// known only at run time they went through memory at every step: a tenth of a likelihood
    /// at n = 730). Each sum still runs over i in order: the same bits however inputs are split.
    fn pass<const D: usize>(&self, j: usize, k0: usize, first: bool, out: &mut [f64]) {
        let n = self.n;
        let (kc, gc) = (
            &self.kinv[j * n..(j + 1) * n],
            &self.gram[j * n..(j + 1) * n],
        );
        let x: [&[f64]; D] = std::array::from_fn(|k| &self.xs[(k0 + k) * n..(k0 + k + 1) * n]);
        let xj: [f64; D] = std::array::from_fn(|k| x[k][j]);
        let alpha_j = self.alpha[j];
        let group_j = self.offsets.get(j);
        let (mut lengths, mut signal, mut group) = ([0.0; D], 0.0, 0.0);
        for i in j..n {
            let weight = if i == j { 0.5 } else { 1.0 };
            let w = self.alpha[i] * alpha_j - kc[i];
            let wk = weight * w * self.sf2 * gc[i];
            for k in 0..D {
                let dz = x[k][i] - xj[k];
                lengths[k] += wk * dz * dz;
            }
            if first {
                signal += 2.0 * wk;
                if group_j.is_some_and(|g| self.offsets[i] == *g) {
                    group += weight * w;
                }
            }
        }
        out[k0..k0 + D].copy_from_slice(&lengths);
        if first {
            let d = out.len() - 2;
            out[d] = signal;
            out[d + 1] = group;
        }
    }
}
