"""Visual meshes MuJoCo cannot read (COLLADA ``.dae``, PLY, GLB, ...) converted once into OBJ files it can.

ROS description packages draw their links with COLLADA files, often several coloured parts in one file. The
dynamics never depend on them (a URDF link's mass is its ``<inertial>``), but the recording shows them. Each
file is read with trimesh (pycollada for COLLADA), its parts placed by the file's own node transforms and
scaled by its ``<unit meter=...>``, and the parts of one colour merged into one OBJ. The result goes to a
cache folder, keyed by the file's content, never next to the user's files:

    $FTC_MJ_CACHE_DIR, else $XDG_CACHE_HOME/ftc_mj, else ~/.cache/ftc_mj   /meshes/<sha256>/part<k>.obj

A cache entry is written in a private folder and renamed into place whole, so concurrent runs and interrupted
ones never see half a conversion.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

#: Mesh formats MuJoCo reads itself.
MUJOCO_FORMATS = (".stl", ".obj", ".msh")
#: Formats converted here: those trimesh reads (COLLADA through pycollada).
CONVERTED_FORMATS = (".dae", ".ply", ".glb", ".gltf", ".off", ".3mf")
#: MuJoCo refuses meshes with fewer vertices.
_MUJOCO_MIN_VERTICES = 4
#: Bumped when the conversion changes, so that old cache entries are not reused.
_CONVERTER_VERSION = "1"


class MeshConversionError(ValueError):
    """A mesh file that cannot be read or has nothing to draw."""


@dataclass(frozen=True)
class MeshPart:
    """One converted part: an OBJ file and its colour (RGBA in [0, 1], None when the file gives none)."""

    path: Path
    rgba: tuple[float, float, float, float] | None


def cache_dir() -> Path:
    """The folder converted meshes are kept in (see the module docstring)."""
    explicit = os.environ.get("FTC_MJ_CACHE_DIR")
    if explicit:
        return Path(explicit)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "ftc_mj"


def convert(source: Path) -> list[MeshPart]:
    """The OBJ parts of ``source`` (converted on first use, then read from the cache).

    Raises:
        MeshConversionError: the file cannot be read or holds no triangles.
    """
    data = source.read_bytes()
    key = hashlib.sha256(_CONVERTER_VERSION.encode() + source.suffix.lower().encode() + data).hexdigest()
    entry = cache_dir() / "meshes" / key
    index = entry / "parts.json"
    if not index.is_file():
        _write_entry(entry, _read_parts(source, data))
    return [MeshPart(entry / part["file"], None if part["rgba"] is None else tuple(part["rgba"]))
            for part in json.loads(index.read_text(encoding="utf-8"))]


def _read_parts(source: Path, data: bytes) -> list[tuple[object, tuple[float, ...] | None]]:
    """(trimesh.Trimesh, rgba) per colour, in the file's frame and in metres."""
    import trimesh  # about 1 s to import; only URDFs with such meshes need it

    try:
        scene = trimesh.load(source, force="scene")
        meshes = [m for m in scene.dump(concatenate=False) if isinstance(m, trimesh.Trimesh) and len(m.faces)]
    except Exception as exc:  # noqa: BLE001 - trimesh and its readers raise anything on a broken file
        raise MeshConversionError(f"trimesh cannot read it: {type(exc).__name__}: {exc}") from None
    if not meshes:
        raise MeshConversionError("it holds no triangles")
    scale = _collada_unit(data) if source.suffix.lower() == ".dae" else 1.0
    by_colour: dict[tuple[float, ...] | None, list] = {}
    for mesh in meshes:
        by_colour.setdefault(_colour(mesh), []).append(mesh)
    parts = []
    for rgba, group in by_colour.items():
        merged = trimesh.util.concatenate(group) if len(group) > 1 else group[0].copy()
        merged.merge_vertices()
        if len(merged.vertices) >= _MUJOCO_MIN_VERTICES:  # a lone triangle: MuJoCo refuses it, nothing to see
            merged.apply_scale(scale)
            parts.append((merged, rgba))
    if not parts:
        raise MeshConversionError(f"it holds no part of {_MUJOCO_MIN_VERTICES} vertices or more (MuJoCo's minimum)")
    return parts


def _collada_unit(data: bytes) -> float:
    """Metres per unit of a COLLADA file (``<asset><unit meter=...>``, default 1)."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise MeshConversionError(f"malformed COLLADA XML: {exc.msg}") from None
    unit = root.find("{*}asset/{*}unit")
    try:
        meter = float(unit.get("meter", "1")) if unit is not None else 1.0
    except ValueError:
        raise MeshConversionError(f"<unit meter={unit.get('meter')!r}> is not a number") from None
    if not np.isfinite(meter) or meter <= 0:
        raise MeshConversionError(f"<unit meter={meter}> must be a number > 0")
    return meter


def _colour(mesh) -> tuple[float, float, float, float] | None:
    """The part's colour: its material's main colour, or its mean vertex/face colour; None without one."""
    visual = mesh.visual
    material = getattr(visual, "material", None)
    colour = getattr(material, "main_color", None) if material is not None else None
    if colour is None and getattr(visual, "kind", None) in ("vertex", "face"):
        colour = np.asarray(visual.vertex_colors if visual.kind == "vertex" else visual.face_colors).mean(axis=0)
    if colour is None:
        return None
    return tuple(round(float(c) / 255.0, 4) for c in np.asarray(colour, dtype=float)[:4])


def _write_entry(entry: Path, parts: list) -> None:
    """Write the parts and their index into a private folder, then rename it to ``entry`` in one step."""
    stage = entry.parent / f".{entry.name}.{uuid.uuid4().hex}"
    stage.mkdir(parents=True)
    try:
        index = []
        for k, (mesh, rgba) in enumerate(parts):
            name = f"part{k}.obj"
            # Geometry only: the colour goes to the MuJoCo geom (MuJoCo ignores OBJ materials).
            (stage / name).write_text(mesh.export(file_type="obj", include_normals=False, include_color=False,
                                                  include_texture=False), encoding="utf-8")
            index.append({"file": name, "rgba": None if rgba is None else list(rgba)})
        (stage / "parts.json").write_text(json.dumps(index), encoding="utf-8")
        try:
            os.replace(stage, entry)
        except OSError:  # another run published the same entry first: theirs is identical
            if not (entry / "parts.json").is_file():
                raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
