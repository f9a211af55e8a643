"""The scenario's ``nominal`` section: the controller's model mismatch (mass scale) and joint friction."""

from __future__ import annotations

from ftc_mj.config.types import PositiveFloat, Strict
from ftc_mj.robot.friction import FrictionSpec


class NominalSpec(Strict):
    #: Scales masses, inertias and armature of the controller's model (1 = exact model).
    mass_scale: PositiveFloat = 1.0
    #: Joint friction and damping, the model file's own by default (:mod:`ftc_mj.robot.friction`).
    friction: FrictionSpec = FrictionSpec()

