//! The σ a shipped model states, measured on its own training data.
//!
//! A navigation filter takes the firmware's variance as the uncertainty of the rate, so it has to
//! hold where the model is wrong, not only where the GP's assumptions are right. The GP's latent
//! variance knows how far a sample lies from the data in the kernel's metric; it does not know a
//! cause the model lacks, a trend that the prior mean extrapolates, or the bias wandering after
//! the data ended. So the blob carries an error model besides it (firmware-core's
//! `blob::ErrorModel`; docs/design.md §4, "The σ contract"):
//!
//! ```text
//! bias variance  = latent(x) + c₀ + c_x·e(x)² + c_w·t + c_d·t²
//! noise variance = σ_w²                        (one sample; a mean of N has σ_w²/N)
//! ```
//!
//! with e(x) the distance beyond the trained range in its widths and t the hours since power-on.
//! Each term has a physical reading: c₀ what the model misses everywhere (an unmodelled cause),
//! c_x its growth beyond the temperatures trained, c_w the bias random walk, c_d a drift of
//! unknown rate; σ_w the white noise (angle random walk) of one sample.
//!
//! **Fitted from the training data alone.** The coefficients come from out-of-sample residuals of
//! the training data: a rate table's groups (or points) left out, closed form; a stream cut
//! forward in time, and across temperature, each part predicted by a model fitted without it
//! ([`Series`]). Each residual r of a 60 s mean or a point is taken as Gaussian with variance
//! `b + Σ c_k φ_k`, b what the predicting model already states (its latent variance and the noise
//! of the mean), φ = (1, e², t, t²); the c_k ≥ 0 maximize the likelihood (L-BFGS-B within the
//! bounds). A term whose covariate does not vary over the residuals is not fitted: those data
//! cannot see it, so it abstains (0).
//!
//! **Few residuals are weak evidence.** A variance estimated from ν independent residuals is
//! itself uncertain: the predictive distribution of the next error is a Student t, whose 95 %
//! interval is wider than ±2σ of the point estimate. The model-error terms are scaled by
//! (t₀.₉₇₅(ν)/1.96)², ν the effective number of independent residuals (each series' count reduced
//! by its lag-1 autocorrelation) less the terms fitted and the power-ons' means taken out of
//! their residuals, at least 2. With hundreds of residuals that factor is 1.
//!
//! **A walk is one path.** A forward split scores one stretch of the bias's random walk, which
//! may have wandered far less than the walk does. Where the training log's reference holds still
//! (a log at rest), the walk is also read from an Allan deviation (its +½ slope), at every
//! cluster time at once: of the shipped model's errors over the whole log, and of the forward
//! split's model's errors over the part it was not fitted on (in sample, the model's own fit
//! takes part of the walk up; a table's static model never saw the stream, so its errors are
//! read alone). Where the larger is more than the split fitted, or where there is no split, it
//! ships (`walk` in `measured`, `walk_read` names whose errors, `walk_fitted_std` the split's).
//!
//! **What the data cannot show, the σ assumes** ([`Prior`]). Absence of evidence is not a measured
//! zero: where the training data hold too few out-of-sample residuals for any term (a 30-minute
//! warm-up has no forward split), the floor is the GP's own noise level on its points inflated by
//! the small-sample factor at the fewest degrees of freedom; where no residual lies beyond the
//! temperatures fitted, or those there cannot tell a growth of the prior's size from none (under
//! two standard errors of its estimate, the other terms held at their fit), or fit less than it
//! short of the whole width the prior is stated for, or the blob does not
//! follow the GP beyond the range as they were scored ([`Prior::follows`]), the extrapolation term
//! is what the model itself changes over one trained width of its temperature (held at the range's
//! edge beyond it, the firmware misses that change per width): its trend next to the range's
//! edges (over the lower and over the upper half of the range, per width, at the other inputs of
//! the points it was fitted on, as an RMS; [`Prior::of`]), told apart by the points' reference
//! rates into a part alike at every output and one in proportion to it ([`split_by_output`]): a
//! gyro's scale factor drifts with temperature too. Where the mean follows a tangent or the GP
//! beyond the range instead, chosen because it missed less than holding on the training points
//! beyond an inner fit, the term is scaled by the share it missed there ([`Prior::for_rule`]);
//! under `follow`, the residuals' test of it then asks about that smaller growth. (At the points'
//! other inputs: along the temperature at inputs no point is near, a (T, V) model fitted on a
//! warm-up's shuffled rates is unconstrained; and the kernel's own expected change is no measure
//! either, its signal variance holding the whole rate response.) Another power-on's bias, which
//! one power-on's residuals cannot hold, is stated by a datasheet, measured by runs left out
//! (a table's, in the floor; a training stream's power-ons, as the mean of their squared mean
//! errors, widened by the small-sample factor for one degree of freedom fewer than power-ons,
//! the other terms fitted to what is left of their residuals), or else assumed as large as the
//! floor ([`Calibration::assume_turn_on`]); its scale factor, by a datasheet, measured on a
//! training stream's power-ons left out (their residuals' error in proportion to the output,
//! widened alike), or else assumed as large as the residuals' error in proportion to the output
//! inside the trained range, where they show one, and where they show none but the outputs move,
//! as large at their RMS as that bias ([`Calibration::assume_scale`]). Each assumed
//! term is named in the calibration (`assumed`), each measured one in `measured`, and both in its
//! one line.
//!
//! **A datasheet states what it knows better** ([`fog_data::channels::Datasheet`],
//! [`Calibration::state`]): the bias's and the scale factor's run-to-run repeatability, the
//! bias's temperature coefficient (the growth beyond the range: a part's bound, where the
//! model's own trend over a narrow band says nothing of a bias that turns over beyond it), and
//! the gap between the heating and the cooling leg, and how far the temperature sensor lags the
//! sensing element ([`heating`]: no term without it). Each takes the place of the term assumed
//! (beyond a range the mean is not held at, the growth its rule assumes stays beside the
//! datasheet's: [`Calibration::set_tempco`]).

use firmware_core::ErrorModel;
use fog_data::sigma::Coverage;
use fog_data::stats::{Line, median, spread};
use fog_data::stream::Stream;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

use crate::analysis::beyond::BeyondChoice;
use crate::data::points::Points;
use crate::firmware::export::{self, ExportError};
use crate::models::gp::GpModel;
use firmware_core::blob::Beyond;

pub mod heating;
mod stated;
pub mod streams;
pub mod tables;
pub mod terms;
mod words;

/// The model-error terms fitted: a floor for a table's residuals and one for a run's, then
/// e(x)², t and t² ([`Residual::terms`]).
const TERMS: usize = 5;
/// Fewest degrees of freedom the small-sample factor takes (module doc): below it a variance is
/// not estimated but guessed, and the factor would grow without bound (on σ, 6.5 at ν = 1).
const MIN_DOF: f64 = 2.0;
/// Residuals that must reach [`SEEN_AT`] for a growth term to be fitted ([`seen`]), and
/// [`A_WIDTH`] for an extrapolation term fitted below the prior to stand (`reached`).
const MIN_SEEN: usize = 3;
/// e² of a whole trained width beyond the range: where the prior's growth is stated.
const A_WIDTH: f64 = 1.0;
/// The covariate a residual must reach to show a growth term: e² at 5% of a width beyond the
/// range, t and t² at 3 minutes (the floors' entries are not used).
const SEEN_AT: [f64; TERMS] = [0.0, 0.0, 0.05 * 0.05, 0.05, 0.05 * 0.05];
/// Largest lag-1 autocorrelation taken: a series that drifts slowly still counts as one residual.
const MAX_RHO: f64 = 0.95;
/// The extrapolation term's index among [`TERMS`].
const EXTRAPOLATION: usize = 2;
/// The walk term's index among [`TERMS`].
const WALK: usize = 3;
/// A datasheet's run-to-run repeatability σ is the spread of one power-on's bias (or scale) about
/// the sensor's mean; the calibration's own power-on is one such draw, taken for the mean, and
/// service another, so their difference, the error, has twice its variance.
const OWN_DRAW: f64 = 2.0;
/// Standard errors of its estimate the prior's growth beyond the range must reach for the residuals
/// to show it ([`extrapolation_shows`]).
const DETECTED: f64 = 2.0;
/// Fewest power-ons of a training stream, each left out in turn, whose residuals measure another
/// power-on's bias rather than assume it: three, two degrees of freedom for their spread (with
/// two power-ons, one degree of freedom, the small-sample factor is 42).
pub const MIN_POWER_ONS: usize = 3;
/// A heating/cooling state the training data must reach on each side of 0 to hold both legs.
const BOTH_LEGS: f32 = 0.5;
/// The share of the trained temperatures a leg's states must span to count as held (a judgement:
/// most of the range, so that a turn's minutes at one end do not count; [`Calibration::set_legs`]).
const LEG_SPAN: f64 = 0.5;

/// Where a series of residuals comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ResidualSource {
    /// A rate table's groups, each left out in turn (closed form, hyperparameters held).
    Groups,
    /// Runs (power-ons) pooled, each left out in turn (closed form, hyperparameters held): a
    /// run left out carries its own turn-on bias, which the others cannot know.
    Runs,
    /// A rate table's points, each left out in turn (closed form).
    Points,
    /// A stream, forward in time: fitted on its earlier part, scored on the later one.
    Forward,
    /// A stream across temperature: fitted inside the middle of its span, scored outside.
    Temperature,
    /// A stream across its heating/cooling legs: fitted on one, scored on the other (a check of
    /// an extension; its residuals do not enter the σ).
    Leg,
    /// A stream the model was not fitted on.
    Stream,
    /// A training stream's power-ons, each left out in turn: fitted on the others, scored on it.
    /// Each carries its own turn-on bias, which the others cannot know.
    PowerOn,
}

impl ResidualSource {
    /// Whether its residuals are of a run (a stream), as a gyro meets in service, rather than of
    /// a rate table's groups or points.
    pub fn is_run(self) -> bool {
        matches!(
            self,
            Self::Forward | Self::Temperature | Self::Leg | Self::Stream | Self::PowerOn
        )
    }

    /// In words, for the terminal.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Groups => "from the table's groups left out",
            Self::Runs => "from the power-ons left out, one at a time",
            Self::Points => "from the table's points left out",
            Self::Forward => "from the training stream forward in time",
            Self::Temperature => "from the training stream beyond the temperatures fitted",
            Self::Leg => "from the training stream's other heating/cooling leg",
            Self::Stream => "from the training stream (not fitted on)",
            Self::PowerOn => "from the training stream's power-ons, each left out in turn",
        }
    }
}

/// One out-of-sample error: a 60 s mean of a stream, or a table point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    /// Prediction − reference, output units.
    pub error: f64,
    /// The variance the predicting model states for it without an error model: its latent
    /// variance and the noise of the mean (or point), output units².
    pub base_var: f64,
    /// e(x)²: how far beyond the predicting model's trained range, in widths, squared.
    pub excess2: f64,
    /// The reference output squared (its mean over a 60 s mean's samples), output units²: where
    /// the shipped σ's extrapolation has a part in proportion to the output, what it multiplies.
    pub output2: f64,
    /// The reference output (its mean over a 60 s mean's samples), output units.
    pub output: f64,
    /// Hours since the data the predicting model was fitted on (time since power-on, for a run it
    /// never saw).
    pub hours: f64,
}

impl Residual {
    /// Whether its error and stated variance are numbers a fit can take.
    fn usable(&self) -> bool {
        self.error.is_finite() && self.base_var.is_finite() && self.base_var >= 0.0
    }

    /// Its variance with the model-error terms `c`, for a residual of a run or of a table.
    fn var(&self, run: bool, c: &[f64; TERMS]) -> f64 {
        self.base_var
            + self
                .terms(run)
                .iter()
                .zip(c)
                .map(|(p, c)| p * c)
                .sum::<f64>()
    }

    /// The covariates of the model-error terms, for a residual of a run or of a table.
    fn terms(&self, run: bool) -> [f64; TERMS] {
        let (table, stream) = if run { (0.0, 1.0) } else { (1.0, 0.0) };
        [
            table,
            stream,
            self.excess2,
            self.hours,
            self.hours * self.hours,
        ]
    }
}

/// Residuals of one test, in time (or group) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// The test.
    pub source: ResidualSource,
    /// Its residuals.
    pub residuals: Vec<Residual>,
}

/// The white noise of one sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct SampleNoise {
    /// Variance of one sample, output units².
    pub var: f64,
    /// The sample interval it describes, s (0: not known, as for a rate table's points).
    pub interval_s: f64,
}

impl SampleNoise {
    /// The noise variance of a mean over `window_s`.
    pub fn of_mean(&self, window_s: f64) -> f64 {
        if self.interval_s > 0.0 && window_s > self.interval_s {
            self.var * self.interval_s / window_s
        } else {
            self.var
        }
    }

    /// From the per-sample errors of one sensor's streams (`(stream, error)` each, `error[i]` NaN
    /// where not scored): half the variance of the differences of consecutive scored samples
    /// (the clock running forward by at most 1.5 steps: not across a gap or a power-on),
    /// robustly (1.4826 × their median absolute deviation), which a drift slower than a sample
    /// leaves out (their standard deviation where more than half are exactly alike, as on an
    /// output quantized coarser than its noise). At the sample interval of the stream with the
    /// most differences, each stream's differences scaled to it as white noise scales (a
    /// sample's variance inversely in proportion to its interval: one noise density), so that a
    /// log recorded at another rate counts alike. `None` with fewer than 10 differences.
    pub fn from_streams(streams: &[(&Stream, &[f64])]) -> Option<Self> {
        let differences = |stream: &Stream, error: &[f64]| -> Vec<f64> {
            let gap = 1.5 * stream.step_s;
            (1..stream.len())
                .filter(|&i| (0.0..=gap).contains(&(stream.time_s[i] - stream.time_s[i - 1])))
                .map(|i| error[i] - error[i - 1])
                .filter(|v| v.is_finite())
                .collect()
        };
        let each: Vec<(f64, Vec<f64>)> = streams
            .iter()
            .map(|(s, e)| (s.step_s, differences(s, e)))
            .collect();
        let interval_s = each.iter().max_by_key(|(_, d)| d.len())?.0;
        let d: Vec<f64> = each
            .iter()
            .flat_map(|(step, d)| {
                let scale = (step / interval_s).sqrt();
                d.iter().map(move |v| v * scale)
            })
            .collect();
        if d.len() < 10 {
            return None;
        }
        let m = median(&d);
        let mad = median(&d.iter().map(|v| (v - m).abs()).collect::<Vec<_>>());
        // An output quantized coarser than its noise changes in fewer than half its samples, and
        // the median of its differences' deviations is 0 though its steps are noise: their
        // standard deviation states them then, not 0 while any differ.
        let robust = if mad > 0.0 { 1.4826 * mad } else { spread(&d) };
        let sd = robust / std::f64::consts::SQRT_2;
        Some(Self {
            var: sd * sd,
            interval_s,
        })
    }
}

/// What one test's residuals show.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct SourceSummary {
    /// The test.
    pub source: ResidualSource,
    /// Residuals.
    pub n: usize,
    /// Independent residuals they are worth (lag-1 autocorrelation taken out).
    pub effective: f64,
    /// Their RMS, output units.
    pub rmse: f64,
    /// The shipped σ on them.
    pub coverage: Coverage,
}

/// The error model of a shipped model and the evidence behind it (`calibration` in the JSON).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Calibration {
    /// What the blob carries.
    #[serde(skip)]
    pub error_model: ErrorModel,
    /// σ_w: one sample's white noise, output units (a point's, the GP's level, where
    /// `sample_interval_s` is 0: no log showed a sample's).
    pub sample_noise_std: f64,
    /// The sample interval σ_w describes, s (0: not known).
    pub sample_interval_s: f64,
    /// √c₀: model error everywhere, output units: in a run where the training data hold one (a
    /// stream), else on the table's points.
    pub floor_std: f64,
    /// The floor the table's left-out groups or points showed, where they were used beside a
    /// run's (not shipped: a gyro in service is in a run, with the whole table trained).
    pub table_floor_std: Option<f64>,
    /// √c_x: model error one trained width beyond the range, output units (where the prior is
    /// assumed, its part alike at every output).
    pub extrapolation_std: f64,
    /// The assumed prior's part in proportion to the output: ppm of the output one trained width
    /// beyond the range (0 where the extrapolation term is fitted, or the training outputs
    /// barely move).
    pub extrapolation_scale_ppm: f64,
    /// Where the extrapolation term is assumed: the share of holding's miss that the rule shipped
    /// beyond the range missed on the training points beyond an inner fit, widened for their
    /// number, which scaled it ([`Prior::for_rule`]); 1 where the term is fitted or zero, or the
    /// rule is `hold`, was asked for or could not be tested. Where `--tempco` states the part
    /// alike at every output, it scales the part in proportion to the output alone.
    pub extrapolation_share: f64,
    /// The growth beyond the range the residuals fitted, per trained width, where the assumed one
    /// ships in its place: they fitted less, and fewer than three of them reached a whole width
    /// beyond the range, where the assumed growth is stated (null where the fit ships or none was
    /// fitted). What they showed near the edge: a datasheet's `tempco` that states less ships it
    /// instead, as fitted.
    pub extrapolation_fitted_std: Option<f64>,
    /// √c_w: random walk, output units per √h: fitted, or where larger the training log's rate
    /// random walk, by the Allan deviation of the errors `walk_read` names ([`Prior`]).
    pub walk_std_per_sqrt_h: f64,
    /// The walk the residuals fitted where the training log's Allan deviation read a larger one,
    /// which ships (null where the fit ships or none was fitted).
    pub walk_fitted_std: Option<f64>,
    /// Whose errors the Allan walk was read on: `whole-log` or `forward-split` (null: not shipped).
    pub walk_read: Option<streams::WalkReading>,
    /// √c_d: drift of unknown rate, output units per h.
    pub trend_std_per_h: f64,
    /// The bias of another power-on (run-to-run repeatability), output units: as stated by
    /// `--repeatability`, measured on a training stream's power-ons left out (`turn-on` in
    /// `measured`), or, where nothing states or measures it, assumed (`turn-on` in
    /// `assumed`: [`Calibration::assume_turn_on`]). 0 where runs left out (several logs or
    /// tables) measured it (it is in the model error) or a datasheet states 0. The blob carries
    /// twice its variance: the calibration's power-on was a draw too. Measured, it is that
    /// variance over 2 as the power-ons left out show it, widened for their number: an upper
    /// figure, not a 1σ to set beside a datasheet's.
    pub turn_on_std: f64,
    /// Where a training stream's power-ons were left out in turn ([`ResidualSource::PowerOn`]):
    /// how many. Their residuals enter the other terms each less its power-on's mean; another
    /// power-on's bias is measured on those means, its scale on their residuals (`measured`).
    pub power_ons_left_out: Option<usize>,
    /// The scale factor of another power-on (run-to-run scale-factor repeatability), ppm of the
    /// output: as stated by `--scale-repeatability`, measured on a training stream's power-ons
    /// left out (`scale` in `measured`), or, where nothing states it, no runs are pooled (their
    /// floor holds it) and the outputs move, assumed (`scale` in `assumed`:
    /// [`Calibration::assume_scale`]); 0: none of these. The blob carries twice its variance, as
    /// for the bias (measured, an upper figure as the bias's is).
    pub scale_repeatability_ppm: f64,
    /// The out-of-sample residuals' model error in proportion to the output inside the trained
    /// range (nearer it than 5 % of a width: a 60 s mean over a table's sweep holds its extreme
    /// rates, a hair beyond the trimmed range), ppm of it: each residual there a draw of the
    /// variance its model states (with the time terms fitted beside it) plus `a + b·y²` at its
    /// reference output y, a the floor of its kind, a and b at the likelihood's maximum, √b (0
    /// where the outputs barely move or b does not make the residuals more likely by the χ²(1)
    /// 95 % point, counted over the independent residuals they are worth). What another
    /// power-on's scale factor is assumed to differ by where nothing states it.
    pub residual_scale_ppm: f64,
    /// The RMS reference output of the out-of-sample residuals inside the trained range (nearer
    /// it than 5 % of a width), output units, where the outputs move: their spread about their
    /// mean, within a 60 s mean and across them, over ten times a sample's noise (else 0, as at
    /// rest). Where the residuals show no error in proportion to the output, another power-on's
    /// scale is assumed as large at this output as its bias.
    pub output_rms: f64,
    /// The bias's temperature coefficient beyond the trained range, output units per °C, as
    /// stated by `--tempco` or the channel's `tempco` in a channels file (a datasheet's; null: not
    /// stated). Over `trained_width_c` it sets the extrapolation term's part alike at every
    /// output, unless the residuals fitted a larger one, shipped or not
    /// ([`Calibration::set_tempco`]).
    pub tempco_per_c: Option<f64>,
    /// The trained width of the shipped blob's temperature input, °C: the width the
    /// extrapolation term is counted in (null: no temperature input, or no blob stated yet).
    pub trained_width_c: Option<f64>,
    /// Residuals the terms were fitted on.
    pub residuals: usize,
    /// Independent residuals they are worth.
    pub effective: f64,
    /// The small-sample factor on the model-error variance.
    pub inflation: f64,
    /// The terms fitted. The others abstain: their covariates did not reach where they would show,
    /// or, for the extrapolation, the residuals could not tell the prior's growth from none, or
    /// fitted less than it without reaching a whole width beyond the range (the prior ships); for
    /// the walk, they fitted less than the training log's Allan deviation reads (it ships).
    pub fitted_terms: Vec<&'static str>,
    /// Each test.
    pub sources: Vec<SourceSummary>,
    /// The GP's σ alone on those residuals.
    pub before: Option<Coverage>,
    /// The shipped σ on the residuals of runs where there are any, else on all (in sample for
    /// the error model; out of sample for the mean).
    pub coverage: Option<Coverage>,
    /// Why there is no error model measured, when there is none.
    pub note: Option<String>,
    /// The terms the data could not show, assumed instead: from the [`Prior`] (`floor`,
    /// `extrapolation`), the heating/cooling leg not trained (`leg`: [`Calibration::set_legs`]),
    /// another power-on's bias (`turn-on`: [`Calibration::assume_turn_on`]) and scale factor
    /// (`scale`: [`Calibration::assume_scale`]).
    pub assumed: Vec<&'static str>,
    /// Another power-on's bias (`turn-on`) and scale factor (`scale`), where measured on the
    /// power-ons left out (`power_ons_left_out`): the bias, the mean of their squared mean
    /// errors; the scale, their residuals' error in proportion to the output as
    /// `residual_scale_ppm` is fitted on all; each widened by the small-sample factor for one
    /// degree of freedom fewer than power-ons. A scale factor moves no power-on's mean error
    /// where its rates are alike in both signs. A datasheet's figure takes their place. And the
    /// walk (`walk`), where it is the training log's rate random walk, read from an Allan
    /// deviation (`walk_read`: [`Prior::walk_var_per_h`]), not fitted.
    pub measured: Vec<&'static str>,
    /// The heating/cooling states the training stream held (0.5 % quantiles; a side that reached
    /// a leg whose states span less than half the trained temperatures, no further than 0:
    /// [`Calibration::set_legs`]; `None`: not known, as for a rate table's soaks, and no leg
    /// term).
    pub legs_trained: Option<(f32, f32)>,
    /// The model error of a full swing of the heating/cooling state beyond those trained, output
    /// units (0 where the training stream held both legs, or its states are not known): stated
    /// by `--hysteresis`, else assumed (`leg` in `assumed`).
    pub leg_std: f64,
    /// The gap between the heating and the cooling leg at one temperature, output units, as
    /// stated by `--hysteresis` or the channel's `hysteresis` in a channels file (a datasheet's
    /// thermal hysteresis; null: not stated): the error of a full swing onto a leg the training
    /// did not hold ([`Calibration::set_hysteresis`]).
    pub hysteresis: Option<f64>,
    /// The heating rates the training held and the model error outside them (module
    /// [`heating`]).
    pub heating: heating::Heating,
}

/// What the σ assumes where the training data cannot show a term (module doc), output units².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Prior {
    /// Model error everywhere: the GP's noise level on its points, × the small-sample factor at
    /// the fewest degrees of freedom.
    pub floor_var: f64,
    /// Model error per trained width beyond the range, squared: the model's change over one width
    /// of a temperature input next to the range's edges, over each half of the range at its
    /// points' other inputs (mean square; holding's miss; × `rule_share`² for another rule,
    /// [`Prior::for_rule`]).
    pub extrapolation_var: f64,
    /// The same change told apart into a part alike at every output (`.0`, output units²) and one
    /// in proportion to it (`.1`, relative²): at output y the prior's growth per width² is
    /// `.0 + .1 · y²`, fitted to each point's own change at its output ([`split_by_output`]);
    /// `(extrapolation_var, 0)` where the points' outputs barely move.
    pub extrapolation_parts: (f64, f64),
    /// The share of holding's miss the rule shipped beyond the range missed where the training
    /// points could test it, widened for their number ([`Prior::for_rule`]); 1 where the rule is
    /// `hold`, was asked for, or could not be tested: the extrapolation parts are scaled by its
    /// square.
    pub rule_share: f64,
    /// Whether the blob's mean follows the GP beyond the range, as every residual is scored
    /// (a split's blob as exported, a table's left-out point by the GP): only then is an
    /// extrapolation term fitted on them a measure of its miss there ([`Prior::for_rule`]).
    pub follows: bool,
    /// The bias's random walk, output units² per hour: the rate random walk read from the Allan
    /// deviation of the model's errors on its training log, and (but for a table's static
    /// model) of the forward split's model's over the part it was not fitted on, the larger
    /// (`streams::allan_walk`, `streams::part_walk`); 0 where none is read: a rate table's
    /// points, a log whose reference moves or too short for a slope +½, and the logs of a
    /// calibration on several, whose power-ons measure the walk their splits see.
    pub walk_var_per_h: f64,
    /// Whose errors `walk_var_per_h` was read on (`None`: not said).
    pub walk_read: Option<streams::WalkReading>,
}

impl Prior {
    /// No prior: terms the data cannot show are 0 (what a rate table's points, which span the
    /// range they are used in, need).
    pub const NONE: Self = Self {
        floor_var: 0.0,
        extrapolation_var: 0.0,
        extrapolation_parts: (0.0, 0.0),
        rule_share: 1.0,
        follows: true,
        walk_var_per_h: 0.0,
        walk_read: None,
    };

    /// The prior of `model` fitted on `points` (module doc): what it changes over one width of
    /// its temperature input next to the range's edges, where holding it there starts to miss,
    /// at the other inputs of each point it was fitted on: its trend over the lower half of the
    /// range and over the upper half (the least-squares slope through it at `HALF_STEPS`
    /// temperatures of each, times the width), as an RMS over both halves and the points; told
    /// apart by the points' outputs (the reference rate) into a bias and a scale part. The halves
    /// are the model's trend there: a slope taken at each point over a tenth of the range follows
    /// the GP's wiggles between its points too, which holding at the edge does not miss and no
    /// bias continues (on four simulated 30-minute warm-ups it made the σ on a cool-down
    /// 1.7–2.5× the error, against 1.02–1.25); one chord over the whole range would not see a
    /// bias that turns over inside it, and a chord per half would follow a wiggle's phase where it
    /// reads the model. The blob holds one term for both edges: the RMS over the halves states
    /// the steeper side up to √2 too narrow there, and the flatter one at least as much too wide
    /// (without bound where it is flat).
    pub fn of(model: &GpModel, points: &Points) -> Self {
        let h = &model.posterior.hyper;
        let sy2 = model.output_scale.powi(2);
        let noise_var = h.observation_var() * sy2;
        let floor_var = noise_var * small_sample_factor(MIN_DOF);
        let noise_std = noise_var.sqrt();
        let x = points.inputs();
        let changes = points
            .features()
            .iter()
            .enumerate()
            .filter(|(k, f)| *k < model.input_range.len() && f.is_temperature())
            .map(|(k, _)| {
                let (lo, hi) = model.input_range[k];
                let width = hi - lo;
                if width <= 0.0 || x.nrows() == 0 {
                    return Vec::new();
                }
                // At each point's other inputs: the model's trend over the lower half of the
                // range and over the upper half (the least-squares slope through it at
                // `HALF_STEPS` temperatures), each times the width; its mean square is the
                // point's.
                x.row_iter()
                    .map(|row| {
                        let mut at: Vec<f64> = row.iter().copied().collect();
                        let mut trend = |from: f64| {
                            let line = Line::fit((0..HALF_STEPS).map(|j| {
                                at[k] = from + 0.5 * width * j as f64 / (HALF_STEPS - 1) as f64;
                                (at[k], model.predict_mean(&at))
                            }));
                            line.map_or(0.0, |l| l.slope * width)
                        };
                        let (lower, upper) = (trend(lo), trend(lo + 0.5 * width));
                        0.5 * (lower * lower + upper * upper)
                    })
                    .collect::<Vec<f64>>()
            })
            .map(|c2| {
                let mean = if c2.is_empty() {
                    0.0
                } else {
                    c2.iter().sum::<f64>() / c2.len() as f64
                };
                (mean, c2)
            })
            .filter(|(mean, _)| mean.is_finite())
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let Some((extrapolation_var, c2)) = changes else {
            return Self {
                floor_var,
                ..Self::NONE
            };
        };
        // A bias model's GP reads no output (its scale factor is given): its change cannot grow
        // with the rate, whatever the rates the points happen to hold.
        let extrapolation_parts = if points.scale_factor.is_some() {
            (extrapolation_var, 0.0)
        } else {
            split_by_output(&c2, &points.rate_dps, noise_std)
        };
        Self {
            floor_var,
            extrapolation_var,
            extrapolation_parts,
            ..Self::NONE
        }
    }

    /// This prior with the bias's random walk (output units² per hour) read on `read`'s errors.
    pub fn with_walk(self, walk_var_per_h: f64, read: streams::WalkReading) -> Self {
        Self {
            walk_var_per_h,
            walk_read: Some(read),
            ..self
        }
    }

    /// The prior of a blob whose mean follows `beyond`'s rule past the range. What [`Prior::of`]
    /// measures is what holding the inputs at the edge misses; where the rule was tested on the
    /// training points beyond a fit on their inner temperatures (`analysis::beyond`) and the rule
    /// shipped missed a share k of what holding missed there ([`BeyondChoice::share`]), the
    /// extrapolation parts are scaled by k², widened by the small-sample factor of the points
    /// that measured it (module doc), never up: a rule that missed more would not ship. The test
    /// reaches a third of a width beyond its fit; a tangent's or the GP's miss grows faster with
    /// the distance than holding's, so far beyond, the share is a measurement taken nearer in.
    /// Under another rule than `follow`, the residuals, scored as the GP follows, do not measure
    /// the rule's miss beyond the range: the term is this prior, where there is one
    /// ([`Prior::follows`]).
    pub fn for_rule(self, beyond: &BeyondChoice) -> Self {
        let follows = beyond.rule == Beyond::Follow;
        let Some(share) = beyond.share() else {
            return Self { follows, ..self };
        };
        let dof = (beyond.scored as f64 - 1.0).max(MIN_DOF);
        let k2 = (share * share * small_sample_factor(dof)).min(1.0);
        Self {
            extrapolation_var: self.extrapolation_var * k2,
            extrapolation_parts: (
                self.extrapolation_parts.0 * k2,
                self.extrapolation_parts.1 * k2,
            ),
            rule_share: k2.sqrt(),
            follows,
            ..self
        }
    }
}

/// Temperatures at which [`Prior::of`] reads the model over each half of its range.
const HALF_STEPS: usize = 11;

/// Each point's squared change `c2` over one width, as a draw of variance `a + b · y²` at its
/// output `y` (a, b ≥ 0, maximum likelihood): a gyro's scale factor changes with temperature as
/// its bias does, so its model's slope grows with the rate, and a variance fitted to every point
/// alike would be too wide at low rates and too narrow at high ones. The points must show the
/// split: where the outputs barely move (their spread under ten times `noise_std`, as on a log at
/// rest, whose reference is one value), or where the split's likelihood does not beat one
/// variance for every point by the χ²(1) 95 % margin (outputs of one magnitude, as a table at ±R
/// alone, or changes that do not grow with it), the bias part takes it all: `(mean c2, 0)`.
/// Pairs that are not finite are left out.
pub fn split_by_output(c2: &[f64], y: &[f64], noise_std: f64) -> (f64, f64) {
    let (c2, y): (Vec<f64>, Vec<f64>) = c2
        .iter()
        .zip(y)
        .filter(|(c, v)| c.is_finite() && v.is_finite())
        .map(|(c, v)| (*c, *v))
        .unzip();
    if c2.is_empty() {
        return (0.0, 0.0);
    }
    let nf = c2.len() as f64;
    let mean_c2 = c2.iter().sum::<f64>() / nf;
    let mean_u = y.iter().map(|v| v * v).sum::<f64>() / nf;
    // False for a NaN noise as well.
    let moves = spread(&y) > terms::MOVES * noise_std;
    if !moves || mean_c2 <= 0.0 || mean_u <= 0.0 {
        return (mean_c2, 0.0);
    }
    // The profile likelihood over the bias part's share r of the variance at the mean output²
    // (the variance at u = y² is s·(r + (1 − r)·u/ū), s at its maximum for each r), as
    // −Σ ln(variance), twice the log-likelihood less a constant: one dimension, searched on a
    // grid fine enough for a prior, from r = 1 (one variance for every point) down, so that a
    // flat likelihood keeps the bias part.
    let log_l = |r: f64| {
        let shape = |v: f64| r + (1.0 - r) * v * v / mean_u;
        let scale = y.iter().zip(&c2).map(|(v, c)| c / shape(*v)).sum::<f64>() / nf;
        let l = -y.iter().map(|v| (scale * shape(*v)).ln()).sum::<f64>();
        (l.is_finite() && scale > 0.0).then_some((l, scale))
    };
    let Some((alike, _)) = log_l(1.0) else {
        return (mean_c2, 0.0);
    };
    let mut best = (alike, 1.0, mean_c2);
    for k in (0..SPLIT_STEPS).rev() {
        let r = (k as f64 / SPLIT_STEPS as f64).max(1e-4);
        if let Some((l, scale)) = log_l(r)
            && l > best.0
        {
            best = (l, r, scale);
        }
    }
    let (l, r, scale) = best;
    if l - alike < SPLIT_MARGIN {
        return (mean_c2, 0.0);
    }
    (scale * r, scale * (1.0 - r) / mean_u)
}

/// Steps of [`split_by_output`]'s search over the bias part's share.
const SPLIT_STEPS: usize = 1000;

/// How much more likely the split must make the points than one variance for all: twice the
/// log-likelihood ratio at the χ²(1) 95 % point (one parameter more).
const SPLIT_MARGIN: f64 = 3.84;

/// (t₀.₉₇₅(ν)/1.96)²: how much wider a variance estimated on ν degrees of freedom must be for
/// its 95% interval (module doc).
pub fn small_sample_factor(dof: f64) -> f64 {
    match (StudentsT::new(0.0, 1.0, dof), Normal::new(0.0, 1.0)) {
        (Ok(t), Ok(n)) => (t.inverse_cdf(0.975) / n.inverse_cdf(0.975)).powi(2),
        _ => 1.0,
    }
}

/// Names of the model-error terms, in covariate order.
const TERM_NAMES: [&str; TERMS] = ["table floor", "floor", "extrapolation", "walk", "trend"];

impl Calibration {
    /// The σ of a blob whose training data hold no out-of-sample residual to measure its model
    /// error on: its noise, and the model error the [`Prior`] assumes (module doc).
    pub fn assumed(noise: SampleNoise, prior: Prior, note: String) -> Self {
        let error_model = ErrorModel {
            sample_noise_var: noise.var as f32,
            sample_interval_s: noise.interval_s as f32,
            floor_var: prior.floor_var as f32,
            extrapolation_var: prior.extrapolation_parts.0 as f32,
            extrapolation_scale_var: prior.extrapolation_parts.1 as f32,
            walk_var_per_h: prior.walk_var_per_h as f32,
            ..ErrorModel::noise_only(0.0)
        };
        let assumed = [
            (prior.floor_var, "floor"),
            (prior.extrapolation_var, "extrapolation"),
        ]
        .iter()
        .filter(|(v, _)| *v > 0.0)
        .map(|(_, name)| *name)
        .collect();
        Self {
            error_model,
            sample_noise_std: noise.var.sqrt(),
            sample_interval_s: noise.interval_s,
            floor_std: prior.floor_var.sqrt(),
            table_floor_std: None,
            extrapolation_std: prior.extrapolation_parts.0.sqrt(),
            extrapolation_scale_ppm: prior.extrapolation_parts.1.sqrt() * 1e6,
            extrapolation_share: if prior.extrapolation_var > 0.0 {
                prior.rule_share
            } else {
                1.0
            },
            extrapolation_fitted_std: None,
            walk_std_per_sqrt_h: prior.walk_var_per_h.sqrt(),
            walk_fitted_std: None,
            walk_read: prior.walk_read.filter(|_| prior.walk_var_per_h > 0.0),
            trend_std_per_h: 0.0,
            turn_on_std: 0.0,
            power_ons_left_out: None,
            scale_repeatability_ppm: 0.0,
            residual_scale_ppm: 0.0,
            output_rms: 0.0,
            tempco_per_c: None,
            trained_width_c: None,
            residuals: 0,
            effective: 0.0,
            inflation: 1.0,
            fitted_terms: Vec::new(),
            sources: Vec::new(),
            before: None,
            coverage: None,
            note: Some(note),
            assumed,
            measured: if prior.walk_var_per_h > 0.0 {
                vec!["walk"]
            } else {
                Vec::new()
            },
            legs_trained: None,
            leg_std: 0.0,
            hysteresis: None,
            heating: heating::Heating::default(),
        }
    }

    /// `blob` with this error model.
    pub fn apply(&self, blob: &[u8]) -> Result<Vec<u8>, ExportError> {
        export::with_error_model(blob, &self.error_model)
    }
}

#[cfg(test)]
mod tests;
