"""``wetcloth.run``: a whole run, as ``wetcloth run`` does it."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ._native import METRICS_COLUMNS, POCKETS_COLUMNS, Scene, run_scene

# Columns that hold counts, kept as integers.
_INT_COLUMNS = {"frame", "pocket_count", "pocket", "particles"}


def _table(rows: list[list[float]], columns: list[str]) -> Any:
    """Rows as a pandas DataFrame when pandas is installed, else a dict of NumPy arrays."""
    data = np.asarray(rows, dtype=np.float64).reshape(len(rows), len(columns))
    cols = {
        name: (data[:, i].astype(np.int64) if name in _INT_COLUMNS else data[:, i])
        for i, name in enumerate(columns)
    }
    try:
        import pandas as pd
    except ImportError:
        return cols
    return pd.DataFrame(cols, columns=columns)


class Run:
    """A finished run: what ``wetcloth run`` writes, in memory.

    ``status`` is ``"complete"`` or ``"failed"`` (a blow-up: ``message`` says why, as run.json
    does; the frames before it are kept). ``metrics`` has the columns of metrics.csv, one row
    per frame, ``pockets`` those of pockets.csv (pandas DataFrames when pandas is installed,
    else dicts of arrays); ``frame(k)`` is frame k's positions, m, ``(n, 3)``. ``out`` is the
    run folder, or None.
    """

    def __init__(self, scene: Scene, record: dict[str, Any]) -> None:
        self.scene = scene
        self.status: str = record["status"]
        self.message: str = record["message"]
        self.time: float = record["time"]
        self.frames_written: int = record["frames_written"]
        self.out: Path | None = Path(record["out"]) if record["out"] is not None else None
        self._metrics = record["metrics"]
        self._pockets = record["pockets"]
        self._frames = record["frames"]

    @property
    def metrics(self) -> Any:
        """metrics.csv: one row per frame written."""
        return _table(self._metrics, list(METRICS_COLUMNS))

    @property
    def pockets(self) -> Any:
        """pockets.csv: one row per sealed air pocket per frame written."""
        return _table(self._pockets, list(POCKETS_COLUMNS))

    @property
    def peak_grab_force(self) -> float:
        """The largest ``grab_force`` of the frames written, N (nan with none)."""
        col = METRICS_COLUMNS.index("grab_force")
        return max((row[col] for row in self._metrics), default=float("nan"))

    def frame(self, k: int) -> np.ndarray:
        """Positions of frame ``k`` (m, read-only ``(n, 3)`` float64): kept in memory, or read
        back from the run folder's OBJ file when the run was made with ``frames=False``."""
        if not 0 <= k < self.frames_written:
            raise IndexError(f"frame {k}: the run wrote frames 0..{self.frames_written - 1}")
        if self._frames is not None:
            return self._frames[k]
        if self.out is None:
            raise ValueError("the run kept no frames (frames=False) and wrote no folder (out=None)")
        path = self.out / "frames" / f"frame_{k:04d}.obj"
        with open(path, encoding="utf-8") as f:
            rows = [line.split()[1:4] for line in f if line.startswith("v ")]
        a = np.asarray(rows, dtype=np.float64)
        a.flags.writeable = False
        return a

    def __repr__(self) -> str:
        return f"Run({self.scene.name!r}, {self.status}, {self.frames_written} frames, t={self.time} s)"


def run(
    scene: Scene | str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    frames: bool = True,
    threads: int | None = None,
) -> Run:
    """Runs ``scene`` (a Scene or a scene file's path) as ``wetcloth run`` does: the same steps,
    frames and metrics, and with ``out`` the same folder. A blow-up does not raise: the Run's
    ``status`` is ``"failed"``. ``frames=False`` keeps no positions in memory. ``threads``: the
    simulation's threads (default: all cores, or RAYON_NUM_THREADS); results do not depend on
    it. The GIL is released while it runs."""
    if not isinstance(scene, Scene):
        scene = Scene.from_file(os.fspath(scene))
    if threads is not None and threads < 1:
        raise ValueError(f"threads = {threads}: give at least 1, or None for all cores")
    record = run_scene(
        scene,
        None if out is None else os.fspath(out),
        frames,
        0 if threads is None else threads,
    )
    return Run(scene, record)
