"""ROS packages on this machine: where ``package://NAME/...`` points.

A ROS package NAME is looked for, in this order,

* among the given folder and the folders above it (a URDF usually lives inside its own package);
* in each folder of ``ROS_PACKAGE_PATH`` (ROS 1: the folder itself when it is called NAME, else ``folder/NAME``);
* in each prefix of ``AMENT_PREFIX_PATH`` (ROS 2: ``prefix/share/NAME``);
* in the install prefixes that Python packages ship inside the environment's site-packages (wheels built with
  cmeel, such as ``example-robot-data``, install ``site-packages/cmeel.prefix/share/NAME``): any folder of a
  site-packages directory that holds ROS 2's package index ``share/ament_index/resource_index/packages/NAME``,
  and ``sys.prefix`` itself.
"""

from __future__ import annotations

import os
import site
import sys
from functools import lru_cache
from pathlib import Path
from urllib.parse import unquote

#: Where a ROS 2 install prefix lists its packages (one empty file per package).
_AMENT_INDEX = Path("share") / "ament_index" / "resource_index" / "packages"


def split_package_uri(uri: str) -> tuple[str, str] | None:
    """``package://NAME/rest`` -> (NAME, rest); None for another kind of name or an incomplete one.

    ``package:///NAME/rest`` (an empty host, as some exporters write) names the same file."""
    if not uri.startswith("package://"):
        return None
    package, _, rest = unquote(uri[len("package://"):]).lstrip("/").partition("/")
    return (package, rest) if package and rest else None


def package_roots(package: str, near: Path | None = None) -> list[Path]:
    """Every folder that may be ROS package ``package``, in lookup order (they need not all exist)."""
    roots = [folder for folder in (near, *near.parents) if folder.name == package] if near is not None else []
    for entry in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        entry_path = Path(entry)
        roots.append(entry_path if entry_path.name == package else entry_path / package)
    prefixes = [Path(p) for p in filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep))]
    prefixes += [prefix for prefix in _python_prefixes() if (prefix / _AMENT_INDEX / package).is_file()]
    roots += [prefix / "share" / package for prefix in prefixes]
    return roots


def package_candidates(uri: str, near: Path | None = None) -> list[Path]:
    """Every path ``package://NAME/rest`` may name, in lookup order (none need exist); [] for another name."""
    parts = split_package_uri(uri)
    if parts is None:
        return []
    package, rest = parts
    return [root / rest for root in package_roots(package, near)]


def resolve_package_uri(uri: str, near: Path | None = None) -> Path | None:
    """The existing file ``package://NAME/rest`` names, or None (see the module's lookup order)."""
    parts = split_package_uri(uri)
    if parts is None:
        return None
    package, rest = parts
    return next((Path(os.path.realpath(path)) for root in package_roots(package, near) if (path := root / rest).is_file()), None)


@lru_cache(maxsize=1)
def _python_prefixes() -> tuple[Path, ...]:
    """Install prefixes inside this Python's site-packages folders (those with a ROS 2 package index), and
    ``sys.prefix``. Listed once per process: installing a package while a run goes on is not expected."""
    folders = [*site.getsitepackages(), site.getusersitepackages(), *sys.path]
    prefixes: list[Path] = []
    for folder in dict.fromkeys(Path(f) for f in folders if f):
        try:
            children = [child for child in folder.iterdir() if (child / _AMENT_INDEX).is_dir()]
        except OSError:  # not a folder, or not readable: nothing installed there
            continue
        prefixes += sorted(children)
    return (*prefixes, Path(sys.prefix))
