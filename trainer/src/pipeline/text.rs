//! A diagnosis in words, as `diagnose` and `investigate` say it: the verdict, each candidate
//! alone, then the selection.

use firmware_core::units::DPH_PER_DPS;

use crate::analysis::diagnose::{Diagnosis, causes_text};

/// The diagnosis as a terminal reads it: the verdict, every candidate alone, then the selection.
pub fn render_diagnosis(d: &Diagnosis) -> String {
    let (k, u) = (d.quantity.bias_per_unit(), d.quantity.bias_unit());
    let mut s = format!(
        "causes: {} — {}\nresidual rmse_60s {:.3e} {} ({:.2} {u}) over {} blocks of 60 s\n\
         candidate       score   forward   parameter   correlation   amplitude ({u})\n",
        causes_text(&d.causes),
        d.explanation,
        d.residual_rmse_60s_dps,
        d.quantity.unit(),
        d.residual_rmse_60s_dps * k,
        d.n_blocks
    );
    // A forward score the test could not see (the input flat in the later half) is marked.
    let forward = |score: f64, sees: bool| {
        if sees {
            format!("{score:>7.3}")
        } else {
            format!("{score:>6.3}*")
        }
    };
    for c in &d.candidates {
        s.push_str(&format!(
            "{:<14} {:>6.3}   {}   {:>9.1}   {:>11.3}   {:>15.2}\n",
            c.id.id(),
            c.score,
            forward(c.forward_score, c.forward_sees),
            c.parameter,
            c.correlation,
            c.amplitude_dph / DPH_PER_DPS * k
        ));
    }
    s.push_str("selection: causes                                of what is left: score   forward   taken\n");
    for st in &d.steps {
        s.push_str(&format!(
            "           {:<38} {:>21.3}   {}   {}\n",
            causes_text(&st.causes),
            st.score,
            forward(st.forward_score, st.forward_sees),
            match (st.added, st.replaces) {
                (true, Some(state)) => format!("yes, in place of the design with {state}"),
                (true, None) => "yes".to_owned(),
                (false, _) => "no".to_owned(),
            }
        ));
        if let Some([score, forward]) = st.state_share {
            s.push_str(&format!(
                "             its heating/cooling state beside plateau constants {score:>7.3}   \
                 {forward:>7.3}\n"
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::diagnose::Step;
    use fog_data::cause::Cause;

    #[test]
    fn the_selection_shows_a_state_s_own_share_and_what_took_its_place() {
        let step = |causes: Vec<Cause>, state_share, replaces, added| Step {
            causes,
            parameters: vec![0.0; 2],
            score: 0.2,
            forward_score: 0.2,
            forward_sees: true,
            state_share,
            replaces,
            added,
        };
        let d = Diagnosis {
            cause: Cause::SensorLag,
            causes: vec![Cause::SensorLag, Cause::ThermalRate],
            candidates: Vec::new(),
            steps: vec![
                step(
                    vec![Cause::SensorLag, Cause::Hysteresis],
                    Some([0.642, 0.699]),
                    None,
                    true,
                ),
                step(
                    vec![Cause::SensorLag, Cause::ThermalRate],
                    None,
                    Some(Cause::Hysteresis),
                    true,
                ),
            ],
            residual_rmse_60s_dps: 1e-3,
            quantity: firmware_core::Quantity::AngularRate,
            n_blocks: 100,
            runner_up: None,
            explanation: String::new(),
            add_feature: None,
            add_features: Vec::new(),
        };
        let text = render_diagnosis(&d);
        assert!(
            text.contains("its heating/cooling state beside plateau constants   0.642     0.699"),
            "{text}"
        );
        assert!(
            text.contains("yes, in place of the design with hysteresis"),
            "{text}"
        );
        assert_eq!(text.matches("plateau constants").count(), 1, "{text}");
    }
}
