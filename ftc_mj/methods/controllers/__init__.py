"""Controller plugins. Built-ins are listed here; third-party packages add theirs through the
``ftc_mj.controllers`` entry-point group (see :mod:`ftc_mj.methods.registry`)."""

from ftc_mj.methods.controllers.base import Controller, SlidingModeController
from ftc_mj.methods.controllers.nftsmc import NFTSMC, AdaptiveNFTSMC
from ftc_mj.methods.controllers.ntsmc import NTSMC
from ftc_mj.methods.controllers.sigmoid_nftsmc import SigmoidNFTSMC
from ftc_mj.methods.controllers.smc import SMC

BUILTIN: dict[str, type[Controller]] = {
    cls.name: cls for cls in (SMC, NTSMC, NFTSMC, AdaptiveNFTSMC, SigmoidNFTSMC)
}

__all__ = ["BUILTIN", "AdaptiveNFTSMC", "Controller", "NFTSMC", "NTSMC", "SMC", "SigmoidNFTSMC",
           "SlidingModeController"]
