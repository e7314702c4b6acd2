//! Our figures beside the reference paper's (He, Liu, Zhao, Liu; docs/design.md §1), from one
//! points file.

use crate::progress::Progress;
use serde::Serialize;

use crate::analysis::evaluate::{self, EvalConfig, EvalError, Evaluation, Fig2, Method};
use crate::data::points::Points;
use crate::models::gp::GpConfig;

/// The paper's leave-one-temperature-out table: (°C, LS-SVR RMSE, GPR RMSE), °/s.
pub const PAPER_LOTO: [(f64, f64, f64); 10] = [
    (-30.0, 3.52e-2, 2.16e-3),
    (-20.0, 2.90e-2, 9.28e-4),
    (-10.0, 4.34e-3, 2.23e-5),
    (-5.0, 6.91e-3, 1.66e-5),
    (0.0, 4.84e-3, 9.87e-6),
    (5.0, 4.48e-3, 1.46e-4),
    (10.0, 1.13e-2, 5.71e-5),
    (20.0, 3.82e-3, 1.78e-4),
    (40.0, 6.57e-3, 9.87e-4),
    (60.0, 2.22e-2, 1.67e-3),
];
/// The paper's LOO RMSE over 140 points, GPR, °/s.
pub const PAPER_LOO_GPR: f64 = 7.03e-4;
/// The paper's LOO RMSE over 140 points, LS-SVR, °/s.
pub const PAPER_LOO_LSSVR: f64 = 1.26e-2;
/// The paper's Fig. 2 worst first-order V-vs-T error: mV, °/s, at rate °/s.
pub const PAPER_FIG2: (f64, f64, f64) = (4.8, 0.13, -80.0);

/// Everything the reproduction table shows.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Reproduction {
    /// GPR evaluation.
    pub gpr: Evaluation,
    /// LS-SVR evaluation (none where it could not be fitted: `skipped` says why).
    pub lssvr: Option<Evaluation>,
    /// Two-step evaluation (none where it could not be fitted).
    pub two_step: Option<Evaluation>,
    /// The Fig. 2 check.
    pub fig2: Fig2,
    /// The methods these points could not be evaluated with, and why.
    pub skipped: Vec<String>,
}

/// The paper's evaluations of `points`: the GP's (an error where it fails), and each rival's
/// where it can be fitted (a two-step model needs soaked plateaus), skipped with the reason where
/// not; on the physics basis where `cfg` asks for one chosen. `bar` counts the fits.
pub fn reproduce(
    points: &Points,
    cfg: &EvalConfig,
    bar: &dyn Progress,
) -> Result<Reproduction, EvalError> {
    // The methods are compared on one basis, the sensor's form, unless one is asked for.
    let cfg = &EvalConfig {
        gp: GpConfig {
            mean: cfg.gp.mean.or_physics(),
            ..cfg.gp.clone()
        },
        ..cfg.clone()
    };
    let gpr = evaluate::evaluate(points, Method::Gpr, cfg, bar)?;
    let mut skipped = Vec::new();
    let mut rival = |method: Method| match evaluate::evaluate(points, method, cfg, bar) {
        Ok(e) => Some(e),
        Err(e) => {
            skipped.push(format!("{}: {e}", method.name()));
            None
        }
    };
    let (lssvr, two_step) = (rival(Method::Lssvr), rival(Method::TwoStep));
    Ok(Reproduction {
        gpr,
        lssvr,
        two_step,
        fig2: evaluate::fig2(points),
        skipped,
    })
}

fn fmt(v: f64) -> String {
    format!("{v:.2e}")
}

impl Reproduction {
    /// The table as text. Leave-one-temperature-out rows are paired with the paper's by rank when
    /// there are ten plateaus (our temperatures are sensor readings, a few °C above the setpoints).
    pub fn render(&self, source: &str) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "Reproduction of He et al. (GPR for FOG temperature drift) on {source}: {} points\n\n",
            self.gpr.n
        ));
        s.push_str("leave-one-out RMSE          ours (°/s)   ours (°/h)   paper (°/s)\n");
        for (name, e, paper) in [
            ("GPR", Some(&self.gpr), Some(PAPER_LOO_GPR)),
            ("LS-SVR", self.lssvr.as_ref(), Some(PAPER_LOO_LSSVR)),
            ("two-step", self.two_step.as_ref(), None),
        ] {
            s.push_str(&format!(
                "  {name:<24}  {:>10}   {:>10}   {:>10}\n",
                e.map_or("—".into(), |e| fmt(e.rmse_dps)),
                e.map_or("—".into(), |e| format!("{:.2}", e.rmse_dph)),
                paper.map_or("—".into(), fmt)
            ));
        }
        s.push_str("\nleave-one-temperature-out RMSE (°/s)\n");
        s.push_str("  T (°C)   GPR ours   GPR paper  LS-SVR ours LS-SVR paper two-step ours\n");
        let paired = self.gpr.per_temperature.len() == PAPER_LOTO.len();
        let mut order: Vec<usize> = (0..self.gpr.per_temperature.len()).collect();
        order.sort_by(|&a, &b| {
            self.gpr.per_temperature[a]
                .temp_c
                .total_cmp(&self.gpr.per_temperature[b].temp_c)
        });
        for (rank, &i) in order.iter().enumerate() {
            let g = &self.gpr.per_temperature[i];
            let find = |e: Option<&Evaluation>| {
                e.and_then(|e| e.per_temperature.iter().find(|x| x.group == g.group))
                    .map_or("—".into(), |x| fmt(x.rmse_dps))
            };
            let (pg, pl) = if paired {
                let p = PAPER_LOTO[rank];
                (fmt(p.2), fmt(p.1))
            } else {
                ("—".into(), "—".into())
            };
            s.push_str(&format!(
                "  {:>6.1}   {:>9}  {:>9}  {:>10}  {:>10}   {:>10}\n",
                g.temp_c,
                fmt(g.rmse_dps),
                pg,
                find(self.lssvr.as_ref()),
                pl,
                find(self.two_step.as_ref())
            ));
        }
        if let Some(w) = &self.fig2.worst {
            s.push_str(&format!(
                "\nFig. 2 check, worst first-order V-vs-T fit: ours {:.2} mV ≈ {:.3} °/s at {:+.0} °/s \
                 (scale factor {:.2} mV/(°/s)); paper {} mV ≈ {} °/s at {:+.0} °/s\n",
                w.worst_mv,
                w.worst_dps,
                w.rate_dps,
                self.fig2.scale_factor_mv_per_dps,
                PAPER_FIG2.0,
                PAPER_FIG2.1,
                PAPER_FIG2.2
            ));
        }
        let qq =
            |e: Option<&Evaluation>| e.map_or("—".into(), |e| format!("{:.4}", e.qq_correlation));
        s.push_str(&format!(
            "Q-Q correlation of LOO residuals (1 = normal): GPR {:.4}, LS-SVR {}, two-step {}\n",
            self.gpr.qq_correlation,
            qq(self.lssvr.as_ref()),
            qq(self.two_step.as_ref())
        ));
        for why in self.skipped.iter().chain(&self.gpr.skipped) {
            s.push_str(&format!("skipped: {why}\n"));
        }
        s
    }
}
