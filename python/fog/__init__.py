"""Temperature-drift compensation for fiber-optic and MEMS gyros, from a notebook.

The trainer's models as scikit-learn estimators (`GaussianProcess`, `LSSVR`, `Polynomial`), the
firmware's own f32 evaluator on a blob (`load_model`, `Model.compensate`), and the trainer's looks
at data (`allan`, `summarize`). Everything is computed by the Rust crates the command line runs;
this package only moves numpy arrays across.
"""

from __future__ import annotations

import contextlib
import enum
import json
import sys
import tempfile
from pathlib import Path
from typing import Any, Iterator

from . import _fog, records
from ._record import Record
from ._fog import (
    LSSVR,
    Compensated,
    FogError,
    GaussianProcess,
    Model,
    NotFittedError,
    Polynomial,
    __version__,
    load_model,
    log_format,
)

__all__ = [
    "LSSVR",
    "Compensated",
    "FogError",
    "GaussianProcess",
    "Model",
    "NotFittedError",
    "Polynomial",
    "Record",
    "Status",
    "__version__",
    "Calibration",
    "records",
    "allan",
    "calibrate",
    "investigate",
    "report",
    "load_model",
    "log_format",
    "summarize",
]


class Status(enum.IntEnum):
    """A compensated sample's validity: the codes of `Compensated.status`, as the C interface's
    `FogStatus`."""

    VALID = 0
    """Inputs inside the trained range."""
    EXTRAPOLATING = 1
    """An input outside the trained range: usable, flag it."""
    DEGRADED = 2
    """A stateful input's history is not to be trusted (a time jump, a stuck sensor): settling."""
    FAULT = 3
    """A reading that cannot be true: the mean is 0, do not use it."""


def _shown_as_written(stream: Any, fd: int) -> bool:
    """Whether what the process writes to its file descriptor `fd` is what `stream` (`sys.stdout`,
    `sys.stderr`) shows: in a terminal or a script it is; in a notebook, under pytest's `capsys`
    or `contextlib.redirect_stdout`, the stream is an object of its own, and the process's lines
    go elsewhere (a notebook's to the kernel's log, not the cell)."""
    try:
        return stream.fileno() == fd
    except (AttributeError, OSError, ValueError):
        return False


@contextlib.contextmanager
def _forwarded() -> Iterator[None]:
    """The commands print from Rust, to the process's file descriptors 1 and 2. Where either is
    not what the person sees (a notebook), its lines are forwarded to `sys.stdout` or
    `sys.stderr` as they are printed, by wurlitzer (the commands run without the GIL, so its
    reader threads run beside them): the command's summary under `quiet=False`, and its warnings
    always. Progress bars draw only in a terminal, so a notebook sees the lines alone."""
    out = None if _shown_as_written(sys.stdout, 1) else sys.stdout
    err = None if _shown_as_written(sys.stderr, 2) else sys.stderr
    if out is None and err is None:
        yield
        return
    try:
        from wurlitzer import pipes
    except ImportError:  # Windows: wurlitzer pipes POSIX file descriptors only.
        yield
        return
    with pipes(stdout=out, stderr=err):
        yield


def _command(args: list[str]) -> None:
    """Runs `trainer ARGS…` in this process, its lines where the person sees them."""
    with _forwarded():
        _fog.trainer(args)


def allan(
    time_s, rate_dps, reference_dps=None, what: str = "rate"
) -> records.AllanAnalysisRecord:
    """The overlapping Allan deviation of `rate_dps` (less `reference_dps` where given; NaN where
    unknown), with its noise terms, as `trainer allan --json` gives each channel's: `tau_s`, `adev_dps`,
    `adev_lo_dps`, `adev_hi_dps`, `arw_deg_per_sqrt_h`, `bias_instability_deg_per_h` (at
    `bias_instability_tau_s`) and `rrw_deg_per_h_per_sqrt_h` (None where the curve does not show
    the term)."""
    return records.AllanAnalysisRecord(_fog.allan(time_s, rate_dps, reference_dps, what))


def summarize(
    path, map=None, points: bool = False, scale_factor=None, channels=None, sensor=None
) -> records.Summary | records.SummarizeRecord:
    """A data file as the loader sees it, before anything is fitted, as `trainer summarize --json`
    gives it: a stream (or, with `points=True`, a points table), its columns named as the
    trainer's (`time_s`, `temp_c`, `voltage_v`, `rate_dps`) or mapped by `map`
    (`{"temp_c": "T"}`, as `--map temp_c=T`). A unit, that is a channels file (`channels`) or a
    PX4 ULog or ArduPilot DataFlash log (each of its sensors, or those named by `sensor`), gives
    the command's whole JSON instead: under `files`, one list per unit of each channel's
    summary. Raises `FogError` with the command's message."""
    if channels is None and sensor is None and _fog.log_format(str(path)) == "csv":
        pairs = None if map is None else [(str(k), str(v)) for k, v in dict(map).items()]
        return records.Summary(_fog.summarize(str(path), pairs, points, scale_factor))
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "summary.json"
        source = {"points" if points else "stream": str(path)}
        args = ["-q", "summarize"] + _arguments(
            **source,
            channels=None if channels is None else str(channels),
            sensor=sensor,
            map=map,
            scale_factor=scale_factor,
            json=str(out),
        )
        _command(args)
        return records.SummarizeRecord(json.loads(out.read_text()))


def _window(w: Any) -> str:
    """A window as the commands take it: "START:END" in seconds from the first sample, either
    side open; a (start, end) pair with None for an open side."""
    if isinstance(w, str):
        return w
    start, end = w
    return f"{'' if start is None else start}:{'' if end is None else end}"


def _arguments(**options: Any) -> list[str]:
    """Keywords as the command's flags: `hold_out_from=2400` is `--hold-out-from=2400`, True a
    bare flag, None and False none, a list a repeated flag, `map` a dict of `--map=NAME=SOURCE`.
    Each value joins its flag with `=`, so that a negative number is read as one."""
    args: list[str] = []
    for key, value in options.items():
        if value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            args.append(flag)
        elif key == "map":
            args += [f"{flag}={name}={source}" for name, source in dict(value).items()]
        elif key in ("window", "exclude"):
            windows = value if isinstance(value, list) else [value]
            args += [f"{flag}={_window(w)}" for w in windows]
        elif key == "rated_temp" and isinstance(value, (list, tuple)):
            low, high = value
            args.append(f"{flag}={low}:{high}")
        elif isinstance(value, (list, tuple)):
            args += [f"{flag}={v}" for v in value]
        else:
            args.append(f"{flag}={value}")
    return args




def _record(path: Path) -> Any:
    """The JSON a command wrote at `path`, as the record class of its contract."""
    fields = json.loads(path.read_text())
    return records.BY_SCHEMA.get(fields["schema"]["name"], Record)(fields)


class Calibration:
    """What `trainer fit` made: the firmware blob (`model`, a `Model`) and the fit's report
    (`report`, its `--json`: the unit, each channel's model, diagnosis and figures). A flight
    controller's log of several sensors gives one of each per sensor: `models` and `reports`, by
    sensor name."""

    def __init__(self, models: dict[str, Model], reports: dict[str, records.FitRecord]):
        self.models = models
        self.reports = reports

    @property
    def model(self) -> Model:
        """The blob, where the log held one sensor (or one unit)."""
        return self._one(self.models)

    @property
    def report(self) -> records.FitRecord:
        """The fit's report, where the log held one sensor (or one unit)."""
        return self._one(self.reports)

    @staticmethod
    def _one(by_name: dict[str, Any]) -> Any:
        if len(by_name) != 1:
            raise ValueError(
                f"the log held {len(by_name)} sensors ({', '.join(by_name)}): take one from "
                "`models` or `reports` by name"
            )
        return next(iter(by_name.values()))

    def __repr__(self) -> str:
        return f"Calibration({', '.join(f'{k}: {v!r}' for k, v in self.models.items())})"


def calibrate(
    log=None,
    *,
    points=None,
    channels=None,
    map=None,
    window=None,
    features: str | None = "auto",
    sensor=None,
    out_dir=None,
    quiet: bool = True,
    **options: Any,
) -> Calibration:
    """Calibrates as `trainer fit` does, in this process and by its own code: the log (a stream
    CSV, a PX4 ULog or an ArduPilot DataFlash log) and/or a rate table (`points`), a unit's
    channels file (`channels`), column maps (`map={"temp_c": "T"}`), the training window
    (`window="0:1860"` or `(0, 1860)`), the inputs the diagnosis extends the model by
    (`features`, "auto" by default; None for the static model alone) and a flight controller's
    sensors (`sensor="gyro0"` or a list). Every other flag of `trainer fit` is a keyword:
    `px4_params="cal.params"`, `repeatability=0.01`, `beyond="hold"`. The blob and the report
    are written to `out_dir` when given (as `model.bin` and `fit.json`, or one per sensor), and
    are returned either way. With `quiet=False` the command also prints its summary to the
    process's stdout and, in a terminal, its progress bars; its warnings go to stderr either way.
    Raises `FogError` with the command's message."""
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(out_dir) if out_dir is not None else Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        args = (["-q"] if quiet else []) + ["fit"] + _arguments(
            stream=None if log is None else str(log),
            points=None if points is None else str(points),
            channels=None if channels is None else str(channels),
            map=map,
            window=window,
            features=features,
            sensor=sensor,
            out=str(folder / "model.bin"),
            json=str(folder / "fit.json"),
            **options,
        )
        _command(args)
        models, reports = {}, {}
        for blob in sorted(folder.glob("model*.bin")):
            name = blob.stem.partition(".")[2] or "model"
            models[name] = load_model(blob)
            report = blob.with_name(blob.name.replace("model", "fit", 1)).with_suffix(".json")
            reports[name] = _record(report)
        return Calibration(models, reports)


def investigate(
    log,
    *,
    valid_stream=None,
    hold_out_from=None,
    window=None,
    points=None,
    channels=None,
    map=None,
    features=None,
    sensor=None,
    quiet: bool = True,
    **options: Any,
) -> records.InvestigateRecord | dict[str, records.InvestigateRecord]:
    """What the static model gets wrong on a stream, forward in time, as `trainer investigate`
    finds it in this process and by its own code: the diagnosis on the training part, the
    extended model's inputs and the gain on the part held out (`valid_stream`, or the log from
    `hold_out_from` seconds on, or its last third). Returns the command's `--json`: for a flight
    controller's log of several sensors, a dict of them by sensor name. Every other flag of
    `trainer investigate` is a keyword, and `quiet=False` shows the command's own output as
    `calibrate`'s does. Raises `FogError` with the command's message."""
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "investigation.json"
        args = (["-q"] if quiet else []) + ["investigate"] + _arguments(
            stream=str(log),
            valid_stream=None if valid_stream is None else str(valid_stream),
            hold_out_from=hold_out_from,
            window=window,
            points=None if points is None else str(points),
            channels=None if channels is None else str(channels),
            map=map,
            features=features,
            sensor=sensor,
            json=str(out),
            **options,
        )
        _command(args)
        if out.exists():
            return _record(out)
        return {
            each.stem.partition(".")[2]: _record(each)
            for each in sorted(Path(scratch).glob("investigation.*.json"))
        }


def report(
    log=None,
    *,
    out_dir,
    points=None,
    valid_stream=None,
    hold_out_from=None,
    channels=None,
    map=None,
    sensor=None,
    quiet: bool = True,
    **options: Any,
) -> records.ReportRecord | dict[str, records.ReportRecord]:
    """Writes `trainer report`'s page and figures into `out_dir`, in this process and by the
    command's own code, and returns the figures behind the page (its `report.json`): for a flight
    controller's log of several sensors, a dict of them by sensor name (a page each, in a folder
    named for it). Every other flag of `trainer report` is a keyword (`px4_params=…`,
    `ardupilot_params=…`, `window=…`). Raises `FogError` with the command's message."""
    folder = Path(out_dir)
    args = (["-q"] if quiet else []) + ["report"] + _arguments(
        stream=None if log is None else str(log),
        points=None if points is None else str(points),
        valid_stream=None if valid_stream is None else str(valid_stream),
        hold_out_from=hold_out_from,
        channels=None if channels is None else str(channels),
        map=map,
        sensor=sensor,
        out=str(folder),
        **options,
    )
    _command(args)
    if (folder / "report.json").exists():
        return _record(folder / "report.json")
    return {
        page.parent.name: _record(page)
        for page in sorted(folder.glob("*/report.json"))
    }
