"""Errors that reach the user as one line, without a traceback: :class:`InputError`; :func:`validation_error`,
which turns a pydantic validation failure into one; and :func:`validate`, which validates a section with its
schema and raises that error."""

from __future__ import annotations

import difflib
import typing
from collections.abc import Callable
from typing import Any, TypeVar

from pydantic import BaseModel, TypeAdapter, ValidationError

Model = TypeVar("Model", bound=BaseModel)


class InputError(Exception):
    """Bad input: a scenario file, a field in it, or a command-line value. Exit status 2.

    ``str(error)`` is the one line shown to the user: ``FILE: FIELD: PROBLEM``.
    """

    def __init__(self, file: str, field: str, problem: str):
        self.file = file
        self.field = field
        self.problem = problem
        location = f"{file}: {field}" if field else file
        super().__init__(_one_line(f"{location}: {problem}"))


def _one_line(text: str) -> str:
    """Escape line breaks and other control characters (a YAML key may contain them)."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def _is_union_tag(part: Any) -> bool:
    """pydantic puts the union member it tried into an error's location ('constrained-float',
    'list[constrained-float]', 'str', 'function-after[...]'); those are not fields a user can write."""
    return isinstance(part, str) and ("[" in part or "-" in part or part in {"str", "int", "float", "bool", "list"})


#: Problems of one validation named in its one line; the rest are counted.
SHOWN_PROBLEMS = 4


def validation_error(file: str, prefix: str, exc: ValidationError,
                     file_of: Callable[[tuple[str | int, ...]], str] | None = None,
                     schema: type[BaseModel] | None = None) -> InputError:
    """A pydantic validation failure as one :class:`InputError`: its first problem as ``FILE: FIELD: PROBLEM``
    (the field path under ``prefix``, union member tags dropped), then up to :data:`SHOWN_PROBLEMS` - 1 more
    as ``; also FIELD: PROBLEM`` (a count of any left), so that one attempt shows what to fix. Unknown keys
    come first (a misspelt ``durration`` is the mistake, not the ``duration`` it leaves missing), each with
    the closest key ``schema`` knows at its place, if one is close.

    ``file_of`` picks the file to name from the field path (relative to the validated model): the file that
    wrote the value, when a scenario inherits from a base (:mod:`ftc_mj.config.inheritance`); default ``file``.
    A problem in another file than the first's names its file too.
    """
    # Group the errors by the value they concern (the location up to the first union tag): a value that fits
    # no member of a union gives one error per member, and counts as one problem.
    groups: dict[tuple, list[dict]] = {}
    for error in exc.errors():
        loc = error["loc"]
        cut = next((i for i, part in enumerate(loc) if _is_union_tag(part)), len(loc))
        groups.setdefault(tuple(loc[:cut]), []).append(error)
    ordered = sorted(groups.values(), key=lambda group: not any(e["type"] == "extra_forbidden" for e in group))
    problems = [_problem(group, prefix, schema) for group in ordered]
    files = [file if file_of is None else file_of(parts) for parts, _, _ in problems]
    _, field, message = problems[0]
    others = [f"{other_file}: {other_field}: {text}" if other_file != files[0] else f"{other_field}: {text}"
              for other_file, (_, other_field, text) in zip(files[1:SHOWN_PROBLEMS], problems[1:SHOWN_PROBLEMS])]
    if others:
        message += "; also " + "; ".join(others)
    left = len(problems) - SHOWN_PROBLEMS
    if left > 0:
        message += f" (and {left} more problem{'s' if left > 1 else ''})"
    return InputError(files[0], field, message)


def _problem(group: list[dict], prefix: str, schema: type[BaseModel] | None) -> tuple[tuple, str, str]:
    """(the path relative to the model, the field path under ``prefix``, the problem) of one group of errors."""
    # The member error that got furthest into the value (e.g. a bad list element) says the most.
    best = max(group, key=lambda error: len(error["loc"]))
    parts = tuple(part for part in best["loc"] if not _is_union_tag(part))
    field = ".".join(p for p in (prefix, ".".join(str(part) for part in parts)) if p)
    message = best["msg"].removeprefix("Value error, ")
    if best["type"] == "extra_forbidden":
        message = "unknown key"
        close = _closest_key(schema, parts)
        if close is not None:
            message += f" (did you mean {close!r}?)"
    elif best["type"] == "missing":
        message = "required field is missing"
    return parts, field, message


def validate(schema: type[Model] | TypeAdapter, raw: Any, file: str, field: str = "",
             context: dict[str, Any] | None = None, file_of: Callable[[tuple], str] | None = None) -> Any:
    """``raw`` validated by ``schema`` (a pydantic model or a :class:`~pydantic.TypeAdapter`), or the one-line
    :class:`InputError` of its first problem, its field path under ``field`` (see :func:`validation_error`)."""
    try:
        if isinstance(schema, TypeAdapter):
            return schema.validate_python(raw, context=context)
        return schema.model_validate(raw, context=context)
    except ValidationError as exc:
        raise validation_error(file, field, exc, file_of,
                               schema if isinstance(schema, type) and issubclass(schema, BaseModel) else None) from None


def _closest_key(schema: type[BaseModel] | None, loc: tuple[str | int, ...]) -> str | None:
    """The known key closest to the unknown last part of ``loc`` in the model that holds it, or None: the
    models are followed along ``loc`` (a list index or a mapping's own key stays on the model it is in)."""
    model = schema
    for part in loc[:-1]:
        fields = getattr(model, "model_fields", None)
        if fields is None:
            return None
        if isinstance(part, str) and part in fields:
            model = _model_in(fields[part].annotation)
    fields = getattr(model, "model_fields", None)
    if fields is None or not isinstance(loc[-1], str):
        return None
    close = difflib.get_close_matches(loc[-1], list(fields), n=1, cutoff=0.75)
    return close[0] if close else None


def _model_in(annotation: Any, depth: int = 0) -> type[BaseModel] | None:
    """The first pydantic model in a field's annotation (through Optional, Annotated, list and dict)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if depth > 8:
        return None
    for argument in typing.get_args(annotation):
        found = _model_in(argument, depth + 1)
        if found is not None:
            return found
    return None
