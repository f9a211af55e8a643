"""The series a batch run records, allocated once, and what the run leaves behind (:class:`BatchRun`).

Every sample of every series is written before the run ends, or lies past its row's stop, where
:meth:`Series.cut` writes NaN: no fill beforehand (a pass over gigabytes in a campaign's batch). The fault
series are written only while a fault may be on, so they start at zero: every buffer does (:func:`buffer`).
"""

from __future__ import annotations

import mmap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

#: The per-row series a run keeps, each ``(steps, rows, n)``.
SERIES = ("q_meas", "q_true", "qd_true", "qdd_true", "qd_hat", "luaf_hat", "luaf_true", "tau", "sliding",
          "fault", "tau_delivered", "fault_torque", "fault_acceleration")
#: Of :data:`SERIES`, those written only while a fault may be on.
_FAULT_SERIES = ("fault", "fault_torque", "fault_acceleration")


@dataclass
class BatchRun:
    """What a batch leaves behind: series ``(steps, rows, n)`` (NaN after a row stopped), per-row status."""

    times: np.ndarray
    members: int
    variants: list[str]
    series: dict[str, np.ndarray]
    #: q_d, its first and second derivatives: ``(steps, n)``, or ``(steps, members, n)`` with parameters.
    reference: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: Per variant: monitor name -> {"qd_hat", "luaf_hat", "luaf_torque"} series ``(steps, members, n)``.
    monitor_series: dict[str, dict[str, dict[str, np.ndarray]]]
    #: Plugin signals per variant: name -> ``(steps, members, n)``.
    extras: dict[str, dict[str, np.ndarray]]
    fault_active: np.ndarray  # (steps, rows)
    qd_measured: np.ndarray | None
    luaf_torque: np.ndarray | None
    body_xpos: np.ndarray | None
    body_xquat: np.ndarray | None
    #: Per row: the number of samples recorded (``steps`` unless it diverged) and the time it diverged.
    done: np.ndarray
    diverged_at: np.ndarray
    #: The monitors' plugin signals per variant: monitor name -> signal name -> ``(steps, members, n)``.
    monitor_extras: dict[str, dict[str, dict[str, np.ndarray]]] = field(default_factory=dict)
    #: Per variant whose diagnosis ran inside the loop, its outputs (:class:`~ftc_mj.analysis.causal.
    #: DiagnosisSeries`, ``(steps, members, n)``).
    diagnosis: dict = field(default_factory=dict)


@dataclass(frozen=True)
class BlockSeries:
    """What one variant records beside the per-row series: its rows, its monitors' names, its plugins'
    signals."""

    name: str
    rows: slice
    monitors: Sequence[str]
    signals: Sequence[str]
    #: Each monitor's plugin signals: monitor name -> signal names.
    monitor_signals: Mapping[str, Sequence[str]] = field(default_factory=dict)


@dataclass
class Series:
    """The buffers of a run (the fields of :class:`BatchRun` of the same names) and the variants they are for."""

    blocks: Sequence[BlockSeries]
    rows: dict[str, np.ndarray]
    qd_measured: np.ndarray | None
    luaf_torque: np.ndarray | None
    monitors: dict[str, dict[str, dict[str, np.ndarray]]]
    extras: dict[str, dict[str, np.ndarray]]
    fault_active: np.ndarray
    body_xpos: np.ndarray | None
    body_xquat: np.ndarray | None
    monitor_extras: dict[str, dict[str, dict[str, np.ndarray]]] = field(default_factory=dict)

    @classmethod
    def allocate(cls, steps: int, rows: int, n: int, members: int, blocks: Sequence[BlockSeries],
                 fault_on: np.ndarray, measures_velocity: bool, torque_space: bool,
                 poses: tuple[np.ndarray, np.ndarray] | None, delivered_is_command: bool = False) -> Series:
        """Buffers for ``steps`` samples. ``fault_on`` ``(steps,)``: whether a fault is on (the same for
        every row); ``torque_space``: the diagnoser's residuals are torques (each estimate times M);
        ``poses``: the plant's body positions and quaternions to record, or None; ``delivered_is_command``:
        no actuator fault acts, so ``tau_delivered`` is ``tau`` itself (one buffer, not a copy: a campaign
        batch's series are gigabytes, each first written page by page)."""
        series = {name: buffer((steps, rows, n)) for name in SERIES
                  if not (delivered_is_command and name == "tau_delivered")}
        if delivered_is_command:
            series["tau_delivered"] = series["tau"]
        monitors = {block.name: {name: {key: buffer((steps, members, n)) for key in ("qd_hat", "luaf_hat")}
                                 | ({"luaf_torque": buffer((steps, members, n))} if torque_space else {})
                                 for name in block.monitors}
                    for block in blocks}
        extras = {block.name: {name: buffer((steps, members, n)) for name in block.signals} for block in blocks}
        monitor_extras = {block.name: {monitor: {name: buffer((steps, members, n)) for name in names}
                                       for monitor, names in block.monitor_signals.items()}
                          for block in blocks}
        return cls(blocks, series, buffer((steps, rows, n)) if measures_velocity else None,
                   buffer((steps, rows, n)) if torque_space else None, monitors, extras,
                   np.repeat(fault_on[:, None], rows, axis=1),
                   None if poses is None else buffer((steps,) + poses[0].shape),
                   None if poses is None else buffer((steps,) + poses[1].shape), monitor_extras)

    def cut(self, done: np.ndarray) -> None:
        """NaN in every series from each row's stop on (``done``: its samples recorded)."""
        for rows_series in {id(values): values for values in (*self.rows.values(), self.qd_measured,
                                                               self.luaf_torque) if values is not None}.values():
            _cut(rows_series, done)  # each buffer once (tau_delivered may be tau)
        for block in self.blocks:
            block_done = done[block.rows]
            for name_series in (*self.monitors[block.name].values(), self.extras[block.name],
                                *self.monitor_extras[block.name].values()):
                for values in name_series.values():
                    _cut(values, block_done)


#: From this many bytes a buffer is mapped memory of its own (:func:`buffer`).
MAPPED_BYTES = 1 << 20


def buffer(shape: tuple[int, ...]) -> np.ndarray:
    """A float64 buffer of ``shape``, zero: from :data:`MAPPED_BYTES` on, anonymous memory mapped in ordinary
    pages (zero until written, backed page by page as the loop first writes it).

    Not NumPy's own allocation: NumPy advises the kernel to back an array of 4 MiB or more with huge pages,
    and where the kernel compacts memory to find them when a page is first touched (``defrag`` set to
    ``madvise``, a common default), a batch that writes gigabytes of series waits on it, several times longer
    than in ordinary pages, with no gain in reading them (``benchmarks/series_memory.py`` measures both)."""
    size = int(np.prod(shape)) * 8
    if size < MAPPED_BYTES or not hasattr(mmap, "MAP_ANONYMOUS"):
        return np.zeros(shape)
    memory = mmap.mmap(-1, size, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    return np.frombuffer(memory, dtype=np.float64).reshape(shape)


def _cut(values: np.ndarray, done: np.ndarray) -> None:
    """NaN from each row's stop on (``values`` is ``(steps, rows, ...)``)."""
    for row in np.flatnonzero(done < len(values)):
        values[done[row]:, row] = np.nan
