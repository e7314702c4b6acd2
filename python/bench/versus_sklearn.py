"""The package's GP against scikit-learn's, in one Python process, and its leave-one-out error
against `trainer loo`'s on the same table.

For each size the simulator writes a rate table (the paper's 140-point protocol; scattered
setpoints above it, `firmware-sim generate scattered --seed 7`). Both fit the paper's model: a
constant mean, an ARD squared exponential plus white noise, inputs and output standardized, four
optimizer starts (ours: the paper's start, a data-informed one and two random; scikit-learn's:
its first and three restarts). Printed per size: the median fit time of each and their ratio,
both log marginal likelihoods, and the RMS leave-one-out error of `fog.GaussianProcess` against
`trainer loo --mean constant --inducing exact` on the same file.

Usage (from the workspace root, after `cargo build --release` and `pip install ./python`, with
scikit-learn installed in the same environment):
    python python/bench/versus_sklearn.py [--sizes 140,500,1000] [--repeats 3] [--json out.json]
"""

import argparse
import csv
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import fog

ROOT = Path(__file__).resolve().parents[2]
RELEASE = ROOT / "target" / "release"
# The paper's model in scikit-learn and the points reader: those of the trainer's own benchmark.
sys.path.insert(0, str(ROOT / "trainer" / "benches"))
from sklearn_gpr import load_points, make_gpr  # noqa: E402


def run(*cmd):
    return subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True).stdout


def points_file(directory, n):
    path = Path(directory) / f"points_{n}.csv"
    if n == 140:
        run(RELEASE / "firmware-sim", "generate", "paper", "--seed", "1", "--out", path, "-q")
    else:
        run(RELEASE / "firmware-sim", "generate", "scattered", "--points", n, "--seed", "7",
            "--out", path, "-q")
    return path


def timed(fit, repeats):
    times, model = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        model = fit()
        times.append(time.perf_counter() - start)
    return statistics.median(times), model


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="140,500,1000")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json")
    args = parser.parse_args()
    rows = []
    print(f"{'n':>6} {'fog (s)':>9} {'sklearn (s)':>12} {'ratio':>7} {'fog log ML':>11} "
          f"{'sklearn log ML':>15} {'LOO fog':>10} {'LOO trainer':>12} {'LOO ratio':>10}")
    with tempfile.TemporaryDirectory() as d:
        for n in (int(s) for s in args.sizes.split(",")):
            path = points_file(d, n)
            x, y = load_points(path)
            ours_s, gp = timed(
                lambda: fog.GaussianProcess(mean="constant", inducing="exact").fit(x, y),
                args.repeats,
            )
            z = (x - x.mean(axis=0)) / x.std(axis=0)
            theirs_s, sk = timed(lambda: make_gpr(restarts=3, seed=0).fit(z, y), args.repeats)
            loo = float(np.sqrt(np.mean(gp.loo_errors() ** 2)))
            out = Path(d) / f"loo_{n}.json"
            run(RELEASE / "trainer", "loo", "--points", path, "--mean", "constant",
                "--inducing", "exact", "--json", out, "-q")
            cli = json.loads(out.read_text())["rmse_dps"]
            row = {
                "n": n,
                "fog_fit_s": ours_s,
                "sklearn_fit_s": theirs_s,
                "ratio": theirs_s / ours_s,
                "fog_log_ml": gp.log_marginal_likelihood_,
                "sklearn_log_ml": float(sk.log_marginal_likelihood_value_),
                "loo_rmse_fog_dps": loo,
                "loo_rmse_trainer_dps": cli,
            }
            rows.append(row)
            print(f"{n:>6} {ours_s:>9.3f} {theirs_s:>12.3f} {row['ratio']:>6.1f}x "
                  f"{row['fog_log_ml']:>11.3f} {row['sklearn_log_ml']:>15.3f} {loo:>10.3e} "
                  f"{cli:>12.3e} {loo / cli:>10.4f}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
