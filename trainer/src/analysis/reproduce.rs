//! Our figures beside the reference paper's (He, Liu, Zhao, Liu; docs/design.md §1), from one
//! points file.

use serde::Serialize;

use crate::analysis::evaluate::{Evaluation, Fig2};

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
#[derive(Debug, Clone, Serialize)]
pub struct Reproduction {
    /// GPR evaluation.
    pub gpr: Evaluation,
    /// LS-SVR evaluation.
    pub lssvr: Evaluation,
    /// Two-step evaluation.
    pub two_step: Evaluation,
    /// The Fig. 2 check.
    pub fig2: Fig2,
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
            ("GPR", &self.gpr, Some(PAPER_LOO_GPR)),
            ("LS-SVR", &self.lssvr, Some(PAPER_LOO_LSSVR)),
            ("two-step", &self.two_step, None),
        ] {
            s.push_str(&format!(
                "  {name:<24}  {:>10}   {:>10.2}   {:>10}\n",
                fmt(e.rmse_dps),
                e.rmse_dph,
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
            let find = |e: &Evaluation| {
                e.per_temperature
                    .iter()
                    .find(|x| x.group == g.group)
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
                find(&self.lssvr),
                pl,
                find(&self.two_step)
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
        s.push_str(&format!(
            "Q-Q correlation of LOO residuals (1 = normal): GPR {:.4}, LS-SVR {:.4}, two-step {:.4}\n",
            self.gpr.qq_correlation, self.lssvr.qq_correlation, self.two_step.qq_correlation
        ));
        s
    }
}
