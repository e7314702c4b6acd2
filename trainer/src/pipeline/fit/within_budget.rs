//! A target's budget and the fit: the channels' model sizes chosen within it before fitting (the
//! default sizes where it holds them), and the fitted blob checked against it after (an
//! extension may make a blob larger than its static model).

use firmware_core::MAX_CENTRES;
use firmware_core::blob::Dims;

use super::{FitPlan, Named};
use crate::analysis::basis::BasisChoice;
use crate::analysis::{basis, budget};
use crate::data::points::Points;
use crate::firmware::unit;
use crate::models::gp::Inducing;
use crate::progress::Messages;

/// A channel's plan, and its prior mean's basis where chosen before its fit.
pub(super) type Planned = (FitPlan, Option<BasisChoice>);

impl FitPlan {
    /// The plans of the channels `named` (each with its loaded streams), their models' sizes chosen
    /// within the budget where one is given (`analysis::budget`): this plan for each, with the
    /// size chosen for its channel, and its prior mean's basis where chosen first (to size it).
    pub(super) fn within_budget(
        &self,
        named: &[Named<'_>],
        messages: &dyn Messages,
    ) -> anyhow::Result<(Vec<Planned>, Option<budget::Report>)> {
        let plans: Vec<FitPlan> = named.iter().map(|(_, p, _)| (*p).clone()).collect();
        if !self.budget.is_set() {
            return Ok((plans.into_iter().map(|p| (p, None)).collect(), None));
        }
        anyhow::ensure!(
            self.gp.inducing == Inducing::Auto,
            "--budget-* chooses the models' sizes: leave --inducing out"
        );
        let points = named
            .iter()
            .map(|(_, plan, streams)| plan.source.static_points(streams, plan.pool, messages))
            .collect::<anyhow::Result<Vec<_>>>()?;
        // Each channel's basis is chosen first: its sizes are the sizes of its model.
        let spinner = messages.busy("choosing each channel's prior mean on temperature bands");
        let plans: Vec<Planned> = plans
            .into_iter()
            .zip(&points)
            .map(|(plan, p)| {
                let (gp, chosen) = basis::resolve(p, &plan.gp);
                (FitPlan { gp, ..plan }, chosen)
            })
            .collect();
        drop(spinner);
        for ((name, _, _), (_, chosen)) in named.iter().zip(&plans) {
            if let Some(c) = chosen {
                messages.result(&format!("{name}: prior mean: {}", c.verdict));
            }
        }
        let dims = |k: usize, m: usize| budget::static_dims(&points[k], plans[k].0.gp.mean, m);
        let smallest: Vec<(&str, Dims)> = named
            .iter()
            .zip(&points)
            .enumerate()
            .map(|(k, ((name, _, _), p))| (*name, dims(k, p.len())))
            .collect();
        budget::check_smallest(&self.budget, &smallest)?;
        let default_cost = default_cost(&points, &dims);
        if self.budget.holds(&default_cost) {
            messages.result(&format!(
                "the budget ({}) holds the models the default fit ships ({default_cost}): no size \
                 is chosen",
                self.budget
            ));
            let report = budget::Report {
                budget: self.budget,
                default_cost,
                channels: named
                    .iter()
                    .map(|(name, _, _)| budget::ChannelSizes {
                        name: (*name).to_owned(),
                        sizes: Vec::new(),
                        chosen: None,
                    })
                    .collect(),
                chosen_cost: default_cost,
            };
            return Ok((plans, Some(report)));
        }
        let spinner = messages.busy("sizing the channels' models within the budget");
        let sizes = named
            .iter()
            .zip(&points)
            .zip(&plans)
            .map(|(((name, _, _), p), (plan, _))| {
                budget::sizes(p, &plan.gp, |step| {
                    spinner.stage(&format!("sizing {name}: {step}"));
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        drop(spinner);
        let (chosen, cost) = budget::choose(&sizes, &self.budget).ok_or_else(|| {
            anyhow::anyhow!(
                "no combination of the channels' sizes fits the budget ({}): the smallest \
                 exceed it once the unit's scratch is added",
                self.budget
            )
        })?;
        let channels: Vec<budget::ChannelSizes> = named
            .iter()
            .zip(sizes)
            .zip(&chosen)
            .map(|(((name, _, _), sizes), &i)| budget::ChannelSizes {
                name: (*name).to_owned(),
                sizes,
                chosen: Some(i),
            })
            .collect();
        messages.result(&format!(
            "the budget ({}) does not hold the default models ({default_cost}); chosen within \
             it, on each channel's points with every fifth held out ({cost}):{}",
            self.budget,
            channels.iter().map(chosen_line).collect::<String>()
        ));
        let out = plans
            .into_iter()
            .zip(&channels)
            .map(|((mut plan, chosen), c)| {
                if let Some(i) = c.chosen {
                    plan.gp.inducing = c.sizes[i].inducing();
                }
                (plan, chosen)
            })
            .collect();
        let report = budget::Report {
            budget: self.budget,
            default_cost,
            channels,
            chosen_cost: cost,
        };
        Ok((out, Some(report)))
    }

    /// The budget checked on the blob as fitted (an extension may have made it larger than its
    /// static model): refused with the figures where it does not fit.
    pub(super) fn check_fitted(&self, f: &unit::UnitFootprint) -> anyhow::Result<()> {
        let cost = budget::Cost {
            ram_bytes: f.unit_bytes + f.scratch_bytes,
            flash_bytes: f.blob_bytes,
            instructions: f.instructions,
        };
        anyhow::ensure!(
            self.budget.holds(&cost),
            "the fitted blob needs {cost}, beyond the budget ({}): the extensions the diagnosis \
             added made it larger than its static models; fit without --features, or raise the \
             budget (nothing written)",
            self.budget
        );
        Ok(())
    }
}

/// What the models the default fit ships would cost together: each channel's exact GP on its
/// points, up to the firmware's centres, with the unit's scratch sized for the largest.
fn default_cost(points: &[Points], dims: &dyn Fn(usize, usize) -> Dims) -> budget::Cost {
    let default: Vec<Dims> = points
        .iter()
        .enumerate()
        .map(|(k, p)| dims(k, p.len().min(MAX_CENTRES)))
        .collect();
    let most_m = default.iter().map(|d| d.m).max().unwrap_or(0);
    default.iter().fold(budget::Cost::unit(most_m), |acc, d| {
        acc + budget::Cost::model(*d)
    })
}

/// One channel's line of the sizes chosen: its size, how far its held-out error is from its best
/// size's, and its RAM.
fn chosen_line(c: &budget::ChannelSizes) -> String {
    let Some(pick) = c.chosen.map(|i| &c.sizes[i]) else {
        return String::new();
    };
    let best = c
        .sizes
        .iter()
        .map(|x| x.held_out_rmse)
        .fold(f64::INFINITY, f64::min);
    format!(
        "\n  {}: {} GP of {} {} ({:+.1}% held-out error against its best size), {} bytes of RAM",
        c.name,
        pick.kind,
        pick.asked,
        if pick.kind == "exact" {
            "points"
        } else {
            "inducing points"
        },
        100.0 * (pick.held_out_rmse / best - 1.0),
        pick.cost.ram_bytes
    )
}
