//! The parameters identification reports ([`Parameter`]), and the static ones it may fit, by
//! name: each knows its field of [`GyroParams`], its name in the unit file and the scale of its
//! step in the fit (the Levenberg–Marquardt vector holds scaled offsets, so that a 1e-6 °C⁻²
//! curvature and a 1 V/(°/s) scale factor move alike).

use crate::gyro::plant::GyroParams;
use serde::Serialize;

use super::source::Record;

/// One static parameter of the output map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Static {
    /// Scale factor at the reference temperature, output units per °/s.
    ScaleFactor,
    /// Its linear temperature coefficient, 1/°C.
    SfTc,
    /// Its quadratic temperature coefficient, 1/°C².
    SfTc2,
    /// The Sagnac phase per unit rate (the sine's compression), s.
    SagnacK,
    /// Scale-factor asymmetry between positive and negative rates.
    Asymmetry,
    /// A coefficient of the bias polynomial in temperature, °/h per °Cⁱ.
    Bias(usize),
    /// An offset at the output, output units.
    OutputOffset,
}

impl Static {
    /// Every static parameter, in the order the identification reports them.
    pub(super) const ALL: [Static; 10] = [
        Static::ScaleFactor,
        Static::SfTc,
        Static::SfTc2,
        Static::SagnacK,
        Static::Asymmetry,
        Static::Bias(0),
        Static::Bias(1),
        Static::Bias(2),
        Static::Bias(3),
        Static::OutputOffset,
    ];

    /// Its name in the unit file.
    pub(super) fn name(self) -> &'static str {
        match self {
            Static::ScaleFactor => "scale_factor_v_per_dps",
            Static::SfTc => "sf_tc_per_c",
            Static::SfTc2 => "sf_tc2_per_c2",
            Static::SagnacK => "sagnac_k_s",
            Static::Asymmetry => "sf_asymmetry",
            Static::Bias(0) => "bias_poly_dph[0]",
            Static::Bias(1) => "bias_poly_dph[1]",
            Static::Bias(2) => "bias_poly_dph[2]",
            Static::Bias(_) => "bias_poly_dph[3]",
            Static::OutputOffset => "output_offset_v",
        }
    }

    /// Its value in `p`.
    pub(super) fn get(self, p: &GyroParams) -> f64 {
        match self {
            Static::ScaleFactor => p.scale_factor_v_per_dps,
            Static::SfTc => p.sf_tc_per_c,
            Static::SfTc2 => p.sf_tc2_per_c2,
            Static::SagnacK => p.sagnac_k_s,
            Static::Asymmetry => p.sf_asymmetry,
            Static::Bias(i) => p.bias_poly_dph[i],
            Static::OutputOffset => p.output_offset_v,
        }
    }

    /// Sets its value in `p`.
    pub(super) fn set(self, p: &mut GyroParams, v: f64) {
        match self {
            Static::ScaleFactor => p.scale_factor_v_per_dps = v,
            Static::SfTc => p.sf_tc_per_c = v,
            Static::SfTc2 => p.sf_tc2_per_c2 = v,
            Static::SagnacK => p.sagnac_k_s = v,
            Static::Asymmetry => p.sf_asymmetry = v,
            Static::Bias(i) => p.bias_poly_dph[i] = v,
            Static::OutputOffset => p.output_offset_v = v,
        }
    }

    /// The size of one unit of its step in the fit, for a map whose scale factor is `s_ref`.
    pub(super) fn step(self, s_ref: f64) -> f64 {
        match self {
            Static::ScaleFactor => s_ref * 1e-3,
            Static::SfTc => 1e-4,
            Static::SfTc2 => 1e-6,
            Static::SagnacK => 0.01,
            Static::Asymmetry => 1e-4,
            Static::Bias(_) => 1.0,
            Static::OutputOffset => s_ref * 1e-2,
        }
    }
}

/// What the data can determine, from the training records: the free static parameters and a
/// reason for each that is not.
pub(super) fn determinable(records: &[&Record]) -> (Vec<Static>, Vec<(Static, String)>) {
    let rated: Vec<&&Record> = records.iter().filter(|r| r.rate_dps.abs() > 0.5).collect();
    let span = |rs: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = rs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        if hi >= lo { hi - lo } else { 0.0 }
    };
    let rated_span = span(&mut rated.iter().map(|r| r.temp_c));
    let all_span = span(&mut records.iter().map(|r| r.temp_c));
    let distinct = |v: &mut dyn Iterator<Item = i64>| {
        let mut v: Vec<i64> = v.collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let temps = distinct(&mut rated.iter().map(|r| r.temp_c.round() as i64));
    let rates = distinct(
        &mut rated
            .iter()
            .map(|r| (r.rate_dps.abs() * 2.0).round() as i64),
    );
    let max_rate = rated.iter().map(|r| r.rate_dps.abs()).fold(0.0, f64::max);
    let both_signs =
        rated.iter().any(|r| r.rate_dps > 0.0) && rated.iter().any(|r| r.rate_dps < 0.0);
    let mut free = Vec::new();
    let mut fixed = Vec::new();
    let mut rule = |j: Static, ok: bool, why: String| {
        if ok {
            free.push(j);
        } else {
            fixed.push((j, why));
        }
    };
    let has_rates = rated.len() >= 3;
    let no_rates =
        || "every reference rate is (near) zero: the data show no scale factor".to_owned();
    rule(Static::ScaleFactor, has_rates, no_rates());
    rule(
        Static::SfTc,
        has_rates && rated_span >= 5.0,
        format!("needs rates at temperatures ≥ 5 °C apart (the data span {rated_span:.1} °C)"),
    );
    rule(
        Static::SfTc2,
        has_rates && rated_span >= 20.0 && temps >= 3,
        format!(
            "needs rates at ≥ 3 temperatures over ≥ 20 °C (the data: {temps} over {rated_span:.1} °C)"
        ),
    );
    rule(
        Static::SagnacK,
        has_rates && max_rate >= 20.0 && rates >= 3,
        format!(
            "needs ≥ 3 rate magnitudes up to ≥ 20 °/s to show the sine's compression (the data: \
             {rates} up to {max_rate:.1} °/s)"
        ),
    );
    rule(
        Static::Asymmetry,
        has_rates && both_signs,
        "needs rates of both signs".to_owned(),
    );
    // An offset at the output and a bias differ only in how the sine's compression treats them
    // (the bias passes through it: S·b·cos(K′ω)), so the offset is known where the sine is.
    rule(
        Static::OutputOffset,
        has_rates && max_rate >= 20.0 && rates >= 3,
        "not separable from the bias without the sine's compression: 0, the bias carries it"
            .to_owned(),
    );
    // The bias polynomial's degree follows the temperature span: a cubic needs 40 °C of it, a
    // quadratic 20 (over less, its curvature is fitted to noise and run-to-run offsets, and it
    // extrapolates wildly past the trained span).
    let degree = match all_span {
        s if s >= 40.0 => 3,
        s if s >= 20.0 => 2,
        s if s >= 2.0 => 1,
        _ => 0,
    };
    for i in 0..4 {
        rule(
            Static::Bias(i),
            i <= degree,
            format!(
                "degree {i} of the bias needs a wider temperature span (the data span \
                 {all_span:.1} °C: degree {degree}); set to 0"
            ),
        );
    }
    (free, fixed)
}

/// One parameter as identified.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Parameter {
    /// Name, as in the unit file.
    pub name: String,
    /// Value in the unit file.
    pub value: f64,
    /// One-sigma uncertainty from the fit's covariance, where fitted.
    pub std_error: Option<f64>,
    /// Whether the data determined it.
    pub determined: bool,
    /// Where it comes from, or why it is nominal.
    pub why: String,
}
