"""``wetcloth.sweep``: every combination of some scene keys' values, run on Dask."""

from __future__ import annotations

import itertools
import math
import os
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from ._errors import SceneError
from ._native import METRICS_COLUMNS, Scene
from ._run import Run, run

#: The columns every sweep row has after the varied keys and the metrics.
TAIL_COLUMNS = ["peak_grab_force", "status", "message", "wall_time"]


def variants(vary: Mapping[str, Iterable[Any]] | Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The runs of a sweep: every combination of a dict of value lists (the last key varying
    fastest), or an explicit list of dicts, as given."""
    if isinstance(vary, Mapping):
        keys = list(vary)
        values = [list(vary[k]) for k in keys]
        return [dict(zip(keys, combo)) for combo in itertools.product(*values)]
    return [dict(v) for v in vary]


def run_variant(
    scene: Scene,
    variant: Mapping[str, Any],
    out: str | None = None,
    measure: Callable[[Run], Mapping[str, Any]] | None = None,
    threads: int = 1,
) -> dict[str, Any]:
    """One row of a sweep: runs ``scene`` with the keys of ``variant`` set. Never raises for a
    bad run: an invalid value is status ``invalid``, a blow-up ``failed``, with the message the
    command line gives."""
    started = time.perf_counter()
    nan = float("nan")
    row: dict[str, Any] = {name: nan for name in METRICS_COLUMNS}
    row.update(peak_grab_force=nan, status="invalid", message="")
    try:
        s = scene.copy()
        for key, value in variant.items():
            s.set(key, value)
        r = run(s, out=out, frames=measure is not None and out is None, threads=threads)
    except SceneError as e:
        row["message"] = str(e)
    else:
        if r.frames_written:
            row.update(dict(zip(METRICS_COLUMNS, r._metrics[-1])))
            row["frame"] = int(row["frame"])
            row["pocket_count"] = int(row["pocket_count"])
        row.update(peak_grab_force=r.peak_grab_force, status=r.status, message=r.message)
        if measure is not None:
            try:
                row.update(measure(r))
            except Exception as e:  # the run stands; the row says what measure did
                note = f"measure raised {e!r}"
                row["message"] = f"{row['message']}\n  {note}" if row["message"] else note
    row["wall_time"] = time.perf_counter() - started
    return row


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def sweep(
    scene: Scene | str | os.PathLike[str],
    vary: Mapping[str, Iterable[Any]] | Iterable[Mapping[str, Any]],
    scheduler: Any = None,
    measure: Callable[[Run], Mapping[str, Any]] | None = None,
    *,
    runs: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> Any:
    """Runs every variant of ``scene`` on Dask and returns a pandas DataFrame, one row per run
    in the order of the variants.

    ``vary``: ``{"air.trapped_air": [0, 1e-4], "cloth.wetness": [0.5, 1.0]}`` (every
    combination) or a list of dicts. ``scheduler``: None for a LocalCluster here (one worker
    process per core, one thread each, rayon on one thread), ``"tcp://HOST:PORT"`` for a
    running ``dask scheduler``, or a ``dask.distributed.Client``. ``measure``: a function of the
    finished :class:`Run` returning a dict of extra columns. ``runs``: a folder to write each
    run's folder in (``run_0000``, ...; must be reachable by the workers).

    Columns: each varied key (dotted name), the metrics.csv columns of the last frame written,
    ``peak_grab_force`` (N, the largest grab_force written), ``status`` (``complete``,
    ``failed`` for a blow-up, ``invalid`` for a refused value), ``message`` (the command line's
    message for the last two, else empty), ``wall_time`` (s), then ``measure``'s, called for
    every run that ran (complete or failed; an exception it raises is noted in ``message``).
    A bad run is a row, never an exception.
    """
    import pandas as pd
    from dask.distributed import Client, LocalCluster
    from dask.distributed import progress as show_progress

    if not isinstance(scene, Scene):
        scene = Scene.from_file(os.fspath(scene))
    todo = variants(vary)
    keys: list[str] = []
    for v in todo:
        keys.extend(k for k in v if k not in keys)
    outs: list[str | None] = [None] * len(todo)
    if runs is not None:
        base = Path(runs).resolve()
        base.mkdir(parents=True, exist_ok=True)
        outs = [str(base / f"run_{i:04d}") for i in range(len(todo))]

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=_cores(),
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={"RAYON_NUM_THREADS": "1"},
        )
        client = Client(cluster)
    elif isinstance(scheduler, str):
        client = Client(scheduler)
    else:
        client = scheduler
    try:
        futures = client.map(
            run_variant,
            [scene] * len(todo),
            todo,
            outs,
            [measure] * len(todo),
            pure=False,
        )
        if progress:
            show_progress(futures)
        rows = []
        for fut, v in zip(futures, todo):
            try:
                row = fut.result()
            except Exception as e:  # a worker died: the run's row says so, the sweep goes on
                row = {name: math.nan for name in METRICS_COLUMNS}
                row.update(
                    peak_grab_force=math.nan,
                    status="failed",
                    message=f"the worker running it failed: {e!r}",
                    wall_time=math.nan,
                )
            rows.append({**v, **row})
    finally:
        if client is not scheduler:
            client.close()
        if cluster is not None:
            cluster.close()
    extra = [c for r in rows for c in r if c not in keys and c not in METRICS_COLUMNS and c not in TAIL_COLUMNS]
    columns = keys + list(METRICS_COLUMNS) + TAIL_COLUMNS + list(dict.fromkeys(extra))
    return pd.DataFrame(rows, columns=columns)
