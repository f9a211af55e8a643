"""Visual mesh files that are missing: the geoms drawn with them dropped, with one warning line, when the
dynamics do not depend on them; an error naming the path looked for when they do, or when the scenario asks
for every file (``robot.strict_meshes``).

A robot copied without its mesh folder (a MuJoCo Menagerie model without ``assets/``, a URDF without its
``meshes/``) still has every number the simulation uses: masses and inertias in its bodies' ``<inertial>``
elements, joints, actuators. Its meshes only draw it. A geom of a missing mesh may be dropped when

* it gives no moving body mass or inertia: its body is welded to the world (no joint between them), or the body has an explicit ``<inertial>`` and the compiler does not
  force inertia from geoms (``inertiafromgeom="true"``), or the geom lies outside ``inertiagrouprange``, or
  its mass is 0 (or unset with density 0);
* it takes part in no contact: contacts are off in the model the testbed simulates (the testbed's
  convention: a rebuilt MJCF and a URDF robot), or the geom collides with nothing (``contype`` and
  ``conaffinity`` 0) and no explicit contact ``<pair>`` names it.

A URDF link's mass is its ``<inertial>`` and its contacts are off (:mod:`ftc_mj.robot.urdf`): there a missing
mesh always qualifies. The warning goes to the ``ftc_mj.robot`` logger (printed on stderr as one line when
the application configures no logging).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco

from ftc_mj.config.errors import InputError

LOGGER = logging.getLogger("ftc_mj.robot")

_INERTIA_FROM_GEOM = mujoco.mjtInertiaFromGeom


@dataclass(frozen=True)
class MissingVisual:
    """A mesh file that is not there: the name the model gives, every path it was looked for at, and the
    body (URDF: link) of each geom drawn with it."""

    name: str
    looked_at: tuple[Path, ...]
    users: tuple[str, ...]


def warn_dropped(source: str, field: str, model: str, missing: Sequence[MissingVisual]) -> None:
    """One warning line: what was dropped and where the files were looked for."""
    if not missing:
        return
    geoms = [user for item in missing for user in item.users]
    bodies = list(dict.fromkeys(geoms))
    LOGGER.warning("warning: %s: %s: %s: %d visual mesh file(s) missing: drawn without them, %d geom(s) dropped "
                   "from %s; looked for %s (robot.strict_meshes: true refuses them)", source, field, model,
                   len(missing), len(geoms), _shortlist(bodies), _where(missing))


def refuse(source: str, field: str, model: str, item: MissingVisual, why: str) -> InputError:
    """The error for a missing mesh file that cannot be dropped."""
    return InputError(source, field, f"{model}: mesh file {item.name!r} not found: looked for "
                                     f"{_where([item])}; {why}")


def _shortlist(names: Sequence[str], most: int = 6) -> str:
    shown = ", ".join(names[:most])
    return shown if len(names) <= most else f"{shown}, ... ({len(names) - most} more)"


def _where(missing: Sequence[MissingVisual]) -> str:
    found = where([path for item in missing for path in item.looked_at])
    unknown = [item.name for item in missing if not item.looked_at]  # a package:// name of no package here
    if unknown:
        found = " or ".join(filter(None, [found, f"{_shortlist(unknown)} (no ROS package of that name here)"]))
    return found


def where(paths: Sequence[Path]) -> str:
    """The paths looked at, grouped by folder: ``/a/assets/{x.obj, y.obj}``."""
    by_folder: dict[Path, list[str]] = {}
    for path in paths:
        names = by_folder.setdefault(path.parent, [])
        if path.name not in names:
            names.append(path.name)
    parts = []
    for folder, names in by_folder.items():
        parts.append(f"{folder}/{names[0]}" if len(names) == 1 else f"{folder}/{{{_shortlist(names)}}}")
    return " or ".join(parts) if len(parts) <= 3 else f"{' or '.join(parts[:3])} or {len(parts) - 3} other folders"


# ------------------------------------------------------------------------------------------------ MJCF


def mesh_path(spec: mujoco.MjSpec, file: str) -> Path:
    """Where MuJoCo's compiler looks for a mesh ``file`` of ``spec``: the model file's folder, then the
    compiler's ``meshdir`` (either may be absolute), with the path part stripped under ``strippath``."""
    name = Path(file).name if spec.strippath else file
    if Path(name).is_absolute():
        return Path(name)
    meshdir = Path(spec.meshdir or "")
    folder = meshdir if meshdir.is_absolute() else Path(spec.modelfiledir or ".") / meshdir
    return Path(os.path.realpath(folder / name))  # a loop of links stays in the path (Path.resolve raises)


def drop_missing_meshes(spec: mujoco.MjSpec, *, contacts_on: bool, strict: bool, model: str, source: str,
                        field: str) -> list[MissingVisual]:
    """Remove from ``spec`` every mesh asset whose file is missing and the geoms drawn with it, if none of them
    matters to the dynamics (see the module docstring); return what was removed (nothing when every file is
    there).

    Args:
        contacts_on: whether the model the testbed simulates computes contacts.
        strict: refuse any missing mesh file.
        model, source, field: the model's name, the scenario file and the field, for the messages.

    Raises:
        InputError: a missing file under ``strict``, or one whose geoms give mass or take part in contacts,
            naming the path looked for.
    """
    missing = {}
    for mesh in spec.meshes:
        if mesh.file and not (path := mesh_path(spec, mesh.file)).is_file():
            missing[mesh.name] = (mesh, path)
    if not missing:
        return []
    paired = {name for pair in spec.pairs for name in (pair.geomname1, pair.geomname2)}
    users: dict[str, list[mujoco.MjsGeom]] = {name: [] for name in missing}
    for geom in spec.geoms:
        if geom.meshname in missing:
            users[geom.meshname].append(geom)
    dropped = []
    for name, (mesh, path) in missing.items():
        geoms = users[name]
        item = MissingVisual(name=mesh.file, looked_at=(path,), users=tuple(g.parent.name for g in geoms))
        if strict:
            raise refuse(source, field, model, item, "robot.strict_meshes is set")
        for geom in geoms:
            if _gives_mass(spec, geom):
                raise refuse(source, field, model, item, f"geom {_geom_label(geom)} gives its body mass and inertia "
                                                         "(no explicit <inertial>)")
            if (contacts_on and (geom.contype or geom.conaffinity)) or (geom.name and geom.name in paired):
                raise refuse(source, field, model, item, f"geom {_geom_label(geom)} takes part in contacts")
        dropped.append(item)
    for name, (mesh, _) in missing.items():
        for geom in users[name]:
            spec.delete(geom)
        spec.delete(mesh)
    return dropped


def _geom_label(geom: mujoco.MjsGeom) -> str:
    return repr(geom.name) if geom.name else f"of body {geom.parent.name!r} (mesh {geom.meshname!r})"


def _gives_mass(spec: mujoco.MjSpec, geom: mujoco.MjsGeom) -> bool:
    """Whether MuJoCo's compiler takes ``geom`` into its body's mass and inertia."""
    mode = spec.compiler.inertiafromgeom
    body = geom.parent
    if _welded_to_world(body):  # its mass never moves: no joint between it and the world
        return False
    if mode == _INERTIA_FROM_GEOM.mjINERTIAFROMGEOM_FALSE or (
            mode == _INERTIA_FROM_GEOM.mjINERTIAFROMGEOM_AUTO and body.explicitinertial):
        return False
    low, high = spec.compiler.inertiagrouprange
    if not low <= geom.group <= high:
        return False
    mass = geom.mass
    return not (mass == 0 or (mass != mass and geom.density == 0))  # NaN: unset, the density decides


def _welded_to_world(body: mujoco.MjsBody) -> bool:
    while body is not None:
        if body.joints:
            return False
        body = body.parent
    return True
