//! The unit conversions every layer uses, defined once: gyro rates are carried in °/s (the
//! firmware's and the data files' unit) and reported in °/h (the unit of every gyro datasheet's
//! bias figures); times in seconds, with hours where a drift is stated per hour.

/// Seconds in an hour.
pub const SECONDS_PER_HOUR: f64 = 3600.0;

/// °/h in one °/s: multiply a rate in °/s by it to state it in °/h.
pub const DPH_PER_DPS: f64 = SECONDS_PER_HOUR;

/// Standard gravity, m/s² (ISO 80000-3): an accelerometer's mg are thousandths of it.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// What a channel of a sensor unit measures, which sets the unit its models predict in and the
/// one its bias figures are stated in: a gyro's angular rate (°/s, biases in °/h) or an
/// accelerometer's specific force (m/s², biases in mg). A unit blob carries it per channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Quantity {
    /// A gyro's angular rate.
    AngularRate,
    /// An accelerometer's specific force.
    SpecificForce,
}

impl Quantity {
    /// The unit its models predict in and the data files carry: `°/s` or `m/s²`.
    pub const fn unit(self) -> &'static str {
        match self {
            Self::AngularRate => "°/s",
            Self::SpecificForce => "m/s²",
        }
    }

    /// The unit a datasheet states its biases in: `°/h` or `mg`.
    pub const fn bias_unit(self) -> &'static str {
        match self {
            Self::AngularRate => "°/h",
            Self::SpecificForce => "mg",
        }
    }

    /// [`Self::bias_unit`]s in one [`Self::unit`]: multiply a value in the first by it to state
    /// it in the second.
    pub fn bias_per_unit(self) -> f64 {
        match self {
            Self::AngularRate => DPH_PER_DPS,
            Self::SpecificForce => 1000.0 / STANDARD_GRAVITY,
        }
    }

    /// The white-noise term of its Allan deviation and that term's unit: angle random walk in
    /// °/√h, or velocity random walk in (m/s)/√h; either is the deviation at τ = 1 s (in
    /// [`Self::unit`]) times 60.
    pub const fn random_walk(self) -> (&'static str, &'static str) {
        match self {
            Self::AngularRate => ("angle random walk", "°/√h"),
            Self::SpecificForce => ("velocity random walk", "(m/s)/√h"),
        }
    }
}
