//! Renders simulated data in the project's CSV formats (docs/design.md §3).

use crate::gyro::paper::Point;
use crate::gyro::stream::Row;

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

/// Renders a stream as a stream CSV (`time_s,temp_c,voltage_v,rate_dps`, then the truth behind it:
/// chamber air, coil temperature and commanded table rate, which loaders ignore).
pub fn stream_csv(rows: &[Row]) -> String {
    let mut s = String::from("time_s,temp_c,voltage_v,rate_dps,air_c,coil_c,table_rate_dps\n");
    for r in rows {
        s.push_str(&format!(
            "{},{:.4},{:.9},{:.9},{:.4},{:.4},{}\n",
            r.time_s, r.temp_c, r.voltage_v, r.rate_dps, r.air_c, r.coil_c, r.table_rate_dps
        ));
    }
    s
}
