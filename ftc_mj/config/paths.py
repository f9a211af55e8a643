"""Input files are untrusted paths: what a run reads is a regular file (not a directory, a device, a pipe or
``/proc`` file without an end), read up to a bound, and each refusal says which of these it is."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from ftc_mj.config.errors import InputError


def input_file_problem(path: Path) -> str | None:
    """Why ``path`` cannot be read as an input file ("not found", "is a directory", "is not a regular file
    (a device, a pipe or a socket)"), or None when it is a regular file (symbolic links followed)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "not found"
    except OSError as exc:
        return exc.strerror or str(exc)
    if stat.S_ISDIR(mode):
        return "is a directory"
    if not stat.S_ISREG(mode):
        return "is not a regular file (a device, a pipe or a socket)"
    return None


def read_input_text(path: Path, limit: int, file: str, field: str = "") -> str:
    """The UTF-8 text of the regular file ``path``, of at most ``limit`` bytes; an :class:`InputError` naming
    ``file`` and ``field`` otherwise. The size is checked while reading, not only by ``stat``: a file under
    ``/proc`` says 0 and may have no end."""
    try:
        # Non-blocking: opening a named pipe would otherwise wait for a writer (no effect on a regular file).
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with open(descriptor, "rb") as handle:
            mode = os.fstat(descriptor).st_mode  # of what was opened, not of what the name named before
            if not stat.S_ISREG(mode):
                raise InputError(file, field, "cannot read the file: " + (
                    "is a directory" if stat.S_ISDIR(mode) else "is not a regular file (a device, a pipe or a socket)"))
            data = handle.read(limit + 1)
    except IsADirectoryError:
        raise InputError(file, field, "cannot read the file: is a directory") from None
    except OSError as exc:
        raise InputError(file, field, f"cannot read the file: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise InputError(file, field, f"the file is larger than {limit // 1024} KiB: too large for an input file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(file, field, "cannot read the file: not UTF-8 text") from None
