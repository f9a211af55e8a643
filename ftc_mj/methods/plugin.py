"""What every method plugin (observer or controller) has: a name, a gain schema, the sensors it needs."""

from __future__ import annotations

from abc import ABC
from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.primitives import scalar


class Method(ABC):
    """Base of observer and controller plugins. The contract:

    * **Shapes.** A method runs ``members`` copies of itself at once (a batch; a single run is one member).
      Its state is ``(members, n)`` arrays (``self.shape``), allocated in ``__init__``; every input it gets
      (readings, reference rows broadcast, the nominal model's ``psi_hat`` ``(members, n)`` and ``M``
      ``(members, n, n)``) and every output it exposes has the member axis first.
    * **Gains.** ``config`` holds the members' validated configurations, stacked by the engine: every gain,
      per-joint or written as one number, is a ``(members, n)`` array (one value per member and joint);
      choices (strings) are shared. Use them as arrays: no ``float(...)`` of a gain, no ``if`` on a gain's
      value (use ``np.where``), so that every member may have its own gains.
    * **Per step.** Update state in place (``out=``, ``[:] =``); allocate in ``__init__``, not per call.
      ``self.dt`` is the period, to multiply by as it is.
    * **Batch-safe.** Member k of a batch gives the bits it gives alone. Plain NumPy on the gains and states
      keeps that; fractional powers and exp go through :mod:`ftc_mj.methods.primitives` (``signed_power``,
      ``power``, ``exp``), and member values are never computed one by one in Python (``math``,
      ``float(gain)``). The rule, its reasons and what a plugin may write freely:
      ``docs/explanation/batching.md``.
    * **Reset.** ``reset`` puts every member back to its initial state; the engine calls it before the first
      period. A run is reproducible only if everything a method integrates is reset there.

    Attributes:
        name: the name scenario files use (``type: ...``).
        Config: the pydantic schema of the method's gains, checked when a scenario loads.
        requires: sensors the method needs; a scenario whose robot lacks one is refused when it loads.
        signal_names: the keys the method puts in ``self.signals`` (what a figure may plot as
            ``extras.NAME``), checked when a scenario loads; None (the default, for plugins that do not
            declare them): any plain name is accepted and a figure of a name never recorded is empty.
    """

    name: ClassVar[str]
    Config: ClassVar[type[GainConfig]]
    requires: ClassVar[frozenset[str]] = frozenset({"position"})
    signal_names: ClassVar[frozenset[str] | None] = None

    def __init__(self, config: GainConfig, n_joints: int, dt: float, members: int | None = None):
        self.config = config
        self.n = n_joints
        self.members = members
        #: The shape of every per-joint state array: ``(members, n)`` (the engine always gives ``members``;
        #: without it, a standalone ``(n,)``, as unit tests of one law use).
        self.shape = (n_joints,) if members is None else (members, n_joints)
        #: The control period [s] as a 0-d array (:func:`~ftc_mj.methods.primitives.scalar`): a number to Python,
        #: and ``self.dt * x`` is ``dt * x`` bit for bit without NumPy converting a float on every call.
        self.dt = scalar(dt)
        #: The period as a ``self.shape`` array, kept for plugins written against it; ``self.dt`` is as fast.
        self.dt_array = np.full(self.shape, float(dt))
        #: Internal per-joint signals worth plotting (e.g. an adaptive gain, Fig. 2.8): name -> array that the
        #: method updates in place. The loop records each one every period beside the estimates.
        self.signals: dict[str, np.ndarray] = {}
