//! The unit conversions every layer uses, defined once: gyro rates are carried in °/s (the
//! firmware's and the data files' unit) and reported in °/h (the unit of every gyro datasheet's
//! bias figures); times in seconds, with hours where a drift is stated per hour.

/// Seconds in an hour.
pub const SECONDS_PER_HOUR: f64 = 3600.0;

/// °/h in one °/s: multiply a rate in °/s by it to state it in °/h.
pub const DPH_PER_DPS: f64 = SECONDS_PER_HOUR;
