"""Fixtures: the `starnet` binary, the shipped model and the real KITTI frames under ../shared.

The binary is the workspace's `target/debug/starnet` (`cargo build` before pytest) or
`$STARNET_BIN`; the sample frames come from `$STARNET_KITTI_SAMPLE` (as the Rust tests), the
development street from `$STARNET_KITTI_REAL_DEV`, both defaulting to ../shared beside the repo.
"""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def _shared(env: str, name: str) -> pathlib.Path:
    return pathlib.Path(os.environ.get(env, REPO.parent / "shared" / name))


@pytest.fixture(scope="session")
def starnet_bin() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("STARNET_BIN", REPO / "target" / "debug" / "starnet"))
    assert path.is_file(), f"{path}: build it first (cargo build --bin starnet) or set STARNET_BIN"
    return path


@pytest.fixture(scope="session")
def model_dir() -> pathlib.Path:
    return REPO / "models" / "quickstart"


@pytest.fixture(scope="session")
def kitti_sample() -> pathlib.Path:
    root = _shared("STARNET_KITTI_SAMPLE", "kitti-sample")
    assert (root / "training" / "velodyne").is_dir(), f"{root}: the real sample frames are missing"
    return root


@pytest.fixture(scope="session")
def kitti_real_dev() -> pathlib.Path:
    root = _shared("STARNET_KITTI_REAL_DEV", "kitti-real-dev")
    assert (root / "ImageSets" / "val.txt").is_file(), f"{root}: the real development street is missing"
    return root


def run(*args) -> str:
    """Runs a command and returns its stdout; a failure shows its stderr."""
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout
