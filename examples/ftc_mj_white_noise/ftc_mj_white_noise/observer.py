"""An observer whose LUaF estimate is white noise: the null a benchmark must score at chance.

Its estimate in the diagnosis space (torque) is unit white noise,

    tau_hat = M(q) z_hat = n_k,   n_k ~ N(0, I) each period,  so  z_hat = M(q)^-1 n_k,

zero during a warm-up of ``warmup`` periods whose readings seed each run's own stream. A plugin sees no run
index, so the seed has to come from what it reads, and the first reading alone does not do: with 2^16-count
encoders and 1e-5 rad of noise most runs read the same quantised initial posture, so their streams were the
same, every healthy and every faulty window drew the same few noise sequences, and the benchmark scored this
observer off chance (PUMA560 AUC 0.41 [0.36, 0.47], Panda 0.60 [0.54, 0.66]). Over a warm-up the readings cross
quantisation steps at instants the encoder noise and the run's model mismatch decide, so each run's (each
member's) hash of its readings seeds a stream of its own; a batch member draws what its single run draws.

White noise in acceleration would not do: the torque-space residual is M(q_meas) z_hat, and a fault that moves
the arm's posture moves M, which a detector would then see. It reads the encoders only and never acts on the
plant.
"""

from __future__ import annotations

import hashlib
from typing import Annotated, ClassVar

import numpy as np
from pydantic import Field, StrictInt

from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.observers import Observer
from ftc_mj.robot.nominal import StepModel


class WhiteNoiseConfig(GainConfig):
    """The warm-up [periods] whose readings seed each run's stream; the estimate's scale is fixed (unit torque),
    which a calibrated threshold absorbs."""

    warmup: Annotated[StrictInt, Field(ge=1, le=100_000)] = 200


class WhiteNoiseObserver(Observer):
    """White noise as the LUaF estimate (torque space) after the warm-up; the position estimate is the
    reading itself."""

    name: ClassVar[str] = "white_noise"
    Config: ClassVar[type[WhiteNoiseConfig]] = WhiteNoiseConfig

    def __init__(self, config: WhiteNoiseConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        rows = 1 if members is None else members
        #: Per member, its warm-up (a batch may give each member its own).
        warmup = np.asarray(config.warmup, dtype=int)  # a batch stacks it per member (and joint)
        self._warmup = np.broadcast_to(warmup.reshape(rows, -1)[:, 0] if warmup.size > 1 else warmup, (rows,))
        self._hashes = [hashlib.blake2b(digest_size=16) for _ in range(rows)]
        self._streams: list[np.random.Generator | None] = [None] * rows
        self._periods = 0
        self._draw = np.zeros((rows, n_joints))

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        self.q_hat[:] = q_meas
        self.injection[:] = 0.0
        readings = np.ascontiguousarray(q_meas).reshape(len(self._hashes), -1)
        for row, stream in enumerate(self._streams):
            if self._periods < self._warmup[row]:
                self._hashes[row].update(readings[row].tobytes())
                self._draw[row] = 0.0
                continue
            if stream is None:
                stream = self._streams[row] = np.random.default_rng(np.frombuffer(self._hashes[row].digest(),
                                                                                   np.uint32))
            self._draw[row] = stream.standard_normal(self.n)
        self._periods += 1
        self.luaf_hat[:] = model.solve_M(self._draw.reshape(self.shape))

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        pass
