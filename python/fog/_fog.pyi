"""Type stubs of the native module: the trainer's models, the firmware's evaluator and the
trainer's looks at data (python/src)."""

from os import PathLike
from typing import Any, Mapping, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]
F32 = npt.NDArray[np.float32]

class FogError(ValueError):
    """What the trainer or the firmware refuses: bad data, a blob that does not decode, a fit
    that cannot be made. The message is the one the command line prints."""

class NotFittedError(ValueError):
    """A model asked for a prediction before it was fitted."""

class GaussianProcess:
    """The paper's Gaussian process: an ARD squared-exponential kernel plus white noise over
    standardized inputs, a prior mean of `mean`, its hyperparameters by L-BFGS-B from the
    paper's start, a data-informed one and `random_starts` seeded random ones.

    mean: "constant" (the paper's, scikit-learn's `normalize_y=True`), "physics" (the
    trainer's form: {1, t, t²} × {1, v, v³} over the first two inputs; `fog.calibrate` chooses
    among physics, poly1 and poly2 on a sensor's points) or "polyN" (N ≤ 5).
    inducing: "auto" (exact up to 1,000 samples, 24 inducing points above), "exact" or a number
    of inducing points."""

    def __init__(
        self,
        mean: str = "physics",
        random_starts: int = 2,
        seed: int = 0,
        inducing: str = "auto",
        max_iters: int = 100,
    ) -> None: ...
    def fit(self, x: ArrayLike, y: ArrayLike) -> "GaussianProcess":
        """Fits to `X` (samples × inputs) and `y`; returns itself. Runs without the GIL."""
    @overload
    def predict(self, x: ArrayLike) -> F64: ...
    @overload
    def predict(self, x: ArrayLike, return_std: bool) -> Union[F64, tuple[F64, F64]]:
        """The predictive mean at each row of `X`; with `return_std`, also the standard
        deviation of a new observation there (latent plus noise)."""
    def loo_errors(self) -> F64:
        """Closed-form leave-one-out errors of the training samples (prediction − target), as
        `trainer loo` takes them."""
    @property
    def log_marginal_likelihood_(self) -> float:
        """The log marginal likelihood of the fitted hyperparameters (standardized data)."""
    @property
    def length_scales_(self) -> list[float]:
        """One length scale per input, in the input's unit."""
    @property
    def signal_std_(self) -> float:
        """σ_f, in the target's unit."""
    @property
    def noise_std_(self) -> float:
        """σ_n, in the target's unit."""
    @property
    def inducing_points_(self) -> int | None:
        """Inducing points of a sparse fit; None for an exact GP."""
    @property
    def warnings_(self) -> list[str]:
        """What the fit warns of (a hyperparameter on its bound, a poorly conditioned kernel)."""
    @property
    def fit_seconds_(self) -> float:
        """Wall time of the fit, s."""

class LSSVR:
    """Least-squares support-vector regression: the GP's kernel, its length scales and
    regularization tuned on the closed-form leave-one-out error."""

    def __init__(self, mean: str = "physics") -> None: ...
    def fit(self, x: ArrayLike, y: ArrayLike) -> "LSSVR": ...
    def predict(self, x: ArrayLike) -> F64: ...
    def loo_errors(self) -> F64: ...
    @property
    def gamma_(self) -> float:
        """The regularization γ."""

class Polynomial:
    """The paper's polynomial in the gyro output (degree 9) times temperature (degree 3). `X`'s
    two columns are the temperature (°C) and the gyro output."""

    def __init__(self) -> None: ...
    def fit(self, x: ArrayLike, y: ArrayLike) -> "Polynomial": ...
    def predict(self, x: ArrayLike) -> F64: ...

class Compensated:
    """The firmware's outputs for every sample of one channel, as `firmware-sim replay`."""

    mean: F32
    """Compensated rate (or acceleration), in the channel's unit (°/s, m/s²)."""
    bias_variance: F32
    """The model's latent variance plus its model error."""
    noise_variance: F32
    """The noise variance of one sample."""
    status: npt.NDArray[np.uint8]
    """`fog.Status` codes: 0 valid, 1 extrapolating, 2 degraded, 3 fault."""
    def to_frame(self) -> Any:
        """The four arrays as a pandas DataFrame, one row per sample (pandas must be installed)."""

class Model:
    """A firmware blob: one model, or a unit of several channels."""

    @staticmethod
    def from_bytes(blob: bytes) -> "Model": ...
    def to_bytes(self) -> bytes: ...
    def save(self, path: Union[str, PathLike[str]]) -> None:
        """Writes the blob, byte for byte as read."""
    @property
    def sensor_id(self) -> str: ...
    @property
    def channels(self) -> list[str]: ...
    def compensate(
        self,
        time_s: ArrayLike,
        temp_c: ArrayLike,
        output: Union[ArrayLike, Sequence[ArrayLike], Mapping[str, ArrayLike]],
        calibration_run: bool = False,
    ) -> Union[Compensated, dict[str, Compensated]]:
        """Every sample through firmware-core's f32 evaluator, bit for bit as the firmware and
        `firmware-sim replay`: one array for a blob of one channel (a `Compensated`), one per
        channel (a list in the blob's order, or a dict by name) for a unit (a dict of them by
        channel name)."""

def load_model(path: Union[str, PathLike[str]]) -> Model:
    """Reads a firmware blob (`trainer fit --out`)."""

def allan(
    time_s: ArrayLike, rate_dps: ArrayLike, reference_dps: ArrayLike | None = None, what: str = "rate"
) -> dict[str, Any]: ...
def summarize(
    path: str,
    map: list[tuple[str, str]] | None = None,
    points: bool = False,
    scale_factor: float | None = None,
) -> dict[str, Any]: ...
def log_format(path: Union[str, PathLike[str]]) -> str:
    """What kind of log `path` is, told by its first bytes as every command tells it: "csv",
    "ulog" (PX4) or "dataflash" (ArduPilot). Raises `FogError` for a binary file of neither."""

def trainer(args: list[str]) -> None:
    """Runs `trainer ARGS…` in this process (what `calibrate` and `investigate` call)."""
