"""The firmware's evaluator from Python equals `firmware-sim replay` bit for bit, on a single-channel
blob and on a unit blob, and a blob read and saved is the same bytes."""

import csv

import numpy as np
import pytest

import fog
from conftest import BLOBS, DATA, run


def read_csv(path, delimiter=","):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f, delimiter=delimiter))
    return {k: [r[k] for r in rows] for k in rows[0]}


def f32(cells):
    """The replay's f32 cells (shortest round-trip decimals) as float32 bits."""
    return np.array([float(c) for c in cells], dtype=np.float32).view(np.uint32)


STATUS = {"ok": 0, "extrapolating": 1, "degraded": 2, "fault": 3}


@pytest.fixture(scope="module")
def stream(tmp_path_factory):
    """The simulator's default stream: soaks, ramps and three power cycles at 1 Hz."""
    path = tmp_path_factory.mktemp("stream") / "stream.csv"
    run("firmware-sim", "generate", "stream", "--seed", "3", "--out", path, "-q")
    return path


def test_a_blob_is_saved_byte_for_byte(tmp_path):
    model = fog.load_model(BLOBS / "gyro.bin")
    model.save(tmp_path / "copy.bin")
    assert (tmp_path / "copy.bin").read_bytes() == (BLOBS / "gyro.bin").read_bytes()
    assert fog.Model.from_bytes(model.to_bytes()).channels == model.channels
    assert len(model.channels) == 1


def test_compensate_is_the_replay_bit_for_bit(stream, tmp_path):
    out = tmp_path / "replay.csv"
    run("firmware-sim", "replay", "--model", BLOBS / "gyro.bin", "--stream", stream, "--out", out, "-q")
    replayed = read_csv(out)
    data = read_csv(stream)
    col = lambda k: np.array(data[k], dtype=float)
    c = fog.load_model(BLOBS / "gyro.bin").compensate(col("time_s"), col("temp_c"), col("voltage_v"))
    assert c.mean.dtype == np.float32 and len(c.mean) == len(data["time_s"])
    np.testing.assert_array_equal(c.mean.view(np.uint32), f32(replayed["comp_rate_dps"]))
    std = np.sqrt(c.bias_variance.astype(np.float64) + c.noise_variance).astype(np.float32)
    np.testing.assert_array_equal(std.view(np.uint32), f32(replayed["comp_std_dps"]))
    np.testing.assert_array_equal(c.status, [STATUS[s] for s in replayed["status"]])
    # The power-on the model was calibrated on, as `--calibration-run` replays it.
    cal = tmp_path / "calibration-run.csv"
    run("firmware-sim", "replay", "--model", BLOBS / "gyro.bin", "--stream", stream, "--out", cal,
        "--calibration-run", "-q")
    first = fog.load_model(BLOBS / "gyro.bin").compensate(
        col("time_s"), col("temp_c"), col("voltage_v"), calibration_run=True
    )
    own = read_csv(cal)
    np.testing.assert_array_equal(first.mean.view(np.uint32), f32(own["comp_rate_dps"]))
    first_std = np.sqrt(first.bias_variance.astype(np.float64) + first.noise_variance)
    np.testing.assert_array_equal(first_std.astype(np.float32).view(np.uint32), f32(own["comp_std_dps"]))
    pd = pytest.importorskip("pandas")
    frame = c.to_frame()
    assert isinstance(frame, pd.DataFrame) and len(frame) == len(c.mean)
    assert frame["mean"].dtype == np.float32


def test_a_unit_blob_takes_one_output_per_channel_and_is_the_replay_bit_for_bit(tmp_path):
    log = DATA / "tofupilot-imu-thermal" / "imu_raw_data.tsv"
    out = tmp_path / "replay.csv"
    run(
        "firmware-sim", "replay", "--model", BLOBS / "imu.bin", "--stream", log,
        "--channels", log.with_name("imu.toml"), "--out", out, "-q",
    )
    replayed = read_csv(out)
    data = read_csv(log, delimiter="\t")
    col = lambda k: np.array(data[k], dtype=float)
    model = fog.load_model(BLOBS / "imu.bin")
    assert model.sensor_id == "tofupilot-example-imu"
    # The channels file's units: the gyros in rad/s (to °/s), the accelerometers in m/s².
    outputs = {
        name: col(f"imu.{name}") * (180.0 / np.pi if name.startswith("gyro") else 1.0)
        for name in model.channels
    }
    comp = model.compensate(col("timestamp") * 1e-6, col("imu.temperature"), outputs)
    assert sorted(comp) == sorted(model.channels)
    for name, c in comp.items():
        np.testing.assert_array_equal(
            c.mean.view(np.uint32), f32(replayed[f"{name}.comp_rate_dps"]), err_msg=name
        )
    # In the blob's order as a list: the same.
    as_list = model.compensate(
        col("timestamp") * 1e-6, col("imu.temperature"), [outputs[n] for n in model.channels]
    )
    for name in model.channels:
        np.testing.assert_array_equal(as_list[name].mean, comp[name].mean)


def test_bad_input_raises_and_names_what_is_wrong(tmp_path):
    with pytest.raises(fog.FogError, match="reading"):
        fog.load_model(tmp_path / "absent.bin")
    (tmp_path / "junk.bin").write_bytes(b"not a blob at all")
    with pytest.raises(fog.FogError, match="decoding"):
        fog.load_model(tmp_path / "junk.bin")
    gyro = fog.load_model(BLOBS / "gyro.bin")
    with pytest.raises(ValueError, match="one length"):
        gyro.compensate([0.0, 1.0], [20.0], [0.0, 0.0])
    imu = fog.load_model(BLOBS / "imu.bin")
    with pytest.raises(ValueError, match="one output per channel"):
        imu.compensate([0.0], [20.0], [0.0])
    with pytest.raises(ValueError, match="no such channel"):
        imu.compensate([0.0], [20.0], {"gyro.w": [0.0]})
    with pytest.raises(ValueError, match="no output for channel"):
        imu.compensate([0.0], [20.0], {"gyro.x": [0.0]})
