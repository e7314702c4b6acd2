//! Which prior-mean basis a model is fitted with, chosen on the training points alone (`--mean
//! auto`, the default of `fit`, `investigate`, `report`'s logs, `loo` of the GP and `challenge`;
//! `reproduce`, and `loo` of another method, compare methods on physics).
//!
//! The physics basis ({1, t, t²} × {1, v, v³}: bias and scale factor quadratic in temperature)
//! is the sensor's form, and a rate table, which turns every rate at every temperature, holds
//! all nine of its terms. A stream need not: a 30-minute warm-up turned ±80 °/s only in its
//! warmest 1.5 °C, so the terms in t·v, t²·v and t²·v³ were fitted on a handful of points, and
//! their GLS coefficients carried the scale factor wrong wherever the high rates came at another
//! temperature, inside the trained range as much as beyond it. On four simulated gyros (the
//! nominal one and three random units) calibrated on such a warm-up and replayed on a cool-down,
//! the physics basis missed by 505 / 1,950 / 1,577 / 1,503 °/h and {1, t, v} by 283 / 293 / 221 /
//! 115 °/h; the GP's σ does not know (its variance leaves out the coefficients' uncertainty), and
//! stated 0.18–0.31× the physics basis's error on the three random units. On the whole 3-hour
//! warm-up physics was the better, 203 against 349 °/h.
//!
//! So each basis is tested as service meets it, on temperatures its model did not see: the
//! points are cut into [`BANDS`] bands of temperature, and each band is predicted by the model
//! fitted on the others, as the firmware predicts it (held at the fit's edge beyond its range,
//! [`beyond::score`]; plain GPs, without per-group offsets or an extension). Another basis than
//! physics ships only where physics's test ran and the other misses by less than [`MARGIN`] of
//! its miss: the bands' errors are one realization, and closer than that they cannot tell two
//! bases apart. The basis is then held, as the hyperparameters are, by every check the model
//! meets afterwards (a forward check, `loo`'s groups left out), which so see a choice made on
//! their own held-out points too. Those four warm-ups chose {1, t, v}; on the whole warm-up the
//! test abstains (below), and physics ships.
//!
//! Three tests that cannot see it: leave-one-out of single points (every point has neighbours at
//! its own temperature and rate; it preferred physics on two of the four and {1, t, v} on none);
//! the bands predicted as the GP follows its mean beyond them (physics missed the whole warm-up's
//! coldest band by 8 °/s, where the firmware holds it at the edge, and lost where it is the
//! better); and the test of the rule beyond the range (an inner fit scored on the points beyond
//! it, [`beyond::choose`]: it kept physics on all four warm-ups).
//!
//! A band held at its fold's edge misses by what the distance costs. Where the fold spans less
//! than [`MIN_FOLD_SHARE`] of its own temperatures and the band's together (the band reaches more
//! than four of its widths beyond it), the bands' errors cannot tell the bases apart, and the test
//! abstains, physics kept and said. The whole 3-hour warm-up holds its last temperature for two
//! and a half hours: two of its three bands are that plateau, and the fold fitted on them (0.2 °C)
//! predicts the ramp's band tens of its widths away.
//! On 25 random units so calibrated (docs/paper.md), the test had chosen {1, t, v} or degree 2 on
//! 12; their models were flat in temperature, and 9 of them stated a σ that covered 43–80 % of a
//! cool-down to −16 °C. Physics missed by less on 11 of the 12 there, and its σ covered 99–100 %.

use serde::Serialize;

use crate::analysis::{beyond, diagnose};
use crate::data::points::{self, Points};
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel, Inducing};
use crate::models::prior::MeanBasis;

/// The commands' default: the basis chosen.
pub const DEFAULT: MeanBasis = MeanBasis::Auto;
/// The bases tried, the sensor's form first.
pub const CANDIDATES: [MeanBasis; 3] = [MeanBasis::Physics, MeanBasis::Poly(1), MeanBasis::Poly(2)];
/// The share of physics's miss another basis must stay under to ship.
pub const MARGIN: f64 = 0.9;
/// Temperature bands left out in turn.
pub const BANDS: usize = 3;
/// The share of the temperatures of a fold and the band it predicts that the fold must span for
/// the test to see a basis: [`diagnose::VISIBLE`], the share under which the diagnosis's forward
/// test cannot see a cause's input move. A band held at its fold's edge misses by what the
/// distance costs; where the fold spans less (its band reaches more than four of its widths
/// beyond it), the bands' errors cannot tell the bases apart. A fold fitted on a plateau (two of
/// the three bands of a warm-up that holds its last temperature for hours) predicts the ramp's
/// band tens of its widths away: that test abstains.
pub const MIN_FOLD_SHARE: f64 = diagnose::VISIBLE;
/// Fewest points in a band: each fold's fit then has two per physics term, and keeps them all
/// (a basis keeps at most half as many terms as points, [`crate::models::prior::PolyPrior`]).
const MIN_PER_BAND: usize = 9;

/// The basis chosen and the evidence (`basis_choice` in `fit --json`).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct BasisChoice {
    /// The basis the model is fitted with.
    pub basis: MeanBasis,
    /// Each basis tried and its RMS error on the bands left out, output units (`null`: its test
    /// could not be fitted, the verdict says why); empty where none was tried (too many points,
    /// too few to band, or a band too far beyond the others for the test to see a basis).
    pub scores: Vec<BasisScore>,
    /// Why, in one line.
    pub verdict: String,
}

/// One basis tried.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct BasisScore {
    /// The basis.
    pub basis: MeanBasis,
    /// Its RMS error on the temperature bands left out, output units.
    pub rmse: Option<f64>,
}

/// `cfg` with the basis chosen for `points` where it asks for one ([`choose`]), and the choice.
pub fn resolve(points: &Points, cfg: &GpConfig) -> (GpConfig, Option<BasisChoice>) {
    let choice = choose(points, cfg);
    let mean = choice.as_ref().map_or(cfg.mean, |c| c.basis);
    (
        GpConfig {
            mean,
            ..cfg.clone()
        },
        choice,
    )
}

/// The basis chosen for `points` (module doc), the models fitted with `cfg`'s other settings;
/// `None` where `cfg` asks for a basis of its own (not [`MeanBasis::Auto`]).
pub fn choose(points: &Points, cfg: &GpConfig) -> Option<BasisChoice> {
    if cfg.mean != MeanBasis::Auto {
        return None;
    }
    let keep = |why: String| BasisChoice {
        basis: MeanBasis::Physics,
        scores: Vec::new(),
        verdict: format!("physics, not chosen: {why}"),
    };
    if points.len() > beyond::MAX_POINTS {
        return Some(keep(format!(
            "{} points are more than the {} the test fits an exact GP on",
            points.len(),
            beyond::MAX_POINTS
        )));
    }
    let Some(bands) = bands(&points.temp_c) else {
        return Some(keep(format!(
            "{} points over {:.1} °C cannot be cut into {BANDS} temperature bands of \
             {MIN_PER_BAND} points or more",
            points.len(),
            points::span(&points.temp_c)
        )));
    };
    if let Some((band, span, reach)) = blind_fold(&points.temp_c, &bands) {
        return Some(keep(format!(
            "with the {band} band left out, the others span {span:.2} °C and that band's \
             farthest point lies {reach:.2} °C beyond them: held at their edge so far, the \
             bands' errors cannot tell the bases apart"
        )));
    }
    // A basis of the same terms on these inputs as one before it is the same model (physics is
    // poly2 on a bias model's temperature alone).
    let d = points.inputs().ncols();
    let mut tried: Vec<MeanBasis> = Vec::new();
    for basis in CANDIDATES {
        if tried.iter().all(|t| t.exponents(d) != basis.exponents(d)) {
            tried.push(basis);
        }
    }
    let unit = points.quantity.unit();
    let mut missed = Vec::new();
    let scores: Vec<BasisScore> = tried
        .into_iter()
        .map(|basis| {
            let cfg = GpConfig {
                mean: basis,
                ..cfg.clone()
            };
            let rmse = match left_out_rmse(points, &cfg, &bands) {
                Ok(r) => {
                    missed.push(format!("{basis} {r:.3e} {unit}"));
                    Some(r)
                }
                Err(e) => {
                    missed.push(format!("{basis} not tested ({e:#})"));
                    None
                }
            };
            BasisScore { basis, rmse }
        })
        .collect();
    // The others that beat physics, best first; the first whose model the firmware's f32
    // carries ships (one that leaves the sine response's cubic to the GP can need weights that
    // cancel).
    let mut better: Vec<(MeanBasis, f64)> = scores[1..]
        .iter()
        .filter_map(|s| s.rmse.map(|r| (s.basis, r)))
        .filter(|(_, r)| scores[0].rmse.is_some_and(|p| *r < MARGIN * p))
        .collect();
    better.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut refused = Vec::new();
    let basis = better
        .into_iter()
        .find(|&(basis, _)| match carried_in_f32(points, cfg, basis) {
            Ok(()) => true,
            Err(e) => {
                refused.push(format!("; {basis} refused, {e:#}"));
                false
            }
        })
        .map_or(MeanBasis::Physics, |(b, _)| b);
    let verdict = format!(
        "{basis}: each of {BANDS} temperature bands predicted from the others (held at their \
         edge beyond them, as the firmware holds) misses by {} (RMS){}{}",
        missed.join(", "),
        refused.concat(),
        match (basis, scores[0].rmse) {
            (MeanBasis::Physics, None) => "; physics kept, its own test not run".to_owned(),
            (MeanBasis::Physics, Some(_)) if refused.is_empty() => format!(
                "; another basis ships only under {:.0} % of physics's",
                MARGIN * 100.0
            ),
            _ => String::new(),
        }
    );
    Some(BasisChoice {
        basis,
        scores,
        verdict,
    })
}

/// Each point's band: its plateau's where the points hold [`BANDS`] plateaus or more that share
/// out whole (a table's soaks), else its place among the temperatures sorted; contiguous, of
/// about equal counts. `None` where a band would hold fewer than [`MIN_PER_BAND`] points or the
/// temperatures do not span a plateau's gap.
fn bands(temps: &[f64]) -> Option<Vec<Vec<usize>>> {
    let n = temps.len();
    if n < BANDS * MIN_PER_BAND || points::span(temps) <= points::PLATEAU_GAP_C {
        return None;
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| temps[a].total_cmp(&temps[b]));
    let enough = |out: &Vec<Vec<usize>>| out.iter().all(|b| b.len() >= MIN_PER_BAND);
    let plateau = points::plateaus(temps);
    let plateaus = plateau.iter().max().map_or(0, |m| m + 1);
    if plateaus >= BANDS {
        let mut count = vec![0usize; plateaus];
        for &p in &plateau {
            count[p] += 1;
        }
        let mut before = 0;
        let mut band_of = vec![0; plateaus];
        for (p, c) in count.iter().enumerate() {
            let middle = before as f64 + *c as f64 / 2.0;
            band_of[p] = ((middle * BANDS as f64 / n as f64) as usize).min(BANDS - 1);
            before += c;
        }
        let mut out = vec![Vec::new(); BANDS];
        for &i in &order {
            out[band_of[plateau[i]]].push(i);
        }
        if enough(&out) {
            return Some(out);
        }
    }
    // Soaks too uneven to share out whole, or none: by rank, each band ending where the
    // temperature next changes, so that no temperature lies in two bands.
    let mut out = vec![Vec::new(); BANDS];
    let mut band = 0;
    for (rank, &i) in order.iter().enumerate() {
        let changes = rank == 0 || temps[i] > temps[order[rank - 1]];
        if changes && band + 1 < BANDS && rank >= (band + 1) * n / BANDS {
            band += 1;
        }
        out[band].push(i);
    }
    enough(&out).then_some(out)
}

/// The first band whose fold cannot see a basis ([`MIN_FOLD_SHARE`]), named (coldest, middle or
/// warmest), with the span of the temperatures fitted without it and how far beyond them the
/// band's farthest point lies, °C; `None` where every fold can. (A middle band lies between its
/// fold's temperatures, and never reaches beyond them.)
fn blind_fold(temps: &[f64], bands: &[Vec<usize>]) -> Option<(&'static str, f64, f64)> {
    (0..bands.len()).find_map(|b| {
        let (lo, hi) = fog_data::stats::extent(
            bands
                .iter()
                .enumerate()
                .filter(|(k, _)| *k != b)
                .flat_map(|(_, band)| band.iter().map(|&i| temps[i])),
        );
        let reach = bands[b]
            .iter()
            .map(|&i| (lo - temps[i]).max(temps[i] - hi))
            .fold(0.0, f64::max);
        let name = match b {
            0 => "coldest",
            b if b + 1 == bands.len() => "warmest",
            _ => "middle",
        };
        (hi - lo < MIN_FOLD_SHARE * (hi - lo + reach)).then_some((name, hi - lo, reach))
    })
}

/// Whether the model of `basis` fitted on every point (an exact GP, `cfg`'s other settings)
/// makes a blob the firmware's f32 follows ([`export::verify`]), or why not.
fn carried_in_f32(points: &Points, cfg: &GpConfig, basis: MeanBasis) -> anyhow::Result<()> {
    let cfg = GpConfig {
        mean: basis,
        inducing: Inducing::Exact,
        ..cfg.clone()
    };
    let model = GpModel::fit(points.inputs(), &points.target(), &cfg)?;
    let blob = export::points_blob(&model, points, &Extension::default())?;
    export::verify(&model, &blob, points, &Extension::default())?;
    Ok(())
}

/// The RMS error, over every point, of the model fitted with `cfg` on the other bands, held at
/// their edge beyond them; or why a fold could not be fitted or predicted.
fn left_out_rmse(points: &Points, cfg: &GpConfig, bands: &[Vec<usize>]) -> anyhow::Result<f64> {
    let mut sum = 0.0;
    for (b, band) in bands.iter().enumerate() {
        let others: Vec<usize> = bands
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != b)
            .flat_map(|(_, o)| o.iter().copied())
            .collect();
        let [hold, _, _] = beyond::score(points, &others, band, cfg)?;
        sum += hold * hold * band.len() as f64;
    }
    let rms = (sum / points.len() as f64).sqrt();
    anyhow::ensure!(rms.is_finite(), "its error is not finite");
    Ok(rms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_keeps_its_soaks_whole_and_a_stream_is_cut_by_rank() {
        // Seven soaks of six points each: whole plateaus, about equal counts.
        let table: Vec<f64> = (0..42)
            .map(|i| (i / 6) as f64 * 10.0 + 0.01 * i as f64)
            .collect();
        let b = bands(&table).unwrap();
        for band in &b {
            let soaks: std::collections::BTreeSet<usize> = band.iter().map(|i| i / 6).collect();
            for s in soaks {
                assert!((0..6).all(|k| band.contains(&(s * 6 + k))), "{b:?}");
            }
        }
        assert_eq!(b.iter().map(Vec::len).sum::<usize>(), 42);
        // A ramp: three bands of ten, coldest first.
        let ramp: Vec<f64> = (0..30).rev().map(|i| 20.0 + 0.1 * i as f64).collect();
        let b = bands(&ramp).unwrap();
        assert_eq!(b.iter().map(Vec::len).collect::<Vec<_>>(), [10, 10, 10]);
        assert!(b[0].iter().all(|&i| ramp[i] < 21.0), "{b:?}");
        // Uneven soaks (12, 15, 3 and 6 points) are shared out whole; one soak of 30 of 36
        // points cannot be, and is not banded.
        let uneven: Vec<f64> = (0..36)
            .map(|i| match i {
                0..12 => 0.0,
                12..27 => 10.0,
                27..30 => 20.0,
                _ => 30.0,
            })
            .collect();
        let b = bands(&uneven).unwrap();
        assert_eq!(b.iter().map(Vec::len).collect::<Vec<_>>(), [12, 15, 9]);
        let one_soak: Vec<f64> = (0..36).map(|i| if i < 30 { 0.0 } else { 10.0 }).collect();
        assert!(bands(&one_soak).is_none());
        // A stream read in 0.5 °C steps, five samples a step: cut by rank where the reading
        // changes, no temperature in two bands.
        let stepped: Vec<f64> = (0..36).map(|i| 20.0 + 0.5 * f64::from(i / 5)).collect();
        let b = bands(&stepped).unwrap();
        assert_eq!(b.iter().map(Vec::len).collect::<Vec<_>>(), [15, 10, 11]);
        for w in b.windows(2) {
            let below = w[0].iter().map(|&i| stepped[i]).fold(f64::MIN, f64::max);
            let above = w[1].iter().map(|&i| stepped[i]).fold(f64::MAX, f64::min);
            assert!(below < above, "{b:?}");
        }
        // Too few points, or no span, cannot be banded.
        assert!(bands(&ramp[..26]).is_none());
        assert!(bands(&[25.0; 30]).is_none());
    }

    #[test]
    fn bands_that_leave_a_plateau_to_fit_on_abstain() {
        // A warm-up: 30 points rising from 25 to 29.8 °C, then 60 held at 30.2–30.4 °C. Two of the
        // three bands are the plateau: the fold without the coldest band spans 0.2 °C, and that
        // band reaches 5.2 °C beyond it.
        let warm_up: Vec<f64> = (0..90)
            .map(|i| {
                if i < 30 {
                    25.0 + f64::from(i) / 6.0
                } else {
                    30.2 + 0.2 * f64::from(i - 30) / 59.0
                }
            })
            .collect();
        let b = bands(&warm_up).unwrap();
        let (band, span, reach) = blind_fold(&warm_up, &b).unwrap();
        assert_eq!(band, "coldest");
        assert!((0.1..0.3).contains(&span), "{span}");
        assert!((5.0..5.5).contains(&reach), "{reach}");
        // Mirrored, a cool-down onto a plateau: the warmest band is the one left to reach.
        let cool_down: Vec<f64> = warm_up.iter().map(|t| 55.0 - t).collect();
        let (band, _, reach) = blind_fold(&cool_down, &bands(&cool_down).unwrap()).unwrap();
        assert_eq!(band, "warmest");
        assert!((5.0..5.5).contains(&reach), "{reach}");
        // The ramp alone: each outer band reaches half a width beyond the other two.
        let ramp = &warm_up[..30];
        assert_eq!(blind_fold(ramp, &bands(ramp).unwrap()), None);
        // The bound: a band 3.9 of its fold's widths beyond it is seen, 4.1 is not.
        let reaching = |widths: f64| {
            let t: Vec<f64> = (0..30)
                .map(|i| match i {
                    0..10 => -widths + 0.01 * f64::from(i),
                    _ => f64::from(i - 10) / 19.0,
                })
                .collect();
            blind_fold(&t, &bands(&t).unwrap())
        };
        assert_eq!(reaching(3.9), None);
        assert!(reaching(4.1).is_some());
        // The choice abstains before fitting anything, and says why.
        let v: Vec<f64> = (0..90).map(|i| (f64::from(i) * 0.7).sin()).collect();
        let points = Points::new(
            warm_up,
            v.clone(),
            v.iter().map(|v| 2.0 * v).collect(),
            vec![String::new(); 90],
            None,
            false,
            None,
        );
        let auto = GpConfig {
            mean: DEFAULT,
            ..GpConfig::default()
        };
        let choice = choose(&points, &auto).unwrap();
        assert_eq!(choice.basis, MeanBasis::Physics);
        assert!(choice.scores.is_empty(), "{choice:?}");
        assert!(
            choice.verdict.contains("the coldest band left out"),
            "{}",
            choice.verdict
        );
    }

    #[test]
    fn a_basis_of_its_own_is_not_chosen_and_auto_is_refused_by_a_fit() {
        let t: Vec<f64> = (0..30).map(|i| 20.0 + 0.3 * f64::from(i)).collect();
        let v: Vec<f64> = t.iter().map(|x| (x * 7.0).sin()).collect();
        let rate: Vec<f64> = t.iter().zip(&v).map(|(t, v)| 2.0 * v + 1e-3 * t).collect();
        let make = |scale_factor| {
            let group = vec![String::new(); t.len()];
            let (t, v, rate) = (t.clone(), v.clone(), rate.clone());
            Points::new(t, v, rate, group, scale_factor, false, None)
        };
        let points = make(None);
        let own = GpConfig {
            mean: MeanBasis::Physics,
            ..GpConfig::default()
        };
        assert!(choose(&points, &own).is_none());
        let auto = GpConfig {
            mean: DEFAULT,
            ..GpConfig::default()
        };
        let refused = crate::models::gp::GpModel::fit(points.inputs(), &points.target(), &auto);
        assert!(
            matches!(refused, Err(crate::models::gp::GpError::UnchosenBasis)),
            "{refused:?}"
        );
        let (cfg, choice) = resolve(&points, &auto);
        let choice = choice.unwrap();
        assert_eq!(cfg.mean, choice.basis);
        assert_eq!(choice.scores.len(), 3, "{choice:?}");
        assert!(choice.scores.iter().all(|s| s.rmse.is_some()), "{choice:?}");
        // A bias model's temperature alone: physics is poly2 there, tried once.
        let bias = make(Some(0.5));
        let choice = choose(&bias, &auto).unwrap();
        let tried: Vec<MeanBasis> = choice.scores.iter().map(|s| s.basis).collect();
        assert_eq!(
            tried,
            [MeanBasis::Physics, MeanBasis::Poly(1)],
            "{choice:?}"
        );
    }
}
