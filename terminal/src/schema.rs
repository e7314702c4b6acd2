//! The contract of every JSON file the two programs write, in one place: each carries
//! `"schema": {"name": …, "version": …}` first, so a script can tell what it reads and refuse what
//! it does not know. A version grows when a field changes meaning or goes away; a new field does
//! not change it. docs/commands.md lists them ([`ALL`]), generated from here; docs/json.md lists
//! each one's fields, generated from the type its body is written from ([`Contract`]).

use schemars::JsonSchema;
use serde::Serialize;

/// A JSON output's name and version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
pub struct Schema {
    /// `program.command`.
    pub name: &'static str,
    /// Its version, from 1.
    pub version: u32,
    /// What writes it, in a few words (not written into the JSON).
    #[serde(skip)]
    pub written_by: &'static str,
}

const fn v1(name: &'static str, written_by: &'static str) -> Schema {
    Schema {
        name,
        version: 1,
        written_by,
    }
}

/// Version 2: the outputs that were one channel's or a unit's, now every one a unit's (one
/// channel's data is a unit of one).
const fn v2(name: &'static str, written_by: &'static str) -> Schema {
    Schema {
        name,
        version: 2,
        written_by,
    }
}

/// Version 3 of a unit's σ (version 2 of `trainer.loo`, whose version 1 was already one table's):
/// another power-on's bias assumed where nothing states or measures it (`turn_on_std` no longer 0
/// for "not stated": `turn-on` in `assumed` says it is assumed), its scale factor likewise where
/// the residuals show an error in proportion to the output (`scale_repeatability_ppm` no longer 0
/// for "not stated": `scale` in `assumed`), and a log's own later part scored as the
/// calibration's power-on.
const fn turn_on_assumed(name: &'static str, version: u32, written_by: &'static str) -> Schema {
    Schema {
        name,
        version,
        written_by,
    }
}

/// `firmware-sim generate board --json`: the simulated flight controller's truth.
pub const BOARD: Schema = v1("sim.board", "firmware-sim generate board --json");

/// `trainer summarize --json`: each file's summary under `files` (a unit's: a list per file of
/// each channel's).
pub const SUMMARIZE: Schema = v1("trainer.summarize", "trainer summarize --json");
/// `trainer fit --json`: the unit and each channel's fit (one channel's data: a unit of one).
pub const FIT: Schema = turn_on_assumed("trainer.fit", 3, "trainer fit --json");
/// `trainer inspect --json`: the blob's footprint, each channel's (a model blob: a unit of one).
pub const INSPECT: Schema = v2("trainer.inspect", "trainer inspect --json");
/// `trainer diagnose --json`: each channel's diagnosis (`channels`).
pub const DIAGNOSE: Schema = v2("trainer.diagnose", "trainer diagnose --json");
/// `trainer investigate --json`: each channel's investigation.
pub const INVESTIGATE: Schema =
    turn_on_assumed("trainer.investigate", 3, "trainer investigate --json");
/// `trainer loo --json`.
pub const LOO: Schema = turn_on_assumed("trainer.loo", 2, "trainer loo --json");
/// `trainer reproduce --json`.
pub const REPRODUCE: Schema = v1("trainer.reproduce", "trainer reproduce --json");
/// `trainer challenge --json`.
pub const CHALLENGE: Schema = v1("trainer.challenge", "trainer challenge --json");
/// `trainer report`'s `report.json` beside its page: each channel's figures and cubics.
pub const REPORT: Schema = turn_on_assumed("trainer.report", 3, "trainer report (report.json)");
/// `trainer allan --json`: each channel's (`channels`).
pub const ALLAN: Schema = v2("trainer.allan", "trainer allan --json");
/// `fog.allan` in Python: one rate's Allan analysis, as each channel of `trainer.allan` holds it.
pub const ALLAN_ANALYSIS: Schema = v1("trainer.allan-analysis", "fog.allan (Python)");
/// `firmware-sim identify --json`: each gyro channel's (`channels`).
pub const IDENTIFY: Schema = v2("sim.identify", "firmware-sim identify --json");
/// The simulator's unit file of one gyro, as `firmware-sim identify --out` wrote it before it
/// wrote axes: `firmware-sim generate --unit` still reads it.
pub const SIM_UNIT: Schema = v1("sim.unit", "firmware-sim identify --out (earlier versions)");
/// The simulator's unit file of a unit's gyro axes (`firmware-sim identify --out`; one gyro's
/// data: one axis).
pub const SIM_AXES: Schema = v1("sim.axes", "firmware-sim identify --out");
/// `firmware-sim generate --json`, one gyro.
pub const GENERATE: Schema = v1("sim.generate", "firmware-sim generate --json");
/// `firmware-sim generate --unit AXES --json`.
pub const GENERATE_UNIT: Schema = v1(
    "sim.generate-unit",
    "firmware-sim generate --json (a unit of axes)",
);
/// `firmware-sim replay --json`: the sensor and each channel's scores.
pub const REPLAY: Schema = v2("sim.replay", "firmware-sim replay --json");
/// `firmware-sim qemu --json`: each channel's scores, their agreement with the host, the cost.
pub const QEMU: Schema = v2("sim.qemu", "firmware-sim qemu --json");

/// A JSON file as written: its contract first, then the fields of its body.
#[derive(Serialize, JsonSchema)]
pub struct Stamped<'a, T: ?Sized> {
    /// Its contract's name and version.
    pub schema: Schema,
    /// The fields of what it holds.
    #[serde(flatten)]
    pub body: &'a T,
}

/// A body of one entry per channel of a unit, under `channels`.
#[derive(Serialize, JsonSchema)]
pub struct PerChannel<'a, T> {
    /// Each channel's, in the unit's order.
    pub channels: &'a [T],
}

/// A body of one entry per file read, under `files`.
#[derive(Serialize, JsonSchema)]
pub struct PerFile<'a, T> {
    /// Each file's, in the order given.
    pub files: &'a [T],
}

/// A contract with the fields its files hold: the JSON Schema of the type the body is written
/// from, its `schema` field first.
pub struct Contract {
    /// Its name, version and writer.
    pub schema: Schema,
    /// The JSON Schema of the whole file.
    pub fields: schemars::Schema,
    /// What the body is, in the words of its type's documentation.
    pub about: Option<String>,
}

impl Contract {
    /// The contract `schema`, whose body is written from a `T`.
    pub fn of<T: JsonSchema + ?Sized + 'static>(schema: Schema) -> Self {
        let body = schemars::schema_for!(T);
        Self {
            schema,
            fields: schemars::schema_for!(Stamped<'static, T>),
            about: body
                .get("description")
                .and_then(|d| d.as_str())
                .map(str::to_owned),
        }
    }
}

/// Every contract, in the order docs/commands.md lists them.
pub const ALL: [Schema; 19] = [
    SUMMARIZE,
    FIT,
    INSPECT,
    DIAGNOSE,
    INVESTIGATE,
    LOO,
    REPRODUCE,
    CHALLENGE,
    REPORT,
    ALLAN,
    ALLAN_ANALYSIS,
    IDENTIFY,
    SIM_UNIT,
    SIM_AXES,
    GENERATE,
    GENERATE_UNIT,
    REPLAY,
    QEMU,
    BOARD,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_contract_has_its_own_name() {
        let mut names: Vec<&str> = ALL.iter().map(|s| s.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), ALL.len());
    }
}
