//! A sensor unit's blob, made of its channels' blobs (each already checked against its host
//! model, [`super::export::verify`]), checked as the firmware will run it, and what it costs the
//! firmware: RAM, flash and instructions per sample.
//!
//! The unit adds nothing to a channel's arithmetic (firmware-core's `unit` module evaluates each
//! channel by the code a model decoded alone uses), so the check here is that the packing lost
//! nothing: every channel of the decoded unit computes, bit for bit, what its own blob computes
//! on a ramp over the unit's trained temperatures.

use firmware_core::blob::unit::{self as format, ChannelBlob};
use firmware_core::features::MAX_FEATURES;
use firmware_core::{Feature, FeatureState, Quantity, Sample, UnitSample};
use fog_data::replay::{self, HostModel};
use serde::Serialize;

use super::export::{ExportError, Footprint, footprint, temperature_input};

/// The trained range of each channel's temperature input (the sensor's reading, or where a
/// channel's model reads the coil's estimate instead, that), and the unit's: where every channel
/// was calibrated (the largest low end, the smallest high end).
fn temperature_range(models: &[Box<HostModel>]) -> Result<[f32; 2], ExportError> {
    let mut range = [f32::NEG_INFINITY, f32::INFINITY];
    for m in models {
        let k = temperature_input(m.features()).ok_or_else(|| {
            ExportError::Unit("a unit's channel has no temperature input".to_owned())
        })?;
        let [lo, hi] = m.trained_range(k).unwrap_or([f32::MIN, f32::MAX]);
        range = [range[0].max(lo), range[1].min(hi)];
    }
    if range[0] > range[1] {
        return Err(ExportError::Unit(format!(
            "the channels' trained temperatures do not overlap ({:.1} … {:.1} °C)",
            range[0], range[1]
        )));
    }
    Ok(range)
}

/// The unit blob of `channels` for sensor `sensor_id`, checked: the unit decodes, its shared
/// features fit the firmware's pipeline, and each channel computes what its own blob does
/// (module doc).
pub fn unit_blob(sensor_id: &str, channels: &[ChannelBlob<'_>]) -> Result<Vec<u8>, ExportError> {
    let models = channels
        .iter()
        .map(|c| replay::decode(c.model))
        .collect::<Result<Vec<_>, _>>()?;
    let temperature_c = temperature_range(&models)?;
    let room = 256 + channels.iter().map(|c| c.model.len() + 64).sum::<usize>();
    let mut buf = vec![0u8; room];
    let n = format::encode(sensor_id, temperature_c, channels, &mut buf)?;
    buf.truncate(n);
    let unit = replay::decode_unit(&buf)?;
    if unit.shared_features().len() > MAX_FEATURES {
        return Err(ExportError::Unit(format!(
            "the channels need {} distinct temperature inputs; the firmware computes {MAX_FEATURES}",
            unit.shared_features().len()
        )));
    }
    follows(&unit, &models, temperature_c)?;
    Ok(buf)
}

/// Every channel of `unit` computes what its own model does, bit for bit, on a 1 Hz ramp over
/// `temperature_c` with each channel's output at the middle of its trained range.
fn follows(
    unit: &replay::HostUnit,
    models: &[Box<HostModel>],
    [lo, hi]: [f32; 2],
) -> Result<(), ExportError> {
    const SAMPLES: u32 = 600;
    let outputs: Vec<f32> = models
        .iter()
        .map(|m| {
            m.features()
                .iter()
                .position(|f| *f == Feature::Voltage)
                .and_then(|k| m.trained_range(k))
                .map_or(0.0, |[a, b]| 0.5 * (a + b))
        })
        .collect();
    let mut shared = FeatureState::default();
    let mut own: Vec<FeatureState> = vec![FeatureState::default(); models.len()];
    let mut scratch = vec![0.0f32; unit.scratch_len()];
    let none = firmware_core::Prediction {
        mean: 0.0,
        bias_variance: 0.0,
        noise_variance: 0.0,
        status: firmware_core::Status::Fault,
    };
    let mut out = vec![none; models.len()];
    for k in 0..SAMPLES {
        let time_s = f64::from(k);
        let temp_c = lo + (hi - lo) * k as f32 / (SAMPLES - 1) as f32;
        let sample = UnitSample {
            time_s,
            temp_c,
            outputs: &outputs,
        };
        unit.compensate(&sample, &mut shared, &mut scratch, &mut out)
            .map_err(|e| ExportError::Unit(format!("the unit refused a sample: {e}")))?;
        for (c, m) in models.iter().enumerate() {
            let alone = Sample {
                time_s,
                temp_c,
                output: outputs[c],
            };
            let expected = m
                .compensate(&alone, &mut own[c], &mut scratch)
                .map_err(|e| ExportError::Unit(format!("a channel refused a sample: {e}")))?;
            if out[c] != expected {
                return Err(ExportError::Unit(format!(
                    "channel {} of the unit blob computes {:?} where its own blob computes \
                     {expected:?} at {temp_c} °C (report it)",
                    unit.channels()[c].name(),
                    out[c]
                )));
            }
        }
    }
    Ok(())
}

/// Each channel of a unit blob (or a model blob, one channel named `rate`) as a model blob of its
/// own: its name, its quantity and the blob its entry's payload makes under a model header, as
/// the trainer's fit of that one channel writes it (an older unit's, of its channels' format).
/// What an analysis of one channel (a diagnosis, a replay of one channel alone) reads.
pub fn channel_blobs(bytes: &[u8]) -> Result<Vec<(String, Quantity, Vec<u8>)>, ExportError> {
    use firmware_core::blob::{self, HEADER_LEN};
    if bytes.get(..4) == Some(&blob::MAGIC[..]) {
        replay::decode(bytes)?;
        return Ok(vec![(
            firmware_core::unit::SINGLE_CHANNEL.to_owned(),
            Quantity::AngularRate,
            bytes.to_vec(),
        )]);
    }
    let header = format::read_header(bytes)?;
    let payload = format::read_payload::<{ replay::MAX_CHANNELS }>(&header)?;
    payload
        .channels
        .iter()
        .map(|entry| {
            let mut out = vec![0u8; HEADER_LEN];
            out.extend_from_slice(entry.model);
            let dims = blob::Dims {
                m: entry.m.into(),
                d: entry.d.into(),
                p: entry.p.into(),
            };
            blob::seal(dims, entry.model.len(), &mut out).map_err(ExportError::Blob)?;
            // The payload's own format: an older unit's channels are of an older one.
            out[4..6].copy_from_slice(&header.model_version.to_le_bytes());
            blob::reseal(&mut out);
            replay::decode(&out)?;
            Ok((entry.name.to_owned(), entry.quantity, out))
        })
        .collect()
}

/// Instructions per sample on the Cortex-M4F of one channel's mean and variance with `m` centres
/// and `d` inputs, through a unit (its share of the feature pipeline included): about 5,100 fixed,
/// 67 + 3d per centre for the mean and 16.8 per multiply-add of the variance's forward
/// substitution, m(m + 1)/2 of them. Fitted to the units `firmware-sim qemu` measured
/// (docs/firmware.md, "Cost on the M4": within 3% of them).
pub fn instructions(m: usize, d: usize) -> f64 {
    let m = m as f64;
    5100.0 + (67.0 + 3.0 * d as f64) * m + 16.8 * m * (m + 1.0) / 2.0
}

/// Bytes of RAM one channel's bookkeeping takes in a `StaticUnit` on a 32-bit target, besides its
/// numbers: its name, quantity, sizes, features, exponents, error model, limits, rule beyond the
/// range, first number and input map, with their padding.
pub fn channel_bytes(d: usize, p: usize) -> usize {
    let error = 4 * firmware_core::ErrorModel::NUMBERS;
    let limits = 4 * firmware_core::blob::Limits::NUMBERS;
    17 + 1 + 12 + (8 * d + 4) + (p * d + 4) + error + limits + 1 + 4 + 2 * d + 8
}

/// What a unit blob costs the firmware (`trainer inspect`, `fit --json`).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct UnitFootprint {
    /// The sensor's ID.
    pub sensor_id: String,
    /// The trained temperature range, °C.
    pub temperature_c: [f32; 2],
    /// Each channel: its name and its model's footprint.
    pub channels: Vec<(String, Footprint)>,
    /// Blob size, bytes: what a calibration slot holds (two slots, twice this in flash).
    pub blob_bytes: usize,
    /// Numbers of all channels: the `N` of a `StaticUnit` sized to this blob.
    pub numbers: usize,
    /// RAM of that `StaticUnit` on a 32-bit target, bytes: 4·N, each channel's bookkeeping and
    /// the unit's (its ID, range and shared features).
    pub unit_bytes: usize,
    /// Variance scratch: 4 bytes per centre of the largest channel.
    pub scratch_bytes: usize,
    /// Instructions per sample on the Cortex-M4F, every channel's mean and variance (the sum of
    /// [`instructions`]: an estimate, measured by `firmware-sim qemu`).
    pub instructions: f64,
}

/// The footprint of a unit blob (or of a model blob, as a unit of one channel).
pub fn unit_footprint(bytes: &[u8]) -> Result<UnitFootprint, ExportError> {
    let unit = replay::decode_unit(bytes)?;
    let mut channels = Vec::new();
    let (mut numbers, mut bookkeeping, mut instr, mut most_m) = (0, 0, 0.0, 0);
    for ch in unit.channels() {
        let dims = ch.dims();
        let f = Footprint::of(dims, 0);
        numbers += f.floats;
        bookkeeping += channel_bytes(dims.d, dims.p);
        instr += instructions(dims.m, dims.d);
        most_m = most_m.max(dims.m);
        channels.push((ch.name().to_owned(), f));
    }
    if unit.channels().len() == 1 && bytes.get(..4) == Some(&firmware_core::blob::MAGIC[..]) {
        channels[0].1 = footprint(bytes)?;
    }
    Ok(UnitFootprint {
        sensor_id: unit.sensor_id().to_owned(),
        temperature_c: unit.temperature_range(),
        channels,
        blob_bytes: bytes.len(),
        numbers,
        unit_bytes: 4 * numbers + bookkeeping + 33 + 8 + (8 * MAX_FEATURES + 4) + 4,
        scratch_bytes: 4 * most_m,
        instructions: instr,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GYRO: &[u8] = include_bytes!("../../../firmware-core/doc/gyro.bin");

    #[test]
    fn a_unit_of_checked_channels_packs_and_says_what_it_costs() {
        let channels = [
            ChannelBlob {
                name: "gyro.x",
                quantity: Quantity::AngularRate,
                model: GYRO,
            },
            ChannelBlob {
                name: "acc.z",
                quantity: Quantity::SpecificForce,
                model: GYRO,
            },
        ];
        let blob = unit_blob("IMU-1", &channels).unwrap();
        let f = unit_footprint(&blob).unwrap();
        let single = footprint(GYRO).unwrap();
        assert_eq!(f.channels.len(), 2);
        assert_eq!(f.numbers, 2 * single.floats);
        assert_eq!(f.scratch_bytes, 4 * single.m);
        assert_eq!(f.sensor_id, "IMU-1");
        // The numbers are most of it; the packing adds less than a model blob's header per channel.
        assert!(f.unit_bytes > 4 * f.numbers && f.unit_bytes < 4 * f.numbers + 600);
        assert!(blob.len() < 2 * GYRO.len() + 64, "{} bytes", blob.len());
        assert_eq!(
            f.instructions,
            2.0 * instructions(single.m, single.d),
            "{f:?}"
        );
        // A model blob is a unit of one channel.
        let one = unit_footprint(GYRO).unwrap();
        assert_eq!(one.channels[0].1.model_bytes, single.model_bytes);
        // Each channel comes back out as the blob it went in as.
        let back = channel_blobs(&blob).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(
            (back[1].0.as_str(), back[1].1),
            ("acc.z", Quantity::SpecificForce)
        );
        assert!(back.iter().all(|(_, _, b)| b == GYRO));
    }

    /// `to` with the heating term and band of `from`.
    fn heating_of(
        from: firmware_core::ErrorModel,
        to: firmware_core::ErrorModel,
    ) -> firmware_core::ErrorModel {
        firmware_core::ErrorModel {
            heating_var: from.heating_var,
            heating_scale_var: from.heating_scale_var,
            heating_temp_min_c: from.heating_temp_min_c,
            heating_temp_max_c: from.heating_temp_max_c,
            heating_rate_at_0c: from.heating_rate_at_0c,
            heating_rate_per_c: from.heating_rate_per_c,
            heating_rate_min: from.heating_rate_min,
            heating_rate_max: from.heating_rate_max,
            ..to
        }
    }

    /// A unit blob of version 4 (channels of format 8) gives its channels back as blobs of that
    /// format, with the same fit's error model but for the heating band, which the current
    /// version states, and the same predictions where no heating rate is read.
    #[test]
    fn a_version_4_units_channels_come_back_without_the_heating_band() {
        let new = channel_blobs(include_bytes!("../../../firmware-core/doc/imu.bin")).unwrap();
        let old = channel_blobs(include_bytes!("../../../firmware-core/doc/imu-v4.bin")).unwrap();
        assert_eq!(old.len(), new.len());
        let mut scratch = vec![0.0f32; 256];
        for ((name, _, a), (_, _, b)) in old.iter().zip(&new) {
            let version = firmware_core::blob::read_header(a).unwrap().version;
            assert_eq!(version, firmware_core::blob::V8, "{name}");
            let (a, b) = (replay::decode(a).unwrap(), replay::decode(b).unwrap());
            let (ea, eb) = (a.error_model(), b.error_model());
            assert_eq!(ea.heating_var, 0.0, "{name}");
            assert!(eb.heating_rate_max > eb.heating_rate_min, "{name}");
            assert_eq!(heating_of(eb, ea), eb, "{name}");
            let x = vec![20.0f32; a.dims().d];
            assert_eq!(
                a.predict(&x, &mut scratch).unwrap(),
                b.predict(&x, &mut scratch).unwrap(),
                "{name}"
            );
        }
    }

    /// A unit blob of version 2 or 3 (channels of format 6 or 7) gives its channels back as blobs
    /// of that format, which compute what the same fit's unit of the current version computes (the
    /// assumed extrapolation term aside, changed since, another power-on's bias, assumed since,
    /// the walk, read since from the training log's Allan deviation where it is larger, and the
    /// heating band, stated since).
    #[test]
    fn an_older_units_channels_come_back_in_their_own_format() {
        use firmware_core::blob::{FORMAT_VERSION, V6, V7};
        let new = include_bytes!("../../../firmware-core/doc/imu.bin");
        let new = channel_blobs(new).unwrap();
        let mut scratch = vec![0.0f32; 256];
        let mut v6_terms = Vec::new();
        for (old, format) in [
            (
                &include_bytes!("../../../firmware-core/doc/imu-v2.bin")[..],
                V6,
            ),
            (
                &include_bytes!("../../../firmware-core/doc/imu-v3.bin")[..],
                V7,
            ),
        ] {
            let old = channel_blobs(old).unwrap();
            assert_eq!(old.len(), 6);
            for (i, ((name, _, a), (_, _, b))) in old.iter().zip(&new).enumerate() {
                let version = |blob: &[u8]| firmware_core::blob::read_header(blob).unwrap().version;
                assert_eq!((version(a), version(b)), (format, FORMAT_VERSION), "{name}");
                let b_bytes = b.clone();
                let (a, b) = (replay::decode(a).unwrap(), replay::decode(b).unwrap());
                // The same fit's error model, but for the extrapolation term assumed: since
                // scaled for the rule shipped beyond the range (`Prior::for_rule`) and taken as the
                // model's trend over each half of its range (`Prior::of`). The older formats read
                // it alike.
                let (ea, eb) = (a.error_model(), b.error_model());
                let older = ea;
                if format == V6 {
                    v6_terms.push(ea.extrapolation_var);
                } else {
                    assert_eq!(ea.extrapolation_var, v6_terms[i], "{name}");
                }
                assert!(eb.extrapolation_var > 0.0, "{name}");
                assert_eq!(ea.turn_on_var, 0.0, "{name}");
                assert!(eb.turn_on_var > 0.0, "{name}");
                let ea = firmware_core::ErrorModel {
                    extrapolation_var: eb.extrapolation_var,
                    extrapolation_scale_var: eb.extrapolation_scale_var,
                    turn_on_var: eb.turn_on_var,
                    walk_var_per_h: eb.walk_var_per_h,
                    ..heating_of(eb, ea)
                };
                assert_eq!(ea, eb, "{name}");
                // Beyond the range (every input at 20): the same mean, noise and status; the
                // bias variance differs by the error model alone: the current blob with the older
                // one's error model written in states the older one's (to f32 rounding).
                let x = vec![20.0f32; a.dims().d];
                let (pa, pb) = (
                    a.predict(&x, &mut scratch).unwrap(),
                    b.predict(&x, &mut scratch).unwrap(),
                );
                assert_eq!(
                    (pa.mean, pa.noise_variance, pa.status),
                    (pb.mean, pb.noise_variance, pb.status),
                    "{name}"
                );
                let mut rewritten = b_bytes;
                firmware_core::blob::set_error_model(&mut rewritten, &older).unwrap();
                let pr = replay::decode(&rewritten)
                    .unwrap()
                    .predict(&x, &mut scratch)
                    .unwrap();
                let (va, vr) = (f64::from(pa.bias_variance), f64::from(pr.bias_variance));
                assert!(
                    va > 0.0 && (vr / va - 1.0).abs() < 1e-5,
                    "{name}: {vr} {va}"
                );
            }
        }
    }
}
