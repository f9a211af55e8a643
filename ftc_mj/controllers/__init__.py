"""Controller plugins. Built-ins are listed here; third-party packages add theirs through the
``ftc_mj.controllers`` entry-point group (see :mod:`ftc_mj.registry`)."""

from ftc_mj.controllers.base import Controller, SlidingModeController
from ftc_mj.controllers.nftsmc import NFTSMC

BUILTIN: dict[str, type[Controller]] = {cls.name: cls for cls in (NFTSMC,)}

__all__ = ["BUILTIN", "Controller", "NFTSMC", "SlidingModeController"]
