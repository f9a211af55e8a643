"""What a run's figures show, shared by the static figures (:mod:`ftc_mj.outputs.figures`) and the Rerun
recording's layout (:mod:`ftc_mj.outputs.recording`): the scenario's ``figures`` section (:class:`FigureSpec`),
the quantities a figure can plot (:data:`QUANTITIES`), one colour and dash per variant (:func:`variant_styles`),
and :class:`Layout`, the whole description stored in the recording so that figures can be redrawn from it.

Without a ``figures`` section a scenario gets :func:`default_figures`: tracking error, velocity and LUaF
estimation, torque (and the diagnosis when there is one), every variant, every joint.
"""

from __future__ import annotations

import json
import re
from collections.abc import Collection, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Annotated, Any, Literal

import mujoco
import numpy as np
from pydantic import Field, model_validator

from ftc_mj.config.errors import InputError
from ftc_mj.config.types import FiniteFloat, JointSelection, NonNegativeFloat, Strict, joint_indices
from ftc_mj.outputs.palette import assign_colours

#: The scenario's validated spec (:class:`ftc_mj.scenario.definition.ScenarioSpec`, which assembles this module's
#: section): read for its variants, terms, metrics and diagnosis. Not imported, since the scenario is above.
ScenarioSpec = Any


@dataclass(frozen=True)
class Quantity:
    """A plottable quantity: its recorded entity prefix, axis label and unit, and an optional companion drawn
    beside it (``truth``: each variant's ground truth; ``reference``: the one reference of all variants;
    ``threshold``: each variant's diagnosis threshold; ``injected``: the injected fault in the diagnosis space)."""

    title: str
    unit: str
    entity: str
    companion: str | None = None
    companion_kind: Literal["truth", "reference", "threshold", "injected"] | None = None


#: Units that depend on the scenario, resolved when the figures compile.
FAULT_UNIT, DIAGNOSIS_UNIT = "<fault>", "<diagnosis>"

QUANTITIES: dict[str, Quantity] = {
    "position": Quantity("Joint position q and reference q_d", "rad", "q", "q_ref", "reference"),
    "tracking_error": Quantity("Tracking error e = q - q_d", "rad", "tracking_error"),
    "velocity": Quantity("Velocity: estimate and truth", "rad/s", "velocity/estimate", "velocity/true", "truth"),
    "velocity_error": Quantity("Velocity estimation error (truth - estimate)", "rad/s", "velocity_error"),
    "luaf": Quantity("Lumped uncertainty and fault (LUaF): estimate and truth", "rad/s^2", "luaf/estimate",
                     "luaf/true", "truth"),
    "luaf_error": Quantity("LUaF estimation error (truth - estimate)", "rad/s^2", "luaf_error"),
    "torque": Quantity("Control torque (command)", "N m", "torque"),
    "torque_delivered": Quantity("Delivered torque", "N m", "torque_delivered"),
    "sliding": Quantity("Sliding variable s", "rad/s", "sliding"),
    "fault": Quantity("Injected fault signal", FAULT_UNIT, "fault"),
    "fault_torque": Quantity("Generalized fault force", "N m", "fault_torque"),
    "fault_acceleration": Quantity("Fault acceleration M^-1 (fault force)", "rad/s^2", "fault_acceleration"),
    "residual": Quantity("Diagnosis residual and threshold", DIAGNOSIS_UNIT, "diagnosis/residual",
                         "diagnosis/threshold", "threshold"),
    "fault_estimate": Quantity("Fault estimate and injected fault", DIAGNOSIS_UNIT, "diagnosis/fault_estimate",
                               "<injected>", "injected"),
    "alarm": Quantity("Diagnosis alarm (0/1)", "", "diagnosis/alarm"),
}
#: Plugins' own signals (``extras.NAME``) whose units are known.
EXTRA_UNITS = {"switching_gain": "rad/s^2", "terminal_slope_term": "rad/s^2"}
EXTRA_PREFIX = "extras."
#: A signal's name: a plain identifier (no leading underscore: never an attribute of Python's own).
_EXTRA = re.compile(r"^extras\.[A-Za-z][A-Za-z0-9_]*$")


# ------------------------------------------------------------------------------------------------- the schema


class Span(Strict):
    """A time span [s]."""

    start: NonNegativeFloat = Field(description="Start of the span [s] (required).")
    end: Annotated[float, Field(gt=0, allow_inf_nan=False)] = Field(description="End of the span [s] (required).")

    @model_validator(mode="after")
    def _ordered(self) -> "Span":
        if self.end <= self.start:
            raise ValueError(f"end {self.end} must be after start {self.start}")
        return self


class ZoomSpec(Span):
    """A second panel per joint on ``[start, end]`` (default end: the end of the run); ``range`` fixes its
    vertical axis (default: the data); ``variants`` shows only these of the figure's (default: all)."""

    end: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = Field(  # type: ignore[assignment]
        None, description="End of the zoom [s]; default: the end of the run.")
    range: Annotated[list[FiniteFloat], Field(min_length=2, max_length=2)] | None = Field(
        None, description="The zoom's vertical axis [low, high] in the quantity's unit; default: the data.")
    variants: Annotated[list[str], Field(min_length=1)] | None = Field(
        None, description="The variants shown in the zoom; default: all of the figure's.")

    @model_validator(mode="after")
    def _ordered(self) -> "ZoomSpec":
        if self.end is not None and self.end <= self.start:
            raise ValueError(f"end {self.end} must be after start {self.start}")
        if self.range is not None and self.range[1] <= self.range[0]:
            raise ValueError(f"range {self.range}: the upper limit must be above the lower one")
        return self


class FigureSpec(Strict):
    """One entry of the scenario's ``figures`` section."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_-]+$")] = Field(
        description="File name (without extension) and the viewer tab's key: letters, digits, '_' and '-'.")
    title: str | None = Field(None, description="Heading; default: the quantity's title.")
    quantity: str = Field(
        description="One of QUANTITIES, or ``extras.NAME`` for a plugin's own signal (e.g. ``extras.switching_gain``).")
    variants: Annotated[list[str], Field(min_length=1)] | None = Field(None,
        description="Variants (and monitors, ``variant.monitor``) in the order of the legend; default: all.")
    joints: JointSelection = Field(None, description="Joints, by 1-based number or MJCF joint name; default: all.")
    window: Span | None = Field(None, description="The time span of the main panels; default: the whole run.")
    zoom: ZoomSpec | None = Field(None,
        description="A zoomed panel beside each joint's, e.g. the steady state after convergence.")

    @model_validator(mode="after")
    def _known_quantity(self) -> "FigureSpec":
        if self.quantity not in QUANTITIES and not _EXTRA.match(self.quantity):
            raise ValueError(f"unknown quantity {self.quantity!r} (quantities: {', '.join(QUANTITIES)}, "
                             "or extras.NAME for a method's own signal)")
        return self


def check_figure_names(spec: ScenarioSpec) -> None:
    """The checks that need the whole scenario (used by its validator): unique figure names, variants that exist
    (the file's variants and their monitors, before any ``--variant`` selection). Spans are not checked
    against the duration: a shortened run (``--duration``) shows what it has."""
    known = [name for name, variant in spec.variants.items()
             for name in (name, *(f"{name}.{monitor}" for monitor in variant.monitors))]
    seen: set[str] = set()
    for index, figure in enumerate(spec.figures):
        where = f"figures.{index}"
        if figure.name in seen:
            raise ValueError(f"{where}.name: {figure.name!r} is used twice")
        seen.add(figure.name)
        for position, variant in enumerate(figure.variants or ()):
            if variant not in known:
                raise ValueError(f"{where}.variants.{position}: unknown variant {variant!r} (variants: {', '.join(known)})")
        for position, variant in enumerate(figure.zoom.variants if figure.zoom and figure.zoom.variants else ()):
            if variant not in (figure.variants or known):
                raise ValueError(f"{where}.zoom.variants.{position}: {variant!r} is not one of the figure's variants")


# ------------------------------------------------------------------------------------------- compiled figures


@dataclass(frozen=True)
class Figure:
    """A compiled figure: everything needed to draw it, in plain data (stored in the recording as JSON)."""

    name: str
    title: str
    quantity: str
    unit: str
    variants: tuple[str, ...]
    joints: tuple[int, ...]  # 0-based
    window: tuple[float, float] | None = None
    zoom: tuple[float, float | None] | None = None
    zoom_range: tuple[float, float] | None = None
    #: The variants of the zoom panel (default: the figure's).
    zoom_variants: tuple[str, ...] | None = None

    def shown_in_zoom(self) -> tuple[str, ...]:
        return tuple(v for v in self.variants if self.zoom_variants is None or v in self.zoom_variants)

    @property
    def entity(self) -> str:
        return self.quantity.replace(".", "/", 1) if self.quantity.startswith(EXTRA_PREFIX) else QUANTITIES[self.quantity].entity

    @property
    def companion(self) -> tuple[str | None, str | None]:
        """(entity prefix, kind) of the companion line; the injected fault's entity depends on the space."""
        quantity = QUANTITIES.get(self.quantity)
        if quantity is None or quantity.companion is None:
            return None, None
        if quantity.companion_kind == "injected":
            entity = "fault_torque" if self.unit == "N m" else "fault_acceleration"
            return entity, "injected"
        return quantity.companion, quantity.companion_kind


@dataclass(frozen=True)
class VariantStyle:
    name: str
    color: str  # "#rrggbb"
    dash: Literal["solid", "dashed"]


def variant_styles(names: Sequence[str], monitors: Collection[str] = (),
                   colours: Mapping[str, str] | None = None) -> list[VariantStyle]:
    """One colour per variant: its colour in ``colours`` (a scenario's, :func:`ftc_mj.outputs.palette.
    declared_colours`: the same whichever variants run), a name it lacks the first colour free after them
    (:func:`ftc_mj.outputs.palette.assign_colours`); ``monitors`` (the names of estimators beside a loop,
    feeding nothing: :attr:`ftc_mj.results.VariantResult.host` is set) dashed, loops solid. The same in every
    figure and in the viewer."""
    known = dict(colours or {})
    chosen = assign_colours([*known, *(n for n in names if n not in known)], known)
    return [VariantStyle(name, chosen[name], "dashed" if name in monitors else "solid") for name in names]


def _units(spec: ScenarioSpec) -> dict[str, str]:
    spaces = {term.space for term in spec.terms if term.kind == "fault"}
    fault = {"acceleration": "rad/s^2", "torque": "N m"}.get(spaces.pop()) if len(spaces) == 1 else "rad/s^2 or N m"
    diagnosis = "N m" if spec.diagnosis is not None and spec.diagnosis.space == "torque" else "rad/s^2"
    return {FAULT_UNIT: fault or "", DIAGNOSIS_UNIT: diagnosis}


def _unit(quantity: str, units: dict[str, str]) -> str:
    if quantity.startswith(EXTRA_PREFIX):
        return EXTRA_UNITS.get(quantity[len(EXTRA_PREFIX):], "")
    unit = QUANTITIES[quantity].unit
    return units.get(unit, unit)


def compile_figures(spec: ScenarioSpec, model: mujoco.MjModel, variant_names: Sequence[str],
                    file: str, signals: Mapping[str, Collection[frozenset[str] | None]] | None = None) -> list[Figure]:
    """The scenario's figures (its ``figures`` section, else :func:`default_figures`) for the variants that
    run (``variant_names``, monitors included): a figure's variants not selected by ``--variant`` are left
    out, and a figure left with none is dropped.

    ``signals``: per variant (and monitor) name, the ``signal_names`` of the methods whose signals its result
    holds (:attr:`ftc_mj.methods.plugin.Method.signal_names`); a figure of ``extras.NAME`` that none of its
    variants' methods declares is refused (a method that declares nothing, None, may record any name)."""
    if not spec.figures:
        return default_figures(spec, model.nv, variant_names)
    units = _units(spec)
    figures = []
    for index, figure in enumerate(spec.figures):
        chosen = [v for v in (figure.variants or variant_names) if v in variant_names]
        if not chosen:
            continue
        joints = joint_indices(figure.joints, model, file, f"figures.{index}.joints")
        if figure.quantity.startswith(EXTRA_PREFIX) and signals is not None:
            _check_signal(figure.quantity[len(EXTRA_PREFIX):], chosen, signals, file, f"figures.{index}.quantity")
        figures.append(Figure(
            name=figure.name,
            title=figure.title or _title(figure.quantity),
            quantity=figure.quantity,
            unit=_unit(figure.quantity, units),
            variants=tuple(chosen),
            joints=tuple(joints),
            window=(figure.window.start, min(figure.window.end, spec.duration))
            if figure.window and figure.window.start < spec.duration else None,
            zoom=(figure.zoom.start, figure.zoom.end) if figure.zoom else None,
            zoom_range=tuple(figure.zoom.range) if figure.zoom and figure.zoom.range else None,
            zoom_variants=tuple(figure.zoom.variants) if figure.zoom and figure.zoom.variants else None,
        ))
    return figures


def _check_signal(name: str, variants: Sequence[str], signals: Mapping[str, Collection[frozenset[str] | None]],
                  file: str, field: str) -> None:
    """Refuse ``extras.NAME`` when no method of ``variants`` records ``name``."""
    declared = [names for variant in variants for names in signals.get(variant, ())]
    if any(names is None for names in declared):
        return  # a method that does not declare its signals may record this one
    recorded = sorted(set().union(*declared))
    if name not in recorded:
        raise InputError(file, field, f"no method of the figure's variants records a signal {name!r} (they record: "
                         f"{', '.join(recorded) or 'none'})")


def _title(quantity: str) -> str:
    if quantity.startswith(EXTRA_PREFIX):
        return f"Method signal: {quantity[len(EXTRA_PREFIX):].replace('_', ' ')}"
    return QUANTITIES[quantity].title


def default_figures(spec: ScenarioSpec, n: int, variant_names: Sequence[str]) -> list[Figure]:
    """Tracking error (zoomed from ``metrics.window_start``), velocity estimation error and LUaF estimation error
    (zoomed from ``metrics.estimation_window_start``), LUaF estimate and truth, torque; with a ``diagnosis``
    section its residual against the threshold and the fault estimate against the injected fault."""
    units = _units(spec)
    metrics = spec.metrics

    def zoom(start: float) -> tuple[float, None] | None:
        return (start, None) if 0 < start < spec.duration else None

    chosen = [("tracking_error", zoom(metrics.window_start)), ("velocity_error", zoom(metrics.estimation_window_start)),
              ("luaf", None), ("luaf_error", zoom(metrics.estimation_window_start)), ("torque", None)]
    if spec.diagnosis is not None:
        chosen += [("residual", None), ("fault_estimate", None)]
    return [Figure(name=quantity, title=_title(quantity), quantity=quantity, unit=_unit(quantity, units),
                   variants=tuple(variant_names), joints=tuple(range(n)), zoom=z) for quantity, z in chosen]


def generic_figures(n: int, variant_names: Sequence[str], quantities: Sequence[str]) -> list[Figure]:
    """One figure per quantity, every variant and joint, no zoom: for recordings written without a scenario."""
    return [Figure(name=q, title=_title(q), quantity=q, unit=_unit(q, {FAULT_UNIT: "", DIAGNOSIS_UNIT: ""}),
                   variants=tuple(variant_names), joints=tuple(range(n))) for q in quantities]


# ----------------------------------------------------------------------------------------- the stored layout


@dataclass
class Layout:
    """Everything the figures need besides the series: stored in the recording (a recording property) by
    :func:`ftc_mj.outputs.recording.write_recording` and read back by ``python -m ftc_mj.figures``.

    Series are stored per joint, one column per variant in ``variants`` order (NaN where a variant has no
    value, e.g. after it diverged); ``samples`` is each variant's own number of samples."""

    scenario: str
    duration: float
    fault_onsets: list[float]
    joints: list[str]
    variants: list[VariantStyle]
    samples: dict[str, int]
    figures: list[Figure] = field(default_factory=list)

    VERSION = 1

    def to_json(self) -> str:
        document = asdict(self)
        document["version"] = self.VERSION
        return json.dumps(document)

    @classmethod
    def from_json(cls, text: str) -> "Layout":
        document = json.loads(text)
        if document.pop("version", None) != cls.VERSION:
            raise ValueError("the recording's figure layout is of another version of ftc_mj")
        document["variants"] = [VariantStyle(**v) for v in document["variants"]]
        document["figures"] = [Figure(**{k: tuple(v) if isinstance(v, list) else v for k, v in f.items()})
                               for f in document["figures"]]
        return cls(**document)

    def style(self, variant: str) -> VariantStyle:
        return next(s for s in self.variants if s.name == variant)

    def column(self, variant: str) -> int:
        return next(i for i, s in enumerate(self.variants) if s.name == variant)


def zoom_span(figure: Figure, duration: float) -> tuple[float, float] | None:
    """The zoom panel's time span, clipped to the run; None when the run ends before it starts."""
    if figure.zoom is None:
        return None
    start, end = figure.zoom
    end = duration if end is None else min(end, duration)
    return (start, end) if start < end else None


def data_range(values: np.ndarray) -> tuple[float, float] | None:
    """A vertical range showing every finite value, with a 5 % margin; None without finite values."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return None
    low, high = float(finite.min()), float(finite.max())
    margin = 0.05 * (high - low) or max(abs(high), 1e-12) * 0.05
    return low - margin, high + margin


#: The most intervals between labelled ticks a stacked time-series panel of the viewer shows readably: its
#: plots (about 90 pixels high when six joints share a tab) label the y axis only at multiples of a power of
#: ten at least about 20 pixels apart.
MAX_TICK_INTERVALS = 4
#: The margin above and below a plot's data and ticks, in parts of its range.
TICK_MARGIN = 0.05


def tick_range(values: np.ndarray, intervals: int = MAX_TICK_INTERVALS) -> tuple[float, float] | None:
    """A vertical range over every finite value that holds at least two multiples of ``step``, the smallest
    power of ten with at most ``intervals`` steps over the data: the viewer's plots label only multiples of a
    power of ten far enough apart, so they show at least two labelled ticks, never a lone ``0``. The data's own
    range where it holds two such multiples; else its ends moved out to the next multiples (one end where one
    multiple is inside already, the one that costs the least room). None without finite values."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return None
    low, high = float(finite.min()), float(finite.max())
    if high - low <= 1e-9 * max(abs(low), abs(high)):  # a constant: a tenth of its size about it (zero: +-1)
        size = max(abs(low), abs(high))
        low, high = (low - 0.05 * size, high + 0.05 * size) if size > 0 else (-1.0, 1.0)
    step = 10.0 ** np.ceil(np.log10((high - low) / intervals))
    first = float(np.ceil(low / step) * step)  # the lowest multiple of step within the data, if any
    if first + step <= high:  # two inside
        bottom, top = low, high
    elif first <= high:  # one inside (the span is below two steps: either range stays within ``intervals``)
        bottom, top = (first - step, high) if low - (first - step) < first + step - high else (low, first + step)
    else:
        bottom, top = first - step, first
    # A margin: the viewer leaves out a tick label at the very edge of a plot.
    margin = TICK_MARGIN * (top - bottom)
    return float(bottom - margin), float(top + margin)
