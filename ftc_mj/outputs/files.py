"""Files that are whole or absent: every file the package writes (recordings, JSON documents, Parquet tables,
YAML, markers) goes through :func:`atomic_path` or :func:`write_atomic`.

A file is written under a hidden temporary name beside its target (same folder, so the same file system),
flushed to disk, then renamed onto the target in one step (``os.replace`` is atomic on POSIX and Windows). A
reader, a concurrent worker or an interrupted run therefore sees the old file, the new one or none, never half
of one; on any error the temporary is removed and the error re-raised. Temporaries end in :data:`TEMPORARY`,
so a folder scan (``*.parquet``) never picks up a killed writer's leftover. The rename never replaces what is
not a regular file (a device node, a pipe): an ``OSError`` instead.

:func:`output_problem` is the check the command lines make of every output path before any work.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pyarrow as pa

#: The suffix of a temporary file.
TEMPORARY = ".tmp"


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path to write ``path``'s content to (for writers that open the file themselves, as Rerun
    does); moved onto ``path`` when the block ends without an error, removed when it raises. Creates the
    parent folders."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # pid and a random part: several processes and several writers in one process never share a temporary.
    temporary = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}{TEMPORARY}")
    try:
        yield temporary
        _replaceable(path)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def _replaceable(path: Path) -> None:
    """Raise unless ``path`` is absent, a regular file or a symbolic link (which the rename replaces, not what
    it names): a rename onto a device node would replace the device."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if not (stat.S_ISREG(mode) or stat.S_ISLNK(mode)):
        raise OSError(errno.EEXIST, "exists and is not a regular file", str(path))


def write_atomic(path: Path, content: bytes) -> None:
    """Write ``content`` to ``path`` so that the file is whole or absent (flushed to disk before the rename)."""
    with atomic_path(path) as temporary:
        with open(temporary, "wb") as handle:
            handle.write(content)
            handle.flush()
            os.fsync(handle.fileno())


def parquet_bytes(table: pa.Table) -> bytes:
    """A table as the bytes of a Parquet file, for :func:`write_atomic`."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


#: File systems whose files are the kernel's, not data (``/proc``, ``/sys``, ``/dev``, ...): never an output.
PSEUDO_FILE_SYSTEMS = frozenset({
    "proc", "sysfs", "devtmpfs", "devpts", "cgroup", "cgroup2", "debugfs", "tracefs", "securityfs", "configfs",
    "pstore", "bpf", "efivarfs", "mqueue", "binfmt_misc", "fusectl", "hugetlbfs", "autofs", "rpc_pipefs",
    "nsfs",
})


def output_problem(path: Path, *, directory: bool = False, inputs: Iterable[Path] = ()) -> str | None:
    """What keeps ``path`` from being written as an output (a file, or with ``directory`` a folder that will
    hold files), or None: checked before any work, so that a run never ends in an unwritable output.

    Refused: an existing target that is not a regular file (a directory, a device, a pipe) or, for a
    folder, not a folder; a target that is one of ``inputs`` (the run's scenario, its bases, its model) or,
    for a folder, holds one of them, or lies inside an input that is a folder (a rosbag2 bag); a nearest
    existing folder that is not a folder, is not writable, or is on a pseudo file system
    (:data:`PSEUDO_FILE_SYSTEMS`). Paths are compared with their symbolic links followed."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        return f"{str(path)!r}: {exc.strerror or exc}"
    if mode is not None:
        if directory and not stat.S_ISDIR(mode):
            return f"{str(path)!r} is not a directory"
        if not directory:
            if stat.S_ISDIR(mode):
                return f"{str(path)!r} is a directory"
            if not stat.S_ISREG(mode):
                return f"{str(path)!r} is not a regular file (a device, a pipe or a socket): not replaced"
    target = Path(os.path.realpath(path))
    for source in inputs:
        source = Path(os.path.realpath(source))
        if source == target:
            return f"{str(path)!r} is an input of this run ({source}): not overwritten"
        if directory and target in source.parents:
            return f"{str(path)!r} holds an input of this run ({source})"
        if source in target.parents and os.path.isdir(source):  # a log that is a folder (a rosbag2 bag)
            return f"{str(path)!r} is inside an input folder of this run ({source})"
    folder = target if directory else target.parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir():
        return f"{str(folder)!r} is not a directory"
    kind = _file_system(folder)
    if kind in PSEUDO_FILE_SYSTEMS:
        return f"{str(folder)!r} is on the kernel's {kind} file system, not a place for files"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"{str(folder)!r} is not writable"
    return None


def _file_system(folder: Path) -> str | None:
    """The type of the file system ``folder`` (a resolved path) is on, from the mount table; None when the
    table cannot be read (not Linux)."""
    try:
        lines = Path("/proc/self/mounts").read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    best, kind = "", None
    text = str(folder)
    for line in lines:
        fields = line.split()
        if len(fields) < 3:
            continue
        # Mount points escape spaces and other bytes as octal (\040).
        point = re.sub(r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)), fields[1])
        inside = text == point or text.startswith(point.rstrip("/") + "/")
        if inside and len(point) >= len(best):
            best, kind = point, fields[2]
    return kind


def check_output(path: Path, file: str, option: str, *, directory: bool = False, inputs: Iterable[Path] = ()) -> None:
    """:func:`output_problem` as the one-line :class:`~ftc_mj.config.errors.InputError` ``FILE: OPTION:
    PROBLEM`` (``file``: the input the command was given)."""
    from ftc_mj.config.errors import InputError

    problem = output_problem(path, directory=directory, inputs=inputs)
    if problem is not None:
        raise InputError(file, option, problem)
