"""Simulations stepped from Python."""

from __future__ import annotations

import numpy as np
import pytest

import wetcloth


def test_arrays_are_read_only_copies(tiny_scene: wetcloth.Scene) -> None:
    sim = wetcloth.Simulation(tiny_scene)
    x = sim.positions
    assert x.shape == (64, 3) and x.dtype == np.float64
    assert not x.flags.writeable and not sim.velocities.flags.writeable
    sim.step(10)
    assert sim.steps == 10
    assert not np.array_equal(sim.positions, x)  # the copy did not follow
    assert np.all(sim.velocities[:, 1] == sim.velocities[:, 1])


def test_advance_takes_the_command_lines_steps(tiny_scene: wetcloth.Scene) -> None:
    sim = wetcloth.Simulation(tiny_scene)
    dt = sim.time_step
    assert dt == pytest.approx(1 / 12000)
    sim.advance(0.01)  # 120 steps of 1/12000 s: 0.01 s up to round-off
    assert sim.steps == 120
    sim.advance(0.0)
    assert sim.steps == 120
    sim.advance(1.5 * dt)  # the first step at or after the time asked for
    assert sim.steps == 122
    with pytest.raises(ValueError):
        sim.advance(-1.0)


def test_metrics_and_pockets_have_the_csv_columns(tiny_scene: wetcloth.Scene) -> None:
    sim = wetcloth.Simulation(tiny_scene)
    sim.advance(0.01)
    m = sim.metrics()
    assert list(m) == wetcloth.METRICS_COLUMNS[1:]
    assert m["trapped_air"] == 2e-5
    # Boyle: pressure times volume is the atmosphere times the trapped air.
    assert m["air_pressure"] * m["air_volume"] == pytest.approx(101325.0 * 2e-5, rel=1e-9)
    (p,) = sim.pockets()
    assert set(p) == set(wetcloth.POCKETS_COLUMNS) - {"frame"}
    assert p["volume"] == m["air_volume"]


def test_a_hand_from_python_pulls_a_particle_to_its_target(tiny_scene: wetcloth.Scene) -> None:
    tiny_scene.set("grab", [])
    sim = wetcloth.Simulation(tiny_scene)
    k = 2 * 8 + 3
    start = sim.positions[k].copy()
    target = start + [0.0, 0.01, 0.0]
    sim.grab([3, 2], list(target))
    sim.advance(0.02)  # 1 cm at up to 2 m/s takes 5 ms
    assert sim.positions[k] == pytest.approx(target, abs=1e-9)
    assert sim.metrics()["grab_force"] > 0.0
    sim.release()
    sim.step()
    assert sim.metrics()["grab_force"] == 0.0
    with pytest.raises(IndexError):
        sim.grab(64, [0.0, 0.0, 0.0])


def test_a_checkpoint_continues_bit_for_bit(tiny_scene: wetcloth.Scene) -> None:
    a = wetcloth.Simulation(tiny_scene)
    a.advance(0.01)
    a.grab(5, [0.0, 0.02, 0.0])
    data = a.checkpoint()
    b = wetcloth.Simulation.restore(tiny_scene, data)
    a.advance(0.01)
    b.advance(0.01)
    assert np.array_equal(a.positions, b.positions)
    assert a.time == b.time
    with pytest.raises(ValueError):
        wetcloth.Simulation.restore(tiny_scene, b"not a checkpoint")


def test_a_blow_up_raises_unstable_and_stops(tiny_scene: wetcloth.Scene) -> None:
    tiny_scene.set("simulation.time_step", 2e-3)
    sim = wetcloth.Simulation(tiny_scene)
    with pytest.raises(wetcloth.Unstable) as e:
        sim.advance(0.04)
    assert e.value.time > 0.0
    assert str(e.value).startswith(f"the simulation blew up at t = {e.value.time:.6f} s")
    assert "try a smaller time_step" in str(e.value)
    steps = sim.steps
    with pytest.raises(wetcloth.Unstable, match="refuses to step"):
        sim.step()
    assert sim.steps == steps
