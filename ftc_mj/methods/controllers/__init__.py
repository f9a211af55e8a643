"""Controller plugins. Built-ins are listed here; third-party packages add theirs through the
``ftc_mj.controllers`` entry-point group (see :mod:`ftc_mj.methods.registry`)."""

from ftc_mj.methods.controllers.active import EffectivenessAccommodation, EventCompensatedNFTSMC, Supervisor
from ftc_mj.methods.controllers.base import Controller, SlidingModeController
from ftc_mj.methods.controllers.computed_torque import ComputedTorque
from ftc_mj.methods.controllers.nftsmc import NFTSMC, AdaptiveNFTSMC
from ftc_mj.methods.controllers.ntsmc import NTSMC
from ftc_mj.methods.controllers.pid import PID
from ftc_mj.methods.controllers.sigmoid_nftsmc import SigmoidNFTSMC
from ftc_mj.methods.controllers.smc import SMC
from ftc_mj.methods.controllers.super_twisting import SuperTwisting

BUILTIN: dict[str, type[Controller]] = {
    cls.name: cls for cls in (SMC, NTSMC, NFTSMC, AdaptiveNFTSMC, SigmoidNFTSMC, ComputedTorque, SuperTwisting, PID,
                                   EventCompensatedNFTSMC, Supervisor, EffectivenessAccommodation)
}

__all__ = ["BUILTIN", "AdaptiveNFTSMC", "ComputedTorque", "Controller", "EffectivenessAccommodation",
           "EventCompensatedNFTSMC", "NFTSMC", "NTSMC", "PID", "SMC", "SigmoidNFTSMC", "SlidingModeController",
           "Supervisor", "SuperTwisting"]
