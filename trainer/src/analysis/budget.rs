//! A target's budget for a unit's models (`fit --budget-ram/--budget-flash/--budget-instructions`):
//! what each channel's model costs the firmware, and the sizes chosen within the budget.
//!
//! A channel's model costs RAM (its numbers, 4 bytes each, and its bookkeeping), flash (its part
//! of the blob) and instructions per sample (its mean and variance on the Cortex-M4F); the unit
//! adds its own bookkeeping and the variance scratch of its largest channel
//! ([`crate::firmware::unit`] has the figures). The rule, in three steps, all before the fit that
//! ships:
//!
//! 1. the smallest models the channels allow (each [`SMALLEST`] centres, or its points where
//!    fewer) are costed from the sizes alone; above the budget, `fit` refuses before fitting, with
//!    the figures;
//! 2. the models the default fit ships (exact up to [`MAX_CENTRES`] points) are costed; within the
//!    budget, nothing is chosen;
//! 3. otherwise each channel's candidate sizes (sparse GPs of the inducing counts of
//!    [`capacity::CANDIDATES`] below its points, and its exact GP where the firmware holds it) are
//!    fitted on four fifths of its points and scored on the fifth left out, and the combination
//!    within the budget whose held-out errors, each over its channel's best, sum least is chosen.
//!
//! The budget is checked again on the blob as fitted, which an extension (`--features`) may make
//! larger than its static model; a blob beyond it is refused with the figures, not written.

use std::fmt;
use std::str::FromStr;

use firmware_core::MAX_CENTRES;
use firmware_core::blob::Dims;
use serde::Serialize;

use crate::analysis::capacity;
use crate::data::points::Points;
use crate::firmware::unit::{channel_bytes, instructions};
use crate::models::gp::{GpConfig, GpError, GpModel, Inducing};
use crate::models::prior::MeanBasis;

/// Centres of the smallest model a channel is given: the fewest inducing points tried.
pub const SMALLEST: usize = capacity::CANDIDATES[0];
/// Every `HOLD_OUT_EVERY`-th point is held out to score the candidate sizes.
const HOLD_OUT_EVERY: usize = 5;
/// Most combinations of sizes searched; beyond, each channel's candidates are cut to the smallest
/// and the exact (a unit of more than seven channels).
const MOST_COMBINATIONS: usize = 1 << 20;

/// A number of bytes, with an optional unit: `131072`, `128K` or `128KiB` (1024), `128KB`
/// (1000), `1M`/`1MiB`, `1MB`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bytes(pub usize);

impl FromStr for Bytes {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let t = s.trim();
        let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
        let (digits, unit) = t.split_at(split);
        let n: usize = digits.parse().map_err(|_| {
            format!("'{s}': expected a number of bytes, e.g. 131072, 128K or 128KiB")
        })?;
        let k = match unit.trim() {
            "" | "B" => 1,
            "K" | "KiB" | "k" => 1024,
            "KB" | "kB" => 1000,
            "M" | "MiB" => 1 << 20,
            "MB" => 1_000_000,
            other => {
                return Err(format!(
                    "'{s}': unknown unit '{other}' (K, KiB, KB, M, MiB, MB)"
                ));
            }
        };
        Ok(Self(n * k))
    }
}

/// A target's budget: each part where given.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Budget {
    /// RAM for the unit (its numbers, bookkeeping and scratch), bytes.
    pub ram_bytes: Option<usize>,
    /// Flash for the blob (one calibration slot), bytes.
    pub flash_bytes: Option<usize>,
    /// Instructions per sample on the Cortex-M4F, every channel's mean and variance.
    pub instructions: Option<f64>,
}

impl Budget {
    /// Whether any part is given.
    pub fn is_set(&self) -> bool {
        self.ram_bytes.is_some() || self.flash_bytes.is_some() || self.instructions.is_some()
    }

    /// Whether `cost` fits every part given.
    pub fn holds(&self, cost: &Cost) -> bool {
        self.ram_bytes.is_none_or(|b| cost.ram_bytes <= b)
            && self.flash_bytes.is_none_or(|b| cost.flash_bytes <= b)
            && self.instructions.is_none_or(|b| cost.instructions <= b)
    }
}

impl fmt::Display for Budget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if let Some(b) = self.ram_bytes {
            parts.push(format!("{b} bytes of RAM"));
        }
        if let Some(b) = self.flash_bytes {
            parts.push(format!("{b} bytes of flash"));
        }
        if let Some(b) = self.instructions {
            parts.push(format!("{b:.0} instructions per sample"));
        }
        f.write_str(&parts.join(", "))
    }
}

/// What a model (or a unit) costs the firmware.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Cost {
    /// RAM, bytes.
    pub ram_bytes: usize,
    /// Flash (blob), bytes.
    pub flash_bytes: usize,
    /// Instructions per sample on the Cortex-M4F.
    pub instructions: f64,
}

impl std::ops::Add for Cost {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            ram_bytes: self.ram_bytes + o.ram_bytes,
            flash_bytes: self.flash_bytes + o.flash_bytes,
            instructions: self.instructions + o.instructions,
        }
    }
}

impl fmt::Display for Cost {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} bytes of RAM, {} of flash, {:.0} instructions per sample",
            self.ram_bytes, self.flash_bytes, self.instructions
        )
    }
}

impl Cost {
    /// One channel's model of sizes `dims`: its numbers and bookkeeping in RAM, its part of the
    /// blob (4 bytes a number, its exponents and features, lengths and its entry's name), its mean
    /// and variance per sample.
    pub fn model(dims: Dims) -> Self {
        let floats = dims.floats();
        Self {
            ram_bytes: 4 * floats + channel_bytes(dims.d, dims.p),
            flash_bytes: 4 * floats + dims.p * dims.d + 5 * dims.d + 24 + 48,
            instructions: instructions(dims.m, dims.d),
        }
    }

    /// What a unit adds once to its channels': its header, ID, range and shared features, and the
    /// variance scratch of its largest channel (`most_m` centres).
    pub fn unit(most_m: usize) -> Self {
        Self {
            ram_bytes: 33 + 8 + 8 * firmware_core::MAX_FEATURES + 8 + 4 * most_m,
            flash_bytes: 22 + 48,
            instructions: 0.0,
        }
    }
}

/// The sizes of one channel's static model before it is fitted: its inputs and the prior-mean
/// monomials its basis keeps once the pure linear ones move to the raw inputs (an upper bound:
/// a fit may drop some).
pub fn static_dims(points: &Points, basis: MeanBasis, m: usize) -> Dims {
    let d = points.features().len();
    let p = basis
        .exponents(d)
        .iter()
        .filter(|e| e.iter().sum::<u8>() != 1)
        .count();
    Dims { m, d, p }
}

/// One size a channel's model may take.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Size {
    /// Inducing points asked for, or the points of the exact GP.
    pub asked: usize,
    /// `sparse` or `exact`.
    pub kind: &'static str,
    /// RMSE on the held-out fifth of the channel's points, in its unit.
    pub held_out_rmse: f64,
    /// What it costs on all the points.
    pub cost: Cost,
}

impl Size {
    /// The GP setting that fits it.
    pub fn inducing(&self) -> Inducing {
        match self.kind {
            "exact" => Inducing::Exact,
            _ => Inducing::Count(self.asked),
        }
    }
}

/// Every size a channel's model may take (module doc), scored on its held-out fifth; `progress`
/// is told each fit.
pub fn sizes(
    points: &Points,
    cfg: &GpConfig,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Size>, GpError> {
    let n = points.len();
    let held = |k: usize| k % HOLD_OUT_EVERY == HOLD_OUT_EVERY - 1;
    let (train, test): (Vec<usize>, Vec<usize>) = (0..n).partition(|&k| !held(k));
    let fit_part = points.select(&train);
    let test_part = points.select(&test);
    let target = test_part.target();
    let score = |inducing: Inducing| -> Result<f64, GpError> {
        let cfg = GpConfig {
            inducing,
            ..cfg.clone()
        };
        let model = GpModel::fit(fit_part.inputs(), &fit_part.target(), &cfg)?;
        let x = test_part.inputs();
        let sq: f64 = (0..x.nrows())
            .map(|i| {
                let row: Vec<f64> = x.row(i).iter().copied().collect();
                (model.predict_mean(&row) - target[i]).powi(2)
            })
            .sum();
        Ok((sq / x.nrows().max(1) as f64).sqrt())
    };
    let mut out = Vec::new();
    for &m in capacity::CANDIDATES.iter().filter(|&&m| m < train.len()) {
        progress(&format!("a sparse GP with {m} inducing points"));
        out.push(Size {
            asked: m,
            kind: "sparse",
            held_out_rmse: score(Inducing::Count(m))?,
            cost: Cost::model(static_dims(points, cfg.mean, m)),
        });
    }
    if n <= MAX_CENTRES {
        progress("the exact GP");
        out.push(Size {
            asked: n,
            kind: "exact",
            held_out_rmse: score(Inducing::Exact)?,
            cost: Cost::model(static_dims(points, cfg.mean, n)),
        });
    }
    Ok(out)
}

/// How the budget was met, as `fit --json` reports it (`budget`).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Report {
    /// The budget.
    pub budget: Budget,
    /// What the default fit's models would cost.
    pub default_cost: Cost,
    /// Each channel's sizes tried (none where the default fit fits the budget) and the one
    /// chosen, by channel name.
    pub channels: Vec<ChannelSizes>,
    /// What the chosen models cost, as estimated before fitting.
    pub chosen_cost: Cost,
}

/// One channel's sizes in a [`Report`].
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ChannelSizes {
    /// The channel.
    pub name: String,
    /// The sizes tried.
    pub sizes: Vec<Size>,
    /// The index of the one chosen in `sizes` (none where the default stood).
    pub chosen: Option<usize>,
}

/// Why no sizes fit the budget.
#[derive(Debug, thiserror::Error)]
#[error(
    "the budget ({budget}) holds less than the smallest models these channels allow need \
     ({smallest}: {each}); raise the budget or calibrate fewer channels (checked before fitting)"
)]
pub struct Refused {
    /// The budget.
    pub budget: Budget,
    /// The smallest unit's cost.
    pub smallest: Cost,
    /// Each channel's smallest model, in words.
    pub each: String,
}

/// Refuses a budget that even the smallest models (each channel's [`SMALLEST`] centres, or its
/// points where fewer, of `dims` inputs and monomials) exceed.
pub fn check_smallest(budget: &Budget, channels: &[(&str, Dims)]) -> Result<Cost, Refused> {
    let each: Vec<(String, Cost)> = channels
        .iter()
        .map(|(name, dims)| {
            let m = dims.m.min(SMALLEST);
            let cost = Cost::model(Dims { m, ..*dims });
            (
                format!("{name} {m} centres, {} bytes of RAM", cost.ram_bytes),
                cost,
            )
        })
        .collect();
    let most_m = channels
        .iter()
        .map(|(_, d)| d.m.min(SMALLEST))
        .max()
        .unwrap_or(0);
    let smallest = each.iter().fold(Cost::unit(most_m), |acc, (_, c)| acc + *c);
    if budget.holds(&smallest) {
        Ok(smallest)
    } else {
        Err(Refused {
            budget: *budget,
            smallest,
            each: each
                .into_iter()
                .map(|(t, _)| t)
                .collect::<Vec<_>>()
                .join("; "),
        })
    }
}

/// The combination of one size per channel within `budget` whose held-out errors, each over its
/// channel's best, sum least (ties: less RAM); `None` where none fits. Returns each channel's
/// index into its sizes and the unit's cost.
pub fn choose(channels: &[Vec<Size>], budget: &Budget) -> Option<(Vec<usize>, Cost)> {
    let best: Vec<f64> = channels
        .iter()
        .map(|s| {
            s.iter()
                .map(|x| x.held_out_rmse)
                .fold(f64::INFINITY, f64::min)
                .max(f64::MIN_POSITIVE)
        })
        .collect();
    let options: Vec<Vec<usize>> = {
        let all: Vec<Vec<usize>> = channels.iter().map(|s| (0..s.len()).collect()).collect();
        let count = all.iter().map(Vec::len).product::<usize>();
        if count <= MOST_COMBINATIONS {
            all
        } else {
            all.into_iter()
                .map(|o| {
                    let last = o.len().saturating_sub(1);
                    if last == 0 { o } else { vec![0, last] }
                })
                .collect()
        }
    };
    let mut pick = vec![0usize; channels.len()];
    let mut winner: Option<(f64, usize, Vec<usize>, Cost)> = None;
    loop {
        let mut cost = Cost::default();
        let mut most_m = 0;
        let mut loss = 0.0;
        for (c, &i) in pick.iter().enumerate() {
            let s = &channels[c][options[c][i]];
            cost = cost + s.cost;
            most_m = most_m.max(s.asked);
            loss += s.held_out_rmse / best[c];
        }
        let cost = cost + Cost::unit(most_m);
        if budget.holds(&cost) {
            let better = winner.as_ref().is_none_or(|(l, ram, _, _)| {
                loss < *l - 1e-12 || (loss <= *l + 1e-12 && cost.ram_bytes < *ram)
            });
            if better {
                let chosen = pick
                    .iter()
                    .enumerate()
                    .map(|(c, &i)| options[c][i])
                    .collect();
                winner = Some((loss, cost.ram_bytes, chosen, cost));
            }
        }
        // Next combination (odometer).
        let mut c = 0;
        loop {
            if c == pick.len() {
                return winner.map(|(_, _, chosen, cost)| (chosen, cost));
            }
            pick[c] += 1;
            if pick[c] < options[c].len() {
                break;
            }
            pick[c] = 0;
            c += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size(asked: usize, rmse: f64, ram: usize) -> Size {
        Size {
            asked,
            kind: "sparse",
            held_out_rmse: rmse,
            cost: Cost {
                ram_bytes: ram,
                flash_bytes: ram,
                instructions: ram as f64,
            },
        }
    }

    #[test]
    fn bytes_read_as_engineers_write_them() {
        assert_eq!("131072".parse::<Bytes>(), Ok(Bytes(131_072)));
        assert_eq!("128K".parse::<Bytes>(), Ok(Bytes(131_072)));
        assert_eq!("128KiB".parse::<Bytes>(), Ok(Bytes(131_072)));
        assert_eq!("128KB".parse::<Bytes>(), Ok(Bytes(128_000)));
        assert_eq!("1M".parse::<Bytes>(), Ok(Bytes(1 << 20)));
        assert!("12Q".parse::<Bytes>().is_err());
        assert!("K".parse::<Bytes>().is_err());
    }

    #[test]
    fn the_budget_takes_the_least_held_out_error_that_fits() {
        // Two channels: the first loses little by shrinking, the second much.
        let a = vec![size(24, 1.05, 100), size(140, 1.0, 1000)];
        let b = vec![size(24, 3.0, 100), size(140, 1.0, 1000)];
        let unit = Cost::unit(140).ram_bytes;
        let budget = |ram| Budget {
            ram_bytes: Some(ram + unit),
            ..Budget::default()
        };
        // Room for both large: both large.
        let (pick, _) = choose(&[a.clone(), b.clone()], &budget(2000)).unwrap();
        assert_eq!(pick, [1, 1]);
        // Room for one large: the second channel's, which loses more by shrinking.
        let (pick, cost) = choose(&[a.clone(), b.clone()], &budget(1100)).unwrap();
        assert_eq!(pick, [0, 1]);
        assert_eq!(cost.ram_bytes, 1100 + unit);
        // Room for neither, even both small.
        let tight = Budget {
            ram_bytes: Some(200),
            ..Budget::default()
        };
        assert!(choose(&[a, b], &tight).is_none());
    }

    #[test]
    fn a_budget_below_the_smallest_models_is_refused_with_the_figures() {
        let dims = Dims { m: 140, d: 2, p: 7 };
        let small = Budget {
            ram_bytes: Some(2000),
            ..Budget::default()
        };
        let e = check_smallest(&small, &[("gyro.x", dims), ("gyro.y", dims)]).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("gyro.x 24 centres") && text.contains("2000 bytes of RAM"),
            "{text}"
        );
        let roomy = Budget {
            ram_bytes: Some(1 << 20),
            ..Budget::default()
        };
        assert!(check_smallest(&roomy, &[("gyro.x", dims)]).is_ok());
    }
}
