//! `trainer fit --px4-params / --ardupilot-params`: each unit's cubics, fitted on the same
//! training samples as its models, written as the autopilots take them
//! ([`crate::firmware::autopilot`]).

use std::path::PathBuf;

use clap::Args;
use fog_terminal::console::Console;
use fog_terminal::io::write_atomically;

use crate::firmware::autopilot::{self, SensorCubics};

/// The autopilots' parameter files `fit` writes beside the blob (and `report` beside its pages).
#[derive(Args, Clone, Default)]
pub(in crate::cli) struct ParamsArgs {
    /// Write PX4's thermal calibration here, as `process_sensor_caldata.py` writes it (TC_G{i}_*,
    /// TC_A{i}_*: a cubic per axis in T − TREF, T clipped to TMIN:TMAX, with the device IDs), and
    /// TC_G_ENABLE, TC_A_ENABLE.
    #[arg(long, value_name = "FILE")]
    pub(super) px4_params: Option<PathBuf>,
    /// Write ArduPilot's thermal calibration here, as `tempcal_IMU.py` writes it (INS_TCALn_*:
    /// ENABLE, TMIN, TMAX and a cubic per axis in T − 35 °C without constant term, ×1e6).
    #[arg(long, value_name = "FILE")]
    pub(super) ardupilot_params: Option<PathBuf>,
}

impl ParamsArgs {
    /// The files asked for.
    pub(in crate::cli) fn files(&self) -> impl Iterator<Item = &PathBuf> {
        self.px4_params.iter().chain(&self.ardupilot_params)
    }

    /// True when a file is asked for.
    pub(in crate::cli) fn asked(&self) -> bool {
        self.files().next().is_some()
    }

    /// Writes the files asked for from every unit's cubics, and says what each holds.
    pub(in crate::cli) fn write(
        &self,
        units: &[SensorCubics],
        console: &Console,
    ) -> anyhow::Result<()> {
        let files = [
            (&self.px4_params, autopilot::px4_params(units), "PX4"),
            (
                &self.ardupilot_params,
                autopilot::ardupilot_parm(units),
                "ArduPilot",
            ),
        ];
        // The axes of a board whose rotation could not be turned back are the vehicle's: an
        // autopilot would apply their curves to the board's (tempcal_IMU.py refuses such a log).
        let unturned: Vec<&str> = units
            .iter()
            .filter(|u| u.vehicle_axes)
            .map(|u| u.name.as_str())
            .collect();
        for (path, text, who) in files {
            let Some(path) = path else { continue };
            if !unturned.is_empty() {
                console.warn(&format!(
                    "{} not written: the board's rotation (AHRS_ORIENTATION) could not be turned \
                     back for {}, so their axes are the vehicle's, and {who} would apply the \
                     curves to the board's",
                    path.display(),
                    unturned.join(", ")
                ));
                continue;
            }
            write_atomically(path, text.as_bytes())?;
            let lines = text.lines().filter(|l| !l.starts_with('#')).count();
            console.result(&format!(
                "wrote {} ({who}: {lines} parameters, the cubics of {})",
                path.display(),
                units
                    .iter()
                    .map(|u| u.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        Ok(())
    }
}
