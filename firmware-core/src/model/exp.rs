//! The kernel's exponential, eight at a time where the processor has vector registers.
//!
//! A host replay of a stream spends most of its time in `libm::expf`, once per sample and centre
//! (38 % of an investigation's, measured with `perf` on `trainer challenge --kind single`), and
//! the host must give the Cortex-M4's numbers bit for bit. [`expf_lanes`] computes exactly what
//! `libm::expf` does (FreeBSD's `e_expf.c`: the same operations in the same order, each IEEE
//! single-precision and correctly rounded), written without branches over a batch so that the
//! compiler vectorizes it; the few arguments outside its primary range (|x| ≥ 87.34, where the
//! result leaves the normal numbers, and NaN) are recomputed by `libm::expf` itself. The
//! Cortex-M4 has no vector unit, so there the evaluator calls `libm::expf` once per centre as
//! before: a batch would only add instructions.

/// Arguments per batch: two SSE registers, one AVX or two NEON ones.
pub(crate) const LANES: usize = 8;

// FreeBSD's constants, by their bits (as libm's `expf` gives them in its comments): a decimal
// short enough for the lints can round to a neighbour.
const LN2_HI: f32 = f32::from_bits(0x3f31_7200);
const LN2_LO: f32 = f32::from_bits(0x35bf_be8e);
const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b);
const P1: f32 = f32::from_bits(0x3e2a_aa8f);
const P2: f32 = f32::from_bits(0xbb35_5215);

/// |x| from here on (bits of the magnitude), libm takes its special cases: overflow, underflow
/// into the subnormals, NaN.
const SPECIAL: u32 = 0x42ae_ac50;
/// Above |x| = 1.5 ln 2 the reduction's multiple of ln 2 is computed; above 0.5 ln 2 it is ±1.
const FAR: u32 = 0x3f85_1592;
const NEAR: u32 = 0x3eb1_7218;
/// At or below |x| = 2⁻¹⁴, exp(x) is 1 + x.
const TINY: u32 = 0x3900_0000;

/// libm's `expf(x)` for |x| < 87.34 (bits of |x| below [`SPECIAL`]), branch-free: each `if`
/// selects between two values both computed, so a loop over it vectorizes.
#[inline(always)]
fn primary(x: f32) -> f32 {
    let bits = x.to_bits();
    let negative = bits >> 31 != 0;
    let hx = bits & 0x7fff_ffff;
    let (half, one) = if negative { (-0.5, -1.0) } else { (0.5, 1.0) };
    let kf = if hx > FAR {
        truncate(INV_LN2 * x + half)
    } else if hx > NEAR {
        one
    } else {
        0.0
    };
    // With k = 0 these are libm's hi = x, lo = 0 and x itself: x − 0·ln2hi and x − 0 are x,
    // −0 included.
    let hi = x - kf * LN2_HI;
    let lo = kf * LN2_LO;
    let r = hi - lo;
    let rr = r * r;
    let c = r - rr * (P1 + rr * P2);
    let y = 1.0 + (r * c / (2.0 - c) - lo + hi);
    // scalbnf(y, k) for −126 ≤ k ≤ 127 is one multiplication by 2ᵏ (k = 0: by 1). The biased
    // exponent k + 127 is read from the low bits of 2²³ + 127 + k, exact for those k.
    let biased = (kf + (EXACT_INTEGERS + 127.0)).to_bits() & 0x7f_ffff;
    let scaled = y * f32::from_bits(biased << 23);
    if hx <= TINY { 1.0 + x } else { scaled }
}

/// 2²³: from here every f32 is an integer, and below 2²⁴ adding it leaves an integer's value in
/// the low bits.
const EXACT_INTEGERS: f32 = 8_388_608.0;

/// `t` rounded toward zero, as libm's `t as i32` does (to a float here), for |t| < 2²²: rounded
/// to the nearest integer by adding and taking away 1.5·2²³, then moved one toward zero where
/// that went past `t`. Not `as i32` itself: its saturation keeps the compiler from vectorizing
/// the conversion (any |t| this large is an argument libm's special cases take).
#[inline(always)]
fn truncate(t: f32) -> f32 {
    const ROUND: f32 = 1.5 * EXACT_INTEGERS;
    let n = (t + ROUND) - ROUND;
    if t >= 0.0 && n > t {
        n - 1.0
    } else if t < 0.0 && n < t {
        n + 1.0
    } else {
        n
    }
}

/// `libm::expf` of each of `x`, in place, bit for bit (`N` arguments: [`LANES`] centres of one
/// sample, or one centre of [`super::LANES`] samples).
#[inline]
pub(crate) fn expf_lanes<const N: usize>(x: &mut [f32; N]) {
    let mut y = [0.0f32; N];
    for (y, x) in y.iter_mut().zip(x.iter()) {
        *y = primary(*x);
    }
    for (y, x) in y.iter_mut().zip(x.iter()) {
        if x.to_bits() & 0x7fff_ffff >= SPECIAL {
            *y = libm::expf(*x);
        }
    }
    *x = y;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every 97th bit pattern of f32 (44 million, each sign, NaNs and infinities included) and
    /// each boundary of libm's cases: the batch gives libm's bits. (Every pattern was compared
    /// once when this was written: none differs.)
    #[test]
    fn the_batch_is_libms_expf_bit_for_bit() {
        let edges = [
            SPECIAL,
            FAR,
            NEAR,
            TINY,
            0x42b1_7218,
            0x42cf_f1b5,
            0,
            0x7f80_0000,
        ];
        let near_edges = edges
            .iter()
            .flat_map(|&e| (0..5u32).map(move |d| e.wrapping_add(d).wrapping_sub(2)))
            .flat_map(|m| [m, m | 0x8000_0000]);
        let patterns = (0..=u32::MAX).step_by(97).chain(near_edges);
        let mut batch = [0.0f32; LANES];
        let mut fill = 0;
        let mut compared = 0u64;
        let mut check = |batch: &[f32; LANES], n: usize| {
            let mut y = *batch;
            expf_lanes(&mut y);
            for (x, y) in batch.iter().zip(y).take(n) {
                let want = libm::expf(*x);
                assert!(
                    want.to_bits() == y.to_bits() || (want.is_nan() && y.is_nan()),
                    "expf({x:e} = {:#x}): libm {want:e}, batch {y:e}",
                    x.to_bits()
                );
            }
            compared += n as u64;
        };
        for p in patterns {
            batch[fill] = f32::from_bits(p);
            fill += 1;
            if fill == LANES {
                check(&batch, LANES);
                fill = 0;
            }
        }
        check(&batch, fill);
        assert!(compared > 44_000_000, "{compared}");
    }
}
