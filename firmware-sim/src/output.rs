//! Renders simulated data in the project's CSV formats (DESIGN §3).

use crate::paper::Point;

/// Renders paper-protocol points as a points CSV (`temp_c,voltage_v,rate_dps` plus the setpoint and
/// the commanded table rate, which loaders ignore unless asked for).
pub fn points_csv(points: &[Point]) -> String {
    let mut s = String::from("temp_c,voltage_v,rate_dps,setpoint_c,table_rate_dps\n");
    for p in points {
        s.push_str(&format!(
            "{:.5},{:.9},{:.9},{},{}\n",
            p.temp_c, p.voltage_v, p.rate_dps, p.setpoint_c, p.table_rate_dps
        ));
    }
    s
}
