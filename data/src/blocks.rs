//! The 60 s blocks every score and diagnosis averages over, cut one way: counted from a
//! stream's first sample, in time order. A block mean is where a gyro's white noise has fallen
//! below its drift, so the drift can be scored and seen. A stream's own are
//! `Stream::half_filled_blocks`.

/// Length of a block, s: of `rmse_60s_dps`, the diagnosis' residual, and the windows screened
/// for handling.
pub const BLOCK_S: f64 = 60.0;

/// The samples `idx` grouped into [`BLOCK_S`] blocks counted from the first sample of `time_s`,
/// in time order (every block, however few samples it holds).
pub fn group(time_s: &[f64], idx: &[usize]) -> Vec<Vec<usize>> {
    let t0 = time_s.first().copied().unwrap_or(0.0);
    let mut blocks: std::collections::BTreeMap<i64, Vec<usize>> = Default::default();
    for &i in idx {
        blocks
            .entry(((time_s[i] - t0) / BLOCK_S).floor() as i64)
            .or_default()
            .push(i);
    }
    blocks.into_values().collect()
}

/// The mean of `x` over each block.
pub fn means(x: &[f64], blocks: &[Vec<usize>]) -> Vec<f64> {
    blocks
        .iter()
        .map(|b| b.iter().map(|&i| x[i]).sum::<f64>() / b.len() as f64)
        .collect()
}
