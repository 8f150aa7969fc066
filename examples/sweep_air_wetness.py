"""Sweep the trapped air and the wetness of the thesis demo on Dask and map the peak force the
hand needs to lift the cloth (docs/python.md shows the picture).

    python examples/sweep_air_wetness.py [--out docs/images/python-sweep.png] [--sequential]
                                         [--workers 2] [--quiet]

The demo is made small enough to run in seconds: a 16 x 16 cloth lifted 5 cm at its centre
between 0.1 s and 0.9 s. Wetness acts through friction here: with `dry_friction_factor = 0.3`
a dry cloth slides on the table with 30 % of the wet cloth's friction. With `--sequential` it
also runs the same variants one after another in this process and prints both wall times.
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from dask.distributed import Client, LocalCluster

import wetcloth

AIR = [0.0, 25e-6, 50e-6, 100e-6, 200e-6, 400e-6]  # m^3 at atmospheric pressure
WETNESS = [0.0, 0.25, 0.5, 0.75, 1.0]


def demo() -> wetcloth.Scene:
    s = wetcloth.Scene.thesis_demo()
    s.set(
        "grab.0",
        {
            "particle": [8, 8],
            "keys": [
                {"time": 0.1, "offset": [0.0, 0.0, 0.0]},
                {"time": 0.9, "offset": [0.0, 0.05, 0.0]},
            ],
        },
    )
    s.set("cloth.resolution", [16, 16])
    s.set("simulation.duration", 1.0)
    s.set("cloth.dry_friction_factor", 0.3)
    return s


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="sweep.png")
    parser.add_argument("--sequential", action="store_true")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args()

    scene = demo()
    vary = {"air.trapped_air": AIR, "cloth.wetness": WETNESS}
    # The cluster wetcloth.sweep starts by itself, made here to time its start apart from
    # the sweep: one worker process per core, one thread each, rayon on one thread.
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, env={"RAYON_NUM_THREADS": "1"})
    client = Client(cluster)
    started = time.perf_counter() - t0
    t0 = time.perf_counter()
    table = wetcloth.sweep(scene, vary, scheduler=client, progress=not args.quiet)
    parallel = time.perf_counter() - t0
    client.close()
    cluster.close()
    print(table[["air.trapped_air", "cloth.wetness", "peak_grab_force", "status", "wall_time"]])
    print(f"sweep of {len(table)} runs on {args.workers} Dask workers: {parallel:.1f} s wall "
          f"(and {started:.1f} s to start the cluster); the runs' own wall times add up to "
          f"{table['wall_time'].sum():.1f} s")
    if args.sequential:
        t0 = time.perf_counter()
        for v in wetcloth._sweep.variants(vary):
            wetcloth._sweep.run_variant(scene, v, threads=1)
        sequential = time.perf_counter() - t0
        print(f"the same runs one after another: {sequential:.1f} s wall "
              f"({sequential / parallel:.2f}x the sweep's)")

    force = table.pivot(index="cloth.wetness", columns="air.trapped_air", values="peak_grab_force")
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
    mesh = ax.pcolormesh(np.arange(len(AIR) + 1), np.arange(len(WETNESS) + 1), force.values,
                         cmap="viridis", shading="flat")
    for i, w in enumerate(WETNESS):
        for j, a in enumerate(AIR):
            f = force.loc[w, a]
            ax.text(j + 0.5, i + 0.5, f"{f:.2f}", ha="center", va="center", fontsize=8,
                    color="white" if f < np.nanmean(force.values) else "black")
    ax.set_xticks(np.arange(len(AIR)) + 0.5, [f"{a * 1e6:g}" for a in AIR])
    ax.set_yticks(np.arange(len(WETNESS)) + 0.5, [f"{w:g}" for w in WETNESS])
    ax.set_xlabel("trapped air (cm$^3$ at atmospheric pressure)")
    ax.set_ylabel("wetness")
    ax.set_title("Peak force to lift the cloth's centre 5 cm (N)")
    fig.colorbar(mesh, ax=ax, label="peak grab force (N)")
    fig.tight_layout()
    fig.savefig(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
