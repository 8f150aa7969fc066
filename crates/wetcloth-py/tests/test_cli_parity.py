"""A run from Python is the command line's run: the same frames, metrics and folder."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

import wetcloth
from conftest import run_cli


def read_obj(path: Path) -> np.ndarray:
    with open(path, encoding="utf-8") as f:
        return np.array([[float(c) for c in line.split()[1:4]] for line in f if line.startswith("v ")])


def test_a_run_from_python_gives_the_command_lines_outputs(
    tmp_path: Path, cli: Path, tiny_file: Path
) -> None:
    ran = run_cli(cli, "run", tiny_file, "--set", "air.trapped_air=4e-5", "--out", tmp_path / "cli")
    assert ran.returncode == 0, ran.stderr
    scene = wetcloth.Scene.from_file(tiny_file)
    scene.set("air.trapped_air", 4e-5)
    r = wetcloth.run(scene, out=tmp_path / "py")
    assert r.status == "complete" and r.frames_written == 5

    # Positions equal the OBJ frames to every digit written (shortest round-trip text).
    for k in range(r.frames_written):
        written = read_obj(tmp_path / "cli" / "frames" / f"frame_{k:04d}.obj")
        assert np.array_equal(r.frame(k), written), k
    # Metrics equal metrics.csv.
    with open(tmp_path / "cli" / "metrics.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    table = r.metrics
    assert list(table.columns) == list(rows[0])
    for k, row in enumerate(rows):
        for name, text in row.items():
            assert table[name][k] == float(text), (k, name)
    # And the folders are the same, file for file.
    for name in ["metrics.csv", "pockets.csv", "scene.toml", "run.json", "rest.obj"] + [
        f"frames/frame_{k:04d}.obj" for k in range(5)
    ]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name


def test_a_blow_up_is_a_failed_run_not_an_exception(
    tmp_path: Path, cli: Path, tiny_file: Path
) -> None:
    ran = run_cli(cli, "run", tiny_file, "--set", "simulation.time_step=2e-3", "--out", tmp_path / "cli")
    assert ran.returncode == 1
    scene = wetcloth.Scene.from_file(tiny_file)
    scene.set("simulation.time_step", 2e-3)
    r = wetcloth.run(scene, out=tmp_path / "cli")
    assert r.status == "failed"
    assert ran.stderr.strip().endswith(f"\nerror: {r.message}")
    assert r.frames_written == len(r.metrics) == 1
