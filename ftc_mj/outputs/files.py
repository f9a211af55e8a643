"""Files that are whole or absent: every file the package writes (recordings, JSON documents, Parquet tables,
YAML, markers) goes through :func:`atomic_path` or :func:`write_atomic`.

A file is written under a hidden temporary name beside its target (same folder, so the same file system),
flushed to disk, then renamed onto the target in one step (``os.replace`` is atomic on POSIX and Windows). A
reader, a concurrent worker or an interrupted run therefore sees the old file, the new one or none, never half
of one; on any error the temporary is removed and the error re-raised. Temporaries end in :data:`TEMPORARY`,
so a folder scan (``*.parquet``) never picks up a killed writer's leftover.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
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
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


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
