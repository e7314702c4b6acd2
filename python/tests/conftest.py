"""Shared fixtures: the workspace's data and its command-line programs, whose results the package
must equal.

The programs are those the README's commands built (`cargo test --workspace --release` or
`cargo build --release`: target/release) or a plain `cargo test --workspace` (target/debug), the
newer of the two; `FOG_BIN_DIR` names another folder.
"""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
BLOBS = ROOT / "firmware-core" / "doc"


def _bin_dir() -> Path:
    if "FOG_BIN_DIR" in os.environ:
        return Path(os.environ["FOG_BIN_DIR"])
    built = [
        ROOT / "target" / profile
        for profile in ("debug", "release")
        if (ROOT / "target" / profile / "trainer").exists()
        and (ROOT / "target" / profile / "firmware-sim").exists()
    ]
    if not built:
        pytest.fail(
            "no trainer and firmware-sim built: run `cargo build --release` "
            "first, or set FOG_BIN_DIR"
        )
    return max(built, key=lambda d: (d / "trainer").stat().st_mtime)


def run(program: str, *args) -> str:
    """Runs one of the workspace's programs; fails the test with its stderr if it fails."""
    exe = _bin_dir() / program
    done = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"{program} {' '.join(map(str, args))} failed:\n{done.stderr}")
    return done.stdout


@pytest.fixture(scope="session")
def paper_points(tmp_path_factory) -> Path:
    """The paper's 140-point rate table, simulated (seed 1)."""
    path = tmp_path_factory.mktemp("paper") / "points.csv"
    run("firmware-sim", "generate", "paper", "--seed", "1", "--out", path, "-q")
    return path
