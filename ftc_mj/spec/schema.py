"""Building blocks of the scenario schema shared by its sections (plant terms, actuator faults, sensors,
diagnosis): strict models, checked number types, expressions, per-joint values and joint selections.

Each section's pydantic model lives in the module of its concept; :mod:`ftc_mj.spec.scenario` assembles them and
compiles the validated values. Unions over a ``kind`` or ``shape`` key are discriminated with tags written
``"<key>-<value>"``: :func:`ftc_mj.spec.scenario._input_error` drops such tags from the field path it reports.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, Union

from pydantic import BaseModel, ConfigDict, Discriminator, Field, StrictFloat, StrictInt, StrictStr, Tag, model_validator

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


class Interval(Strict):
    """From ``onset`` until ``end`` (for good when absent) [s]."""

    onset: NonNegativeFloat
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
