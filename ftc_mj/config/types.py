"""Building blocks of the scenario schema shared by its sections (plant terms, actuator faults, sensors,
diagnosis): strict models, checked number types, expressions, per-joint values and joint selections; and the
functions that compile them once the robot is known (per-joint arrays, joint indices, parsed expressions),
raising :class:`~ftc_mj.config.errors.InputError` with the field's path.

Each section's pydantic model and its compile function live in the module of its concept;
:mod:`ftc_mj.scenario.definition` assembles them. Unions over a ``kind`` or ``shape`` key are discriminated with
tags written ``"<key>-<value>"``: :func:`ftc_mj.config.errors.validation_error` drops such tags from the field
path it reports.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, Union

import mujoco
import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    StrictFloat,
    StrictInt,
    StrictStr,
    Tag,
    model_validator,
)

from ftc_mj.config import expressions
from ftc_mj.config.errors import InputError

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# Strict: a YAML boolean must not pass as the number 1.
ExpressionText = StrictStr | StrictInt | StrictFloat
#: The name of one of the scenario's ``parameters`` where a number may also be given by one.
ParameterName = Annotated[StrictStr, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]
#: Joints by 1-based number or by MJCF joint name; ``None`` (absent) means every joint.
JointSelection = Annotated[list[Annotated[int, Field(ge=1)] | StrictStr], Field(min_length=1)] | None


class Strict(BaseModel):
    """A schema section: unknown keys are errors."""

    model_config = ConfigDict(extra="forbid")


class Interval(Strict):
    """From ``onset`` until ``end`` (for good when absent) [s]."""

    #: Start [s].
    onset: NonNegativeFloat
    #: End [s]; for good when absent.
    end: PositiveFloat | None = None

    @model_validator(mode="after")
    def _end_after_onset(self) -> "Interval":
        if self.end is not None and self.end <= self.onset:
            raise ValueError(f"end {self.end} must be after the onset {self.onset}")
        return self


def tagged_union(key: str, members: Mapping[str, type[BaseModel]], default: str | None = None) -> Any:
    """The union of ``members`` chosen by the value of ``key`` (``default`` when the key is absent), with one
    clear error naming the choices for a missing or unknown value. Members are tagged ``"<key>-<value>"``."""

    def choose(value: Any) -> str | None:
        chosen = value.get(key, default) if isinstance(value, dict) else getattr(value, key, None)
        return f"{key}-{chosen}" if isinstance(chosen, str) else None

    union = Union[tuple(Annotated[member, Tag(f"{key}-{name}")] for name, member in members.items())]  # noqa: UP007
    discriminator = Discriminator(choose, custom_error_type=f"invalid_{key}",
                                  custom_error_message=f"{key} must be one of: {', '.join(members)}")
    return Annotated[union, discriminator]


# ------------------------------------------------------------------------------ compiling the building blocks


def joint_vector(values: float | list[float], n: int) -> np.ndarray:
    """"A number or one per joint", the one rule of every such field (gains, thresholds, initial states): one
    number for every joint, or a list with one value per joint, as a float vector of ``n``.

    Raises:
        ValueError: a list whose length is not ``n`` (its message names both lengths).
    """
    if not isinstance(values, list):
        return np.full(n, float(values))
    if len(values) != n:
        raise ValueError(f"has {len(values)} values, the robot has {n} joints")
    return np.asarray(values, dtype=float)


def per_joint(values: float | list[float], n: int, file: str, field: str) -> np.ndarray:
    """:func:`joint_vector` of a compiled section's field, its problem an :class:`InputError` naming it."""
    try:
        return joint_vector(values, n)
    except ValueError as exc:
        raise InputError(file, field, str(exc)) from None


def per_selected(values: Any, indices: list[int], file: str, field: str) -> list:
    """One value for all selected joints, or a list with one per selected joint."""
    if not isinstance(values, list):
        return [values] * len(indices)
    if len(values) != len(indices):
        raise InputError(file, field, f"has {len(values)} values for {len(indices)} joints")
    return values


def joint_indices(selection: JointSelection, model: mujoco.MjModel, file: str, field: str) -> list[int]:
    """DOF indices of a joint selection (1-based numbers or MJCF names), in the order given; all when None."""
    n = model.nv
    if selection is None:
        return list(range(n))
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): int(model.jnt_dofadr[j]) for j in range(model.njnt)}
    indices: list[int] = []
    for position, item in enumerate(selection):
        if isinstance(item, str):
            if item not in names:
                raise InputError(file, f"{field}.{position}", f"unknown joint {item!r} (joints: {', '.join(name for name in names if name)})")
            index = names[item]
        elif item > n:
            raise InputError(file, f"{field}.{position}", f"joint {item} does not exist, the robot has {n} joints")
        else:
            index = item - 1
        if index in indices:
            raise InputError(file, f"{field}.{position}", f"joint {item!r} is listed twice")
        indices.append(index)
    return indices


def joint_mask(indices: list[int], n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[indices] = True
    return mask


def parse_expression(text: ExpressionText, variables: list[str], file: str, field: str):
    """An expression of the scenario file, parsed (:func:`ftc_mj.config.expressions.parse`)."""
    try:
        return expressions.parse(text, variables)
    except expressions.ExpressionError as exc:
        raise InputError(file, field, str(exc)) from None
