//! The summary statistics every layer uses, defined once, and the step of a quantized record.
//! Each is NaN for no values: an RMS of nothing is not zero error, and a NaN shows in a report
//! where a zero would pass for a result. The extent of nothing is (∞, −∞), the identities of min
//! and max, inside which no value lies.

/// Arithmetic mean; NaN for no values.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Root mean square; NaN for no values.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

/// Standard deviation about the mean, dividing by n (the spread of these values, not an estimate
/// of a population's); NaN for no values.
pub fn spread(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// The lowest and the highest value (NaN skipped, as `f64::min` and `f64::max` skip it); (∞, −∞)
/// for no values.
pub fn extent(v: impl IntoIterator<Item = f64>) -> (f64, f64) {
    v.into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
}

/// The value at quantile `q` ∈ [0, 1] of `sorted` (ascending), the nearest rank: no
/// interpolation between two values. NaN for no values.
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        n => sorted[((q.clamp(0.0, 1.0) * (n - 1) as f64).round() as usize).min(n - 1)],
    }
}

/// Median; NaN for no values.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let h = s.len() / 2;
    if s.len() % 2 == 1 {
        s[h]
    } else {
        0.5 * (s[h - 1] + s[h])
    }
}

/// A least-squares straight line y = intercept + slope·x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// y at x = 0.
    pub intercept: f64,
    /// dy/dx.
    pub slope: f64,
}

impl Line {
    /// The least-squares line through (x, y) pairs; `None` where x does not vary (or there are
    /// no pairs), which each caller settles in its own terms.
    pub fn fit(xy: impl IntoIterator<Item = (f64, f64)>) -> Option<Line> {
        let (x, y): (Vec<f64>, Vec<f64>) = xy.into_iter().unzip();
        let (mx, my) = (mean(&x), mean(&y));
        let sxx: f64 = x.iter().map(|u| (u - mx).powi(2)).sum();
        let sxy: f64 = x.iter().zip(&y).map(|(u, v)| (u - mx) * (v - my)).sum();
        (sxx > 0.0).then(|| {
            let slope = sxy / sxx;
            Line {
                intercept: my - slope * mx,
                slope,
            }
        })
    }

    /// The line's value at `x`.
    pub fn at(&self, x: f64) -> f64 {
        self.intercept + self.slope * x
    }
}

/// The step of a quantized signal: where every value of `values` is a whole multiple of one step
/// (a decimated logger keeps the ADC's raw steps; an averaging one does not) and the values repeat
/// (fewer distinct values than half the samples), that step; `None` otherwise. Quantization adds
/// white noise of step/√12 per sample, which the Allan deviation reads as angle random walk
/// (the trainer's `allan::quantization_arw`).
pub fn quantization_step(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 20 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    v.dedup();
    let step = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    if !(step.is_finite() && step > 0.0) || 2 * v.len() > values.len() {
        return None;
    }
    let whole = v.iter().all(|x| {
        let k = x / step;
        (k - k.round()).abs() < 1e-3
    });
    whole.then_some(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_statistic_follows_its_definition_and_is_nan_for_nothing() {
        assert_eq!(rms(&[3.0, -4.0]), (12.5f64).sqrt());
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
        assert_eq!(spread(&[1.0, 3.0]), 1.0);
        assert_eq!(median(&[3.0, 1.0, 2.0, 10.0]), 2.5);
        assert!(rms(&[]).is_nan() && mean(&[]).is_nan() && median(&[]).is_nan());
        let l = Line::fit([(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert_eq!((l.intercept, l.slope, l.at(3.0)), (1.0, 2.0, 7.0));
        assert_eq!(Line::fit([(1.0, 1.0), (1.0, 2.0)]), None);
        let sorted = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(
            [0.0, 0.25, 0.6, 1.0, 2.0].map(|q| quantile(&sorted, q)),
            [1.0, 2.0, 3.0, 5.0, 5.0]
        );
        assert!(quantile(&[], 0.5).is_nan());
    }
}
