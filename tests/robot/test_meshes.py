"""Visual meshes MuJoCo cannot read, converted once into cached OBJ parts (ftc_mj.robot.meshes).

* A COLLADA file's parts are placed by their nodes, scaled by its ``<unit meter>``, one OBJ per colour.
* The conversion runs once: the second call reads the cache (trimesh is not called again); the cache lives in
  ``FTC_MJ_CACHE_DIR`` and never next to the source; a changed file is a new cache entry.
* A broken file raises MeshConversionError, and leaves no cache entry behind.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

from ftc_mj.robot import meshes
from ftc_mj.robot.meshes import MeshConversionError, convert

TWO_COLOURS = Path(__file__).resolve().parents[1] / "data" / "meshes" / "two_colours.dae"


@pytest.fixture()
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("FTC_MJ_CACHE_DIR", str(folder))
    return folder


def vertices(path: Path) -> np.ndarray:
    return np.array([[float(v) for v in line.split()[1:4]] for line in path.read_text().splitlines()
                     if line.startswith("v ")])


def test_collada_parts_by_colour_placed_and_in_metres(tmp_path, cache):
    source = tmp_path / "two.dae"
    shutil.copy(TWO_COLOURS, source)
    parts = convert(source)
    assert len(parts) == 2
    by_colour = {part.rgba: part for part in parts}
    red = by_colour[(0.8, 0.102, 0.102, 1.0)]  # 0.1 as 8-bit colour, 26/255
    blue = by_colour[(0.102, 0.2, 0.902, 1.0)]
    np.testing.assert_allclose(vertices(red.path), [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]], atol=1e-12)
    # 10 mm in the file, moved 5 mm by its node: 15 mm
    np.testing.assert_allclose(vertices(blue.path), [[0, 0, 0.015], [0.1, 0, 0.015], [0, 0.1, 0.015], [0.1, 0.1, 0.015]], atol=1e-12)
    assert all(cache in part.path.parents for part in parts)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "two.dae"]  # nothing next to the source


def test_converted_once_then_read_from_the_cache(tmp_path, cache, monkeypatch):
    source = tmp_path / "two.dae"
    shutil.copy(TWO_COLOURS, source)
    first = convert(source)

    def fail(*args, **kwargs):
        raise AssertionError("converted again")

    monkeypatch.setattr(trimesh, "load", fail)
    assert convert(source) == first
    # A changed file is another entry (keyed by content), converted anew.
    source.write_text(source.read_text().replace("100 0 0", "200 0 0"))
    with pytest.raises(MeshConversionError):
        convert(source)
    monkeypatch.undo()
    monkeypatch.setenv("FTC_MJ_CACHE_DIR", str(cache))
    changed = convert(source)
    assert changed[0].path.parent != first[0].path.parent
    assert len(list((cache / "meshes").iterdir())) == 2


@pytest.mark.parametrize("text, problem", [
    ("<COLLADA/>", "cannot read"),
    ("not xml at all", "cannot read"),
])
def test_broken_files_raise_and_leave_no_entry(tmp_path, cache, text, problem):
    source = tmp_path / "bad.dae"
    source.write_text(text)
    with pytest.raises(MeshConversionError) as info:
        convert(source)
    assert problem in str(info.value)
    assert not (cache / "meshes").exists() or not any((cache / "meshes").iterdir())


def test_parts_too_small_for_mujoco_are_dropped(tmp_path, cache):
    """MuJoCo needs 4 vertices in a mesh: a part with fewer (a lone triangle) is left out; a file of such
    parts only is refused."""
    source = tmp_path / "one.dae"
    text = TWO_COLOURS.read_text()
    source.write_text(text.replace('<p>0 1 2 1 3 2</p>', '<p>0 1 2</p>', 1).replace('count="2"><input semantic="VERTEX" source="#a-vtx"', 'count="1"><input semantic="VERTEX" source="#a-vtx"')
                      .replace('<float_array id="a-arr" count="12">0 0 0 100 0 0 0 100 0 100 100 0', '<float_array id="a-arr" count="9">0 0 0 100 0 0 0 100 0').replace('accessor source="#a-arr" count="4"', 'accessor source="#a-arr" count="3"'))
    parts = convert(source)
    assert [part.rgba for part in parts] == [(0.102, 0.2, 0.902, 1.0)]


def test_bad_unit_is_refused(tmp_path, cache):
    source = tmp_path / "unit.dae"
    source.write_text(TWO_COLOURS.read_text().replace('meter="0.001"', 'meter="-1"'))
    with pytest.raises(MeshConversionError, match="unit meter"):
        convert(source)


def test_cache_folder_defaults(monkeypatch, tmp_path):
    monkeypatch.delenv("FTC_MJ_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert meshes.cache_dir() == tmp_path / "ftc_mj"
    monkeypatch.setenv("FTC_MJ_CACHE_DIR", str(tmp_path / "x"))
    assert meshes.cache_dir() == tmp_path / "x"
