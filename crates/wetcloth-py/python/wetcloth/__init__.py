"""wetcloth: wet cloth that sticks, from Python.

A mass-spring cloth on a table with the air trapped under it (after W. Yamada, 2012): scenes
(:class:`Scene`), simulations stepped from Python (:class:`Simulation`), whole runs as the
command line does them (:func:`run`), and parameter sweeps on Dask (:func:`sweep`). SI units
(m, kg, s, N, Pa, m^3), Y up. See docs/python.md.
"""

from __future__ import annotations

from ._errors import SceneError, Unstable
from ._native import (
    METRICS_COLUMNS,
    POCKETS_COLUMNS,
    Scene,
    Simulation,
    __version__,
    parse_value,
)
from ._run import Run, run
from ._sweep import sweep

__all__ = [
    "METRICS_COLUMNS",
    "POCKETS_COLUMNS",
    "Run",
    "Scene",
    "SceneError",
    "Simulation",
    "Unstable",
    "__version__",
    "parse_value",
    "run",
    "sweep",
]
