//! What identification could not do, as a typed error.

/// What identification could not do.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// Neither points nor a stream.
    #[error("nothing to identify from: give --points, --stream or both")]
    NoData,
    /// Too few measurements for the fit and its held-out test.
    #[error("{0} measurements: identification needs at least 12 (a third is held out)")]
    TooFew(usize),
    /// Every reference rate is zero and no scale factor was given.
    #[error(
        "every reference rate is (near) zero, so the data show no scale factor: give the gyro's \
         nominal one (--scale-factor K, output units per °/s), as for a static log"
    )]
    NoScaleFactor,
    /// The fit produced numbers that are not finite.
    #[error("the fit diverged (non-finite parameters); check the --map units")]
    Diverged,
}
