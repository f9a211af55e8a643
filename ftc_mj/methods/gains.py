"""Typed gain configurations for method plugins.

Every observer and controller declares its gains as a pydantic model derived from :class:`GainConfig`, so a
scenario file is checked when it loads: unknown keys, missing values, non-positive gains and per-joint vectors
of the wrong length are reported with their field path. A per-joint gain is written as one number (the same
for every joint, the dissertation's ``diag(15, 15, 15)``) or as a list with one value per joint; either way the
plugin receives a NumPy vector.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationInfo


def _joint_vector(value: Any, info: ValidationInfo) -> np.ndarray:
    n_joints = (info.context or {}).get("n_joints")
    if isinstance(value, list):
        if n_joints is not None and len(value) != n_joints:
            raise ValueError(f"has {len(value)} values, the robot has {n_joints} joints")
        return np.asarray(value, dtype=float)
    return np.full(n_joints if n_joints is not None else 1, float(value))


PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
PositiveJoints = Annotated[PositiveFloat | list[PositiveFloat], AfterValidator(_joint_vector)]
NonNegativeJoints = Annotated[NonNegativeFloat | list[NonNegativeFloat], AfterValidator(_joint_vector)]
Exponent = Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]


class GainConfig(BaseModel):
    """Base of every plugin's gains: strict keys, immutable, NumPy vectors allowed."""

    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)


def stack(configs: Sequence[GainConfig], n_joints: int) -> GainConfig:
    """One configuration for a batch of members from one validated configuration per member.

    Per-joint gains and single numbers both become contiguous ``(members, n)`` arrays; a field that is None must be None for every member, and a
    choice (a string such as ``compensation``) must be the same for every member, since it selects the law's
    form rather than a value. The result is not validated again: each member's values were.
    """
    first = configs[0]
    values: dict[str, Any] = {}
    for name in type(first).model_fields:
        column = [getattr(config, name) for config in configs]
        if all(value is None for value in column):
            values[name] = None
        elif any(value is None for value in column):
            raise ValueError(f"{name}: given for some members and not for others")
        elif isinstance(column[0], np.ndarray):
            values[name] = np.stack([np.asarray(value, dtype=float) for value in column])
        elif isinstance(column[0], (bool, str)):
            if any(value != column[0] for value in column):
                raise ValueError(f"{name}: differs between members ({column[0]!r}, ...); it selects the law's form")
            values[name] = column[0]
        else:
            # One per member and joint (not one column to broadcast): an exponent of one element would take
            # NumPy's scalar fast paths (x ** 0.5 as sqrt), which differ in the last bit from the general power
            # a batch of many members computes, and member k would not be its own run.
            values[name] = np.repeat(np.asarray(column, dtype=float)[:, None], n_joints, axis=1)
    return type(first).model_construct(**values)
