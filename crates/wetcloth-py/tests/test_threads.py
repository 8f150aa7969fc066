"""Stepping releases the GIL: two simulations on two Python threads run side by side."""

from __future__ import annotations

import threading
import time

import pytest

import wetcloth


def workload() -> wetcloth.Scene:
    s = wetcloth.Scene.thesis_demo()
    s.set("grab", [])
    s.set("cloth.resolution", [24, 24])
    return s


def timed(sims: list[wetcloth.Simulation], steps: int) -> tuple[float, float]:
    """Wall and process CPU time of stepping every simulation on its own thread."""
    threads = [threading.Thread(target=s.step, args=(steps,)) for s in sims]
    wall, cpu = time.perf_counter(), time.process_time()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return time.perf_counter() - wall, time.process_time() - cpu


def test_python_runs_while_a_simulation_steps() -> None:
    """A Python loop on the main thread keeps going while another thread steps: with the GIL
    held it would stand still until the step returned."""
    sim = wetcloth.Simulation(workload())
    t = threading.Thread(target=sim.step, args=(4000,))
    count = 0
    t.start()
    while t.is_alive():
        count += 1
    t.join()
    assert count > 10_000, count


def test_two_threads_step_at_the_same_time() -> None:
    """The two step() calls overlap in time, however busy the machine: with the GIL held by
    a step, the second thread's call could only start once the first had returned."""
    scene = workload()
    sims = [wetcloth.Simulation(scene), wetcloth.Simulation(scene)]
    spans: list[tuple[float, float]] = [(0.0, 0.0), (0.0, 0.0)]

    def go(i: int) -> None:
        t0 = time.perf_counter()
        sims[i].step(3000)
        spans[i] = (t0, time.perf_counter())

    threads = [threading.Thread(target=go, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    (a0, a1), (b0, b1) = spans
    overlap = min(a1, b1) - max(a0, b0)
    assert overlap > 0.8 * min(a1 - a0, b1 - b0), spans


def test_two_simulations_take_well_under_twice_one() -> None:
    scene = workload()
    # About 0.6 s of stepping for one simulation on this machine.
    probe = wetcloth.Simulation(scene)
    t0 = time.perf_counter()
    probe.step(500)
    steps = max(500, int(500 * 0.6 / (time.perf_counter() - t0)))
    tries = []
    for _ in range(5):  # the machine may be shared: take the best of five
        one, cpu_one = timed([wetcloth.Simulation(scene)], steps)
        two, cpu_two = timed([wetcloth.Simulation(scene), wetcloth.Simulation(scene)], steps)
        tries.append((round(two / one, 2), round(cpu_one / one, 2), round(cpu_two / two, 2)))
        # Two threads at once: under 1.6 times one's wall time, or the CPU time of more than
        # 1.4 cores in that wall time (both impossible while one thread holds the GIL).
        if two < 1.6 * one or cpu_two > 1.4 * two:
            return
    message = f"(two/one wall time, cores busy with one, with two) per try: {tries}"
    if max(c for _, c, _ in tries) < 0.9:
        # One thread alone never got a whole core: other programs hold this machine's cores,
        # so there is no second core to show. (With the GIL held on an idle machine one thread
        # gets its core, and the test fails.) The overlap test above holds either way.
        pytest.skip(f"the machine is busy: {message}")
    raise AssertionError(message)
