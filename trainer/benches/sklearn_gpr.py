"""Reference competitor for the Rust trainer's Gaussian-process regression.

Fits scikit-learn's GaussianProcessRegressor to gyro calibration points
(inputs: temp_c, voltage_v; target: rate_dps) and reports the two figures
the Rust trainer is benchmarked on: closed-form leave-one-out RMSE with the
fitted hyperparameters, and wall-clock time of the fit itself.
"""

import argparse
import csv
import json
import statistics
import sys
import time
import warnings

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

CHECK_POINTS = 5


def load_points(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    x = np.array([[float(r["temp_c"]), float(r["voltage_v"])] for r in rows])
    y = np.array([float(r["rate_dps"]) for r in rows])
    return x, y


def standardize(x):
    return (x - x.mean(axis=0)) / x.std(axis=0)


def make_gpr(restarts, seed):
    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(
        length_scale=[1.0, 1.0], length_scale_bounds=(1e-3, 1e3)
    ) + WhiteKernel(1e-2, (1e-12, 1e1))
    return GaussianProcessRegressor(
        kernel=kernel, normalize_y=True, n_restarts_optimizer=restarts, random_state=seed
    )


def train_covariance(gpr, x):
    """K as sklearn factorizes it: fitted kernel (white noise included) plus alpha jitter."""
    return gpr.kernel_(x) + gpr.alpha * np.eye(len(x))


def loo_residuals(gpr, x):
    """R&W eq. 5.12, r_i = [K^-1 y]_i / [K^-1]_ii, on sklearn's normalized y_train_."""
    factor = cho_factor(train_covariance(gpr, x), lower=True)
    k_inv = cho_solve(factor, np.eye(len(x)))
    return cho_solve(factor, gpr.y_train_) / np.diag(k_inv)


def brute_force_residuals(gpr, x, count):
    residuals = []
    for i in range(count):
        keep = np.arange(len(x)) != i
        refit = GaussianProcessRegressor(kernel=gpr.kernel_, alpha=gpr.alpha, optimizer=None)
        refit.fit(x[keep], gpr.y_train_[keep])
        residuals.append(gpr.y_train_[i] - refit.predict(x[i : i + 1])[0])
    return np.array(residuals)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", required=True, help="CSV with temp_c,voltage_v,rate_dps")
    parser.add_argument("--restarts", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=5, help="fits timed (median reported)")
    parser.add_argument("--json", help="write results to this JSON file")
    parser.add_argument(
        "--check-rtol",
        type=float,
        default=1e-8,
        help="max relative disagreement allowed between closed-form and brute-force LOO",
    )
    args = parser.parse_args()

    x_raw, y = load_points(args.points)
    x = standardize(x_raw)

    times = []
    for _ in range(args.repeats):
        gpr = make_gpr(args.restarts, args.seed)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            start = time.perf_counter()
            gpr.fit(x, y)
            times.append(time.perf_counter() - start)

    residuals = loo_residuals(gpr, x)
    brute = brute_force_residuals(gpr, x, min(CHECK_POINTS, len(x)))
    disagreement = float(np.max(np.abs(residuals[: len(brute)] - brute) / np.abs(brute)))
    if disagreement > args.check_rtol:
        sys.exit(
            f"closed-form LOO disagrees with {len(brute)} brute-force refits: max relative "
            f"difference {disagreement:.2e} > {args.check_rtol:g} "
            f"(cond(K) = {np.linalg.cond(train_covariance(gpr, x)):.1e})"
        )

    result = {
        "loo_rmse_dps": float(np.sqrt(np.mean(residuals**2)) * np.ravel(gpr._y_train_std)[0]),
        "fit_seconds_median": statistics.median(times),
        "fit_seconds_min": min(times),
        "n": len(y),
        "restarts": args.restarts,
        "kernel": str(gpr.kernel_),
        "log_marginal_likelihood": float(gpr.log_marginal_likelihood_value_),
    }

    print(f"points            : {result['n']}")
    print(f"restarts          : {result['restarts']} (seed {args.seed})")
    print(f"fitted kernel     : {result['kernel']}")
    print(f"log marginal lik. : {result['log_marginal_likelihood']:.6f}")
    print(f"LOO RMSE          : {result['loo_rmse_dps']:.6e} dps")
    print(
        f"fit time          : median {result['fit_seconds_median'] * 1e3:.2f} ms, "
        f"min {result['fit_seconds_min'] * 1e3:.2f} ms over {args.repeats} fits"
    )
    print(f"LOO check         : max relative difference {disagreement:.2e} vs {len(brute)} refits")
    for message in sorted({str(w.message).splitlines()[0] for w in caught}):
        print(f"fit warning       : {message}")

    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
