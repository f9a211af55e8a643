"""Typed gain configurations for method plugins.

Every observer and controller declares its gains as a pydantic model derived from :class:`GainConfig`, so a
scenario file is checked when it loads: unknown keys, missing values, non-positive gains and per-joint vectors
of the wrong length are reported with their field path. A per-joint gain is written as one number (the same
for every joint, the dissertation's ``diag(15, 15, 15)``) or as a list with one value per joint; either way the
plugin receives a NumPy vector.
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationInfo, model_validator

from ftc_mj.config.types import NonNegativeFloat, PositiveFloat, joint_vector


def _joint_vector(value: Any, info: ValidationInfo) -> np.ndarray:
    """:func:`~ftc_mj.config.types.joint_vector` for the robot of the validation context (``n_joints``);
    without one, a list as given and a number as one element."""
    n_joints = (info.context or {}).get("n_joints")
    if n_joints is None:
        n_joints = len(value) if isinstance(value, list) else 1
    return joint_vector(value, n_joints)


PositiveJoints = Annotated[PositiveFloat | list[PositiveFloat], AfterValidator(_joint_vector)]
NonNegativeJoints = Annotated[NonNegativeFloat | list[NonNegativeFloat], AfterValidator(_joint_vector)]
Exponent = Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]


class GainConfig(BaseModel):
    """Base of every plugin's gains: strict keys, immutable, NumPy vectors allowed."""

    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)


class SuperTwistingGains(GainConfig):
    r"""The gains of a super-twisting term
    :math:`k_1 |x|^{1/2} \operatorname{sign}(x) + \int k_2 \operatorname{sign}(x)\, dt`: either ``L``, the
    bound that Levant's rule takes them from (:math:`k_1 = 1.5 L^{1/2}`, :math:`k_2 = 1.1 L`; Levant 1998,
    2003), or both ``k1`` and ``k2``. Shared by the super-twisting observer (4.37) and the super-twisting
    controller."""

    L: PositiveJoints | None = None
    k1: PositiveJoints | None = None
    k2: PositiveJoints | None = None

    @model_validator(mode="after")
    def _gains_given(self) -> "SuperTwistingGains":
        explicit = (self.k1 is not None, self.k2 is not None)
        if self.L is None and not all(explicit):
            raise ValueError("give L (k1 = 1.5 L^(1/2), k2 = 1.1 L) or both k1 and k2")
        if self.L is not None and any(explicit):
            raise ValueError("give either L or k1, k2, not both")
        return self

    def gains(self) -> tuple[np.ndarray, np.ndarray]:
        """(``k1``, ``k2``), from Levant's rule when only ``L`` is given."""
        if self.L is not None:
            return 1.5 * np.sqrt(self.L), 1.1 * self.L
        return self.k1, self.k2

