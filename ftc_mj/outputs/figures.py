"""Static figures (matplotlib, Agg) of a run, drawn from its recording: one file per figure of its
:class:`~ftc_mj.outputs.layout.Layout`, a row of axes per joint, every variant overlaid in its one colour and
dash, the zoom panel beside, the fault onsets marked, one legend above the axes (it hides no data). Two sizes
(:data:`PRESETS`): ``page`` (8 in wide, the default) and ``column`` (3.5 in, one column of a two-column paper
such as IEEE's, its fonts at 7-8 pt when printed at that size). A line that lies on one drawn before it (two
variants alike to within a pixel for most of their length) is drawn dashed, so the one beneath shows through
its gaps; a truth band every variant shares is drawn once, grey as the legend's swatch (truths that differ:
one band per group of alike ones, in its first variant's colour).

Long series are reduced to their per-pixel envelope (minimum and maximum of each of :data:`ENVELOPE_BINS` time
bins, in time order) before drawing: the same picture, chattering included, at a fraction of the points, which
keeps PDF and SVG files small.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure as Drawing
from matplotlib.lines import Line2D
from matplotlib.ticker import ScalarFormatter

from ftc_mj.outputs.layout import Figure, Layout, data_range, zoom_span

FORMATS = ("png", "svg", "pdf")
#: Time bins of a drawn line's envelope: above twice this many samples a line is drawn as its envelope.
ENVELOPE_BINS = 1500
#: Width of a figure [in] and height of one joint's row [in] (the ``page`` preset).
WIDTH, ROW_HEIGHT = 8.0, 1.55
TRUTH_ALPHA, TRUTH_WIDTH, LINE_WIDTH = 0.35, 3.0, 0.9
DASHES = {"solid": "-", "dashed": "--"}
def over_alike(k: int) -> tuple[float, tuple[float, float]]:
    """The dash of the k-th line (k >= 1) drawn over alike ones: dashes of one period (6 pt) that fall in the
    earlier lines' gaps (k = 1: [0, 3], 2: [3, 4.5], 3 and more: [4.5, 5.25]), so that every line shows."""
    offset, on = ((0.0, 3.0), (3.0, 1.5), (4.5, 0.75))[min(k, 3) - 1]
    return (-offset, (on, 6.0 - on))
#: Two lines are alike where they differ by less than ALIKE of the panel's data range on ALIKE_SHARE of their
#: points (a line that covers another for most of its length hides it).
ALIKE, ALIKE_SHARE = 0.004, 0.9
#: The colour of a truth band that is every variant's (the legend's "truth" swatch).
TRUTH_COLOUR = "0.3"


@dataclass(frozen=True)
class Preset:
    """A figure's size [in] and font sizes [pt]."""

    width: float
    row_height: float
    title: float
    label: float
    tick: float
    legend: float
    legend_columns: int


#: ``page``: a full-width figure; ``column``: 3.5 in, a one-column figure of a two-column paper.
PRESETS: dict[str, Preset] = {
    "page": Preset(WIDTH, ROW_HEIGHT, title=10, label=8, tick=7, legend=7.5, legend_columns=5),
    "column": Preset(3.5, 1.15, title=8, label=7, tick=6, legend=6, legend_columns=3),
}

#: Series of one recording: entity -> (times [s], values (N, V)).
Series = dict[str, tuple[np.ndarray, np.ndarray]]


def entities_of(figure: Figure, layout: Layout) -> list[str]:
    """The recording entities a figure draws."""
    companion, _ = figure.companion
    prefixes = [figure.entity] + ([companion] if companion else [])
    return [f"/{prefix}/joint{joint + 1}" for prefix in prefixes for joint in figure.joints]


def envelope(t: np.ndarray, y: np.ndarray, bins: int = ENVELOPE_BINS) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)`` reduced to the minimum and maximum of each of ``bins`` equal time bins, in the order they occur
    (a bin with a NaN keeps one, so gaps stay gaps); unchanged when short."""
    n = len(t)
    if n <= 2 * bins:
        return t, y
    size = -(-n // bins)
    padded = np.concatenate([y, np.full(bins * size - n, np.nan)]).reshape(bins, size)
    gaps = np.isnan(padded)
    start = np.arange(bins) * size
    rows = np.concatenate([start + np.argmin(np.where(gaps, np.inf, padded), axis=1),
                           start + np.argmax(np.where(gaps, -np.inf, padded), axis=1),
                           (start + np.argmax(gaps, axis=1))[gaps.any(axis=1)]])
    rows = np.unique(rows[rows < n])
    return t[rows], y[rows]


def _tex(unit: str) -> str:
    """Plain units (rad/s^2, M^-1) in matplotlib's math text."""
    return unit.replace("^2", "$^2$").replace("^-1", "$^{-1}$")


def draw(figure: Figure, layout: Layout, series: Series, scenario_in_title: bool = False,
         preset: str = "page") -> Drawing:
    """One figure: a row per joint (overview, and the zoom panel when there is one), a legend above; the
    scenario's name after the title when ``scenario_in_title``; sized by ``preset`` (:data:`PRESETS`)."""
    size = PRESETS[preset]
    zoom = zoom_span(figure, layout.duration)
    columns = 2 if zoom else 1
    rows = len(figure.joints)
    handles = _legend(figure, layout, figure.companion[1])
    legend_rows = -(-len(handles) // min(size.legend_columns, len(handles)))
    fig = Drawing(figsize=(size.width, size.row_height * rows + 0.6 + 0.16 * legend_rows * size.legend / 7.5),
                  layout="constrained", facecolor="white")
    axes = fig.subplots(rows, columns, squeeze=False, sharex="col", width_ratios=[3, 2][:columns])
    companion, kind = figure.companion
    window = figure.window or (0.0, layout.duration)
    for row, joint in enumerate(figure.joints):
        main = series.get(f"/{figure.entity}/joint{joint + 1}")
        extra = series.get(f"/{companion}/joint{joint + 1}") if companion else None
        for column in range(columns):
            ax = axes[row, column]
            span = window if column == 0 else zoom
            variants = figure.variants if column == 0 else figure.shown_in_zoom()
            _panel(ax, variants, layout, main, extra, kind, span)
            if column == 1:
                limits = figure.zoom_range or (_visible_range(main, variants, layout, span) if main else None)
                if limits is not None:
                    ax.set_ylim(*limits)
            for onset in layout.fault_onsets:
                if span[0] <= onset <= span[1]:
                    ax.axvline(onset, color="0.45", linestyle=":", linewidth=1.0, zorder=0)
            ax.set_xlim(*span)
            ax.grid(True, linewidth=0.3, alpha=0.6)
            ax.tick_params(labelsize=size.tick)
            formatter = ScalarFormatter(useMathText=True)
            formatter.set_powerlimits((-3, 3))
            ax.yaxis.set_major_formatter(formatter)
            ax.yaxis.get_offset_text().set_fontsize(size.tick)
        label = layout.joints[joint] + (f" [{_tex(figure.unit)}]" if figure.unit else "")
        axes[row, 0].set_ylabel(label, fontsize=size.label)
    for column in range(columns):
        axes[-1, column].set_xlabel("time [s]", fontsize=size.label)
    if zoom:
        separator = "\n" if preset == "column" else ", "  # a narrow figure: the variants on a line of their own
        which = "" if figure.zoom_variants is None else f"{separator}{', '.join(figure.shown_in_zoom())}"
        axes[0, 1].set_title(f"zoom: {zoom[0]:g}-{zoom[1]:g} s{which}",
                             fontsize=size.tick if preset == "column" else size.label)
    fig.suptitle(f"{figure.title}  ({layout.scenario})" if scenario_in_title else figure.title, fontsize=size.title,
                 wrap=True)
    fig.legend(handles=handles, loc="outside lower center", ncol=min(size.legend_columns, len(handles)),
               fontsize=size.legend, frameon=False)
    fig.get_layout_engine().set(h_pad=0.02, w_pad=0.04, hspace=0.02)
    return fig


def _panel(ax: Axes, variants: Sequence[str], layout: Layout, main: tuple | None, extra: tuple | None,
           kind: str | None, span: tuple[float, float]) -> None:
    """One axes: each variant's companion line (truth wide and pale, or threshold dotted) and its own line; the
    legend's first variant drawn last, on top. A line alike to one beneath it (:data:`ALIKE`) is drawn with
    :func:`over_alike` dashes; a truth band alike to one drawn already is not drawn again."""
    drawn: list[np.ndarray] = []
    scale = _scale(main, [layout.column(v) for v in variants], span) if main is not None else 0.0
    if extra is not None and kind == "truth":
        _truth_bands(ax, variants, layout, extra, span, scale)
    for variant in reversed(variants):
        style = layout.style(variant)
        column = layout.column(variant)
        if extra is not None and kind not in ("reference", "truth"):  # threshold, injected fault: thin dotted
            t, values = extra
            y = values[:, column] if values.shape[1] > column else values[:, 0]
            ax.plot(*_cut(t, y, span), color=style.color, linestyle=":", linewidth=LINE_WIDTH, zorder=2)
        if main is not None:
            t, values = main
            cut = _cut(t, values[:, column], span)
            over = sum(_alike(cut[1], other, scale) for other in drawn)
            ax.plot(*cut, color=style.color, linestyle=over_alike(over) if over else DASHES[style.dash],
                    linewidth=LINE_WIDTH, zorder=3)
            drawn.append(cut[1])
    if extra is not None and kind == "reference":
        ax.plot(*_cut(extra[0], extra[1][:, 0], span), color="0.2", linestyle="--", linewidth=LINE_WIDTH, zorder=4)


def _truth_bands(ax: Axes, variants: Sequence[str], layout: Layout, extra: tuple, span: tuple[float, float],
                 scale: float) -> None:
    """The truths, wide and pale: one grey band where every variant's is alike (the legend's swatch), else one
    band per group of alike truths in the colour of its first variant."""
    t, values = extra
    cuts = {v: _cut(t, values[:, layout.column(v)] if values.shape[1] > layout.column(v) else values[:, 0], span)
            for v in variants}
    groups: list[list[str]] = []
    for variant in variants:
        group = next((g for g in groups if _alike(cuts[variant][1], cuts[g[0]][1], scale)), None)
        if group is None:
            groups.append([variant])
        else:
            group.append(variant)
    for group in reversed(groups):
        colour = TRUTH_COLOUR if len(groups) == 1 else layout.style(group[0]).color
        ax.plot(*cuts[group[0]], color=colour, alpha=TRUTH_ALPHA, linewidth=TRUTH_WIDTH, zorder=1)


def same_roc(p_fa: np.ndarray, p_d: np.ndarray, others: list[np.ndarray], tolerance: float = 0.005) -> int:
    """How many of ``others`` (each the :func:`roc_profile` of a curve drawn before) the ROC curve through
    (p_fa, p_d) is drawn as the same line as, to ``tolerance`` (0: none; for :func:`over_alike`): two
    detectors whose peaks differ but rank the runs alike give one line. Appends this curve's profile."""
    profile = roc_profile(p_fa, p_d)
    found = sum(bool(np.allclose(profile, other, atol=tolerance)) for other in others)
    others.append(profile)
    return found


def roc_profile(p_fa: np.ndarray, p_d: np.ndarray, points: int = 201) -> np.ndarray:
    """A ROC curve as the highest detection probability reached at or below each of ``points`` false-alarm
    probabilities from 0 to 1 (the curve is monotone, so this is the line drawn, whatever its thresholds)."""
    x, y = np.asarray(p_fa, float), np.asarray(p_d, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = np.concatenate(([0.0], x[ok])), np.concatenate(([0.0], y[ok]))
    grid = np.linspace(0.0, 1.0, points)
    order = np.argsort(x, kind="stable")
    best = np.maximum.accumulate(y[order])
    return best[np.searchsorted(x[order], grid, side="right") - 1]


def _scale(main: tuple, columns: Sequence[int], span: tuple[float, float]) -> float:
    """The data range of a panel's lines within ``span`` (0 when it has none)."""
    t, values = main
    inside = values[(t >= span[0]) & (t <= span[1])][:, columns]
    finite = inside[np.isfinite(inside)]
    return float(np.ptp(finite)) if finite.size else 0.0


def _alike(a: np.ndarray, b: np.ndarray, scale: float) -> bool:
    """Two drawn lines of the same samples that differ by less than :data:`ALIKE` of the panel's range."""
    if a.shape != b.shape:
        return False
    with np.errstate(invalid="ignore"):
        close = (np.abs(a - b) <= ALIKE * scale) | (np.isnan(a) & np.isnan(b))
    return bool(close.mean() >= ALIKE_SHARE) if close.size else False


def _cut(t: np.ndarray, y: np.ndarray, span: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The samples within ``span`` (one beyond each end, so the line reaches the axes), as their envelope."""
    first, last = np.searchsorted(t, span[0]), np.searchsorted(t, span[1], side="right")
    first, last = max(first - 1, 0), min(last + 1, len(t))
    return envelope(t[first:last], y[first:last])


def _visible_range(main: tuple, variants: Sequence[str], layout: Layout,
                   span: tuple[float, float]) -> tuple[float, float] | None:
    t, values = main
    inside = (t >= span[0]) & (t <= span[1])
    return data_range(values[inside][:, [layout.column(v) for v in variants]])


def _legend(figure: Figure, layout: Layout, kind: str | None) -> list[Line2D]:
    handles = [Line2D([], [], color=layout.style(v).color, linestyle=DASHES[layout.style(v).dash], label=v)
               for v in figure.variants]
    if kind == "truth":
        handles.append(Line2D([], [], color=TRUTH_COLOUR, alpha=TRUTH_ALPHA, linewidth=TRUTH_WIDTH,
                              label="truth (wide, pale)"))
    elif kind == "reference":
        handles.append(Line2D([], [], color="0.2", linestyle="--", label="reference $q_d$"))
    elif kind in ("threshold", "injected"):
        handles.append(Line2D([], [], color="0.3", linestyle=":", label="threshold" if kind == "threshold"
                              else "injected fault"))
    if layout.fault_onsets:
        handles.append(Line2D([], [], color="0.45", linestyle=":", label="fault onset"))
    return handles


#: Colours of a PNG's palette: line plots look the same at a third of the size of full colour.
PNG_COLOURS = 64


def save(fig: Drawing, stem: Path, formats: Sequence[str], dpi: int) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each format, without time stamps (a regenerated figure is the same
    file). PNGs are stored with a :data:`PNG_COLOURS`-colour palette that holds every opaque colour of the
    figure's legends exactly (:func:`png_palette`), so a swatch keeps its variant's colour even when its lines
    cover few pixels."""
    written = []
    for fmt in formats:
        path = stem.with_suffix(f".{fmt}")
        if fmt == "png":
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
            buffer.seek(0)
            # White (the background) and black (the text) exact, not a median cut's near-white and near-black.
            _quantised(buffer, [(255, 255, 255), (0, 0, 0), *legend_colours(fig)]).save(path, optimize=True)
        else:
            metadata = {"Date": None} if fmt == "svg" else {"CreationDate": None, "ModDate": None}
            fig.savefig(path, format=fmt, metadata=metadata)
        written.append(path)
    return written


def legend_colours(fig: Drawing) -> list[tuple[int, int, int]]:
    """The opaque line colours of the figure's legends (8-bit RGB), in order, without repeats."""
    from matplotlib.colors import to_rgba

    found: list[tuple[int, int, int]] = []
    for legend in fig.legends:
        for handle in legend.legend_handles:
            get = getattr(handle, "get_color", None)
            if get is None:
                continue
            r, g, b, a = to_rgba(get(), handle.get_alpha())
            rgb = (round(r * 255), round(g * 255), round(b * 255))
            if a == 1 and rgb not in found:
                found.append(rgb)
    return found


def png_palette(image, fixed: Sequence[tuple[int, int, int]], size: int = PNG_COLOURS) -> list[int]:
    """A flat RGB palette of ``size`` colours: ``fixed`` first, exactly, then the median-cut colours of the
    image (white included) not already there."""
    from PIL import Image

    cut = image.quantize(colors=size, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    flat = cut.getpalette()[:3 * size]
    colours = list(dict.fromkeys([*fixed, *(tuple(flat[i:i + 3]) for i in range(0, len(flat), 3))]))[:size]
    colours += [colours[-1]] * (size - len(colours))
    return [c for colour in colours for c in colour]


def _quantised(buffer: io.BytesIO, fixed: Sequence[tuple[int, int, int]]):
    """The image on :func:`png_palette`'s colours, each pixel the nearest of them (squared RGB distance). The
    mapping is computed here, over the image's distinct colours: Pillow's own ``quantize(palette=...)`` looks
    colours up in a coarse cube and put pure white on (251, 252, 252)."""
    from PIL import Image

    image = Image.open(buffer).convert("RGB")
    flat = png_palette(image, fixed)
    palette = np.array(flat, dtype=np.int32).reshape(-1, 3)
    pixels = np.asarray(image, dtype=np.int32).reshape(-1, 3)
    distinct, inverse = np.unique(pixels, axis=0, return_inverse=True)
    nearest = np.argmin(((distinct[:, None, :] - palette[None, :, :]) ** 2).sum(axis=2), axis=1)
    indices = nearest.astype(np.uint8)[inverse.reshape(-1)].reshape(image.size[1], image.size[0])
    out = Image.fromarray(indices, mode="P")
    out.putpalette(flat)
    return out
