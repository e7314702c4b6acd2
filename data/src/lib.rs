//! What the project's data are, under both programs (the trainer and the bench): a log read as
//! every command reads it, and what is measured on it.
//!
//! - [`columns`]: CSV columns found by name or by a `--map`; [`stream`]: a log recorded in time
//!   order, with its windows and handling; [`blocks`]: its 60 s means; [`channels`]: a sensor
//!   unit's channels, named once in a channels file; [`autopilot`]: a flight controller's log (PX4
//!   ULog, ArduPilot DataFlash), each sensor instance a unit. A new kind of log is read here and
//!   nowhere else.
//! - [`replay`]: every sample of a stream through firmware-core's evaluator (the host build of
//!   the code the gyro runs) and its scores; [`sigma`]: how well a stated σ covers the errors;
//!   [`stats`]: the few statistics both take.
//! - [`cause`]: the physical causes' ids, one vocabulary for the diagnosis that names them and the
//!   simulator that hides them; [`selection`]: the one rule by which the diagnosis and the
//!   simulator's twin of a measured gyro choose them.
//! - [`allan`]: a log's Allan deviation and noise terms; [`minimize`]: the one 1-D search the
//!   lag fits share.
//!
//! Nothing here draws, prompts or parses a command line: the programs above do, from what these
//! functions return.

pub mod allan;
pub mod autopilot;
pub mod blocks;
pub mod cause;
pub mod channels;
pub mod columns;
pub mod minimize;
pub mod replay;
pub mod selection;
pub mod sigma;
pub mod stats;
pub mod stream;
