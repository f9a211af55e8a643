"""An observer whose LUaF estimate is white noise: the null a benchmark must score at chance.

Its estimate in the diagnosis space (torque) is unit white noise,

    tau_hat = M(q) z_hat = n_k,   n_k ~ N(0, I) each period,  so  z_hat = M(q)^-1 n_k,

drawn from a stream seeded by the first readings (the encoders' noise differs between runs, so runs differ).
White noise in acceleration would not do: the torque-space residual is M(q_meas) z_hat, and a fault that
moves the arm's posture moves M, which a detector would then see (a float on the Panda's elbow raises the scale
of M(q) n: AUC 0.59-0.87 in a first try). It reads the encoders only and never acts on the plant.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.observers import Observer
from ftc_mj.robot.nominal import StepModel


class WhiteNoiseConfig(GainConfig):
    """No gains: the estimate's scale is fixed (unit torque), which a calibrated threshold absorbs."""


class WhiteNoiseObserver(Observer):
    """White noise as the LUaF estimate (torque space); the position estimate is the reading itself."""

    name: ClassVar[str] = "white_noise"
    Config: ClassVar[type[WhiteNoiseConfig]] = WhiteNoiseConfig

    def __init__(self, config: WhiteNoiseConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self._rng: np.random.Generator | None = None

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        if self._rng is None:
            self._rng = np.random.default_rng(np.frombuffer(np.ascontiguousarray(q_meas).tobytes(), np.uint32))
        self.q_hat[:] = q_meas
        self.luaf_hat[:] = model.solve_M(self._rng.standard_normal(self.shape))
        self.injection[:] = 0.0

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        pass
