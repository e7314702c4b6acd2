//! Do no harm when pooling: a static model fitted on a rate table and a long stream's samples
//! together must predict that stream better than the table alone, or the table's model ships.
//!
//! The check is forward in time, like the extension's ([`crate::analysis::investigate`]): every
//! stream is cut after two thirds of its 60 s blocks, the pooled model is fitted on the table and
//! the streams' earlier parts, the table's model on the table alone, and both blobs are replayed
//! over the streams' later parts. A pooled fit can lose: the streams' 1 Hz samples outnumber the
//! table's points a thousand to one and carry a noise the table's 2-minute means have averaged
//! away, so a fit that spends its few inducing points and its one noise level on them can come
//! out worse where the table alone was good (docs/performance.md).

use std::path::Path;

use fog_data::replay;
use fog_data::stats::rms;
use fog_data::stream::Stream;
use serde::Serialize;

use crate::analysis::investigate::{FORWARD_MIN_BLOCKS, Forward, forward};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpError, GpModel, Hyperparameters};

/// Which static model a pooled fit ships.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum Pooling {
    /// The model of the table and the streams' samples.
    Pooled,
    /// The model of the rate table alone.
    TableOnly,
}

/// The comparison (`trainer fit --json`: `pool_check`).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct PoolCheck {
    /// Where each stream was cut, s from its first sample.
    pub split_s: Vec<f64>,
    /// Samples the pooled model was fitted on (the table's and the earlier parts').
    pub pooled_samples: usize,
    /// Its centres (inducing points of a sparse GP).
    pub pooled_centres: usize,
    /// Its hyperparameters (normalized units).
    pub pooled_hyperparameters: Hyperparameters,
    /// 60 s blocks scored, over every stream's later part.
    pub later_blocks: usize,
    /// The pooled model's `rmse_60s_dps` on the later parts.
    pub pooled_rmse_60s_dps: f64,
    /// The table's model's `rmse_60s_dps` on the later parts.
    pub table_rmse_60s_dps: f64,
    /// The model shipped: the one with the lower figure.
    pub shipped: Pooling,
    /// Why, in words.
    pub verdict: String,
}

/// Errors of the check.
#[derive(Debug, thiserror::Error)]
pub enum PoolError {
    /// A stream too short to cut forward in time.
    #[error(
        "{path}: too short to check the pooled model forward in time: {blocks} blocks of 60 s \
         with a reference rate, {FORWARD_MIN_BLOCKS} needed (checked before fitting)"
    )]
    TooShort {
        /// The stream's file.
        path: String,
        /// Its 60 s blocks with a reference rate.
        blocks: usize,
    },
    /// Building the pooled points.
    #[error(transparent)]
    Points(#[from] crate::data::points::PointsError),
    /// A fit.
    #[error(transparent)]
    Fit(#[from] GpError),
    /// Exporting or decoding a blob.
    #[error(transparent)]
    Export(#[from] export::ExportError),
    /// Decoding a blob.
    #[error(transparent)]
    Blob(#[from] firmware_core::BlobError),
}

/// Every stream of `streams` cut forward in time, or the error of the first too short to cut:
/// `fit` cuts them before fitting anything, so that a pooled fit it could not check is refused
/// at once, and [`check`] scores on these cuts.
pub(crate) fn forward_cuts(streams: &[(&Path, Stream)]) -> Result<Vec<Forward>, PoolError> {
    streams
        .iter()
        .map(|(path, stream)| {
            forward(stream).ok_or_else(|| PoolError::TooShort {
                path: path.display().to_string(),
                blocks: stream.half_filled_blocks(&stream.referenced()).len(),
            })
        })
        .collect()
}

/// Checks pooling `streams` with `table` forward in time, on their `cuts` ([`forward_cuts`]).
/// `fit` fits a static model as the caller ships one; `table_model` is its fit on `table` alone.
pub(crate) fn check(
    table: &Points,
    table_model: &GpModel,
    (streams, cuts): (&[(&Path, Stream)], &[Forward]),
    fit: &dyn Fn(&Points) -> Result<GpModel, GpError>,
) -> Result<PoolCheck, PoolError> {
    let mut pooled = table.clone();
    for ((path, _), cut) in streams.iter().zip(cuts) {
        pooled = pooled.pooled(Points::from_stream_samples(
            path,
            &cut.early,
            table.scale_factor,
        )?)?;
    }
    let pooled_model = fit(&pooled)?;
    let score = |model: &GpModel, points: &Points| -> Result<f64, PoolError> {
        let blob = export::points_blob(model, points, &Extension::default())?;
        let fw = replay::decode(&blob)?;
        // Blocks of every stream together: the squared block errors pool by their counts.
        let (mut sum, mut blocks) = (0.0, 0usize);
        for cut in cuts {
            let e = replay::means(&fw, &cut.later).block_errors(&cut.later);
            sum += rms(&e).powi(2) * e.len() as f64;
            blocks += e.len();
        }
        Ok((sum / blocks.max(1) as f64).sqrt())
    };
    let pooled_rmse = score(&pooled_model, &pooled)?;
    let table_rmse = score(table_model, table)?;
    let shipped = if pooled_rmse < table_rmse {
        Pooling::Pooled
    } else {
        Pooling::TableOnly
    };
    let figures = format!(
        "on the last third of the stream{} ({} blocks of 60 s), the table pooled with the \
         earlier samples scores {pooled_rmse:.3e} °/s against the table alone's {table_rmse:.3e}",
        if streams.len() > 1 { "s" } else { "" },
        cuts.iter().map(|c| c.later_blocks).sum::<usize>()
    );
    let verdict = match shipped {
        Pooling::Pooled => format!("{figures}: the pooled model is shipped"),
        Pooling::TableOnly => {
            format!("{figures}: pooling does no good there, so the table's model is shipped")
        }
    };
    Ok(PoolCheck {
        split_s: cuts.iter().map(|c| c.split_s).collect(),
        pooled_samples: pooled.len(),
        pooled_centres: pooled_model.posterior.xs.nrows(),
        pooled_hyperparameters: pooled_model.posterior.hyper.clone(),
        later_blocks: cuts.iter().map(|c| c.later_blocks).sum(),
        pooled_rmse_60s_dps: pooled_rmse,
        table_rmse_60s_dps: table_rmse,
        shipped,
        verdict,
    })
}
