//! How results read on a terminal: the optimizer's starts, named causes, a diagnosis.

use firmware_sim::cause::Cause;
use firmware_sim::console::Console;

use crate::analysis::diagnose::{self, Diagnosis};
use crate::models::gp::GpModel;

/// Under --verbose: every optimizer start of a fit, where it began and ended.
pub(super) fn log_starts(console: &Console, model: &GpModel) {
    if !console.verbose() {
        return;
    }
    console.detail("optimizer starts (θ = ln ℓ…, ln σ_f, ln σ_n[, ln σ_g]; normalized):");
    for (i, s) in model.starts.iter().enumerate() {
        let fmt = |t: &[f64]| {
            t.iter()
                .map(|v| format!("{v:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        console.detail(&format!(
            "  {i:>2}: [{}] → [{}]  log ML {}  {} likelihoods, {} evaluations: {}",
            fmt(&s.start),
            s.end.as_deref().map_or("failed".to_owned(), fmt),
            s.log_marginal_likelihood
                .map_or("—".to_owned(), |l| format!("{l:.3}")),
            s.likelihoods,
            s.evaluations,
            s.status
        ));
    }
}

/// Named causes joined by " + ", or `none`.
pub(super) fn causes_text(causes: &[Cause]) -> String {
    if causes.is_empty() {
        return "none".to_owned();
    }
    diagnose::joined(causes)
}

/// The diagnosis as a terminal reads it: the verdict, every candidate alone, then the selection.
pub(super) fn render_diagnosis(d: &Diagnosis) -> String {
    let mut s = format!(
        "causes: {} — {}\nresidual rmse_60s {:.3e} °/s ({:.2} °/h) over {} blocks of 60 s\n\
         candidate       score   forward   parameter   correlation   amplitude (°/h)\n",
        causes_text(&d.causes),
        d.explanation,
        d.residual_rmse_60s_dps,
        d.residual_rmse_60s_dps * 3600.0,
        d.n_blocks
    );
    for c in &d.candidates {
        s.push_str(&format!(
            "{:<14} {:>6.3}   {:>7.3}   {:>9.1}   {:>11.3}   {:>15.2}\n",
            c.id.id(),
            c.score,
            c.forward_score,
            c.parameter,
            c.correlation,
            c.amplitude_dph
        ));
    }
    s.push_str("selection: causes                                of what is left: score   forward   taken\n");
    for st in &d.steps {
        s.push_str(&format!(
            "           {:<38} {:>21.3}   {:>7.3}   {}\n",
            causes_text(&st.causes),
            st.score,
            st.forward_score,
            if st.added { "yes" } else { "no" }
        ));
    }
    s
}
