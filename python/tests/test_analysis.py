"""The Allan deviation and the summary from Python equal `trainer allan` and `trainer summarize`
on the same log."""

import csv
import json

import numpy as np
import pytest

import fog
from conftest import DATA, run

LOG = DATA / "tofupilot-imu-thermal" / "imu_raw_data.tsv"


def columns(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    return {k: np.array([float(r[k]) for r in rows]) for k in ("timestamp", "imu.gyro.z", "imu.temperature")}


def test_allan_is_the_commands(tmp_path):
    out = tmp_path / "allan.json"
    run(
        "trainer", "allan", "--stream", LOG, "--map", "time_s=timestamp*1e-6",
        "--map", "temp_c=imu.temperature", "--map", "voltage_v=imu.gyro.z",
        "--map", "rate_dps=0", "--scale-factor", "1", "--json", out, "-q",
    )
    [cli] = json.loads(out.read_text())["channels"]
    assert (cli.pop("name"), cli.pop("quantity"), cli.pop("units")) == ("rate", "angular-rate", "°/s")
    c = columns(LOG)
    t = c["timestamp"] * 1e-6
    ours = fog.allan(t, c["imu.gyro.z"] / 1.0, reference_dps=np.zeros_like(t), what="output / 1")
    for field in ("tau_s", "adev_dps", "adev_lo_dps", "adev_hi_dps"):
        assert getattr(ours, field) == cli[field], field
    assert ours.to_dict() == cli
    assert ours.of == "output / 1 − reference"


def test_allan_leaves_out_what_has_no_reference():
    t = np.arange(4000.0)
    rate = np.random.default_rng(2).normal(size=t.size)
    reference = np.zeros_like(t)
    reference[1000:1100] = np.nan
    a = fog.allan(t, rate, reference_dps=reference)
    assert a.runs == 2 and a.samples == 3900 and a.of == "rate − reference"
    with pytest.raises(fog.FogError, match="too few"):
        fog.allan([0.0, 1.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="one length"):
        fog.allan([0.0, 1.0], [0.0])


def test_summarize_is_the_commands(tmp_path):
    maps = {"time_s": "timestamp*1e-6", "temp_c": "imu.temperature", "voltage_v": "imu.gyro.z", "rate_dps": "0"}
    out = tmp_path / "summary.json"
    run("trainer", "summarize", "--stream", LOG, *sum((["--map", f"{k}={v}"] for k, v in maps.items()), []), "--json", out, "-q")
    [cli] = json.loads(out.read_text())["files"][0]
    assert (cli.pop("channel"), cli.pop("quantity"), cli.pop("units")) == ("rate", "angular-rate", "°/s")
    ours = fog.summarize(LOG, map=maps)
    assert ours.to_dict() == cli
    assert ours.rows == cli["rows"]
    with pytest.raises(fog.FogError, match="missing column"):
        fog.summarize(LOG)


def test_a_units_summary_is_the_commands_on_a_channels_file_and_a_flight_controllers_log(tmp_path):
    out = tmp_path / "unit.json"
    channels = LOG.with_name("imu.toml")
    run("trainer", "summarize", "--stream", LOG, "--channels", channels, "--json", out, "-q")
    assert fog.summarize(LOG, channels=channels).to_dict() == json.loads(out.read_text())
    board = tmp_path / "cal.bin"
    run("firmware-sim", "generate", "board", "--seed", "1", "--minutes", "20", "--out", board, "-q")
    assert fog.log_format(board) == "dataflash"
    run("trainer", "summarize", "--stream", board, "--sensor", "imu1", "--json", out, "-q")
    ours = fog.summarize(board, sensor="imu1")
    assert ours.to_dict() == json.loads(out.read_text())
    [imu1] = ours.files
    assert [ch.channel for ch in imu1] == ["gyr.x", "gyr.y", "gyr.z", "acc.x", "acc.y", "acc.z"]
    assert dict(imu1[0].columns)["voltage_v"] == "IMU[1].GyrX × 180/π"
    junk = tmp_path / "x.bin"
    junk.write_bytes(bytes(range(1, 200)))
    with pytest.raises(fog.FogError, match="neither a CSV"):
        fog.log_format(junk)


def test_tables_come_as_pandas_frames():
    pd = pytest.importorskip("pandas")
    t = np.arange(3000.0)
    a = fog.allan(t, np.random.default_rng(4).normal(size=t.size))
    frame = a.to_frame()
    assert isinstance(frame, pd.DataFrame)
    assert list(frame.columns) == ["tau_s", "adev_dps", "adev_lo_dps", "adev_hi_dps"]
    assert frame["tau_s"].tolist() == a.tau_s


def test_every_record_class_names_its_fields_types():
    """The generated classes resolve: every annotation names a type the module defines, so a
    notebook's editor and mypy know each field; each contract has its class."""
    import typing

    for name in fog.records.__all__:
        if name == "BY_SCHEMA":
            continue
        cls = getattr(fog.records, name)
        hints = typing.get_type_hints(cls)
        assert issubclass(cls, fog.Record), name
        assert all(k in hints for k in cls.__annotations__), name
    assert fog.records.BY_SCHEMA["trainer.allan-analysis"] is fog.records.AllanAnalysisRecord
    assert "tau_s" in typing.get_type_hints(fog.records.AllanAnalysisRecord)
    assert "channels" in typing.get_type_hints(fog.records.AllanRecord)


def test_a_field_of_either_of_two_classes_is_read_as_the_one_its_fields_name():
    """A fit's `extension` is an `Extension` or an `ExtensionFit`, a `loo`'s `parameters` one of
    four methods' fields: each object is read as the class whose fields it holds."""
    r = fog.records
    alone = {"offset": 0.1, "temperature": None, "terms": []}
    fitted = {"extension": alone, "fits": [], "point_offsets": []}
    assert type(r.ChannelEntry({"extension": alone}).extension) is r.Extension
    ext = r.ChannelEntry({"extension": fitted}).extension
    assert type(ext) is r.ExtensionFit
    assert type(ext.extension) is r.Extension
    poly = {name: 0 for name in r.PolyModel.__annotations__}
    assert type(r.LooRecord({"parameters": poly}).parameters) is r.PolyModel
