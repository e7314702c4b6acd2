"""`fog.calibrate` and `fog.investigate` are `trainer fit` and `trainer investigate`: the same blob,
byte for byte, and the same report, on the MEMS log and a flight controller's log."""

import contextlib
import io
import json

import numpy as np
import pytest

import fog
from conftest import DATA, run

LOG = DATA / "tofupilot-imu-thermal" / "imu_raw_data.tsv"
CHANNELS = LOG.with_name("imu.toml")


def without_timings(value):
    """A report without its wall times, which no two runs share."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def test_calibrate_is_trainer_fit(tmp_path):
    run(
        "trainer", "fit", "--stream", LOG, "--channels", CHANNELS, "--window", ":2400",
        "--features", "auto", "--out", tmp_path / "imu.bin", "--json", tmp_path / "fit.json", "-q",
    )
    c = fog.calibrate(LOG, channels=CHANNELS, window=(None, 2400), out_dir=tmp_path / "py")
    assert c.model.to_bytes() == (tmp_path / "imu.bin").read_bytes()
    assert (tmp_path / "py" / "model.bin").read_bytes() == (tmp_path / "imu.bin").read_bytes()
    cli = json.loads((tmp_path / "fit.json").read_text())
    assert without_timings(c.report.to_dict()) == without_timings(cli)
    assert [ch.name for ch in c.report.channels] == c.model.channels
    # The report is typed as its contract: its class, and its nested objects' classes.
    assert isinstance(c.report, fog.records.FitRecord)
    assert isinstance(c.report.channels[0], fog.records.ChannelEntry)
    assert isinstance(c.report.channels[0].firmware_agreement, fog.records.AgreementReport)
    assert isinstance(c.report.footprint, fog.records.UnitFootprint)
    pd = pytest.importorskip("pandas")
    frame = c.report.to_frame()
    assert isinstance(frame, pd.DataFrame)
    assert frame["name"].tolist() == c.model.channels and "shipped" in frame


def test_calibrate_takes_a_flight_controllers_log_sensor_by_sensor(tmp_path):
    board = tmp_path / "cal.ulg"
    run("firmware-sim", "generate", "board", "--seed", "1", "--minutes", "40", "--out", board, "-q")
    c = fog.calibrate(board, sensor=["gyro0", "accel1"], features=None, px4_params=tmp_path / "cal.params")
    assert sorted(c.models) == ["accel1", "gyro0"]
    assert c.models["gyro0"].channels == ["x", "y", "z"]
    assert "TC_G0_X0_0" in (tmp_path / "cal.params").read_text()
    with pytest.raises(ValueError, match="2 sensors"):
        c.model
    # The blob compensates the log's samples as the firmware would.
    t = np.arange(10.0)
    comp = c.models["gyro0"].compensate(t, np.full(10, 30.0), [np.zeros(10)] * 3)
    assert set(comp) == {"x", "y", "z"} and all(len(v.mean) == 10 for v in comp.values())


def test_investigate_is_trainer_investigate(tmp_path):
    maps = {"time_s": "timestamp*1e-6", "temp_c": "imu.temperature", "rate_dps": "0",
            "voltage_v": "imu.gyro.z*57.29577951"}
    flags = sum((["--map", f"{k}={v}"] for k, v in maps.items()), [])
    out = tmp_path / "inv.json"
    run("trainer", "investigate", "--stream", LOG, "--hold-out-from", "2400", "--scale-factor", "1",
        *flags, "--json", out, "-q")
    ours = fog.investigate(LOG, hold_out_from=2400, scale_factor=1, map=maps)
    assert without_timings(ours.to_dict()) == without_timings(json.loads(out.read_text()))
    assert ours.channels[0].static_score.rmse_60s_dps > 0


def test_a_datasheets_figures_are_keywords_and_reach_the_sigma(tmp_path):
    # Gyro y of the MEMS log on ten minutes at its cold end, a datasheet's bias temperature
    # coefficient stated as `trainer fit --tempco` takes it.
    maps = {"time_s": "timestamp*1e-6", "temp_c": "imu.temperature", "rate_dps": "0",
            "voltage_v": "imu.gyro.y*57.29577951"}
    flags = sum((["--map", f"{k}={v}"] for k, v in maps.items()), [])
    out = tmp_path / "fit.json"
    run("trainer", "fit", "--stream", LOG, "--window", "1000:1660", "--scale-factor", "1", *flags,
        "--tempco", "0.03", "--out", tmp_path / "g.bin", "--json", out, "-q")
    c = fog.calibrate(LOG, map=maps, window=(1000, 1660), scale_factor=1, features=None,
                      tempco=0.03)
    calibration = c.report.channels[0].calibration
    assert calibration.tempco_per_c == 0.03
    assert calibration.extrapolation_std == pytest.approx(0.03 * calibration.trained_width_c)
    assert without_timings(c.report.to_dict()) == without_timings(json.loads(out.read_text()))
    with pytest.raises(fog.FogError, match="--tempco must be a number"):
        fog.calibrate(LOG, map=maps, scale_factor=1, tempco=-1)


def test_keywords_are_flags_whose_values_may_begin_with_a_minus():
    assert fog._arguments(rated_temp=(-40, 85), exclude=[(-5, 10)], tempco=-1, quiet=False) == [
        "--rated-temp=-40:85", "--exclude=-5:10", "--tempco=-1"]


def test_investigate_takes_each_sensor_of_a_boards_log(tmp_path):
    board = tmp_path / "cal.ulg"
    run("firmware-sim", "generate", "board", "--seed", "7", "--minutes", "30", "--out", board, "-q")
    both = fog.investigate(board, sensor=["gyro0", "gyro1"])
    assert sorted(both) == ["gyro0", "gyro1"]
    alone = fog.investigate(board, sensor="gyro1")
    assert without_timings(both["gyro1"].to_dict()) == without_timings(alone.to_dict())
    assert [ch.name for ch in alone.channels] == ["x", "y", "z"]


def test_a_commands_refusal_is_a_python_exception(tmp_path):
    with pytest.raises(fog.FogError, match="cannot read"):
        fog.calibrate(tmp_path / "absent.csv")
    with pytest.raises(fog.FogError, match="--bogus"):
        fog.calibrate(LOG, bogus=1)
    with pytest.raises(fog.FogError, match="missing column"):
        fog.investigate(LOG)


def test_report_writes_the_page_and_returns_its_figures(tmp_path):
    board = tmp_path / "cal.ulg"
    run("firmware-sim", "generate", "board", "--seed", "2", "--minutes", "40", "--out", board, "-q")
    pages = fog.report(board, sensor=["gyro0", "gyro1"], out_dir=tmp_path / "report")
    assert sorted(pages) == ["gyro0", "gyro1"]
    assert (tmp_path / "report" / "gyro1" / "report.html").is_file()
    for name, page in pages.items():
        assert [ch.name for ch in page.channels] == ["x", "y", "z"], name
        for ch in page.channels:
            assert ch.cubic.project.rmse_per_degree > 0
            assert ch.cubic_verdict.startswith("the cubic")


def test_quiet_false_prints_what_the_command_prints(tmp_path, capfd):
    fog.calibrate(LOG, channels=CHANNELS, window=(None, 2400), features=None)
    assert capfd.readouterr().out == ""
    fog.calibrate(LOG, channels=CHANNELS, window=(None, 2400), features=None, quiet=False)
    printed = capfd.readouterr().out
    cli = run(
        "trainer", "fit", "--stream", LOG, "--channels", CHANNELS, "--window", ":2400",
        "--out", tmp_path / "imu.bin",
    )
    # The same lines, each channel's, but for the fit's wall time and where the blob went.
    def lines(text):
        return [line for line in text.splitlines() if " ms" not in line and "wrote" not in line]

    assert "gyro.x (angular rate in °/s, [1/6])" in printed
    assert lines(printed) == lines(cli)


def test_in_a_notebook_the_commands_lines_and_warnings_reach_the_cell(tmp_path, capsys):
    # capsys is what a notebook is: sys.stdout and sys.stderr are objects of their own, and what
    # the process writes to its file descriptors 1 and 2 would not be shown.
    fog.calibrate(LOG, channels=CHANNELS, window=(None, 2400), features=None, quiet=False)
    shown = capsys.readouterr()
    assert "gyro.x (angular rate in °/s, [1/6])" in shown.out
    assert "firmware (f32) vs host (f64)" in shown.out
    # A warning reaches the cell even when quiet: a rate table with an impossible row, left out.
    table = tmp_path / "table.csv"
    run("firmware-sim", "generate", "paper", "--seed", "1", "--out", table, "-q")
    with table.open("a") as f:
        f.write("400.0,0.38,0,400,0\n")
    fog.calibrate(points=table, features=None, exclude_implausible=True)
    shown = capsys.readouterr()
    assert shown.out == ""
    assert "column temp_c: 400 lies far outside the other rows" in shown.err
    assert shown.err.startswith("warning: ")
    # Only stdout redirected (`contextlib.redirect_stdout`): its lines follow it.
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        fog.calibrate(points=table, features=None, exclude_implausible=True, quiet=False)
    assert "fitted GP on 140 points" in buf.getvalue()
