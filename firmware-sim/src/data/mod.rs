//! The project's data files as their readers see them: CSV columns found by name or `--map`
//! ([`columns`]), a stream recorded in time order ([`stream`]) and its 60 s [`blocks`], a log
//! loaded as every command loads it, with its flags ([`log`]), and a sensor unit's channels named
//! once in a channels file ([`channels`]). Rate-table points are read through [`columns`] by the
//! trainer, which alone turns them into model inputs.

pub mod blocks;
pub mod channels;
pub mod columns;
pub mod log;
pub mod stream;
