//! Test helpers: a small model built in f64 exactly as the trainer would, its blob, and an f64
//! reference evaluator to compare the f32 one against.

use std::vec::Vec;

use crate::blob::{self, Dims, ErrorModel, Feature, Payload};

/// A model in f64, before it is rounded into a blob.
pub struct Reference {
    pub dims: Dims,
    pub offset: Vec<f64>,
    pub scale: Vec<f64>,
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    pub length: Vec<f64>,
    pub exponents: Vec<u8>,
    pub prior: Vec<f64>,
    /// Coefficients of the raw linear terms (output units per raw input unit).
    pub raw: Vec<f64>,
    pub signal_var: f64,
    pub noise_var: f64,
    /// Centres in z (not divided by the length scales).
    pub centres: Vec<[f64; 2]>,
    pub weights: Vec<f64>,
    /// The variance besides the latent one.
    pub error: ErrorModel,
}

fn kernel(a: [f64; 2], b: [f64; 2], l: &[f64]) -> f64 {
    let r2: f64 = (0..2).map(|k| ((a[k] - b[k]) / l[k]).powi(2)).sum();
    (-0.5 * r2).exp()
}

impl Reference {
    /// A 2-input model with 5 centres and a linear prior mean.
    pub fn small() -> Self {
        let centres = vec![
            [-1.0, -0.5],
            [-0.3, 0.8],
            [0.2, -1.1],
            [0.9, 0.4],
            [1.4, 1.2],
        ];
        Self {
            dims: Dims { m: 5, d: 2, p: 3 },
            offset: vec![15.0, 0.1],
            scale: vec![25.0, 1.5],
            min: vec![-30.0, -3.0],
            max: vec![60.0, 3.0],
            length: vec![1.3, 0.7],
            exponents: vec![0, 0, 1, 0, 0, 1],
            prior: vec![0.01, -0.02, 0.5],
            raw: vec![-0.003, 26.31578947368421],
            signal_var: 0.04,
            noise_var: 1e-6,
            centres,
            weights: vec![0.3, -0.7, 0.45, -0.2, 0.6],
            error: ErrorModel {
                sample_noise_var: 4e-6,
                sample_interval_s: 1.0,
                floor_var: 1e-4,
                extrapolation_var: 2e-3,
                walk_var_per_h: 1e-5,
                trend_var_per_h2: 1e-6,
                turn_on_var: 3e-5,
                leg_var: 4e-4,
                leg_min: 0.5,
                leg_max: 1.0,
                scale_var: 4e-6,
                extrapolation_scale_var: 5e-5,
                heating_var: 2e-4,
                heating_scale_var: 1e-4,
                heating_rate_at_0c: 0.0,
                heating_rate_per_c: 0.0,
                heating_rate_min: -0.5,
                heating_rate_max: 0.5,
                heating_temp_min_c: -30.0,
                heating_temp_max_c: 60.0,
            },
        }
    }

    fn z(&self, x: [f64; 2]) -> [f64; 2] {
        [
            (x[0] - self.offset[0]) / self.scale[0],
            (x[1] - self.offset[1]) / self.scale[1],
        ]
    }

    /// Packed rows of chol(K/σ_f²) at the centres.
    pub fn factor(&self) -> Vec<f64> {
        let m = self.dims.m;
        let ratio = self.noise_var / self.signal_var;
        let mut l = vec![vec![0.0; m]; m];
        for i in 0..m {
            for j in 0..=i {
                let mut s = kernel(self.centres[i], self.centres[j], &self.length);
                if i == j {
                    s += ratio;
                }
                s -= (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
                l[i][j] = if i == j { s.sqrt() } else { s / l[j][j] };
            }
        }
        (0..m).flat_map(|i| l[i][..=i].to_vec()).collect()
    }

    /// Mean and latent variance in f64.
    pub fn predict(&self, x: [f64; 2]) -> (f64, f64) {
        let z = self.z(x);
        let mut mean = 0.0;
        for (j, c) in self.prior.iter().enumerate() {
            let e = &self.exponents[j * 2..j * 2 + 2];
            mean += c * z[0].powi(i32::from(e[0])) * z[1].powi(i32::from(e[1]));
        }
        mean += self.raw[0] * x[0] + self.raw[1] * x[1];
        let k: Vec<f64> = self
            .centres
            .iter()
            .map(|c| kernel(z, *c, &self.length))
            .collect();
        mean += k.iter().zip(&self.weights).map(|(a, b)| a * b).sum::<f64>();
        let f = self.factor();
        let mut v = vec![0.0; k.len()];
        for i in 0..k.len() {
            let row = &f[i * (i + 1) / 2..(i + 1) * (i + 2) / 2];
            let dot: f64 = (0..i).map(|j| row[j] * v[j]).sum();
            v[i] = (k[i] - dot) / row[i];
        }
        let var = self.signal_var * (1.0 - v.iter().map(|a| a * a).sum::<f64>()).max(0.0);
        (mean, var)
    }

    /// The model error in f64 at `x`, whose compensated output is `mean`, and `hours` since
    /// another power-on than calibration's, on a heating/cooling state trained (blob module doc).
    pub fn model_error(&self, x: [f64; 2], mean: f64, hours: f64) -> f64 {
        let e2: f64 = (0..2)
            .map(|k| {
                let excess = (self.min[k] - x[k]).max(x[k] - self.max[k]).max(0.0);
                (excess / (self.max[k] - self.min[k])).powi(2)
            })
            .sum();
        let e = &self.error;
        f64::from(e.floor_var)
            + f64::from(e.turn_on_var)
            + f64::from(e.scale_var) * mean * mean
            + (f64::from(e.extrapolation_var) + f64::from(e.extrapolation_scale_var) * mean * mean)
                * e2
            + f64::from(e.walk_var_per_h) * hours
            + f64::from(e.trend_var_per_h2) * hours * hours
    }

    /// The flat f32 array of the blob layout.
    pub fn floats(&self) -> Vec<f32> {
        let s = self.dims.sections();
        let mut out = vec![0.0f32; self.dims.floats()];
        let mut put = |range: core::ops::Range<usize>, values: &[f64]| {
            for (o, v) in out[range].iter_mut().zip(values) {
                *o = *v as f32;
            }
        };
        put(s.offset, &self.offset);
        put(s.scale, &self.scale);
        put(s.min, &self.min);
        put(s.max, &self.max);
        put(s.length, &self.length);
        put(s.prior, &self.prior);
        let hi: Vec<f64> = self.raw.iter().map(|&r| f64::from(r as f32)).collect();
        let lo: Vec<f64> = self.raw.iter().zip(&hi).map(|(r, h)| r - h).collect();
        put(s.raw_hi, &hi);
        put(s.raw_lo, &lo);
        put(s.variances, &[self.signal_var, self.noise_var]);
        let centres: Vec<f64> = self
            .centres
            .iter()
            .flat_map(|c| [c[0] / self.length[0], c[1] / self.length[1]])
            .collect();
        put(s.centres, &centres);
        put(s.weights, &self.weights);
        put(s.factor, &self.factor());
        out
    }

    /// The blob, with the flat array passed through `edit` first (to corrupt it on purpose).
    pub fn blob_with(&self, edit: impl FnOnce(&mut Vec<f32>)) -> Vec<u8> {
        self.encoded(edit, self.error)
    }

    /// The blob with another error model.
    pub fn blob_with_error(&self, error: ErrorModel) -> Vec<u8> {
        self.encoded(|_| {}, error)
    }

    /// The blob with other inputs than (temperature, output): the same numbers, read as a model
    /// of `features`.
    pub fn blob_of(&self, features: [Feature; 2]) -> Vec<u8> {
        self.encoded_as(features, |_| {}, self.error)
    }

    fn encoded(&self, edit: impl FnOnce(&mut Vec<f32>), error: ErrorModel) -> Vec<u8> {
        self.encoded_as([Feature::Temperature, Feature::Voltage], edit, error)
    }

    fn encoded_as(
        &self,
        features: [Feature; 2],
        edit: impl FnOnce(&mut Vec<f32>),
        error: ErrorModel,
    ) -> Vec<u8> {
        let mut floats = self.floats();
        edit(&mut floats);
        let payload = Payload {
            features: features.as_slice(),
            exponents: self.exponents.as_slice(),
            floats: floats.as_slice(),
            beyond: blob::Beyond::Hold,
            error,
            limits: blob::Limits::DEFAULT,
        };
        let mut buf = vec![0u8; 4096];
        let n = blob::encode(self.dims, &payload, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// The blob as the trainer would write it.
    pub fn blob(&self) -> Vec<u8> {
        self.blob_with(|_| {})
    }
}

/// The unit blob of `channels` (name, quantity, model blob), for sensor `id`, calibrated over
/// −30…60 °C.
pub fn unit_blob(id: &str, channels: &[(&str, crate::units::Quantity, Vec<u8>)]) -> Vec<u8> {
    let entries: Vec<blob::unit::ChannelBlob<'_>> = channels
        .iter()
        .map(|(name, quantity, model)| blob::unit::ChannelBlob {
            name,
            quantity: *quantity,
            model,
        })
        .collect();
    let mut buf = vec![0u8; 1 << 16];
    let n = blob::unit::encode(id, [-30.0, 60.0], &entries, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// The same model as a version-4 blob: the payload without its rule beyond the range, error
/// model and limits.
pub fn as_v4(blob: &[u8]) -> Vec<u8> {
    let mut v4 =
        blob[..blob.len() - 4 * (ErrorModel::NUMBERS + blob::Limits::NUMBERS) - 1].to_vec();
    v4[4..6].copy_from_slice(&blob::V4.to_le_bytes());
    blob::reseal(&mut v4);
    v4
}

/// The same model as a blob of `version`, 6, 7 or 8: the error model without its last numbers (the
/// heating term; at 7 the extrapolation's scale part too; at 6 the scale term too).
fn without_last(blob: &[u8], version: u16, numbers: usize) -> Vec<u8> {
    let dropped = 4 * (ErrorModel::NUMBERS - numbers);
    let at = blob.len() - 4 * blob::Limits::NUMBERS - dropped;
    let mut old = blob[..at].to_vec();
    old.extend_from_slice(&blob[at + dropped..]);
    old[4..6].copy_from_slice(&version.to_le_bytes());
    blob::reseal(&mut old);
    old
}

/// The same model as a version-8 blob: the error model without its last eight numbers, the
/// heating term and its band.
pub fn as_v8(blob: &[u8]) -> Vec<u8> {
    without_last(blob, blob::V8, ErrorModel::V8_NUMBERS)
}

/// The same model as a version-7 blob: the error model without its last nine numbers, the
/// heating term and the extrapolation's scale part.
pub fn as_v7(blob: &[u8]) -> Vec<u8> {
    without_last(blob, blob::V7, ErrorModel::V7_NUMBERS)
}

/// The same model as a version-6 blob: the error model without its last ten numbers, the scale
/// term, the extrapolation's scale part and the heating term.
pub fn as_v6(blob: &[u8]) -> Vec<u8> {
    without_last(blob, blob::V6, ErrorModel::V6_NUMBERS)
}

/// The same model as a version-5 blob: no rule beyond the range, the error model's first six
/// numbers, no limits.
pub fn as_v5(blob: &[u8]) -> Vec<u8> {
    let tail = 4 * (ErrorModel::NUMBERS + blob::Limits::NUMBERS);
    let kept = 4 * ErrorModel::V5_NUMBERS;
    let at = blob.len() - tail;
    // The one byte of `Beyond` before the error model goes.
    let mut v5 = blob[..at - 1].to_vec();
    v5.extend_from_slice(&blob[at..at + kept]);
    v5[4..6].copy_from_slice(&blob::V5.to_le_bytes());
    blob::reseal(&mut v5);
    v5
}
