"""What every command shares around its work: its outputs checked against its inputs and against each other
before any work (:class:`Outputs`), and its exit status on bad input, a failed write or an interruption
(:func:`exit_status`), in one place.

A command declares each output it will write (an option, a path, whether it is a folder) and the files it
reads (the scenario, its bases, the robot's model and mesh files, a replayed log, a campaign or tuning file,
a recording): :meth:`Outputs.check` refuses, as one line ``FILE: OPTION: PROBLEM``, an output that is one of
the inputs (symbolic links and other names of one file resolved), that is another option's output, that is
not a regular file (a device such as ``/dev/full``, a pipe) or that cannot be written. Files are then written
through :meth:`Outputs.write` (or :meth:`Outputs.writing` for writers that open the file themselves), whole or
not at all (:func:`ftc_mj.outputs.files.write_atomic`).

:func:`exit_status` wraps a command's ``main``: bad input (:class:`~ftc_mj.config.errors.InputError`) and a
write that fails (a full disk) are one line and exit 2; Ctrl-C (``KeyboardInterrupt``) is one line and exit
130; a worker process that died is one line and exit 1. On exit 2 and 130, the files this command wrote so far
are removed: what a command writes is its whole output or nothing. (Commands that keep finished work on an
interruption, ``campaign run``, ``tune``, ``bench``, keep it in their results folder, which they resume from:
they say so in their interruption line.)
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ftc_mj.config.errors import InputError

#: What ``run``, ``calibrate`` and the other commands that write their outputs at the end say on Ctrl-C.
NOTHING_WRITTEN = "interrupted: nothing written"
#: What the commands that keep finished work in a results folder say on Ctrl-C.
WORK_KEPT = "interrupted: what finished is saved; run the same command again to go on"


@dataclass(frozen=True)
class Output:
    """One output of a command: the option that names it, its path, and whether it is a folder."""

    option: str
    path: Path
    directory: bool = False


@dataclass
class Outputs:
    """A command's outputs, checked against its inputs before any work and written whole or not at all.

    ``file`` is the input the errors name (the file the command was given)."""

    file: str
    declared: list[Output] = field(default_factory=list)
    #: The files written so far (removed if the command then fails or is interrupted).
    written: list[Path] = field(default_factory=list)

    def __post_init__(self) -> None:
        _ACTIVE.append(self)

    def add(self, option: str, path: Path | None, directory: bool = False) -> None:
        """Declare an output (nothing when ``path`` is None: the option was not given)."""
        if path is not None:
            self.declared.append(Output(option, Path(path), directory))

    def check(self, inputs: Iterable[Path | str] = ()) -> None:
        """Refuse an output that is an input, another output, not a regular file or not writable.

        Raises:
            InputError: ``FILE: OPTION: PROBLEM`` of the first such output.
        """
        from ftc_mj.outputs.files import output_problem

        inputs = [Path(p) for p in inputs]
        seen: dict[str, Output] = {}
        for output in self.declared:
            problem = output_problem(output.path, directory=output.directory, inputs=inputs)
            if problem is not None:
                raise InputError(self.file, output.option, problem)
            target = os.path.realpath(output.path)
            other = seen.get(target)
            if other is not None:
                raise InputError(self.file, output.option, f"{str(output.path)!r} is also the path of {other.option}"
                                 + (f" ({other.path})" if other.option == output.option else ""))
            for folder, holder in seen.items():
                if holder.directory and target.startswith(folder.rstrip(os.sep) + os.sep):
                    raise InputError(self.file, output.option, f"{str(output.path)!r} is inside {holder.option}'s "
                                     f"folder {str(holder.path)!r}")
            seen[target] = output

    def write(self, option: str, path: Path, content: bytes) -> None:
        """Write one output whole (an atomic rename), or raise the one-line error of a failed write."""
        from ftc_mj.outputs.files import write_atomic

        with self.writing(option, path):
            write_atomic(path, content)

    @contextlib.contextmanager
    def writing(self, option: str, path: Path) -> Iterator[None]:
        """A block that writes ``path`` itself (through an atomic path): a failed write becomes the one-line
        :class:`InputError`, a written file is recorded to be removed if the command fails later."""
        try:
            yield
        except OSError as error:
            raise InputError(self.file, option, f"cannot write {error.filename or path}: "
                             f"{error.strerror or error}") from None
        self.written.append(Path(path))

    def remove_written(self) -> None:
        for path in self.written:
            Path(path).unlink(missing_ok=True)
        self.written.clear()


#: The :class:`Outputs` of the commands running in this process (a command may call another: ``campaign
#: replay`` runs ``run``).
_ACTIVE: list[Outputs] = []


#: What the commands with worker processes say when one died.
WORKER_DIED = ("error: a worker process died (out of memory or killed); what finished is saved: run the same "
               "command again to go on, with fewer --workers")


def exit_status(interrupted: str = NOTHING_WRITTEN, died: str = WORKER_DIED
                ) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """Wrap a command's ``main(argv, prog) -> status``: bad input exit 2, Ctrl-C exit 130 (saying
    ``interrupted``), a dead worker process exit 1 (saying ``died``), each one line on stderr; the files
    written by an :class:`Outputs` of the command removed on 2 and 130."""

    def wrap(main: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(main)
        def command(argv: Sequence[str] | None = None, *rest, **options) -> int:
            from concurrent.futures.process import BrokenProcessPool

            depth = len(_ACTIVE)
            try:
                return main(argv, *rest, **options)
            except InputError as error:
                _remove_written(depth)
                print(f"error: {error}", file=sys.stderr)
                return 2
            except KeyboardInterrupt:
                _remove_written(depth)
                print(interrupted, file=sys.stderr)
                _end_if_threads_run()
                return 130
            except BrokenProcessPool:  # a worker killed (out of memory, a signal): not the input's fault
                print(died, file=sys.stderr)
                return 1
            finally:
                del _ACTIVE[depth:]

        return command

    return wrap


#: The names the engine's threads start with (:func:`ftc_mj.engine.runner.run_batch`).
ENGINE_THREADS = "ftc_mj-batch"


def _end_if_threads_run() -> None:
    """End the process now (exit 130) if the engine's threads still run: a thread inside MuJoCo's
    step cannot be interrupted, and Python would wait for it to finish its work (a minute) before exiting.
    Everything the command says is said and its outputs removed by then."""
    import threading

    if threading.current_thread() is threading.main_thread() and any(
            thread.is_alive() and thread.name.startswith(ENGINE_THREADS) for thread in threading.enumerate()):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)


def _remove_written(depth: int) -> None:
    for outputs in _ACTIVE[depth:]:
        outputs.remove_written()
