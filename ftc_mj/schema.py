"""Building blocks of the scenario schema shared by its sections (plant terms, actuator faults, sensors,
diagnosis): strict models, checked number types, expressions, per-joint values and joint selections.

Each section's pydantic model lives in the module of its concept; :mod:`ftc_mj.scenario` assembles them and
compiles the validated values. Unions over a ``kind`` or ``shape`` key are discriminated with tags written
``"<key>-<value>"``: :func:`ftc_mj.scenario._input_error` drops such tags from the field path it reports.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Discriminator, Field, StrictFloat, StrictInt, StrictStr

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# Strict: a YAML boolean must not pass as the number 1.
ExpressionText = StrictStr | StrictInt | StrictFloat
#: Joints by 1-based number or by MJCF joint name; ``None`` (absent) means every joint.
JointSelection = Annotated[list[Annotated[int, Field(ge=1)] | StrictStr], Field(min_length=1)] | None


class Strict(BaseModel):
    """A schema section: unknown keys are errors."""

    model_config = ConfigDict(extra="forbid")


def tagged_union(key: str, choices: Sequence[str], default: str | None = None) -> Discriminator:
    """A discriminator choosing the member whose tag is ``"<key>-<value of key>"`` (``default`` when the key
    is absent), with one clear error naming the ``choices`` for a missing or unknown value."""

    def choose(value: Any) -> str | None:
        chosen = value.get(key, default) if isinstance(value, dict) else getattr(value, key, None)
        return f"{key}-{chosen}" if isinstance(chosen, str) else None

    return Discriminator(choose, custom_error_type=f"invalid_{key}",
                         custom_error_message=f"{key} must be one of: {', '.join(choices)}")


def per_joint(values: float | Sequence[float], n: int, describe: Callable[[int], str]) -> np.ndarray:
    """One number for all ``n`` entries or a list of exactly ``n``, as a float array.

    Raises:
        ValueError: with ``describe(len(values))`` as the message, on a list of the wrong length.
    """
    if isinstance(values, (list, tuple)):
        if len(values) != n:
            raise ValueError(describe(len(values)))
        return np.asarray(values, dtype=float)
    return np.full(n, float(values))
