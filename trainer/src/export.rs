//! Export of a fitted GP as a firmware blob, built with firmware-core's own types (one definition
//! of the format), and the f32 fidelity of the result.
//!
//! Everything is computed in f64 and rounded once: weights `w = α·σ_f²·s_y`, variances in output
//! units², centres divided by the length scales, and the variance factor `L/σ_f` (the Cholesky
//! factor of K/σ_f²), packed by rows.

use firmware_core::blob::{self, Dims, Feature, HEADER_LEN, Payload};
use firmware_core::model::Model;
use serde::Serialize;

use crate::gp::GpModel;

/// The largest model the trainer exports: 256 centres already need about 132 KB of f32 on the
/// microcontroller, the top of a Cortex-M4's RAM. The host decodes blobs back into these
/// capacities (heapless storage is inline, so they also bound the host's stack use).
pub const MAX_CENTRES: usize = 256;
/// Host-side input capacity.
pub const MAX_INPUTS: usize = 8;
/// Host-side exponent capacity.
pub const MAX_EXPONENTS: usize = 8 * 165;
/// Host-side float capacity, for MAX_CENTRES centres.
pub const MAX_FLOATS: usize = Dims {
    m: MAX_CENTRES,
    d: MAX_INPUTS,
    p: 165,
}
.floats();

/// The model type the host decodes blobs into (boxed: it is large).
pub type HostModel = Model<MAX_INPUTS, MAX_EXPONENTS, MAX_FLOATS>;

/// Errors of export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The model is too large for the blob format or the host capacities.
    #[error("model too large to export: {0}")]
    TooLarge(String),
    /// The firmware encoder or decoder refused the blob.
    #[error("blob: {0}")]
    Blob(firmware_core::BlobError),
}

/// Builds the blob of a fitted GP with inputs (temperature, voltage).
pub fn to_blob(model: &GpModel) -> Result<Vec<u8>, ExportError> {
    let post = &model.posterior;
    let h = &post.hyper;
    let (m, d) = post.xs.shape();
    let p = model.prior.coefficients.len();
    if m > MAX_CENTRES || d > MAX_INPUTS {
        return Err(ExportError::TooLarge(format!(
            "{m} centres × {d} inputs; a firmware model holds at most {MAX_CENTRES} centres \
             (about 132 KB of f32 on the microcontroller) and {MAX_INPUTS} inputs: fit on fewer points"
        )));
    }
    let dims = Dims { m, d, p };
    let sf2 = h.signal_std.powi(2);
    let sy = model.output_scale;
    let mut floats: Vec<f64> = Vec::with_capacity(dims.floats());
    floats.extend(&model.input_norm.offset);
    floats.extend(&model.input_norm.scale);
    floats.extend(model.input_range.iter().map(|r| r.0));
    floats.extend(model.input_range.iter().map(|r| r.1));
    floats.extend(&h.length_scales);
    floats.extend(&model.prior.coefficients);
    floats.extend([sf2 * sy * sy, h.noise_std.powi(2) * sy * sy]);
    for i in 0..m {
        floats.extend((0..d).map(|k| post.xs[(i, k)]));
    }
    floats.extend(post.alpha.iter().map(|a| a * sf2 * sy));
    let l = post.chol.l_dirty();
    let sf = h.signal_std;
    for i in 0..m {
        floats.extend((0..=i).map(|j| l[(i, j)] / sf));
    }
    let floats: Vec<f32> = floats.into_iter().map(|v| v as f32).collect();
    let exponents: Vec<u8> = model.prior.exponents.iter().flatten().copied().collect();
    let payload = Payload {
        features: [Feature::Temperature, Feature::Voltage]
            .get(..d)
            .unwrap_or(&[]),
        exponents: exponents.as_slice(),
        floats: floats.as_slice(),
    };
    let mut buf = vec![0u8; HEADER_LEN + 16 + exponents.len() + 5 * floats.len()];
    let n = blob::encode(dims, &payload, &mut buf).map_err(ExportError::Blob)?;
    buf.truncate(n);
    Ok(buf)
}

/// Decodes a blob into host capacities (boxed: the capacities make the value large).
pub fn decode(bytes: &[u8]) -> Result<Box<HostModel>, ExportError> {
    HostModel::decode(bytes)
        .map(Box::new)
        .map_err(ExportError::Blob)
}

/// Largest |firmware f32 mean − host f64 mean| over samples of raw inputs (rows of `x`), output
/// units: how faithfully the blob carries the model.
pub fn f32_fidelity(model: &GpModel, firmware: &HostModel, x: &nalgebra::DMatrix<f64>) -> f64 {
    x.row_iter()
        .map(|row| {
            let host = model.predict(&row.iter().copied().collect::<Vec<_>>()).mean;
            let raw: Vec<f32> = row.iter().map(|&v| v as f32).collect();
            (f64::from(firmware.predict_mean(&raw).mean) - host).abs()
        })
        .fold(0.0, f64::max)
}

/// Size and static memory of a blob's model on the firmware.
#[derive(Debug, Clone, Serialize)]
pub struct Footprint {
    /// Centres, inputs, prior-mean monomials.
    pub m: usize,
    /// Inputs.
    pub d: usize,
    /// Prior-mean monomials.
    pub p: usize,
    /// Blob size, bytes.
    pub blob_bytes: usize,
    /// Numbers in the flat array: 5d + p + 2 + m·d + m + m(m+1)/2.
    pub floats: usize,
    /// Static memory of `Model<d, p·d, floats>` on a 32-bit target, bytes:
    /// 4·floats + p·d + d, three 4-byte vector lengths and 12 bytes of dimensions, rounded up to 4.
    pub model_bytes: usize,
    /// Scratch the variance path needs: m f32, bytes.
    pub scratch_bytes: usize,
}

/// The footprint of a blob, for `trainer inspect`.
pub fn footprint(bytes: &[u8]) -> Result<Footprint, ExportError> {
    let header = blob::read_header(bytes).map_err(ExportError::Blob)?;
    let Dims { m, d, p } = header.dims;
    let floats = header.dims.floats();
    Ok(Footprint {
        m,
        d,
        p,
        blob_bytes: bytes.len(),
        floats,
        model_bytes: (4 * floats + p * d + d + 3 * 4 + 12).div_ceil(4) * 4,
        scratch_bytes: 4 * m,
    })
}
