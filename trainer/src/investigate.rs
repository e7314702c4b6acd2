//! The investigation in one call: static fit on the soaked points → replay on a held-out stream →
//! diagnosis → extended fit on the points plus a training stream → replay on the held-out stream
//! → the gain.

use indicatif::ProgressBar;
use serde::Serialize;

use crate::cause::Cause;
use crate::dataset::Points;
use crate::diagnose::{self, Diagnosis, Residual};
use crate::export::{self, Extension};
use crate::extend::{self, Fitted};
use crate::gp::{GpConfig, GpModel};
use crate::replay::{self, Score};
use crate::stream::Stream;

/// Steps of an investigation: static fit, replay and diagnosis, extended fit, extended replay.
pub const STEPS: u64 = 4;

/// The result (DESIGN §6 names where they exist).
#[derive(Debug, Clone, Serialize)]
pub struct Investigation {
    /// The static model on the held-out stream.
    pub static_score: Score,
    /// Diagnosis of the static model on the held-out stream.
    pub diagnosis: Diagnosis,
    /// Inputs the extended model adds (`--features` names).
    pub added_inputs: Vec<&'static str>,
    /// The extension fitted on the training stream (absent when the cause is `none`).
    pub extension: Option<Fitted>,
    /// The extended model on the held-out stream.
    pub extended_score: Score,
    /// Static over extended `rmse_60s_dps` on the held-out stream.
    pub gain: f64,
    /// What the static fit warned of ([`GpModel::warnings`]).
    pub warnings: Vec<String>,
}

impl Investigation {
    /// The named cause.
    pub fn cause(&self) -> Cause {
        self.diagnosis.cause
    }
}

/// The models an investigation produced.
pub struct Blobs {
    /// The static model.
    pub static_blob: Vec<u8>,
    /// The extended model (the static one when nothing was added).
    pub extended_blob: Vec<u8>,
}

/// Runs the investigation; `chosen` overrides the inputs the diagnosis calls for. `bar` counts its
/// [`STEPS`].
pub fn investigate(
    points: &Points,
    train: &Stream,
    valid: &Stream,
    cfg: &GpConfig,
    chosen: Option<&[Cause]>,
    bar: &ProgressBar,
) -> anyhow::Result<(Investigation, Blobs)> {
    bar.inc_length(STEPS);
    bar.set_message(format!("static fit on {} points", points.len()));
    let model = GpModel::fit(&points.inputs(), &points.target(), cfg)?;
    let static_blob = export::points_blob(&model, points, &Extension::default())?;
    let (fw, _) =
        export::verify(&model, &static_blob, points, &Extension::default()).map_err(|e| {
            let warned = model.warnings();
            let e = anyhow::Error::from(e);
            if warned.is_empty() {
                e
            } else {
                e.context(format!("static fit (it warned: {})", warned.join("; ")))
            }
        })?;
    bar.inc(1);
    bar.set_message("replay and diagnosis of the held-out stream");
    let comp = replay::replay(&fw, valid);
    let static_score = replay::score(valid, &comp);
    let diagnosis = diagnose::diagnose_residual(&Residual::from_replay(&fw, valid, &comp));
    let named = [diagnosis.cause];
    let causes: Vec<Cause> = chosen
        .unwrap_or(&named)
        .iter()
        .copied()
        .filter(|c| *c != Cause::None)
        .collect();
    bar.inc(1);
    bar.set_message("extended fit on the training stream");
    let (extension, extended_blob) = if causes.is_empty() {
        (None, static_blob.clone())
    } else {
        let ext = extend::fit(&model, points, train, &causes)?;
        (Some(ext.fitted), ext.blob)
    };
    bar.inc(1);
    bar.set_message("replay of the extended model");
    let ext = export::decode(&extended_blob)?;
    let extended_score = replay::score(valid, &replay::replay(&ext, valid));
    let gain = static_score.rmse_60s_dps / extended_score.rmse_60s_dps;
    bar.inc(1);
    Ok((
        Investigation {
            static_score,
            added_inputs: causes
                .iter()
                .filter_map(|c| extend::feature_name(*c))
                .collect(),
            diagnosis,
            extension,
            extended_score,
            gain,
            warnings: model.warnings(),
        },
        Blobs {
            static_blob,
            extended_blob,
        },
    ))
}
