//! The validity a prediction carries, shared by the feature pipeline (the health of its inputs)
//! and the evaluator (the worse of that and the trained range).

/// Validity of a prediction, from best to worst (a prediction carries the worst that applies).
/// Every function that returns one must have it looked at: a `Fault` ignored is a stale value used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[must_use = "a Fault status means the outputs are not to be used"]
pub enum Status {
    /// Inputs inside the trained range.
    Valid,
    /// An input lies outside the trained range: the model extrapolates.
    Extrapolating,
    /// The inputs are readings, but a stateful input's history is not to be trusted: after a time
    /// jump or a clock running backwards, while the temperature sensor seems stuck, and until the
    /// filters have settled after either ([`crate::features`] has the rules).
    Degraded,
    /// An input is NaN, infinite or impossible (or missing): the output is not a compensation.
    Fault,
}
