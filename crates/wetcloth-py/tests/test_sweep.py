"""Sweeps on Dask: rows equal to separate `wetcloth run`s, on a LocalCluster and on a real
scheduler with two workers; bad runs are rows, not failures."""

from __future__ import annotations

import csv
import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import wetcloth
from conftest import run_cli, tiny

VARY = {
    "air.trapped_air": [1e-5, 4e-5],
    "cloth.wetness": [0.5, 1.0],
    "collider.0.friction": [0.3, 0.6],
}
METRICS = list(wetcloth.METRICS_COLUMNS)


@pytest.fixture(scope="module")
def local_rows() -> pd.DataFrame:
    return wetcloth.sweep(tiny(), VARY, progress=False)


def test_a_sweep_has_the_columns_and_rows_asked_for(local_rows: pd.DataFrame) -> None:
    assert list(local_rows.columns) == list(VARY) + METRICS + [
        "peak_grab_force",
        "status",
        "message",
        "wall_time",
    ]
    assert len(local_rows) == 8
    # Every combination, the last key fastest, in order.
    assert list(local_rows["collider.0.friction"]) == [0.3, 0.6] * 4
    assert list(local_rows["air.trapped_air"]) == [1e-5] * 4 + [4e-5] * 4
    assert set(local_rows["status"]) == {"complete"}
    assert set(local_rows["message"]) == {""}
    assert (local_rows["wall_time"] > 0).all()


def test_a_local_sweep_equals_separate_command_line_runs(
    local_rows: pd.DataFrame, tmp_path: Path, cli: Path, tiny_file: Path
) -> None:
    for i, row in local_rows.iterrows():
        sets = [a for k in VARY for a in ("--set", f"{k}={row[k]!r}")]
        out = tmp_path / f"run{i}"
        ran = run_cli(cli, "run", tiny_file, *sets, "--out", out)
        assert ran.returncode == 0, ran.stderr
        with open(out / "metrics.csv", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        for name in METRICS:
            assert row[name] == float(rows[-1][name]), (i, name)
        assert row["peak_grab_force"] == max(float(r["grab_force"]) for r in rows)
    # The varied keys mattered: trapped air changes the pressure.
    assert local_rows["air_pressure"].nunique() > 1


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_sweep_on_a_scheduler_with_two_workers_gives_the_same_rows(
    local_rows: pd.DataFrame, tmp_path: Path
) -> None:
    from dask.distributed import Client

    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    bindir = Path(sys.executable).parent
    env = {**os.environ, "RAYON_NUM_THREADS": "1"}
    common = dict(env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    scheduler = subprocess.Popen(
        [bindir / "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
         "--dashboard-address", ":0"],
        **common,
    )
    workers = None
    try:
        workers = subprocess.Popen(
            [bindir / "dask", "worker", address, "--nworkers", "2", "--nthreads", "1",
             "--host", "127.0.0.1", "--dashboard-address", ":0"],
            **common,
        )
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            assert len(client.scheduler_info()["workers"]) == 2
        rows = wetcloth.sweep(tiny(), VARY, scheduler=address, progress=False)
    finally:
        for p in (workers, scheduler):
            if p is not None:
                p.send_signal(signal.SIGINT)
        for p in (workers, scheduler):
            if p is not None:
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
    same = [c for c in local_rows.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(rows[same], local_rows[same])


def test_an_invalid_and_a_blowing_up_variant_are_rows() -> None:
    rows = wetcloth.sweep(
        tiny(),
        [
            {"cloth.mass": 0.02},
            {"cloth.mass": -1},
            {"simulation.time_step": 2e-3},
            {"cloth.mass": 0.03},
        ],
        measure=lambda run: {
            "frames_written": run.frames_written,
            "height": run.frame(run.frames_written - 1)[:, 1].max(),
        },
        progress=False,
    )
    assert list(rows["status"]) == ["complete", "invalid", "failed", "complete"]
    # measure's columns come last, for the runs that ran, the failed one included.
    assert list(rows.columns[-2:]) == ["frames_written", "height"]
    assert list(rows["frames_written"].fillna(-1)) == [5, -1, 1, 5]
    assert rows.iloc[0]["height"] == rows.iloc[0]["max_height"]
    invalid, failed = rows.iloc[1], rows.iloc[2]
    assert invalid["message"].startswith("set cloth.mass: cloth.mass = -1 is out of range")
    assert all(math.isnan(invalid[name]) for name in METRICS)
    assert failed["message"].startswith("the simulation blew up at t = ")
    assert failed["frame"] == 0  # the last frame written before the blow-up
    assert math.isnan(rows.iloc[2]["cloth.mass"]) and rows.iloc[1]["cloth.mass"] == -1
    assert rows.iloc[0]["grab_force"] > 0


def test_the_command_line_sweep_writes_the_csv_and_the_runs(
    tmp_path: Path, cli: Path, tiny_file: Path
) -> None:
    env = {**os.environ, "VIRTUAL_ENV": sys.prefix}
    out, runs = tmp_path / "sweep.csv", tmp_path / "runs"
    ran = subprocess.run(
        [str(cli), "--quiet", "sweep", str(tiny_file), "--vary", "air.trapped_air=1e-5,4e-5",
         "--vary", "cloth.size=[0.1,0.1],[0.12,0.12]", "--out", str(out), "--runs", str(runs)],
        env=env, capture_output=True, text=True, timeout=300,
    )
    assert ran.returncode == 0, ran.stderr
    table = pd.read_csv(out)
    assert list(table["status"]) == ["complete"] * 4
    assert list(table["cloth.size"]) == ["[0.1, 0.1]", "[0.12, 0.12]"] * 2
    assert (runs / "run_0003" / "metrics.csv").is_file()
    with open(runs / "run_0003" / "metrics.csv", encoding="utf-8") as f:
        last = list(csv.DictReader(f))[-1]
    assert table["air_pressure"][3] == float(last["air_pressure"])


def test_the_command_line_says_how_to_install_the_package(
    tmp_path: Path, cli: Path, tiny_file: Path
) -> None:
    bare = tmp_path / "bin"
    bare.mkdir()
    # The interpreter the virtual environment was made from, without the package.
    base = Path(sys.base_prefix) / "bin" / "python3"
    (bare / "python3").symlink_to(base)
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["PATH"] = f"{bare}:/usr/bin:/bin"
    ran = run_cli_env(cli, env, "sweep", tiny_file, "--vary", "cloth.mass=0.02", "--out", tmp_path / "s.csv")
    if subprocess.run([base, "-c", "import wetcloth"], capture_output=True).returncode == 0:
        pytest.skip(f"{base} has the package installed")
    assert ran.returncode == 1
    assert "pip install" in ran.stderr and "crates/wetcloth-py" in ran.stderr, ran.stderr


def run_cli_env(cli: Path, env: dict[str, str], *args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(cli), *map(str, args)], env=env, capture_output=True, text=True, timeout=120
    )
