"""The trainer's models as scikit-learn estimators: the GP's leave-one-out error equals
`trainer loo`'s on the same table; bad input raises."""

import json

import numpy as np
import pytest

import fog
from conftest import run


def load_points(path):
    """The table's inputs (temperature, output) and its reference rate."""
    t = np.genfromtxt(path, delimiter=",", names=True)
    return np.column_stack([t["temp_c"], t["voltage_v"]]), t["rate_dps"]


def test_the_gp_loo_error_is_the_commands(paper_points, tmp_path):
    x, y = load_points(paper_points)
    gp = fog.GaussianProcess(mean="constant").fit(x, y)
    ours = float(np.sqrt(np.mean(gp.loo_errors() ** 2)))
    out = tmp_path / "loo.json"
    run("trainer", "loo", "--points", paper_points, "--mean", "constant", "--json", out, "-q")
    cli = json.loads(out.read_text())["rmse_dps"]
    assert abs(ours / cli - 1) < 0.02, (ours, cli)


def test_the_gp_predicts_with_its_std_and_states_what_it_learned():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (80, 2))
    y = np.sin(3 * x[:, 0]) + 0.2 * x[:, 1] + 0.01 * rng.standard_normal(80)
    gp = fog.GaussianProcess(mean="constant", random_starts=1).fit(x, y)
    mean, std = gp.predict(x, return_std=True)
    assert mean.shape == std.shape == (80,)
    assert np.sqrt(np.mean((mean - y) ** 2)) < 0.03
    # The noise it learned is the noise put in, and the std of a new observation is at least it.
    assert 0.005 < gp.noise_std_ < 0.02
    assert (std >= gp.noise_std_ * 0.999).all()
    assert len(gp.length_scales_) == 2 and np.isfinite(gp.log_marginal_likelihood_)
    assert np.array_equal(gp.predict(x), mean)


def test_lssvr_and_the_polynomial_fit_beside_it(paper_points):
    x, y = load_points(paper_points)
    lssvr = fog.LSSVR(mean="constant").fit(x, y)
    assert np.sqrt(np.mean((lssvr.predict(x) - y) ** 2)) < 0.05
    assert lssvr.gamma_ > 0 and len(lssvr.loo_errors()) == len(y)
    poly = fog.Polynomial().fit(x, y)
    assert np.sqrt(np.mean((poly.predict(x) - y) ** 2)) < 0.05


def test_bad_input_raises_not_crashes():
    with pytest.raises(fog.NotFittedError):
        fog.GaussianProcess().predict([[0.0, 0.0]])
    with pytest.raises(ValueError, match="one length"):
        fog.GaussianProcess().fit([[0.0, 1.0], [1.0, 2.0]], [1.0])
    with pytest.raises(ValueError, match="not finite"):
        fog.GaussianProcess().fit([[0.0, np.nan], [1.0, 2.0]], [1.0, 2.0])
    with pytest.raises(ValueError, match="expected constant, physics"):
        fog.GaussianProcess(mean="cubic")
    with pytest.raises(ValueError, match="fog.calibrate's"):
        fog.LSSVR(mean="auto")
    with pytest.raises(ValueError, match="two"):
        fog.Polynomial().fit(np.zeros((50, 3)), np.zeros(50))
    with pytest.raises(fog.FogError):
        fog.Polynomial().fit(np.zeros((5, 2)), np.zeros(5))
    gp = fog.GaussianProcess(random_starts=0).fit(np.random.default_rng(1).normal(size=(20, 2)), np.arange(20.0))
    with pytest.raises(ValueError, match="fitted on 2"):
        gp.predict(np.zeros((3, 3)))
