"""Bounds on what a robot file may cost, checked before MuJoCo or yourdfpy reads it, and the files a model
reads (for the command lines' check that no output replaces an input).

A robot file is untrusted input: a URDF of 100,000 links or an MJCF ``<replicate count="100000">`` would keep
MuJoCo's parser busy for minutes and its model would not fit a run. The bounds are far above any robot arm
or humanoid (a humanoid has about 40 links; MuJoCo Menagerie's largest scenes a few hundred bodies) and each
refusal names its bound:

* :data:`MAX_MODEL_BYTES`: a model file (URDF, MJCF and each MJCF ``<include>``);
* :data:`MAX_LINKS`: a URDF's ``<link>`` and ``<joint>`` elements, each;
* :data:`MAX_BODIES`: an MJCF's bodies, ``<replicate>`` counts multiplied out (nested ones too);
* :data:`MAX_ELEMENTS`: an MJCF's elements, ``<replicate>`` counts multiplied out;
* :data:`MAX_INCLUDES`: an MJCF's ``<include>`` files, all levels;
* :data:`MAX_MESH_BYTES`: a mesh, texture or height-field file a model names.

A file named through a loop of symbolic links is refused with the operating system's words ("too many
levels of symbolic links"), not followed.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

from lxml import etree

from ftc_mj.config.errors import InputError
from ftc_mj.config.paths import input_file_problem

#: The largest model file read [bytes].
MAX_MODEL_BYTES = 32 * 2**20
#: The most ``<link>`` (and, separately, ``<joint>``) elements of a URDF.
MAX_LINKS = 1000
#: The most bodies of an MJCF, replicated ones counted.
MAX_BODIES = 1000
#: The most elements of an MJCF, replicated ones counted.
MAX_ELEMENTS = 200_000
#: The most ``<include>`` files of an MJCF.
MAX_INCLUDES = 100
#: The largest mesh, texture or height-field file a model names [bytes].
MAX_MESH_BYTES = 256 * 2**20

#: MJCF elements whose ``file`` attribute names an asset, and the compiler folder it is looked up in.
_ASSET_FOLDERS = {"mesh": "meshdir", "skin": "meshdir", "texture": "texturedir", "hfield": "assetdir"}


def resolved(path: Path) -> Path:
    """``path`` made absolute with its symbolic links followed, without raising on a loop of links (the loop
    stays in the path, and reading it then fails with ``ELOOP``): ``Path.resolve`` raises ``RuntimeError``
    there on Python 3.11."""
    return Path(os.path.realpath(path))


def check_model_file(path: Path, file: str, field: str) -> None:
    """Refuse a model file of more than :data:`MAX_MODEL_BYTES`."""
    size = _size(path, file, field)
    if size > MAX_MODEL_BYTES:
        raise InputError(file, field, f"{path.name} is {size / 2**20:.0f} MiB, more than the "
                         f"{MAX_MODEL_BYTES // 2**20} MiB a model file may have (MAX_MODEL_BYTES)")


def check_mesh_file(path: Path, file: str, field: str) -> None:
    """Refuse a mesh (texture, height field) file behind a loop of links, or of more than
    :data:`MAX_MESH_BYTES`. A missing file is left to the caller (a missing visual may be dropped)."""
    try:
        size = os.stat(path).st_size
    except FileNotFoundError:
        return
    except OSError as exc:
        raise InputError(file, field, f"{str(path)!r}: {exc.strerror or exc}") from None
    if size > MAX_MESH_BYTES:
        raise InputError(file, field, f"{str(path)!r} is {size / 2**20:.0f} MiB, more than the "
                         f"{MAX_MESH_BYTES // 2**20} MiB a mesh file may have (MAX_MESH_BYTES)")


def _size(path: Path, file: str, field: str) -> int:
    problem = input_file_problem(path)
    if problem is not None:
        raise InputError(file, field, f"{str(path)!r} {problem}")
    return os.stat(path).st_size


def check_urdf_counts(root: etree._Element, file: str) -> None:
    """Refuse a URDF of more than :data:`MAX_LINKS` links or joints (before yourdfpy reads it)."""
    for kind in ("link", "joint"):
        count = sum(1 for _ in root.iterchildren(kind))
        if count > MAX_LINKS:
            raise InputError(file, "<robot>", f"has {count} <{kind}> elements, more than the {MAX_LINKS} a robot "
                             "file may have (MAX_LINKS)")


def _parse(path: Path, file: str, field: str) -> etree._Element | None:
    """An MJCF file's XML, parsed without entities, DTDs or network (MuJoCo parses it again); None when it is
    not well-formed XML (MuJoCo's parser then refuses it at once, in its own words)."""
    check_model_file(path, file, field)
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        return etree.parse(io.BytesIO(path.read_bytes()), parser).getroot()
    except etree.XMLSyntaxError:
        return None
    except OSError as exc:
        raise InputError(file, field, f"{str(path)!r}: {exc.strerror or exc}") from None


def mjcf_files(path: Path, file: str, field: str) -> list[Path]:
    """Check an MJCF file's cost (module docstring) before MuJoCo parses it; return the files it reads (the
    file, its includes, the asset files that exist).

    Raises:
        InputError: a bound exceeded, naming it; an include or asset behind a loop of symbolic links.
    """
    path = resolved(path)
    folder = path.parent
    counts = {"bodies": 0, "elements": 0, "includes": 0}
    folders: dict[str, str] = {}
    found: list[Path] = [path]

    def visit(element: etree._Element | None, multiplicity: int) -> None:
        for child in element if element is not None else ():
            if not isinstance(child.tag, str):  # comments, processing instructions
                continue
            counts["elements"] += multiplicity
            if counts["elements"] > MAX_ELEMENTS:
                raise InputError(file, field, f"{path.name} has more than {MAX_ELEMENTS} elements, replicated "
                                 "ones counted (MAX_ELEMENTS)")
            if child.tag == "body":
                counts["bodies"] += multiplicity
                if counts["bodies"] > MAX_BODIES:
                    raise InputError(file, field, f"{path.name} has more than {MAX_BODIES} bodies, replicated "
                                     "ones counted (MAX_BODIES)")
            if child.tag == "compiler":
                folders.update({key: child.get(key) for key in ("meshdir", "texturedir", "assetdir")
                                if child.get(key)})
            name = child.get("file")
            if child.tag == "include" and name:
                counts["includes"] += 1
                if counts["includes"] > MAX_INCLUDES:
                    raise InputError(file, field, f"{path.name} includes more than {MAX_INCLUDES} files "
                                     "(MAX_INCLUDES)")
                included = resolved(folder / name)
                found.append(included)
                visit(_parse(included, file, field), multiplicity)
                continue
            if name and child.tag in _ASSET_FOLDERS:
                for candidate in _asset_candidates(folder, folders, child.tag, name):
                    check_mesh_file(candidate, file, field)
                    if candidate.is_file():
                        found.append(resolved(candidate))
            count = _replicate_count(child) if child.tag == "replicate" else 1
            visit(child, multiplicity * count)

    visit(_parse(path, file, field), 1)
    return list(dict.fromkeys(found))


def _replicate_count(element: etree._Element) -> int:
    """A ``<replicate>``'s count (1 when it is not a number: MuJoCo's parser then says what is wrong)."""
    try:
        return max(int(element.get("count", "1")), 1)
    except ValueError:
        return 1


def _asset_candidates(folder: Path, folders: dict[str, str], tag: str, name: str) -> list[Path]:
    """Every path an asset's ``file`` may name: under its compiler folder (or ``assetdir``), or the model's."""
    candidates = []
    for key in (_ASSET_FOLDERS[tag], "assetdir"):
        if key in folders:
            candidates.append(folder / folders[key] / name)
    candidates.append(folder / name)
    return list(dict.fromkeys(candidates))
