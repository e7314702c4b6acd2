//! The project's data files as their readers see them: CSV columns found by name or `--map`
//! ([`columns`]), and a stream recorded in time order ([`stream`]). Rate-table points are read
//! through [`columns`] by the trainer, which alone turns them into model inputs.

pub mod columns;
pub mod stream;
