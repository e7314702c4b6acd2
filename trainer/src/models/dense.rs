//! The O(n³) kernels of the exact GP and LS-SVR at the speed of the machine: Cholesky, triangular
//! solves and the inverse from a Cholesky factor, the symmetric eigendecomposition and the
//! symmetric product G Gᵀ, on faer (blocked, SIMD, spread over the cores by rayon). The rest of
//! the trainer speaks nalgebra, so matrices cross over by copy: O(n²) against the O(n³) of the
//! work. nalgebra's own Cholesky and triangular solves are unblocked and single-threaded, and
//! these kernels are most of a likelihood evaluation at the sizes an exact GP is fitted at.
//! [`DenseFloor`] times them (the `fit_timing` example) to say how far a fit is from what they
//! allow.

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::{factor, inverse};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve;
use faer::{Accum, MatMut, MatRef, Side};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use serde::Serialize;

/// A column-major nalgebra matrix seen as a faer one (both store columns contiguously): no copy.
fn view(m: &DMatrix<f64>) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())
}

/// The same, writable.
fn view_mut(m: &mut DMatrix<f64>) -> MatMut<'_, f64> {
    let (r, c) = m.shape();
    MatMut::from_column_major_slice_mut(m.as_mut_slice(), r, c)
}

/// A faer matrix copied into nalgebra.
fn copy(m: MatRef<'_, f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

/// The Cholesky factorization of a symmetric positive definite matrix, in its own storage (its
/// lower triangle is read and overwritten by the factor; faer may use the upper triangle as scratch,
/// which nalgebra's `l_dirty` allows), or `None` when it is not positive definite.
pub fn cholesky(mut k: DMatrix<f64>) -> Option<Cholesky<f64, Dyn>> {
    let n = k.nrows();
    let par = faer::get_global_parallelism();
    let mut mem = MemBuffer::new(factor::cholesky_in_place_scratch::<f64>(
        n,
        par,
        Default::default(),
    ));
    factor::cholesky_in_place(
        view_mut(&mut k),
        Default::default(),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .ok()?;
    // A factor with a non-finite entry (from a non-finite input) is no factor.
    lower_finite(&k).then(|| Cholesky::pack_dirty(k))
}

/// Whether every entry of a square matrix's lower triangle is finite.
pub fn lower_finite(k: &DMatrix<f64>) -> bool {
    let n = k.nrows();
    k.as_slice()
        .chunks(n.max(1))
        .enumerate()
        .all(|(j, c)| c[j..].iter().all(|v| v.is_finite()))
}

/// L⁻¹ B, for the factor L of `chol` (its lower triangle read), in B's storage.
pub fn solve_lower(chol: &Cholesky<f64, Dyn>, mut b: DMatrix<f64>) -> DMatrix<f64> {
    triangular_solve::solve_lower_triangular_in_place(
        view(chol.l_dirty()),
        view_mut(&mut b),
        faer::get_global_parallelism(),
    );
    b
}

/// L⁻ᵀ B, for the factor L of `chol` (its lower triangle read), in B's storage.
pub fn solve_lower_transpose(chol: &Cholesky<f64, Dyn>, mut b: DMatrix<f64>) -> DMatrix<f64> {
    triangular_solve::solve_upper_triangular_in_place(
        view(chol.l_dirty()).transpose(),
        view_mut(&mut b),
        faer::get_global_parallelism(),
    );
    b
}

/// The lower triangle of K⁻¹ from the Cholesky factor of K, as L⁻ᵀ L⁻¹ (the triangular inverse,
/// then the triangular product: 2n³/3 flops); the strict upper triangle is zero. Only the
/// factor's lower triangle is read. The likelihood gradient needs no more than this.
pub fn inverse_lower(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let l = chol.l_dirty();
    let n = l.nrows();
    let par = faer::get_global_parallelism();
    let mut out = DMatrix::zeros(n, n);
    let mut mem = MemBuffer::new(inverse::inverse_scratch::<f64>(n, par));
    inverse::inverse(view_mut(&mut out), view(l), par, MemStack::new(&mut mem));
    out
}

/// K⁻¹ from the Cholesky factor of K ([`inverse_lower`], mirrored).
pub fn inverse_from_cholesky(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let mut inv = inverse_lower(chol);
    inv.fill_upper_triangle_with_lower_triangle();
    inv
}

/// The lower triangle of G Gᵀ (the strict upper triangle is zero): half a general product's flops.
pub fn outer_lower(g: &DMatrix<f64>) -> DMatrix<f64> {
    let n = g.nrows();
    let mut out = DMatrix::zeros(n, n);
    triangular::matmul(
        view_mut(&mut out),
        BlockStructure::TriangularLower,
        Accum::Replace,
        view(g),
        BlockStructure::Rectangular,
        view(g).transpose(),
        BlockStructure::Rectangular,
        1.0,
        faer::get_global_parallelism(),
    );
    out
}

/// A − G Gᵀ in A's lower triangle (its strict upper triangle is left alone).
pub fn subtract_outer_lower(a: &mut DMatrix<f64>, g: &DMatrix<f64>) {
    triangular::matmul(
        view_mut(a),
        BlockStructure::TriangularLower,
        Accum::Add,
        view(g),
        BlockStructure::Rectangular,
        view(g).transpose(),
        BlockStructure::Rectangular,
        -1.0,
        faer::get_global_parallelism(),
    );
}

/// How far an exact fit is from what this machine's dense linear algebra allows: every likelihood
/// evaluation factors K (n³/3 flops) and inverts it from the factor (2n³/3), so the floor is the
/// fit's likelihood count times one such pair, timed here at the same n. The rest of a fit's time
/// is the O(n²) work around them and the search's own.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct DenseFloor {
    /// Likelihood evaluations of the fit's optimizer runs.
    pub likelihoods: u64,
    /// One Cholesky + inverse at the fit's n, the best of three, s.
    pub dense_seconds: f64,
    /// n³ over that time.
    pub gflops: f64,
    /// `likelihoods` × `dense_seconds`.
    pub floor_seconds: f64,
    /// The fit's time over the floor.
    pub ratio: f64,
}

impl DenseFloor {
    /// Times the dense pair at `n` and sets a fit of `likelihoods` evaluations that took
    /// `fit_seconds` against it.
    pub fn measure(n: usize, likelihoods: u64, fit_seconds: f64) -> Self {
        // Symmetric, off-diagonal entries within ±0.5 and n on the diagonal: diagonally dominant,
        // so positive definite without a product of its own to build.
        let k = DMatrix::from_fn(n, n, |i, j| match (i.min(j), i.max(j)) {
            (a, b) if a == b => n as f64,
            (a, b) => ((a * 7 + b * 13) % 17) as f64 / 17.0 - 0.5,
        });
        let dense_seconds = (0..3)
            .map(|_| {
                let t = Instant::now();
                let chol = cholesky(k.clone()).expect("diagonally dominant: positive definite");
                std::hint::black_box(inverse_lower(&chol));
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        let floor_seconds = likelihoods as f64 * dense_seconds;
        Self {
            likelihoods,
            dense_seconds,
            gflops: (n as f64).powi(3) / dense_seconds * 1e-9,
            floor_seconds,
            ratio: fit_seconds / floor_seconds,
        }
    }
}

/// The eigendecomposition of a symmetric matrix (lower triangle read): eigenvalues in
/// nondecreasing order and the orthonormal eigenvectors as columns, or `None` when it does not
/// converge.
pub fn symmetric_eigen(a: &DMatrix<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
    let evd = view(a).self_adjoint_eigen(Side::Lower).ok()?;
    let s = evd.S().column_vector();
    let values = DVector::from_fn(s.nrows(), |i, _| s[i]);
    Some((values, copy(evd.U())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd(n: usize) -> DMatrix<f64> {
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.5);
        &a * a.transpose() + DMatrix::identity(n, n) * 0.1
    }

    #[test]
    fn factor_and_inverse_agree_with_nalgebra() {
        let k = spd(70);
        let ours = cholesky(k.clone()).unwrap();
        let reference = Cholesky::new(k.clone()).unwrap();
        assert!((ours.l() - reference.l()).amax() < 1e-10);
        let inv = inverse_from_cholesky(&ours);
        assert!((&inv * &k - DMatrix::identity(70, 70)).amax() < 1e-8);
        assert_eq!(inv, inv.transpose());
    }

    #[test]
    fn the_outer_products_lower_triangle_is_nalgebras() {
        let g = DMatrix::from_fn(40, 40, |i, j| ((i * 5 + j * 11) % 13) as f64 - 6.0);
        let full = &g * g.transpose();
        let lower = outer_lower(&g);
        assert_eq!(
            lower.upper_triangle(),
            DMatrix::from_diagonal(&full.diagonal())
        );
        assert!((lower.lower_triangle() - full.lower_triangle()).amax() < 1e-9);
    }

    #[test]
    fn an_indefinite_matrix_has_no_factor() {
        let mut k = spd(5);
        k[(2, 2)] = -1.0;
        assert!(cholesky(k).is_none());
    }

    #[test]
    fn triangular_solves_read_only_the_factor() {
        // A dirty factor: its strict upper triangle holds what the factorization left, not zeros.
        let k = spd(90);
        let chol = cholesky(k.clone()).unwrap();
        let l = chol.l();
        let b = DMatrix::from_fn(90, 3, |i, j| (i as f64 * 0.37 + j as f64).sin());
        let x = solve_lower(&chol, b.clone());
        assert!((&l * &x - &b).amax() < 1e-9);
        let xt = solve_lower_transpose(&chol, b.clone());
        assert!((l.transpose() * &xt - &b).amax() < 1e-9);
    }

    #[test]
    fn eigenvectors_reconstruct_the_matrix() {
        let a = spd(40);
        let (values, vectors) = symmetric_eigen(&a).unwrap();
        assert!(values.as_slice().windows(2).all(|w| w[0] <= w[1]));
        let back = &vectors * DMatrix::from_diagonal(&values) * vectors.transpose();
        assert!((back - a).amax() < 1e-9);
    }
}
