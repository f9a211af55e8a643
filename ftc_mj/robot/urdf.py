"""URDF robots: read and check a URDF file, then build the testbed's MuJoCo model from it.

A URDF is untrusted input. It is parsed strictly (no DTD, no entities), read with yourdfpy and checked element
by element; any problem raises :class:`~ftc_mj.config.errors.InputError` naming the URDF file and the element
(``joint 'elbow'``, ``link 'forearm'``, ``link 'forearm': visual 1: mesh``). Then MuJoCo's own URDF compiler
builds an ``MjSpec`` from it (visual geometry kept, mesh paths resolved here), which is edited into the
testbed's conventions, those of ``models/*.xml``:

* locked joints removed, their angle baked into the child body's frame (exact, no constraint); a mimic joint
  must be locked, and is locked by itself where its leader is (at ``multiplier * leader + offset``); a
  ``<mimic>`` on a fixed joint constrains nothing and is ignored;
* per free joint, in kinematic order, a torque motor and the joint sensors (:mod:`ftc_mj.robot.editing`);
  optional armature (URDF has none);
* contacts disabled (``<collision>`` elements are not used), inertia only from ``<inertial>``,
  ``implicitfast`` integrator, 1 ms timestep (the scenario sets its own);
* visual meshes in a format MuJoCo does not read (COLLADA ``.dae`` as ROS packages ship them, PLY, glTF)
  converted once into cached OBJ parts, one per colour (:mod:`ftc_mj.robot.meshes`).

Kinematic order is depth first from the root link, children in the order their joints appear in the file:
the order of ``qpos`` in the compiled model.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import unquote
import mujoco
import numpy as np
from lxml import etree

from ftc_mj.robot import cost, editing, meshes as mesh_files, visuals
from ftc_mj.robot.meshes import CONVERTED_FORMATS, MUJOCO_FORMATS, MeshConversionError, MeshPart
from ftc_mj.robot.packages import package_candidates, resolve_package_uri
from ftc_mj.robot.visuals import MissingVisual
from ftc_mj.config.errors import InputError

if TYPE_CHECKING:  # imported when a URDF is read: it takes about 1 s (trimesh), which MJCF runs need not pay
    import yourdfpy

#: URDF joint types the testbed simulates (a fixed-base arm); floating and planar joints are refused.
SUPPORTED_JOINTS = ("revolute", "continuous", "prismatic", "fixed")
#: Mesh formats a URDF may use: those MuJoCo reads, and those converted for it.
MESH_FORMATS = MUJOCO_FORMATS + CONVERTED_FORMATS
# Relative tolerance of the inertia checks (A + B >= C, eigenvalues >= 0): files round their numbers.
_INERTIA_TOLERANCE = 1e-9


@dataclass(frozen=True)
class UrdfRobot:
    """A checked URDF: its parse, and its joints in kinematic order."""

    path: Path
    urdf: yourdfpy.URDF
    #: Revolute, continuous and prismatic joints, in kinematic order.
    movable: tuple[str, ...]
    #: The files MuJoCo reads for every <mesh> element used (the file itself, or its converted parts, each
    #: with the colour the file gives it), by its filename as written.
    meshes: Mapping[str, tuple[MeshPart, ...]]
    #: The parsed XML, for MuJoCo's URDF compiler.
    xml: etree._Element
    #: Mesh files that are not there, by filename as written: their visuals are dropped
    #: (:mod:`ftc_mj.robot.visuals`; a link's mass is its <inertial>, and contacts are off).
    missing: Mapping[str, MissingVisual] = dataclass_field(default_factory=dict)

    def joint(self, name: str) -> yourdfpy.Joint:
        return self.urdf.joint_map[name]


def is_urdf(path: Path) -> bool:
    """A robot model file is read as URDF when its name ends in ``.urdf`` (any case), else as MJCF."""
    return path.suffix.lower() == ".urdf"


# ------------------------------------------------------------------------------------------- reading


def read_urdf(path: Path, strict_meshes: bool = True) -> UrdfRobot:
    """Parse and check a URDF file.

    Args:
        strict_meshes: refuse a mesh file that is missing; False: note it in :attr:`UrdfRobot.missing` (its
            visuals are then left out of the model).

    Raises:
        InputError: naming the file and the element, for a malformed file, an unsupported or inconsistent
            joint, a moving link without a physical inertial, or a mesh that cannot be read (or found, under
            ``strict_meshes``; the message lists the paths looked at).
    """
    path = Path(path)
    file = str(path)
    root = _parse_xml(path)
    _check_xml(file, root)
    import yourdfpy

    try:
        # yourdfpy's own loader falls back to a recovering parser on broken XML; it is only given a tree
        # that parsed strictly.
        urdf = yourdfpy.URDF.load(io.BytesIO(etree.tostring(root)), build_scene_graph=False, load_meshes=False,
                                  mesh_dir=str(path.parent))
    except Exception as exc:  # noqa: BLE001 - yourdfpy raises KeyError, ValueError, IndexError... on bad values
        raise InputError(file, "", f"yourdfpy cannot read it: {type(exc).__name__}: {exc}") from None
    movable = _check_tree(file, urdf)
    for joint in urdf.robot.joints:
        _check_joint(file, joint)
    moving_links = {joint.child for joint in urdf.robot.joints if joint.type != "fixed"}
    meshes: dict[str, tuple[MeshPart, ...]] = {}
    missing: dict[str, MissingVisual] = {}
    for link in urdf.robot.links:
        _check_inertial(file, link, link.name in moving_links)
        for index, geometry in enumerate(_drawn_geometries(link)):
            element = f"link {link.name!r}: {geometry.label} {index + 1}"
            _check_geometry(file, element, geometry.geometry, path.parent, meshes, missing, strict_meshes,
                            link.name)
    if not urdf.validate(validation_fn=lambda errors: not errors):  # anything yourdfpy knows that we did not
        raise InputError(file, "", f"invalid URDF: {urdf.errors[0]}")
    return UrdfRobot(path=path, urdf=urdf, movable=tuple(movable), meshes=meshes, xml=root, missing=missing)


def _parse_xml(path: Path) -> etree._Element:
    file = str(path)
    cost.check_model_file(path, file, "")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(file, "", f"cannot read the file: {exc.strerror or exc}") from None
    # No entity expansion and no network: a URDF needs neither, and both are ways to attack a parser.
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        tree = etree.parse(io.BytesIO(data), parser)
    except etree.XMLSyntaxError as exc:
        line = f"line {exc.lineno}" if exc.lineno else ""
        raise InputError(file, line, f"malformed XML: {exc.msg}") from None
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise InputError(file, "DOCTYPE", "a URDF file may not declare a DTD")
    root = tree.getroot()
    if root.tag != "robot":
        raise InputError(file, f"<{root.tag}>", "the root element of a URDF file must be <robot>")
    if not root.get("name"):
        raise InputError(file, "<robot>", "has no name attribute")
    cost.check_urdf_counts(root, file)
    return root


#: Numeric attributes of URDF elements and how many numbers each holds.
_NUMBERS = {"xyz": 3, "rpy": 3, "size": 3, "scale": 3, "rgba": 4, "value": 1, "radius": 1, "length": 1,
            "ixx": 1, "ixy": 1, "ixz": 1, "iyy": 1, "iyz": 1, "izz": 1, "lower": 1, "upper": 1, "effort": 1,
            "velocity": 1, "damping": 1, "friction": 1, "multiplier": 1, "offset": 1}
_NUMBER_WORDS = {1: "a number", 3: "three numbers", 4: "four numbers"}


def _check_xml(file: str, root: etree._Element) -> None:
    """What yourdfpy would fail on without saying where: names, joint parts, geometry, numbers."""
    for kind in ("link", "joint", "material"):
        for element in root.findall(kind):
            name = element.get("name")
            where = f"{kind} {name!r}" if name else f"<{kind}> (line {element.sourceline})"
            if not name and kind != "material":
                raise InputError(file, where, "has no name attribute")
            if kind == "joint":
                if not element.get("type"):
                    raise InputError(file, where, "has no type attribute")
                for part in ("parent", "child"):
                    if element.find(part) is None or not element.find(part).get("link"):
                        raise InputError(file, where, f"needs a <{part} link=...>")
            for shape in element.findall("visual") + element.findall("collision"):
                if shape.find("geometry") is None:
                    raise InputError(file, f"{where}: <{shape.tag}> (line {shape.sourceline})", "has no <geometry>")
            for sub in element.iter():
                for attribute in set(_NUMBERS) & set(sub.attrib):
                    text = sub.get(attribute)
                    try:
                        count = len([float(v) for v in text.split()])
                    except ValueError:
                        count = -1
                    if count != _NUMBERS[attribute]:
                        raise InputError(file, f"{where}: <{sub.tag} {attribute}> (line {sub.sourceline})",
                                         f"{text!r} is not {_NUMBER_WORDS[_NUMBERS[attribute]]}")


def _check_tree(file: str, urdf: yourdfpy.URDF) -> list[str]:
    """Names unique, joints between existing links, one root, a tree; the movable joints in kinematic order."""
    links = [link.name for link in urdf.robot.links]
    if not links:
        raise InputError(file, "<robot>", "has no <link> elements (a robot is a tree of links joined by joints)")
    for kind, names in (("link", links), ("joint", [joint.name for joint in urdf.robot.joints])):
        for name in names:
            if not name:
                raise InputError(file, f"<{kind}>", "has no name attribute")
            if names.count(name) > 1:
                raise InputError(file, f"{kind} {name!r}", f"the name is used by {names.count(name)} {kind}s")
    children: dict[str, list] = {name: [] for name in links}
    parent_joint: dict[str, str] = {}
    for joint in urdf.robot.joints:
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in children:
                raise InputError(file, f"joint {joint.name!r}", f"its {role} link {link!r} does not exist")
        if joint.child in parent_joint:
            raise InputError(file, f"joint {joint.name!r}",
                             f"link {joint.child!r} is already the child of joint {parent_joint[joint.child]!r} "
                             "(closed kinematic loops are not supported: a link has one parent joint)")
        parent_joint[joint.child] = joint.name
        children[joint.parent].append(joint)
    roots = [name for name in links if name not in parent_joint]
    if len(roots) != 1:
        problem = ("no root link (the joints form a closed loop, which is not supported)" if not roots
                   else f"{len(roots)} root links: {roots}")
        raise InputError(file, "<robot>", f"must be one tree of links; found {problem}")
    # Depth first, children in the order of their joints in the file: MuJoCo's body (and so qpos) order.
    order, seen, stack = [], {roots[0]}, list(reversed(children[roots[0]]))
    while stack:
        joint = stack.pop()
        if joint.type != "fixed":
            order.append(joint.name)
        seen.add(joint.child)
        stack.extend(reversed(children[joint.child]))
    if len(seen) != len(links):
        loose = next(name for name in links if name not in seen)
        raise InputError(file, f"link {loose!r}", "is not connected to the root link (the joints form a closed "
                                                  "loop, which is not supported)")
    for joint in urdf.robot.joints:
        # A fixed joint's mimic constrains nothing (exporters write them for a gripper's rigid parts).
        leader = joint.mimic.joint if joint.mimic is not None and joint.type != "fixed" else None
        if leader is not None and (leader not in urdf.joint_map or urdf.joint_map[leader].type == "fixed"
                                   or leader == joint.name):
            raise InputError(file, f"joint {joint.name!r}: mimic", f"joint {leader!r} is not another movable joint")
    return order


def _finite(value: float | None) -> bool:
    return value is not None and math.isfinite(value)


def _check_joint(file: str, joint: yourdfpy.Joint) -> None:
    element = f"joint {joint.name!r}"
    if joint.type in ("floating", "planar"):
        raise InputError(file, element, f"type {joint.type!r} is not supported: a {joint.type} joint makes a "
                                        "mobile base, and the testbed simulates fixed-base arms (make it fixed)")
    if joint.type not in SUPPORTED_JOINTS:
        raise InputError(file, element, f"type {joint.type!r} is not supported (a fixed-base arm: "
                                        f"{', '.join(SUPPORTED_JOINTS)})")
    if joint.mimic is not None:
        for attribute in ("multiplier", "offset"):
            value = getattr(joint.mimic, attribute)
            if value is not None and not _finite(value):
                raise InputError(file, f"{element}: mimic", f"{attribute} must be a number, got {value}")
    if joint.type == "fixed":
        return
    axis = np.asarray(joint.axis, dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-9:
        raise InputError(file, f"{element}: axis",
                         f"{axis.tolist()} is not a direction (three finite numbers, not all 0)")
    limit = joint.limit
    if limit is None:
        if joint.type != "continuous":
            raise InputError(file, element, f"a {joint.type} joint needs a <limit> with lower and upper")
        return
    for attribute in ("effort", "velocity"):
        value = getattr(limit, attribute)
        # URDF requires both; 0 is what exporters write for "unknown" and is read as "no limit".
        if not _finite(value) or value < 0:
            raise InputError(file, f"{element}: limit", f"{attribute} must be a number >= 0, got {value}")
    if joint.type != "continuous":
        if not (_finite(limit.lower) and _finite(limit.upper)) or limit.lower > limit.upper:
            raise InputError(file, f"{element}: limit", f"needs finite lower <= upper, got lower={limit.lower}, "
                                                        f"upper={limit.upper}")


def _check_inertial(file: str, link: yourdfpy.Link, moving: bool) -> None:
    element = f"link {link.name!r}"
    inertial = link.inertial
    if inertial is None:
        if moving:
            raise InputError(file, element, "moves (it is the child of a movable joint) but has no <inertial>")
        return
    mass = inertial.mass
    if not _finite(mass) or mass < 0 or (moving and mass <= 0):
        raise InputError(file, f"{element}: inertial", f"mass must be a number {'> 0' if moving else '>= 0'}, "
                                                       f"got {mass}")
    inertia = np.asarray(inertial.inertia, dtype=float)
    if not np.all(np.isfinite(inertia)):
        raise InputError(file, f"{element}: inertial", "inertia has a value that is not a finite number")
    moments = np.linalg.eigvalsh(inertia)
    scale = _INERTIA_TOLERANCE * max(float(moments.max()), 1e-12)
    a, b, c = moments
    if a < -scale or a + b < c - scale:
        raise InputError(file, f"{element}: inertial", f"inertia is not physical: principal moments {a:.6g}, "
                                                       f"{b:.6g}, {c:.6g} (need all >= 0 and A + B >= C)")


@dataclass(frozen=True)
class _Drawn:
    label: str  # "visual" or "collision"
    geometry: yourdfpy.Geometry


def _drawn_geometries(link: yourdfpy.Link) -> list[_Drawn]:
    """What the 3-D view shows of a link: its visuals, or its collision shapes if it has no visual."""
    if link.visuals:
        return [_Drawn("visual", visual.geometry) for visual in link.visuals]
    return [_Drawn("collision", collision.geometry) for collision in link.collisions]


def _check_geometry(file: str, element: str, geometry: yourdfpy.Geometry | None, base: Path,
                    meshes: dict[str, tuple[MeshPart, ...]], missing: dict[str, MissingVisual],
                    strict_meshes: bool, link: str) -> None:
    shapes = [s for s in (geometry.box, geometry.cylinder, geometry.sphere, geometry.mesh) if s is not None] \
        if geometry is not None else []
    if len(shapes) != 1:
        raise InputError(file, element, "needs exactly one of <box>, <cylinder>, <sphere>, <mesh> in <geometry>")
    if geometry.mesh is None:
        sizes = ([*geometry.box.size] if geometry.box is not None else
                 [geometry.cylinder.radius, geometry.cylinder.length] if geometry.cylinder is not None else
                 [geometry.sphere.radius])
        if not all(_finite(v) and v > 0 for v in sizes):
            raise InputError(file, element, f"sizes must be numbers > 0, got {[float(v) for v in sizes]}")
        return
    filename = geometry.mesh.filename or ""
    for candidate in mesh_candidates(filename, base):
        cost.check_mesh_file(candidate, file, f"{element}: mesh")
    target = resolve_mesh(filename, base)
    if target is None:
        looked_at = tuple(mesh_candidates(filename, base))
        if strict_meshes or not (looked_at or filename.startswith("package://")):
            where = (f"looked for {visuals.where(looked_at)}" if looked_at else
                     "no ROS package of that name was found" if filename.startswith("package://") else
                     "not a file name")
            raise InputError(file, f"{element}: mesh", f"file {filename!r} not found: {where} (relative names are "
                                                       "relative to the URDF file; package://NAME/... is looked up "
                                                       "in the folders above it, ROS_PACKAGE_PATH, "
                                                       "AMENT_PREFIX_PATH and the ROS packages installed with "
                                                       "Python packages)")
        known = missing.get(filename)
        users = (known.users if known is not None else ()) + (link,)
        missing[filename] = MissingVisual(name=filename, looked_at=looked_at, users=users)
        return
    scale = geometry.mesh.scale
    if scale is not None and not all(_finite(v) and v != 0 for v in np.atleast_1d(scale)):
        raise InputError(file, f"{element}: mesh", f"scale must be non-zero numbers, got {scale}")
    suffix = target.suffix.lower()
    if suffix in MUJOCO_FORMATS:
        meshes[filename] = (MeshPart(target, None),)
    elif suffix in CONVERTED_FORMATS:
        if filename not in meshes:
            try:
                meshes[filename] = tuple(mesh_files.convert(target))
            except (MeshConversionError, OSError) as exc:
                raise InputError(file, f"{element}: mesh", f"{filename!r}: MuJoCo reads {', '.join(MUJOCO_FORMATS)} "
                                                           f"meshes, and this {suffix} file cannot be converted: "
                                                           f"{exc}") from None
    else:
        raise InputError(file, f"{element}: mesh", f"{filename!r}: MuJoCo reads {', '.join(MUJOCO_FORMATS)} meshes, "
                                                   f"and {', '.join(CONVERTED_FORMATS)} are converted; not "
                                                   f"{target.suffix or 'files without an extension'}")


def mesh_candidates(filename: str, base: Path) -> list[Path]:
    """Every path a URDF mesh ``filename`` may name, in the lookup order of :func:`resolve_mesh`."""
    if filename.startswith("package://"):
        return package_candidates(filename, base)
    name = unquote(filename[len("file://"):]) if filename.startswith("file://") else filename
    return [cost.resolved(base / name)] if name and "://" not in name else []


def files(path: Path) -> list[Path]:
    """The files a URDF reads: the file and the mesh files it names that exist."""
    root = _parse_xml(path)
    found = [cost.resolved(path)]
    for mesh in root.iter("mesh"):
        target = resolve_mesh(mesh.get("filename") or "", path.parent)
        if target is not None:
            found.append(target)
    return list(dict.fromkeys(found))


def resolve_mesh(filename: str, base: Path) -> Path | None:
    """The existing file a URDF mesh ``filename`` names, or None.

    Plain and ``file://`` names are relative to ``base`` (the URDF's folder) unless absolute.
    ``package://NAME/rest`` is looked up as :mod:`ftc_mj.robot.packages` says (the folders above ``base``,
    ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, ROS packages installed with Python packages).
    """
    if filename.startswith("package://"):
        return resolve_package_uri(filename, base)
    name = unquote(filename[len("file://"):]) if filename.startswith("file://") else filename
    candidate = base / name if name and "://" not in name else None
    return cost.resolved(candidate) if candidate is not None and candidate.is_file() else None


# ------------------------------------------------------------------------------------------ building


def load_model(
    path: Path,
    *,
    joints: Sequence[str] | None = None,
    lock: Mapping[str, float] | None = None,
    torque_limits: float | Sequence[float] | str | None = None,
    armature: float | Sequence[float] | None = None,
    strict_meshes: bool = False,
    source: str,
    field: str = "robot",
) -> mujoco.MjModel:
    """The testbed's MuJoCo model of a URDF robot.

    Args:
        path: the URDF file.
        joints: the joints to control, in kinematic order; the other movable joints are locked (at their
            ``lock`` value, else at 0, or at the limit nearest 0 with a warning where 0 is outside the joint's
            limits). Default: every movable joint not locked.
        lock: joints to lock, by name, at an angle [rad] (a position [m] for a prismatic joint). A mimic joint
            whose leader is locked is locked with it, at ``multiplier * leader + offset``.
        torque_limits: |torque| limit of the free joints' motors [N m or N], one value or one per free joint;
            replaces the URDF's effort limits. Without it (or with ``"model"``), a joint's effort limit (when > 0) is its torque
            limit and a joint without one is unlimited.
        armature: reflected rotor inertia of the free joints [kg m^2], one value or one per free joint
            (URDF cannot express it).
        strict_meshes: refuse a missing mesh file; default: its visuals are dropped, with one warning line
            (the dynamics never depend on them: mass from <inertial>, contacts off).
        source, field: the file and field path the options come from (a scenario's ``robot``), for errors.

    Raises:
        InputError: for a problem in the URDF (naming it and the element) or in the options (naming
            ``source`` and the option's field).
    """
    robot = read_urdf(path, strict_meshes=strict_meshes)
    lock = dict(lock or {})
    if joints is not None:
        lock.update(_hold_the_others(robot, joints, lock, source, field))
    lock = _with_mimic_joints(robot, lock, source, field)
    free = _check_lock(robot, lock, source, field)
    limits = _torque_limits(robot, free, None if torque_limits == "model" else torque_limits, source, field)
    armatures = editing.per_joint(armature, free, source, f"{field}.armature")

    spec = _compile_urdf(robot)
    editing.lock_joints(spec, _compile(spec, robot.path), lock)
    if armatures is not None:
        for name, value in zip(free, armatures):
            spec.joint(name).armature = value
    editing.add_motors_and_sensors(spec, free, limits)
    editing.disable_contacts(spec)  # visual only: contacts are off in this testbed
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST  # as models/*.xml (see models/README.md)
    spec.option.timestep = 0.001
    # URDF semantics: a link's mass is its <inertial>, never its geometry.
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    model = _compile(spec, robot.path)
    compiled = [model.joint(i).name for i in range(model.njnt)]
    if compiled != free:  # the actuators, sensors and scenario vectors assume this order
        raise RuntimeError(f"{robot.path}: MuJoCo ordered the joints {compiled}, expected {free}")
    visuals.warn_dropped(source, f"{field}.model", robot.path.name, list(robot.missing.values()))
    return model


def _hold_the_others(robot: UrdfRobot, joints: Sequence[str], lock: Mapping[str, float], source: str,
                     field: str) -> dict[str, float]:
    """Check the controlled ``joints``; the movable joints neither controlled, locked nor mimic joints are held
    at 0, or at their limit nearest 0 where 0 is outside their limits (one warning line names them: a
    humanoid's arm whose elbow cannot straighten)."""
    name_of_file = robot.path.name
    for k, name in enumerate(joints):
        if name not in robot.movable:
            raise InputError(source, f"{field}.joints.{k}", f"{name_of_file} has no movable joint {name!r} (movable "
                                                            f"joints: {', '.join(robot.movable)})")
        if name in lock:
            raise InputError(source, f"{field}.joints.{k}", f"joint {name!r} is also in {field}.lock")
    in_order = [name for name in robot.movable if name in joints]
    if list(joints) != in_order or len(set(joints)) != len(joints):
        raise InputError(source, f"{field}.joints", f"must name each joint once, in kinematic order (the order of "
                                                    f"qpos): {in_order}")
    held, moved = {}, []
    for name in robot.movable:
        if name not in joints and name not in lock and robot.joint(name).mimic is None:
            limit = robot.joint(name).limit
            value = 0.0
            if robot.joint(name).type != "continuous" and limit is not None and not limit.lower <= 0.0 <= limit.upper:
                value = float(min(max(0.0, limit.lower), limit.upper))  # the limit nearest 0
                moved.append(f"{name} at {value:g} (limits [{limit.lower:g}, {limit.upper:g}])")
            held[name] = value
    if moved:
        visuals.LOGGER.warning("warning: %s: %s.lock: %d joint(s) not in %s.joints are locked at their limit "
                               "nearest 0, which is outside their limits: %s (%s.lock sets another value)",
                               source, field, len(moved), field, "; ".join(moved), field)
    return held


def _with_mimic_joints(robot: UrdfRobot, lock: dict[str, float], source: str, field: str) -> dict[str, float]:
    """``lock`` with every mimic joint whose leader is locked, at the value the mimic gives; a mimic joint
    given its own value must agree with it. A mimic joint left free is refused: the testbed drives every free
    joint with its own motor, and a mimic joint has none of its own."""
    name_of_file = robot.path.name
    # A fixed joint that carries a <mimic> follows nothing: it has no value to lock.
    followers = {joint.name: joint for joint in robot.urdf.robot.joints
                 if joint.mimic is not None and joint.type != "fixed"}
    # Chains (a mimic of a mimic) resolve in as many passes as they are long.
    for _ in range(len(followers)):
        for name, joint in followers.items():
            leader, mimic = joint.mimic.joint, joint.mimic
            if leader not in lock:
                continue
            value = (1.0 if mimic.multiplier is None else mimic.multiplier) * lock[leader] + (mimic.offset or 0.0)
            if name not in lock:
                lock[name] = value
            elif not math.isclose(lock[name], value, rel_tol=1e-9, abs_tol=1e-12):
                raise InputError(source, f"{field}.lock.{name}",
                                 f"{lock[name]} disagrees with the mimic of {name_of_file}: joint {name!r} follows "
                                 f"{leader!r}, so it is at {value:.12g} (leave it out to follow its leader)")
    for name, joint in followers.items():
        if name not in lock or joint.mimic.joint not in lock:
            raise InputError(source, f"{field}.lock", f"joint {name!r} of {name_of_file} mimics {joint.mimic.joint!r}: "
                                                      f"lock {joint.mimic.joint!r} (the mimic joint follows it) or "
                                                      f"{name!r} (a mimic joint has no motor of its own)")
    return lock


def _check_lock(robot: UrdfRobot, lock: Mapping[str, float], source: str, field: str) -> list[str]:
    """Check the joints to lock; return the free joints in kinematic order."""
    name_of_file = robot.path.name
    for name, value in lock.items():
        element = f"{field}.lock.{name}"
        if name not in robot.urdf.joint_map:
            raise InputError(source, element, f"{name_of_file} has no joint {name!r} (movable joints: "
                                              f"{', '.join(robot.movable) or 'none'})")
        joint = robot.joint(name)
        if joint.type == "fixed":
            raise InputError(source, element, f"joint {name!r} of {name_of_file} is fixed: there is nothing to lock")
        if joint.type != "continuous" and not joint.limit.lower <= value <= joint.limit.upper:
            raise InputError(source, element, f"{value} is outside the limits of joint {name!r} "
                                              f"[{joint.limit.lower}, {joint.limit.upper}]")
    free = [name for name in robot.movable if name not in lock]
    if not free:
        raise InputError(source, f"{field}.lock", f"locks every movable joint of {name_of_file}: nothing to control")
    return free


def _torque_limits(robot: UrdfRobot, free: list[str], torque_limits: float | Sequence[float] | None, source: str,
                   field: str) -> list[float | None]:
    given = editing.per_joint(torque_limits, free, source, f"{field}.torque_limits")
    if given is not None:
        return list(given)
    efforts = [robot.joint(name).limit.effort if robot.joint(name).limit is not None else None for name in free]
    return [effort if effort else None for effort in efforts]  # effort 0: not given (exporters' "unknown")


def _compile_urdf(robot: UrdfRobot) -> mujoco.MjSpec:
    """MuJoCo's URDF compiler on the checked file: visuals kept, every mesh as an absolute path (a converted
    mesh as one visual per part, coloured as its file colours it unless the URDF gives a material)."""
    root = etree.fromstring(etree.tostring(robot.xml))  # a copy to edit
    for link in root.findall("link"):
        has_visual = link.find("visual") is not None
        for collision in link.findall("collision"):
            if has_visual:
                link.remove(collision)  # contacts are off: collision shapes serve nothing
            else:
                collision.tag = "visual"  # drawn in its place, as read_urdf checked it
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is not None and mesh.get("filename", "") in robot.missing:
                link.remove(visual)  # drawn with a file that is not there (read_urdf noted it)
            elif mesh is not None:
                _split_mesh_visual(link, visual, robot.meshes[mesh.get("filename", "")])
    geom_names: set[str | None] = set()
    for visual in root.findall("link/visual"):
        name = visual.get("name")
        if name is not None and (not name or name in geom_names):
            del visual.attrib["name"]  # MuJoCo would warn on stdout and drop it anyway
        geom_names.add(name)
    # MuJoCo's URDF parser does not read <mimic>; the mimic joints are locked (or refused) here.
    for mimic in root.findall("joint/mimic"):
        mimic.getparent().remove(mimic)
    extension = root.find("mujoco")
    if extension is None:
        extension = etree.Element("mujoco")
        root.insert(0, extension)
    compiler = extension.find("compiler")
    if compiler is None:
        compiler = etree.SubElement(extension, "compiler")
    # MuJoCo's URDF defaults drop visual geoms, merge bodies joined by fixed joints and strip mesh paths.
    compiler.attrib.update({"discardvisual": "false", "fusestatic": "false", "strippath": "false"})
    try:
        spec = mujoco.MjSpec.from_string(etree.tostring(root, encoding="unicode"))
    except ValueError as exc:
        raise InputError(str(robot.path), "", f"MuJoCo cannot read it: {_first_lines(exc)}") from None
    for mesh in spec.meshes:  # drawn only (mass from <inertial>): a flat mesh, a logo or a plate, is fine
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    return spec


def _split_mesh_visual(link: etree._Element, visual: etree._Element, parts: Sequence[MeshPart]) -> None:
    """Point ``visual`` at its mesh file, or replace it by one visual per converted part. A part's colour is
    used where the URDF gives the visual no material colour of its own."""
    named = {m.get("name") for m in link.getparent().findall("material") if m.find("color") is not None}
    own_colour = any(m.find("color") is not None or m.get("name") in named for m in visual.findall("material"))
    position = list(link).index(visual)
    for k, part in enumerate(parts):
        copy = visual if k == 0 else etree.fromstring(etree.tostring(visual))
        copy.find("geometry/mesh").set("filename", str(part.path))
        if k > 0:
            if copy.get("name"):
                copy.set("name", f"{copy.get('name')}_{k}")
            link.insert(position + k, copy)
        if part.rgba is not None and not own_colour:
            for material in copy.findall("material"):
                copy.remove(material)
            rgba = " ".join(f"{c:g}" for c in part.rgba)
            material = etree.SubElement(copy, "material", name=f"mesh_rgba_{rgba.replace(' ', '_')}")
            etree.SubElement(material, "color", rgba=rgba)


def _first_lines(exc: Exception) -> str:
    """MuJoCo's error, its element included, on one line."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    return "; ".join(lines[:2]).removeprefix("Error: ") or "unknown error"


def _compile(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        raise InputError(str(path), "", f"MuJoCo cannot compile it: {_first_lines(exc)}") from None
