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
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationInfo

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
