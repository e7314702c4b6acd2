"""Exact GP fits, ours against scikit-learn, on the same points files in one run.

For each size the simulator writes a rate table (the paper's 140-point protocol; scattered
setpoints in -30...60 degC and rates in +-80 deg/s, 2-min means, above it). Both sides fit the paper's
model (constant mean, ARD squared exponential plus white noise, inputs and output standardized)
with four optimizer starts: ours its default (the paper's start, a data-informed one and two
random), scikit-learn's first plus three restarts. Printed per size: both fit times (median),
their ratio, both log marginal likelihoods, and our fit against this machine's dense-algebra
floor (fit_timing's doc).

Usage (from the workspace root, after `cargo build --release`, with scikit-learn installed):
    python3 trainer/benches/versus_sklearn.py [--sizes 140,500,1000,2000] [--repeats 1]
        [--dir bench-data] [--json versus.json]
"""

import argparse
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RELEASE = os.path.join(ROOT, "target", "release")


def run(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return out.stdout


def points_file(directory, n):
    path = os.path.join(directory, f"points_{n}.csv")
    if not os.path.exists(path):
        sim = os.path.join(RELEASE, "firmware-sim")
        if n == 140:
            run([sim, "generate", "paper", "--seed", "1", "--out", path, "-q"])
        else:
            run([sim, "generate", "scattered", "--points", str(n), "--seed", "7", "--out", path, "-q"])
    return path


def ours(path, repeats):
    exe = os.path.join(RELEASE, "examples", "fit_timing")
    if not os.path.exists(exe):
        sys.exit(f"{exe} missing: cargo build --release -p trainer --example fit_timing")
    return json.loads(run([exe, path, str(repeats), "--json"]))


def sklearn(path, repeats):
    text = run(
        [sys.executable, os.path.join(HERE, "sklearn_gpr.py"), "--points", path,
         "--restarts", "3", "--repeats", str(repeats), "--check-rtol", "1e-2"]
    )
    median = float(re.search(r"fit time\s*: median ([0-9.]+) ms", text).group(1)) / 1e3
    lml = float(re.search(r"log marginal lik\. : (-?[0-9.]+)", text).group(1))
    return {"fit_seconds_median": median, "log_marginal_likelihood": lml}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="140,500,1000,2000")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--dir", default="bench-data")
    parser.add_argument("--json")
    args = parser.parse_args()
    os.makedirs(args.dir, exist_ok=True)
    rows = []
    print(f"{'n':>6} {'ours (s)':>10} {'sklearn (s)':>12} {'ratio':>7} {'ours log ML':>13} "
          f"{'sklearn log ML':>15} {'ours / floor':>13} {'GFLOP/s':>8}")
    for n in (int(s) for s in args.sizes.split(",")):
        path = points_file(args.dir, n)
        a = ours(path, args.repeats)
        b = sklearn(path, args.repeats)
        row = {"n": n, "ours": a, "sklearn": b,
               "ratio": b["fit_seconds_median"] / a["fit_seconds_median"]}
        rows.append(row)
        print(f"{n:>6} {a['fit_seconds_median']:>10.3f} {b['fit_seconds_median']:>12.3f} "
              f"{row['ratio']:>6.1f}x {a['log_marginal_likelihood']:>13.3f} "
              f"{b['log_marginal_likelihood']:>15.3f} "
              f"{a['fit_seconds_median'] / a['floor_seconds']:>12.2f}x {a['gflops']:>8.1f}",
              flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
