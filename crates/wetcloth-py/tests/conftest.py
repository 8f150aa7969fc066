"""Shared fixtures: the command line to compare with, and a tiny scene that runs in
milliseconds (an 8 x 8 cloth of the thesis demo, lifted 1 cm in 40 ms)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

import wetcloth

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `wetcloth` binary (WETCLOTH_BIN, else the workspace's release build)."""
    path = Path(os.environ.get("WETCLOTH_BIN", REPO / "target" / "release" / "wetcloth"))
    if not path.is_file():
        pytest.fail(f"{path} not found: build it with `cargo build --release -p wetcloth-cli`")
    return path


def tiny() -> wetcloth.Scene:
    s = wetcloth.Scene.thesis_demo()
    s.set("name", "tiny")
    s.set("simulation.integrator", "verlet")
    s.set("simulation.duration", 0.04)
    s.set("simulation.frame_rate", 100)
    s.set(
        "grab.0",
        {
            "particle": [4, 4],
            "keys": [
                {"time": 0.0, "offset": [0.0, 0.0, 0.0]},
                {"time": 0.04, "offset": [0.0, 0.01, 0.0]},
            ],
        },
    )
    s.set("cloth.size", [0.1, 0.1])
    s.set("cloth.resolution", [8, 8])
    s.set("air.trapped_air", 2e-5)
    return s


@pytest.fixture
def tiny_scene() -> wetcloth.Scene:
    return tiny()


@pytest.fixture
def tiny_file(tmp_path: Path) -> Path:
    """The tiny scene as a file, for the command line."""
    path = tmp_path / "tiny.toml"
    path.write_text(tiny().to_toml(), encoding="utf-8")
    return path


def run_cli(cli: Path, *args: str | os.PathLike[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(cli), "--quiet", *map(str, args)], capture_output=True, text=True, timeout=300
    )
