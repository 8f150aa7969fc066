"""Scenes from Python: the scene file's key paths, validation and messages."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

import wetcloth
from conftest import REPO


def test_a_shipped_scene_reads_and_writes_back() -> None:
    s = wetcloth.Scene.from_file(REPO / "scenes" / "air-400.toml")
    again = wetcloth.Scene.from_toml(s.to_toml(), "again.toml")
    assert again == s
    assert s.get("air.trapped_air") == pytest.approx(400e-6)
    assert pickle.loads(pickle.dumps(s)) == s


def test_set_and_get_by_dotted_path() -> None:
    s = wetcloth.Scene.thesis_demo()
    s.set("cloth.mass", 0.05)
    s.set("collider.0.friction", 0.3)
    s.set("air.model", "pockets")
    assert s.get("cloth.mass") == 0.05
    assert s.get("collider[0].friction") == 0.3
    assert s.get("air.model") == "pockets"
    assert s.get("grab.0.particle") == [25, 25]
    assert s.get("grab.1.particle") is None  # a valid key the scene lacks
    assert "mass = 0.05" in s.to_toml()


def test_a_bad_key_raises_scene_error_naming_it() -> None:
    s = wetcloth.Scene.thesis_demo()
    with pytest.raises(wetcloth.SceneError) as e:
        s.set("cloth.masss", 0.05)
    assert isinstance(e.value, ValueError)
    assert e.value.key == "cloth.masss"
    assert "unknown key `cloth.masss`; did you mean `mass`?" in str(e.value)
    with pytest.raises(wetcloth.SceneError) as e:
        s.get("collider.0.frictoin")
    assert e.value.key == "collider[0].frictoin"
    assert s == wetcloth.Scene.thesis_demo()


def test_a_bad_value_gets_the_command_lines_message(tmp_path: Path, cli: Path) -> None:
    s = wetcloth.Scene.thesis_demo()
    with pytest.raises(wetcloth.SceneError) as e:
        s.set("cloth.mass", -1)
    assert (e.value.key, e.value.value, e.value.line) == ("cloth.mass", "-1", None)
    # The same words as `wetcloth run --set cloth.mass=-1`.
    from conftest import run_cli

    out = run_cli(cli, "run", "--set", "cloth.mass=-1", "--out", tmp_path / "x")
    assert out.returncode == 2
    assert out.stderr.strip() == f"error: {e.value}"
    with pytest.raises(wetcloth.SceneError) as e:
        s.set("cloth.resolution", "fine")
    assert "has the wrong type" in str(e.value)


def test_file_errors_carry_their_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("name = \"bad\"\n[cloth]\nmass = -1\n", encoding="utf-8")
    with pytest.raises(wetcloth.SceneError) as e:
        wetcloth.Scene.from_file(path)
    assert (e.value.key, e.value.value, e.value.line) == ("cloth.mass", "-1", 3)
    assert str(e.value).startswith(f"{path}:3:8: cloth.mass = -1 is out of range")


def test_values_parse_as_on_the_command_line() -> None:
    assert wetcloth.parse_value("[0.2,0.2]") == [0.2, 0.2]
    assert wetcloth.parse_value("pockets") == "pockets"
    assert wetcloth.parse_value("4e-4") == 4e-4
    assert wetcloth.parse_value("true") is True
