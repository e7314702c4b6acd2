//! The one 1-D minimizer of the project: a golden-section search in a bracket from a starting
//! point, for the time constants that a grid finds roughly (a coil lag, a sensor lag) and that
//! need refining between the grid's neighbours. Written here rather than taken from an
//! optimization crate because it is twenty lines and the crate would pull in a dependency tree
//! for them; it follows the classic four-point scheme (the bracket ends and two interior points
//! in the golden ratio, one new evaluation per step).

/// The golden ratio φ.
const PHI: f64 = 1.618_033_988_749_895;
/// 1/φ = φ − 1: the share of the bracket kept at each step.
const G1: f64 = PHI - 1.0;
/// 1 − 1/φ.
const G2: f64 = 1.0 - G1;

/// The point and value of the least `f` found by golden-section search in `lo..=hi` from
/// `start`, stopping when the inner points are within `tolerance` (relative) of each other's
/// bracket or after `max_steps` steps. `Ok(None)` for an empty bracket, a start outside it, or a
/// function that never returned a finite value; an error of `f` stops the search.
pub fn golden_section<E>(
    mut f: impl FnMut(f64) -> Result<f64, E>,
    (lo, hi): (f64, f64),
    start: f64,
    tolerance: f64,
    max_steps: u32,
) -> Result<Option<(f64, f64)>, E> {
    if !(hi > lo && (lo..=hi).contains(&start)) {
        return Ok(None);
    }
    let (mut x0, mut x3) = (lo, hi);
    let (mut x1, mut x2) = if hi - start > start - lo {
        (start, start + G2 * (hi - start))
    } else {
        (start - G2 * (start - lo), start)
    };
    let (mut f1, mut f2) = (f(x1)?, f(x2)?);
    let mut best: Option<(f64, f64)> = None;
    let mut keep = |x1: f64, f1: f64, x2: f64, f2: f64| {
        let (x, v) = if f1 < f2 { (x1, f1) } else { (x2, f2) };
        if best.is_none_or(|(_, b)| v < b) && v < f64::INFINITY {
            best = Some((x, v));
        }
    };
    keep(x1, f1, x2, f2);
    for _ in 0..max_steps {
        if tolerance * (x1.abs() + x2.abs()) >= (x3 - x0).abs() {
            break;
        }
        if f2 < f1 {
            (x0, x1) = (x1, x2);
            x2 = G1 * x1 + G2 * x3;
            f1 = f2;
            f2 = f(x2)?;
        } else {
            (x3, x2) = (x2, x1);
            x1 = G1 * x2 + G2 * x0;
            f2 = f1;
            f1 = f(x1)?;
        }
        keep(x1, f1, x2, f2);
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_a_parabolas_minimum_from_either_side_and_refuses_an_empty_bracket() {
        for start in [0.0, 2.0, 10.0] {
            let (x, v) = golden_section(
                |x| Ok::<_, ()>((x - 3.0).powi(2) + 1.0),
                (0.0, 10.0),
                start,
                1e-6,
                100,
            )
            .unwrap()
            .unwrap();
            assert!((x - 3.0).abs() < 1e-4 && (v - 1.0).abs() < 1e-8, "{x} {v}");
        }
        assert_eq!(
            golden_section(Ok::<_, ()>, (1.0, 1.0), 1.0, 1e-3, 10),
            Ok(None)
        );
        assert_eq!(
            golden_section(|_| Err("no"), (0.0, 1.0), 0.5, 1e-3, 10),
            Err("no")
        );
    }
}
