//! The byte records of a replay through a device: what the host sends for each sample and what
//! the device answers. The Cortex-M4 image under QEMU reads and writes these (firmware-sim's
//! `qemu` command); defined here, beside the types they carry, so the two ends cannot drift apart.
//!
//! ```text
//! sample (20 bytes)  time_s f64 LE | temp_c f32 LE | output f32 LE | flags u32 LE (bit 0: power-on)
//! result  (9 bytes)  mean f32 LE | bias variance f32 LE | status u8 (Valid 0, Extrapolating 1,
//!                    Degraded 2, Fault 3)
//! ```
//!
//! A unit of c channels ([`crate::unit`]) sends the sample record with its first channel's output,
//! then the other c − 1 outputs (f32 LE each): 20 + 4(c − 1) bytes; and gets c result records
//! back, in channel order. A unit of one channel's records are the single-channel ones.

use crate::features::Sample;
use crate::status::Status;
use crate::unit::UnitSample;

/// Bytes of one sample record.
pub const SAMPLE_BYTES: usize = 20;
/// Bytes of one result record.
pub const RESULT_BYTES: usize = 9;
/// Flag bit of a sample at power-on (the feature state goes through
/// [`crate::features::FeatureState::power_on`] before it).
const POWER_ON: u32 = 1;

/// A sample, and whether the gyro was powered on at it, as a record.
pub fn encode_sample(sample: &Sample, power_on: bool) -> [u8; SAMPLE_BYTES] {
    let mut out = [0u8; SAMPLE_BYTES];
    out[..8].copy_from_slice(&sample.time_s.to_le_bytes());
    out[8..12].copy_from_slice(&sample.temp_c.to_le_bytes());
    out[12..16].copy_from_slice(&sample.output.to_le_bytes());
    let flags = if power_on { POWER_ON } else { 0 };
    out[16..].copy_from_slice(&flags.to_le_bytes());
    out
}

/// The sample of a record, and whether it is a power-on.
pub fn decode_sample(record: &[u8; SAMPLE_BYTES]) -> (Sample, bool) {
    let [
        t0,
        t1,
        t2,
        t3,
        t4,
        t5,
        t6,
        t7,
        a0,
        a1,
        a2,
        a3,
        b0,
        b1,
        b2,
        b3,
        f0,
        f1,
        f2,
        f3,
    ] = *record;
    let sample = Sample {
        time_s: f64::from_le_bytes([t0, t1, t2, t3, t4, t5, t6, t7]),
        temp_c: f32::from_le_bytes([a0, a1, a2, a3]),
        output: f32::from_le_bytes([b0, b1, b2, b3]),
    };
    (sample, u32::from_le_bytes([f0, f1, f2, f3]) & POWER_ON != 0)
}

/// A prediction's mean, bias variance and status as a record (the noise variance is the blob's).
pub fn encode_result(mean: f32, variance: f32, status: Status) -> [u8; RESULT_BYTES] {
    let mut out = [0u8; RESULT_BYTES];
    out[..4].copy_from_slice(&mean.to_le_bytes());
    out[4..8].copy_from_slice(&variance.to_le_bytes());
    out[8] = status as u8;
    out
}

/// The mean, bias variance and status of a record; a status byte beyond the known ones reads as
/// `Fault`.
pub fn decode_result(record: &[u8; RESULT_BYTES]) -> (f32, f32, Status) {
    let [m0, m1, m2, m3, v0, v1, v2, v3, s] = *record;
    let status = match s {
        0 => Status::Valid,
        1 => Status::Extrapolating,
        2 => Status::Degraded,
        _ => Status::Fault,
    };
    (
        f32::from_le_bytes([m0, m1, m2, m3]),
        f32::from_le_bytes([v0, v1, v2, v3]),
        status,
    )
}

/// Bytes of one sample record of a unit of `channels` channels.
pub const fn unit_sample_bytes(channels: usize) -> usize {
    SAMPLE_BYTES + 4 * channels.saturating_sub(1)
}

/// Writes the record of a unit's sample (and whether the unit was powered on at it) into the
/// start of `out`; returns its length, or `None` where `out` is too short or the sample has no
/// output.
pub fn encode_unit_sample(
    sample: &UnitSample<'_>,
    power_on: bool,
    out: &mut [u8],
) -> Option<usize> {
    let (first, rest) = sample.outputs.split_first()?;
    let len = unit_sample_bytes(sample.outputs.len());
    let out = out.get_mut(..len)?;
    let head = encode_sample(
        &Sample {
            time_s: sample.time_s,
            temp_c: sample.temp_c,
            output: *first,
        },
        power_on,
    );
    let (h, tail) = out.split_at_mut(SAMPLE_BYTES);
    h.copy_from_slice(&head);
    for (dst, v) in tail.chunks_exact_mut(4).zip(rest) {
        dst.copy_from_slice(&v.to_le_bytes());
    }
    Some(len)
}

/// Reads a unit sample record of `outputs.len()` channels: its time, temperature and power-on
/// flag, with the outputs written into `outputs`; `None` where the record is too short.
pub fn decode_unit_sample(record: &[u8], outputs: &mut [f32]) -> Option<(f64, f32, bool)> {
    let record = record.get(..unit_sample_bytes(outputs.len()))?;
    let (head, tail) = record.split_first_chunk::<SAMPLE_BYTES>()?;
    let (sample, power_on) = decode_sample(head);
    let (first, rest) = outputs.split_first_mut()?;
    *first = sample.output;
    for (dst, b) in rest.iter_mut().zip(tail.chunks_exact(4)) {
        *dst = f32::from_le_bytes(b.try_into().ok()?);
    }
    Some((sample.time_s, sample.temp_c, power_on))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_are_pinned_by_their_bytes_and_read_back() {
        let sample = Sample {
            time_s: 1.5,
            temp_c: -2.0,
            output: 0.25,
        };
        let bytes = encode_sample(&sample, true);
        assert_eq!(
            bytes,
            [
                0, 0, 0, 0, 0, 0, 0xf8, 0x3f, 0, 0, 0, 0xc0, 0, 0, 0x80, 0x3e, 1, 0, 0, 0
            ]
        );
        assert_eq!(decode_sample(&bytes), (sample, true));
        assert!(!decode_sample(&encode_sample(&sample, false)).1);

        let bytes = encode_result(1.0, 0.5, Status::Degraded);
        assert_eq!(bytes, [0, 0, 0x80, 0x3f, 0, 0, 0, 0x3f, 2]);
        assert_eq!(decode_result(&bytes), (1.0, 0.5, Status::Degraded));
        for status in [
            Status::Valid,
            Status::Extrapolating,
            Status::Degraded,
            Status::Fault,
        ] {
            assert_eq!(decode_result(&encode_result(0.0, 0.0, status)).2, status);
        }
    }

    #[test]
    fn a_units_sample_record_is_the_single_record_and_the_other_outputs() {
        let outputs = [0.25f32, -1.0, 2.0];
        let sample = UnitSample {
            time_s: 1.5,
            temp_c: -2.0,
            outputs: &outputs,
        };
        let mut buf = [0u8; 40];
        assert_eq!(encode_unit_sample(&sample, true, &mut buf), Some(28));
        let single = encode_sample(
            &Sample {
                time_s: 1.5,
                temp_c: -2.0,
                output: 0.25,
            },
            true,
        );
        assert_eq!(&buf[..20], &single);
        assert_eq!(&buf[20..28], &[0, 0, 0x80, 0xbf, 0, 0, 0, 0x40]);
        let mut back = [0.0f32; 3];
        assert_eq!(decode_unit_sample(&buf, &mut back), Some((1.5, -2.0, true)));
        assert_eq!(back, outputs);
        assert_eq!(encode_unit_sample(&sample, true, &mut buf[..27]), None);
        assert_eq!(decode_unit_sample(&buf[..27], &mut back), None);
        assert_eq!(unit_sample_bytes(1), SAMPLE_BYTES);
    }
}
