//! The error model's terms fitted to out-of-sample residuals (the parent module's doc): which
//! terms the residuals can show at all, the likelihood's maximum over those, the small-sample
//! factor on what it finds, and the prior where they cannot show a term.

use fog_data::sigma::Coverage;
use fog_data::stats::rms;
use rcompat_lbfgsb::{Bounds, OptimControl, optim_lbfgsb_with_gradient};

use super::{
    A_WIDTH, Calibration, DETECTED, EXTRAPOLATION, ErrorModel, MAX_RHO, MIN_DOF, MIN_POWER_ONS,
    MIN_SEEN, OWN_DRAW, Prior, Residual, ResidualSource, SEEN_AT, SPLIT_MARGIN, SampleNoise,
    Series, SourceSummary, TERM_NAMES, TERMS, WALK, small_sample_factor,
};

/// Independent residuals a series is worth: n (1 − ρ)/(1 + ρ), ρ the lag-1 autocorrelation of
/// its standardized residuals (clamped to 0 … [`MAX_RHO`]).
pub(super) fn effective(z: &[f64]) -> f64 {
    let n = z.len() as f64;
    if z.len() < 3 {
        return n;
    }
    let mean = z.iter().sum::<f64>() / n;
    let c0: f64 = z.iter().map(|v| (v - mean).powi(2)).sum();
    let c1: f64 = z.windows(2).map(|w| (w[0] - mean) * (w[1] - mean)).sum();
    let rho = if c0 > 0.0 {
        (c1 / c0).clamp(0.0, MAX_RHO)
    } else {
        0.0
    };
    n * (1.0 - rho) / (1.0 + rho)
}

/// Fits the error model to `series` (module doc); `noise` is one sample's white noise. A table's
/// residuals and a run's each get their floor; the blob carries the run's where there are runs
/// (a gyro in service is in one, with every group of the table trained), the table's otherwise.
/// A term the residuals cannot show is `prior`'s (module doc).
pub fn calibrate(series: &[Series], noise: SampleNoise, prior: Prior) -> Calibration {
    let power_ons = power_on_means(series);
    let centred;
    let series = match &power_ons {
        Some(means) => {
            centred = centre(series, means);
            centred.as_slice()
        }
        None => series,
    };
    let all: Vec<(Residual, bool)> = series
        .iter()
        .flat_map(|s| s.residuals.iter().map(|r| (*r, s.source.is_run())))
        .filter(|(r, _)| r.usable())
        .collect();
    if all.len() < 3 {
        return Calibration::assumed(
            noise,
            prior,
            format!(
                "{} out-of-sample residuals in the training data: too few to measure the model \
                 error",
                all.len()
            ),
        );
    }
    let mut seen = seen(&all);
    let mut c = maximum_likelihood(&all, &seen);
    // The extrapolation term is fitted where the residuals reach beyond the range; it is used
    // wherever a sample does, often many widths further. Residuals that cannot tell a growth of
    // the prior's size (its mean over the training points, whatever its split by the output)
    // from none abstain, and the prior is assumed; so do residuals scored under another rule
    // beyond the range than the blob's (they follow the GP there), where there is a prior to
    // assume: with none (no temperature input) the term fitted stands. The other terms are then
    // fitted without it. (Kept in their fit beside them, as the GP's miss, it left acc x of the
    // MEMS log 5.64× too wide held out, against 4.55×; the simulated cool-down calibrated on
    // 60 → 43 °C 0.29, against 4.19.)
    let other_rule = !prior.follows && prior.extrapolation_var > 0.0;
    if seen[EXTRAPOLATION]
        && (other_rule || !extrapolation_shows(series, &c, prior.extrapolation_var))
    {
        seen[EXTRAPOLATION] = false;
        c = maximum_likelihood(&all, &seen);
    }
    let fitted: Vec<usize> = (0..TERMS).filter(|&k| seen[k]).collect();
    let standardized: Vec<Vec<f64>> = series
        .iter()
        .map(|s| {
            s.residuals
                .iter()
                .map(|r| r.error / r.var(s.source.is_run(), &c).sqrt())
                .filter(|z| z.is_finite())
                .collect()
        })
        .collect();
    let eff: f64 = standardized.iter().map(|z| effective(z)).sum();
    // Each power-on's mean taken out of its residuals is one more number fitted on them.
    let centred_means = power_ons.as_ref().map_or(0, Vec::len);
    let dof = (eff - (fitted.len() + centred_means) as f64).max(MIN_DOF);
    let inflation = small_sample_factor(dof);
    let fit = c;
    let mut c = c.map(|v| v * inflation);
    // A forward split scores one stretch of the bias's random walk, which may wander far less
    // (or more) than the walk does: where it fits less than the training log's Allan deviation
    // reads ([`Prior::walk_var_per_h`]), or shows none, the Allan's stands. (On twelve simulated
    // room logs, the σ of the earlier half fitted on the later covered 80.5 % of its 60 s means
    // with the split's walk alone, 86.0 % with the Allan deviation's read on the shipped model's
    // errors, and covers 93.1 % with it read on the forward split's model's too.) The other
    // terms keep their fit beside the split's walk: a trend it fitted in the walk's place stays
    // beside the Allan's (wide, never narrow).
    let allan_walk = c[WALK] < prior.walk_var_per_h;
    let walk_fitted_std = (allan_walk && seen[WALK]).then(|| c[WALK].sqrt());
    if allan_walk {
        c[WALK] = prior.walk_var_per_h;
    }
    // A fit below the prior measures the growth only as far out as its residuals reach: a
    // stream's temperature split, a tenth of a width beyond the range. Less growth there says
    // the model holds near its edge, not that a width out costs less than its own trend there (a
    // bias that bends beyond the range grows faster than the distance): the prior stands, unless
    // the residuals reach a whole width ([`reached`]). It is compared as the fit is, one
    // number over the points' outputs, and ships told apart by them: at low rates it may state
    // less than the fit, at high rates more. The other terms keep their fit beside the growth
    // fitted, which is what the residuals beyond showed. (With the prior, the simulated power-on
    // log fitted on its later half covers its colder earlier half 95 %, not 78 %; with the other
    // terms refitted without the growth, as where the residuals cannot tell it, a heating-only
    // ramp's σ was 14× its error.)
    let fitted_below = seen[EXTRAPOLATION]
        && c[EXTRAPOLATION] < prior.extrapolation_var
        && !reached(&all, EXTRAPOLATION, A_WIDTH);
    let extrapolation_fitted_std = fitted_below.then(|| c[EXTRAPOLATION].sqrt());
    let mut assumed = Vec::new();
    let mut extrapolation_scale = 0.0;
    let mut extrapolation_share = 1.0;
    if (fitted_below || !seen[EXTRAPOLATION]) && prior.extrapolation_var > 0.0 {
        (c[EXTRAPOLATION], extrapolation_scale) = prior.extrapolation_parts;
        extrapolation_share = prior.rule_share;
        assumed.push(TERM_NAMES[EXTRAPOLATION]);
    }
    let runs = all.iter().any(|(_, run)| *run);
    // What the blob carries: the run's floor (the table's where there is no run), for every
    // residual alike.
    let floor = if runs { c[1] } else { c[0] };
    let shipped = [0.0, floor, c[EXTRAPOLATION], c[WALK], c[4]];
    let shipped_sigma =
        |r: &Residual| (r.var(true, &shipped) + extrapolation_scale * r.output2 * r.excess2).sqrt();
    let sources = summaries(series, &standardized, &shipped_sigma);
    let scored: Vec<&Residual> = all
        .iter()
        .filter(|(_, run)| *run || !runs)
        .map(|(r, _)| r)
        .collect();
    // The residuals' error in proportion to the output inside the trained range, beyond what the
    // predicting model states: what another power-on's scale factor is assumed to differ by
    // where nothing states it ([`Calibration::assume_scale`]). Beyond the range the error grows
    // with the output as the model's slope does, which the extrapolation term states.
    let residual_scale = proportional_error(&all, &fit, noise.var.sqrt(), eff / all.len() as f64);
    let turn_on_var = power_ons.as_deref().map(between_power_ons);
    // Another power-on's scale factor, where the power-ons were left out: their residuals' error
    // in proportion to the output, fitted on theirs alone, widened for as many draws as the bias
    // is. Over a table's rates, positive and negative alike, a scale moves no power-on's mean
    // error, and stays in what centring leaves.
    let scale_var = power_ons.as_ref().map(|means| {
        let theirs: Vec<(Residual, bool)> = series
            .iter()
            .filter(|s| s.source == ResidualSource::PowerOn)
            .flat_map(|s| s.residuals.iter().map(|r| (*r, true)))
            .filter(|(r, _)| r.usable())
            .collect();
        let z: Vec<f64> = theirs
            .iter()
            .map(|(r, run)| r.error / r.var(*run, &fit).sqrt())
            .filter(|z| z.is_finite())
            .collect();
        let independent = effective(&z) / theirs.len().max(1) as f64;
        proportional_error(&theirs, &fit, noise.var.sqrt(), independent)
            * small_sample_factor(means.len() as f64 - 1.0)
    });
    let error_model = ErrorModel {
        sample_noise_var: noise.var as f32,
        sample_interval_s: noise.interval_s as f32,
        floor_var: floor as f32,
        extrapolation_var: c[EXTRAPOLATION] as f32,
        walk_var_per_h: c[WALK] as f32,
        trend_var_per_h2: c[4] as f32,
        extrapolation_scale_var: extrapolation_scale as f32,
        turn_on_var: turn_on_var.unwrap_or(0.0) as f32,
        scale_var: scale_var.unwrap_or(0.0) as f32,
        ..ErrorModel::noise_only(0.0)
    };
    Calibration {
        error_model,
        sample_noise_std: noise.var.sqrt(),
        sample_interval_s: noise.interval_s,
        floor_std: floor.sqrt(),
        table_floor_std: (runs && seen[0]).then(|| c[0].sqrt()),
        extrapolation_std: c[EXTRAPOLATION].sqrt(),
        extrapolation_scale_ppm: extrapolation_scale.sqrt() * 1e6,
        extrapolation_share,
        extrapolation_fitted_std,
        walk_std_per_sqrt_h: c[WALK].sqrt(),
        walk_fitted_std,
        walk_read: prior.walk_read.filter(|_| allan_walk),
        trend_std_per_h: c[4].sqrt(),
        turn_on_std: (turn_on_var.unwrap_or(0.0) / OWN_DRAW).sqrt(),
        power_ons_left_out: power_ons.as_ref().map(Vec::len),
        scale_repeatability_ppm: (scale_var.unwrap_or(0.0) / OWN_DRAW).sqrt() * 1e6,
        residual_scale_ppm: residual_scale.sqrt() * 1e6,
        output_rms: output_rms(&all, noise.var.sqrt()),
        tempco_per_c: None,
        trained_width_c: None,
        residuals: all.len(),
        effective: eff,
        inflation,
        fitted_terms: fitted
            .iter()
            .filter(|&&k| !(fitted_below && k == EXTRAPOLATION))
            .filter(|&&k| !(allan_walk && k == WALK))
            .map(|&k| TERM_NAMES[k])
            .collect(),
        sources,
        before: Some(coverage(&scored, &|r| r.base_var.sqrt())),
        coverage: Some(coverage(&scored, &shipped_sigma)),
        note: None,
        assumed,
        measured: [
            ("turn-on", turn_on_var.is_some()),
            ("scale", scale_var.is_some_and(|v| v > 0.0)),
            ("walk", allan_walk),
        ]
        .into_iter()
        .filter(|(_, measured)| *measured)
        .map(|(name, _)| name)
        .collect(),
        legs_trained: None,
        leg_std: 0.0,
        hysteresis: None,
        heating: super::heating::Heating::default(),
    }
}

/// Each power-on left out ([`ResidualSource::PowerOn`]) with a usable residual: its index in
/// `series` and its mean error, where there are at least [`MIN_POWER_ONS`]; `None` otherwise.
fn power_on_means(series: &[Series]) -> Option<Vec<(usize, f64)>> {
    let means: Vec<(usize, f64)> = series
        .iter()
        .enumerate()
        .filter(|(_, s)| s.source == ResidualSource::PowerOn)
        .filter_map(|(i, s)| {
            let e: Vec<f64> = s
                .residuals
                .iter()
                .filter(|r| r.usable())
                .map(|r| r.error)
                .collect();
            let mean = e.iter().sum::<f64>() / e.len() as f64;
            mean.is_finite().then_some((i, mean))
        })
        .collect();
    (means.len() >= MIN_POWER_ONS).then_some(means)
}

/// `series` with each power-on left out less its mean error (`means`, as [`power_on_means`]),
/// and without a power-on that has none: what is left is the in-run error the other terms are
/// fitted to.
fn centre(series: &[Series], means: &[(usize, f64)]) -> Vec<Series> {
    series
        .iter()
        .enumerate()
        .filter_map(|(i, s)| {
            if s.source != ResidualSource::PowerOn {
                return Some(s.clone());
            }
            let (_, m) = means.iter().find(|(j, _)| *j == i)?;
            let mut s = s.clone();
            for r in &mut s.residuals {
                r.error -= m;
            }
            Some(s)
        })
        .collect()
}

/// The variance of another power-on's mean error about the model, measured on the power-ons left
/// out: the mean of their squared mean errors (`means`), widened by the small-sample factor for
/// one degree of freedom fewer than power-ons (left out of a stream in turn, each is scored
/// against the others' mean: their errors nearly sum to 0). Four power-ons are four draws of a
/// turn-on, however many residuals each holds. Nothing is taken off for the noise of a mean:
/// centred, the residuals leave each power-on's mean model error to this term alone.
fn between_power_ons(means: &[(usize, f64)]) -> f64 {
    let k = means.len() as f64;
    means.iter().map(|(_, m)| m * m).sum::<f64>() / k * small_sample_factor(k - 1.0)
}

/// How `sigma` covers the residuals `rs`.
fn coverage(rs: &[&Residual], sigma: &dyn Fn(&Residual) -> f64) -> Coverage {
    let errors: Vec<f64> = rs.iter().map(|r| r.error).collect();
    let sigmas: Vec<f64> = rs.iter().map(|r| sigma(r)).collect();
    Coverage::of(&errors, &sigmas)
}

/// Each series' residuals summed up: their count, independent count (from their `standardized`
/// values), RMS and how the shipped `sigma` covers them.
fn summaries(
    series: &[Series],
    standardized: &[Vec<f64>],
    sigma: &dyn Fn(&Residual) -> f64,
) -> Vec<SourceSummary> {
    series
        .iter()
        .zip(standardized)
        .filter(|(s, _)| !s.residuals.is_empty())
        .map(|(s, z)| {
            let rs: Vec<&Residual> = s.residuals.iter().collect();
            SourceSummary {
                source: s.source,
                n: rs.len(),
                effective: effective(z),
                rmse: rms(&rs.iter().map(|r| r.error).collect::<Vec<_>>()),
                coverage: coverage(&rs, sigma),
            }
        })
        .collect()
}

/// Which terms the residuals can show: a floor where there are residuals of its kind; a growth
/// term where at least [`MIN_SEEN`] residuals reach [`SEEN_AT`] of its covariate (5% of a trained
/// width beyond the range, 3 minutes). A term fitted on covariates that barely move would be
/// extrapolated from nothing: residuals 0.01% of a width beyond the range say nothing about one
/// width beyond.
fn seen(all: &[(Residual, bool)]) -> [bool; TERMS] {
    let mut seen = [false; TERMS];
    for (_, run) in all {
        seen[0] |= !run;
        seen[1] |= *run;
    }
    for k in 2..TERMS {
        seen[k] = reached(all, k, SEEN_AT[k]);
    }
    seen
}

/// Whether at least [`MIN_SEEN`] residuals reach `at` of the covariate of term `k`: what [`seen`]
/// asks of every growth term, and [`A_WIDTH`] beyond the range (the distance the prior's growth
/// is stated for, [`Prior::of`]) what a fit below the prior must reach to stand.
fn reached(all: &[(Residual, bool)], k: usize, at: f64) -> bool {
    all.iter().filter(|(r, run)| r.terms(*run)[k] >= at).count() >= MIN_SEEN
}

/// Whether the residuals of `series` can tell an extrapolation term as large as the larger of the
/// fitted one (`c`) and the `prior`'s from none: that size at least [`DETECTED`] standard errors of
/// its estimate, the other terms held at their fit. The standard error is from the term's Fisher
/// information, ½ Σ e⁴ / v² (v each residual's variance with the term at that size), each series'
/// share reduced by its lag-1 autocorrelation as the small-sample factor's count is. Residuals a
/// tenth of a width beyond the range cannot show what two widths beyond costs, whatever they fit
/// there. (Counting the terms fitted beside it, a heating-only calibration's growth in time,
/// which rises with the distance as a heating leg does, would make it abstain there too, and the
/// prior, a clamp's error, is 14–20× too wide on the cooling leg its tangent or GP follows.) True
/// where there is no prior ([`Prior::NONE`]): [`seen`] decides alone.
pub(super) fn extrapolation_shows(series: &[Series], c: &[f64; TERMS], prior: f64) -> bool {
    let size = c[EXTRAPOLATION].max(prior);
    if prior <= 0.0 || size <= 0.0 {
        return true;
    }
    let mut at = *c;
    at[EXTRAPOLATION] = size;
    let information: f64 = series
        .iter()
        .map(|s| {
            let run = s.source.is_run();
            let (mut information, mut z) = (0.0, Vec::new());
            for r in s.residuals.iter().filter(|r| r.usable()) {
                let v = r.var(run, &at);
                if v > 0.0 {
                    information += 0.5 * (r.terms(run)[EXTRAPOLATION] / v).powi(2);
                    z.push(r.error / v.sqrt());
                }
            }
            if z.is_empty() {
                0.0
            } else {
                information * effective(&z) / z.len() as f64
            }
        })
        .sum();
    size * information.sqrt() >= DETECTED
}

/// How far beyond its model's trained range a residual may lie and still count as inside it
/// for the error in proportion to the output ([`proportional_error`], [`output_rms`]), widths
/// squared: nearer than the extrapolation term is seen at ([`SEEN_AT`]). A 60 s mean over a
/// table's sweep holds its extreme rates, a hair beyond the voltage input's trimmed range, so
/// that none of a stream's residuals lay exactly inside and none showed the scale.
const INSIDE: f64 = SEEN_AT[EXTRAPOLATION];

/// How many times a sample's noise the outputs must spread over to move
/// ([`proportional_error`], [`output_rms`], [`super::streams::allan_walk`],
/// [`super::split_by_output`]).
pub(super) const MOVES: f64 = 10.0;

/// The RMS reference output of the residuals inside the range ([`INSIDE`]), where the outputs
/// move: their spread about their mean, within a 60 s mean and across them, over [`MOVES`]
/// times a sample's noise and a thousandth of their RMS (a gyro or accelerometer at rest does
/// not, whatever its output, and its mean square less its squared mean is rounding). Else 0.
fn output_rms(all: &[(Residual, bool)], noise_std: f64) -> f64 {
    let inside: Vec<&Residual> = all
        .iter()
        .filter(|(r, _)| r.excess2 < INSIDE && r.output2.is_finite() && r.output.is_finite())
        .map(|(r, _)| r)
        .collect();
    let n = inside.len() as f64;
    let mean_u = inside.iter().map(|r| r.output2).sum::<f64>() / n;
    let mean_y = inside.iter().map(|r| r.output).sum::<f64>() / n;
    // Within each 60 s mean, and of the means about theirs (two passes: no cancellation there).
    let within = inside
        .iter()
        .map(|r| (r.output2 - r.output * r.output).max(0.0))
        .sum::<f64>()
        / n;
    let across = inside
        .iter()
        .map(|r| (r.output - mean_y).powi(2))
        .sum::<f64>()
        / n;
    let rms = mean_u.sqrt();
    let spread = (within + across).sqrt();
    if spread > MOVES * noise_std && spread > 1e-3 * rms {
        rms
    } else {
        0.0
    }
}

/// The residuals' model error in proportion to the output inside the trained range (nearer it
/// than [`INSIDE`]), as a variance per output² (relative²; [`Calibration::residual_scale_ppm`]
/// is its root): each residual there a Gaussian draw of variance `v + a + b·y²`, v what its
/// model states with the time terms `c` fitted beside it, a the floor of its kind (a table's, a
/// run's; refitted here), y its reference output (the root of its mean square); a, b ≥ 0 at the
/// likelihood's maximum. b
/// where the outputs move (their magnitudes' spread over ten times `noise_std`, as
/// [`split_by_output`](super::split_by_output) asks) and b makes the residuals more likely than
/// the floors alone by [`SPLIT_MARGIN`], the log-likelihood ratio counted over the independent
/// residuals they are worth (`independent`: the share of the residuals the small-sample factor
/// counts as independent, as neighbours in a series say much the same); else 0, and 0 where a
/// search fails. With b on its bound at 0, the margin, the χ²(1) 95 % point, makes a test at
/// about 2.5 %. The stated variance is an offset in each residual's variance, not taken off its
/// squared error: a squared error less it, clipped at 0, is no Gaussian draw, and where the
/// stated variance grows with the output the clipping alone made a part in proportion to it.
fn proportional_error(
    all: &[(Residual, bool)],
    c: &[f64; TERMS],
    noise_std: f64,
    independent: f64,
) -> f64 {
    let mut beside = *c;
    beside[0] = 0.0;
    beside[1] = 0.0;
    // Each residual's squared error, the variance stated for it, its output² and whether it is a
    // run's.
    let inside: Vec<(f64, f64, f64, bool)> = all
        .iter()
        .filter(|(r, _)| r.excess2 < INSIDE)
        .map(|(r, run)| (r.error * r.error, r.var(*run, &beside), r.output2, *run))
        .filter(|(e2, v, u, _)| e2.is_finite() && v.is_finite() && u.is_finite())
        .collect();
    let n = inside.len() as f64;
    let mean_e2 = inside.iter().map(|r| r.0).sum::<f64>() / n;
    let mean_u = inside.iter().map(|r| r.2).sum::<f64>() / n;
    let mean_y = inside.iter().map(|r| r.2.sqrt()).sum::<f64>() / n;
    let spread = (inside
        .iter()
        .map(|r| (r.2.sqrt() - mean_y).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    // False for a NaN noise, or no residuals, as well.
    if !(spread > MOVES * noise_std && mean_e2 > 0.0 && mean_u > 0.0) {
        return 0.0;
    }
    // p = (a of a table, a of a run, b), in units of the residuals' mean square error and of it
    // per mean output², so that the search sees numbers of order one.
    let nll = |p: &[f64]| -> (f64, Vec<f64>) {
        let (mut f, mut g) = (0.0, vec![0.0; 3]);
        for (e2, v, u, run) in &inside {
            let floor = usize::from(*run);
            let v = (v + (p[floor] + p[2] * u / mean_u) * mean_e2).max(f64::MIN_POSITIVE);
            f += 0.5 * (v.ln() + e2 / v);
            let dv = 0.5 * (1.0 / v - e2 / (v * v)) * mean_e2;
            g[floor] += dv;
            g[2] += dv * u / mean_u;
        }
        (f, g)
    };
    let floors: Vec<f64> = [false, true]
        .iter()
        .map(|kind| {
            if inside.iter().any(|r| r.3 == *kind) {
                1e6
            } else {
                0.0
            }
        })
        .collect();
    let start: Vec<f64> = floors.iter().map(|&u| 0.1f64.min(u)).chain([0.0]).collect();
    let Some(alike) = minimize(start, [floors.clone(), vec![0.0]].concat(), &nll) else {
        return 0.0;
    };
    // From the floors' own fit: the search only lowers the likelihood's negative from there, so
    // the ratio below is never negative.
    let Some(split) = minimize(alike.clone(), [floors, vec![1e6]].concat(), &nll) else {
        return 0.0;
    };
    let ratio = 2.0 * (nll(&alike).0 - nll(&split).0) * independent.min(1.0);
    if ratio.is_nan() || ratio < SPLIT_MARGIN {
        return 0.0;
    }
    split[2].max(0.0) * mean_e2 / mean_u
}

/// The c ≥ 0 that maximize the Gaussian likelihood of the residuals (module doc), for the terms
/// `seen` (the others 0). Each term is scaled to the residuals' size and its covariate's so the
/// search sees numbers of order one.
fn maximum_likelihood(all: &[(Residual, bool)], seen: &[bool; TERMS]) -> [f64; TERMS] {
    let scale = all.iter().map(|(r, _)| r.error * r.error).sum::<f64>() / all.len() as f64;
    if scale.is_nan() || scale <= 0.0 {
        return [0.0; TERMS];
    }
    let spread: Vec<f64> = (0..TERMS)
        .map(|k| {
            all.iter()
                .map(|(r, run)| r.terms(*run)[k])
                .fold(0.0f64, f64::max)
        })
        .collect();
    // u_k = c_k · spread_k / scale: the share of the residuals' variance term k explains at its
    // largest covariate.
    let unit = |k: usize| {
        if seen[k] && spread[k] > 0.0 {
            scale / spread[k]
        } else {
            0.0
        }
    };
    let nll = |u: &[f64]| -> (f64, Vec<f64>) {
        let mut f = 0.0;
        let mut g = vec![0.0; TERMS];
        for (r, run) in all {
            let phi = r.terms(*run);
            let v = r.base_var + (0..TERMS).map(|k| u[k] * unit(k) * phi[k]).sum::<f64>();
            let v = v.max(f64::MIN_POSITIVE);
            f += 0.5 * (v.ln() + r.error * r.error / v);
            let dv = 0.5 * (1.0 / v - r.error * r.error / (v * v));
            for (k, gk) in g.iter_mut().enumerate() {
                *gk += dv * unit(k) * phi[k];
            }
        }
        (f, g)
    };
    let upper: Vec<f64> = seen.iter().map(|&s| if s { 1e6 } else { 0.0 }).collect();
    let start: Vec<f64> = seen.iter().map(|&s| if s { 0.1 } else { 0.0 }).collect();
    let best = minimize(start.clone(), upper, &nll).unwrap_or(start);
    let mut c = [0.0; TERMS];
    for (k, ck) in c.iter_mut().enumerate() {
        *ck = best[k].max(0.0) * unit(k);
    }
    c
}

/// A negative log-likelihood: its value and gradient at a point.
type Objective<'a> = dyn Fn(&[f64]) -> (f64, Vec<f64>) + 'a;

/// The minimum of `f` within 0 … `upper`, searched from `start` by L-BFGS-B; `None` where the
/// search fails (an objective that is not a number on its way, say).
fn minimize(start: Vec<f64>, upper: Vec<f64>, f: &Objective) -> Option<Vec<f64>> {
    let n = start.len();
    let bounds = Bounds::new(vec![0.0; n], upper).ok()?;
    optim_lbfgsb_with_gradient(
        start,
        bounds,
        |p: &[f64]| f(p).0,
        |p: &[f64]| f(p).1,
        OptimControl {
            maxit: 500,
            ..OptimControl::default_for_dimension(n)
        },
    )
    .ok()
    .map(|r| r.par)
}
