"""What every method plugin (observer or controller) has: a name, a gain schema, the sensors it needs."""

from __future__ import annotations

from abc import ABC
from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig


class Method(ABC):
    """Base of observer and controller plugins.

    Attributes:
        name: the name scenario files use (``type: ...``).
        Config: the pydantic schema of the method's gains, checked when a scenario loads.
        requires: sensors the method needs; a scenario whose robot lacks one is refused when it loads.
    """

    name: ClassVar[str]
    Config: ClassVar[type[GainConfig]]
    requires: ClassVar[frozenset[str]] = frozenset({"position"})

    def __init__(self, config: GainConfig, n_joints: int, dt: float):
        self.config = config
        self.n = n_joints
        self.dt = dt
        #: Internal per-joint signals worth plotting (e.g. an adaptive gain, Fig. 2.8): name -> array that the
        #: method updates in place. The loop records each one every period beside the estimates.
        self.signals: dict[str, np.ndarray] = {}
