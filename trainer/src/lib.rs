//! Host trainer for FOG temperature-drift compensation: loads rate-table data, fits the reference
//! paper's Gaussian-process map ω = f(T, V) and its rivals (LS-SVR, the traditional two-step
//! bias/scale-factor model), evaluates them the way the paper does, exports firmware blobs, and
//! finds, names and fixes what a model gets wrong (docs/design.md §1).
//!
//! Layers, each using only those listed before it (and fog-data, firmware-core below; the bench,
//! firmware-sim, in `demo`, `challenge` and the twin): [`progress`] (how long work reports how far
//! it has come), [`data`] (rate-table points as model inputs), [`models`] (the regressions),
//! [`firmware`] (the blob and its checks), [`analysis`] (evaluation, diagnosis, extension,
//! investigation, noise terms, the simulator's twin), [`plot`] (the figures' common drawing),
//! [`report`], [`pipeline`] (what each command does, as a
//! library: a plan and the data in, a typed result out), [`cli`]. The integration test `layers` holds them to it.

pub mod analysis;
pub mod cli;
pub mod data;
pub mod firmware;
pub mod models;
pub mod pipeline;
pub mod plot;
pub mod progress;
pub mod report;
