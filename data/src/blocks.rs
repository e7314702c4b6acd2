//! The 60 s blocks every score and diagnosis averages over, cut one way: counted from a
//! stream's first sample, and again from wherever its clock runs back, in file order. A block mean is where a gyro's white noise has fallen
//! below its drift, so the drift can be scored and seen. A stream's own are
//! `Stream::half_filled_blocks`.

/// Length of a block, s: of `rmse_60s_dps`, the diagnosis' residual, and the windows screened
/// for handling.
pub const BLOCK_S: f64 = 60.0;

/// The samples `idx` grouped into [`BLOCK_S`] blocks counted from the first sample of `time_s`,
/// in file order (every block, however few samples it holds). A clock that runs back (a log of
/// power-ons each timed from its own start) starts the count again from there: a block holds
/// one stretch of the clock, so its mean is never of two power-ons at the same minute. A gap
/// does not start it again: a block can span a power-off shorter than itself.
pub fn group(time_s: &[f64], idx: &[usize]) -> Vec<Vec<usize>> {
    // Each sample's stretch, and the stretch's first time.
    let mut stretch = Vec::with_capacity(time_s.len());
    let mut origins = Vec::new();
    for (i, &t) in time_s.iter().enumerate() {
        if i == 0 || t < time_s[i - 1] {
            origins.push(t);
        }
        stretch.push(origins.len() - 1);
    }
    let mut blocks: std::collections::BTreeMap<(usize, i64), Vec<usize>> = Default::default();
    for &i in idx {
        let k = stretch[i];
        blocks
            .entry((k, ((time_s[i] - origins[k]) / BLOCK_S).floor() as i64))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_that_runs_back_starts_its_blocks_again() {
        // Two power-ons at 1 Hz, each timed 0…119 s.
        let time_s: Vec<f64> = (0..240).map(|i| f64::from(i % 120)).collect();
        let idx: Vec<usize> = (0..240).collect();
        let blocks = group(&time_s, &idx);
        assert_eq!(blocks.len(), 4);
        for (k, b) in blocks.iter().enumerate() {
            assert_eq!(*b, (60 * k..60 * (k + 1)).collect::<Vec<_>>());
        }
        // One clock: two blocks of a minute each, from its first sample.
        let one: Vec<f64> = (0..120).map(|i| 30.0 + f64::from(i)).collect();
        let blocks = group(&one, &(0..120).collect::<Vec<_>>());
        assert_eq!(blocks.iter().map(Vec::len).collect::<Vec<_>>(), [60, 60]);
    }
}
