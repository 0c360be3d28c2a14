"""Shared fixtures: a small synthetic sequence in memory, and the repository's paths."""

import os
import pathlib

import pytest

import kfx

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = pathlib.Path(os.environ.get("KFX_SHARED_DIR", ROOT.parent / "shared"))
INPUT = "synthetic:frames=24,width=160,height=120"


@pytest.fixture(scope="session")
def frames():
    return list(kfx.open(INPUT))


@pytest.fixture()
def reconstruction():
    return kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)


def kfx_cli():
    """The CLI built beside the package (KFX_CLI, else build/release/kfx), or None."""
    path = pathlib.Path(os.environ.get("KFX_CLI", ROOT / "build" / "release" / "kfx"))
    return path if path.exists() else None
