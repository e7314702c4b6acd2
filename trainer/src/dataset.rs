//! Rate-table points ready for fitting: inputs (T, V), target ω, and the temperature plateaus that
//! leave-one-temperature-out and the two-step model need.

use std::path::Path;

use firmware_core::Feature;
use firmware_core::features::{self, FeatureState, Sample};
use nalgebra::{DMatrix, DVector};

use crate::data::{self, ColumnMap, DataError};

/// The inputs of a rate-table model, in order: the paper's (T, V).
pub const POINT_FEATURES: [Feature; 2] = [Feature::Temperature, Feature::Voltage];

/// Gap between sorted temperatures that separates two plateaus, °C. Soaked plateaus of a thermal
/// chamber are ≥ 5 °C apart; readings within one plateau scatter by hundredths of a degree.
pub const PLATEAU_GAP_C: f64 = 1.0;

/// Averaged rate-table points (DESIGN §3 `points`).
#[derive(Debug, Clone)]
pub struct Points {
    /// Temperature, °C.
    pub temp_c: Vec<f64>,
    /// Gyro output (V, counts…).
    pub voltage_v: Vec<f64>,
    /// Reference rate, °/s.
    pub rate_dps: Vec<f64>,
    /// Group of each point (plateau index, or the `--group` column's label), as labels.
    pub group: Vec<String>,
}

/// Errors specific to rate-table points.
#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    /// Loading failed.
    #[error(transparent)]
    Data(#[from] DataError),
    /// Fewer than two temperature plateaus: no temperature dependence can be learnt or tested.
    #[error(
        "{path}: {found} temperature plateau(s) (points closer than {gap} °C are one plateau); at least two are needed to learn a temperature dependence"
    )]
    TooFewTemperatures {
        /// The file.
        path: String,
        /// Plateaus found.
        found: usize,
        /// The plateau gap, °C.
        gap: f64,
    },
}

/// Plateau index of each temperature: sorted temperatures split where the gap exceeds
/// [`PLATEAU_GAP_C`]; indices ascend with temperature.
pub fn plateaus(temps: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..temps.len()).collect();
    order.sort_by(|&a, &b| temps[a].total_cmp(&temps[b]));
    let mut id = vec![0; temps.len()];
    let mut current = 0;
    for w in 0..order.len() {
        if w > 0 && temps[order[w]] - temps[order[w - 1]] > PLATEAU_GAP_C {
            current += 1;
        }
        id[order[w]] = current;
    }
    id
}

impl Points {
    /// Loads a points CSV; `group` names a column whose values define the groups for
    /// leave-one-group-out (default: temperature plateaus).
    pub fn load(path: &Path, maps: &[ColumnMap], group: Option<&str>) -> Result<Self, PointsError> {
        let labels: Vec<&str> = group.into_iter().collect();
        let c = data::read_columns(
            path,
            &["temp_c", "voltage_v", "rate_dps"],
            &[],
            &labels,
            maps,
        )?;
        data::require_varying(&c, "voltage_v", "the gyro output carries no information")?;
        data::require_varying(
            &c,
            "rate_dps",
            "a single rate carries no scale-factor information",
        )?;
        let temp_c = c.get("temp_c").to_vec();
        let found = plateaus(&temp_c).into_iter().max().map_or(0, |m| m + 1);
        if found < 2 {
            return Err(PointsError::TooFewTemperatures {
                path: path.display().to_string(),
                found,
                gap: PLATEAU_GAP_C,
            });
        }
        let group = match group {
            Some(g) => c.labels.get(g).cloned().unwrap_or_default(),
            None => plateaus(&temp_c).iter().map(usize::to_string).collect(),
        };
        Ok(Self {
            voltage_v: c.get("voltage_v").to_vec(),
            rate_dps: c.get("rate_dps").to_vec(),
            temp_c,
            group,
        })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.temp_c.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.temp_c.is_empty()
    }

    /// Model inputs, one row per point, in the order of [`POINT_FEATURES`]: computed by
    /// firmware-core's feature pipeline, so they are exactly what the firmware computes (each
    /// point is a soaked, independent sample: a fresh pipeline state).
    pub fn inputs(&self) -> DMatrix<f64> {
        let d = POINT_FEATURES.len();
        let mut x = DMatrix::zeros(self.len(), d);
        let mut row = [0.0f32; POINT_FEATURES.len()];
        for i in 0..self.len() {
            let sample = Sample {
                time_s: 0.0,
                temp_c: self.temp_c[i] as f32,
                output: self.voltage_v[i] as f32,
            };
            features::compute(
                &POINT_FEATURES,
                &sample,
                &mut FeatureState::default(),
                &mut row,
            );
            for (k, v) in row.iter().enumerate() {
                x[(i, k)] = f64::from(*v);
            }
        }
        x
    }

    /// Targets: the reference rate.
    pub fn target(&self) -> DVector<f64> {
        DVector::from_column_slice(&self.rate_dps)
    }

    /// The subset at `idx`.
    pub fn select(&self, idx: &[usize]) -> Self {
        let pick = |v: &[f64]| idx.iter().map(|&i| v[i]).collect();
        Self {
            temp_c: pick(&self.temp_c),
            voltage_v: pick(&self.voltage_v),
            rate_dps: pick(&self.rate_dps),
            group: idx.iter().map(|&i| self.group[i].clone()).collect(),
        }
    }

    /// Distinct groups in order of first appearance, with their member indices.
    pub fn groups(&self) -> Vec<(String, Vec<usize>)> {
        let mut out: Vec<(String, Vec<usize>)> = Vec::new();
        for (i, g) in self.group.iter().enumerate() {
            match out.iter_mut().find(|(name, _)| name == g) {
                Some((_, members)) => members.push(i),
                None => out.push((g.clone(), vec![i])),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateaus_split_on_gaps() {
        assert_eq!(
            plateaus(&[20.0, -30.0, 20.01, -29.98, 5.0]),
            vec![2, 0, 2, 0, 1]
        );
    }

    #[test]
    fn one_temperature_is_refused() {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        std::io::Write::write_all(&mut f, b"temp_c,voltage_v,rate_dps\n20,1,1\n20.01,2,2\n")
            .unwrap();
        let e = Points::load(f.path(), &[], None).unwrap_err();
        assert!(e.to_string().contains("1 temperature plateau(s)"), "{e}");
    }
}
