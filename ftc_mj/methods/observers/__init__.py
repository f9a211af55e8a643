"""Observer plugins. Built-ins are listed here; third-party packages add theirs through the
``ftc_mj.observers`` entry-point group (see :mod:`ftc_mj.methods.registry`)."""

from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.observers.disturbance import DisturbanceObserver
from ftc_mj.methods.observers.eso import ESO
from ftc_mj.methods.observers.kalman import KalmanObserver
from ftc_mj.methods.observers.levant import Levant
from ftc_mj.methods.observers.momentum import LevantMomentumObserver, MomentumObserver
from ftc_mj.methods.observers.ndob import NDOB, LevantNDOB
from ftc_mj.methods.observers.sosmo import SOSMO
from ftc_mj.methods.observers.tosmo import TOSMO, HighSpeedTOSMO

BUILTIN: dict[str, type[Observer]] = {
    cls.name: cls
    for cls in (DisturbanceObserver, ESO, SOSMO, TOSMO, HighSpeedTOSMO, Levant, NDOB, LevantNDOB, KalmanObserver,
                MomentumObserver, LevantMomentumObserver)
}

__all__ = ["BUILTIN", "DisturbanceObserver", "ESO", "HighSpeedTOSMO", "KalmanObserver", "Levant",
           "LevantMomentumObserver", "LevantNDOB", "MomentumObserver", "NDOB", "Observer", "SOSMO", "TOSMO"]
