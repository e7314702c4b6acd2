//! The cause ids of docs/design.md §5: a public interface (JSON output, command lines, the
//! simulator's hidden effects), so they are defined once, here.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A physical cause of a static model's error on a stream.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    Serialize,
    Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum Cause {
    /// The residual is noise (ARW, bias instability).
    None,
    /// Bias ∝ dT/dt of the coil (Shupe, thermal stress).
    ThermalRate,
    /// The temperature sensor leads the coil by a thermal time constant.
    SensorLag,
    /// Bias transient after power-on.
    WarmUp,
    /// Bias differs after heating vs after cooling, persisting through soaks.
    Hysteresis,
    /// Slow monotonic in-run drift.
    TimeDrift,
}

impl Cause {
    /// Every cause, in docs/design.md §5's order.
    pub const ALL: [Cause; 6] = [
        Cause::None,
        Cause::ThermalRate,
        Cause::SensorLag,
        Cause::WarmUp,
        Cause::Hysteresis,
        Cause::TimeDrift,
    ];

    /// The stable id.
    pub fn id(self) -> &'static str {
        match self {
            Cause::None => "none",
            Cause::ThermalRate => "thermal-rate",
            Cause::SensorLag => "sensor-lag",
            Cause::WarmUp => "warm-up",
            Cause::Hysteresis => "hysteresis",
            Cause::TimeDrift => "time-drift",
        }
    }
}

/// An id that is not one of docs/design.md §5's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown cause '{0}': expected one of none, thermal-rate, sensor-lag, warm-up, hysteresis, \
     time-drift"
)]
pub struct UnknownCause(pub String);

impl FromStr for Cause {
    type Err = UnknownCause;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Cause::ALL
            .into_iter()
            .find(|c| c.id() == s)
            .ok_or_else(|| UnknownCause(s.to_owned()))
    }
}

impl fmt::Display for Cause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_through_text_and_json() {
        for c in Cause::ALL {
            assert_eq!(c.id().parse::<Cause>().unwrap(), c);
            assert_eq!(
                serde_json::to_string(&c).unwrap(),
                format!("\"{}\"", c.id())
            );
        }
        assert!("shupe".parse::<Cause>().is_err());
    }
}
