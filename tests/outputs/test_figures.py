"""Static figures drawn from a recording: one row per joint, the zoom panel, each variant's line its own data
in its one colour and dash, the fault onset marked; the envelope keeps every bin's extremes."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.outputs import figures
from ftc_mj.outputs.recording import read_entities, read_layout, write_recording

SCENARIO = Path(__file__).parents[2] / "scenarios" / "puma_fault.yaml"


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """1.2 s of Chapter 5 with the fault moved to 0.6 s (onset marks), every variant."""
    scenario = load_scenario(SCENARIO, duration=1.2, overrides=["terms.2.onset=0.6", "diagnosis.baseline.start=0.1",
                                                                    "diagnosis.baseline.end=0.5"])
    path = tmp_path_factory.mktemp("figures") / "short.rrd"
    write_recording(path, scenario=scenario.name, model=scenario.model, results=run_scenario(scenario),
                    fault_onsets=scenario.fault_onsets, seed=0, figures=scenario.figures)
    return path


def test_backend_is_non_interactive() -> None:
    assert matplotlib.get_backend().lower() == "agg"


def test_figure_draws_each_variants_own_data(recording: Path) -> None:
    layout = read_layout(recording)
    figure = next(f for f in layout.figures if f.name == "fig5_3_velocity_error")
    series = read_entities(recording, set(figures.entities_of(figure, layout)))
    fig = figures.draw(figure, layout, series)
    axes = np.array(fig.axes).reshape(3, 2)  # three joints, overview and zoom (0-1 s)
    t, values = series["/velocity_error/joint2"]
    for variant in figure.variants:  # three observers, in their colours and dashes
        style = layout.style(variant)
        lines = [line for line in axes[1, 0].get_lines() if line.get_color() == style.color]
        assert len(lines) == 1 and lines[0].get_linestyle() == "-"
        np.testing.assert_array_equal(lines[0].get_ydata(), values[:, layout.column(variant)])
    assert not any(line.get_color() == layout.style("nftsmc").color for line in axes[1, 0].get_lines())
    onsets = [line for line in axes[0, 0].get_lines() if list(line.get_xdata()) == [0.6, 0.6]]
    assert len(onsets) == 1  # the fault onset, marked
    assert axes[0, 1].get_xlim() == (0.0, 1.0)
    assert "rad/s" in axes[0, 0].get_ylabel() and axes[0, 0].get_ylabel().startswith("joint1")
    legend = [text.get_text() for text in fig.legends[0].get_texts()]
    assert legend == ["proposed", "nftsmc_tosmo", "nftsmc_sosmo", "fault onset"]
    matplotlib.pyplot.close(fig)


def test_truth_beside_the_estimate_and_zoom_past_the_run(recording: Path) -> None:
    layout = read_layout(recording)
    figure = next(f for f in layout.figures if f.name == "fig5_4_luaf")  # zoom 9.5-12 s: beyond a 1.2 s run
    fig = figures.draw(figure, layout, read_entities(recording, set(figures.entities_of(figure, layout))))
    assert len(fig.axes) == 3  # no zoom column
    colours = [line.get_color() for line in fig.axes[0].get_lines()]
    # Each estimate in its colour; the ground truth, the same for every variant to within a pixel, once, grey.
    assert colours.count(figures.TRUTH_COLOUR) == 1
    assert all(colours.count(layout.style(v).color) == 1 for v in figure.variants), colours
    matplotlib.pyplot.close(fig)


@pytest.mark.slow  # a closed-loop run of seconds
def test_save_every_format(recording: Path, tmp_path: Path) -> None:
    from PIL import Image

    layout = read_layout(recording)
    figure = layout.figures[0]
    fig = figures.draw(figure, layout, read_entities(recording, set(figures.entities_of(figure, layout))))
    written = figures.save(fig, tmp_path / figure.name, ["png", "svg", "pdf"], dpi=60)
    assert [p.suffix for p in written] == [".png", ".svg", ".pdf"] and all(p.stat().st_size > 1000 for p in written)
    image = Image.open(written[0])
    assert image.mode == "P" and image.size[0] == int(figures.WIDTH * 60)
    assert written[1].read_text().startswith("<?xml") and written[2].read_bytes().startswith(b"%PDF")


def test_envelope_keeps_extremes_and_gaps() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(100_000) * 1e-3
    y = rng.standard_normal(len(t))
    y[50_000:50_500] = np.nan
    te, ye = figures.envelope(t, y, bins=1000)
    assert len(te) <= 3000 and np.all(np.diff(te) > 0)
    assert np.nanmax(ye) == np.nanmax(y) and np.nanmin(ye) == np.nanmin(y)
    for k in (0, 499, 999):  # every bin's extremes are kept
        part = y[k * 100:(k + 1) * 100]
        inside = ye[(te >= t[k * 100]) & (te <= t[(k + 1) * 100 - 1])]
        assert np.nanmax(inside) == np.nanmax(part) and np.nanmin(inside) == np.nanmin(part)
    assert np.isnan(ye).any()  # the gap stays a gap
    short = np.arange(10.0)
    assert figures.envelope(short, short)[0] is short


def test_a_line_on_an_alike_one_is_dashed_and_a_shared_truth_drawn_once():
    """Three variants, two of them alike (a difference of 0.1% of the range) and one apart, over their truths
    (two alike, one apart): the upper of the alike lines dashed so that the lower shows; two truth bands, each
    in its group's first variant's colour; with every truth alike, one band, grey."""
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    t = np.linspace(0.0, 1.0, 200)
    base = np.sin(2 * np.pi * t)
    main = (t, np.column_stack([base, base + 0.001, base + 0.5]))
    truth = (t, np.column_stack([base, base, base + 0.5]))
    styles = {name: SimpleNamespace(color=colour, dash="solid") for name, colour in
              (("a", "#d62728"), ("b", "#1f77b4"), ("c", "#2ca02c"))}
    layout = SimpleNamespace(style=styles.__getitem__, column="abc".index)
    ax = Figure().subplots()
    figures._panel(ax, ["a", "b", "c"], layout, main, truth, "truth", (0.0, 1.0))
    lines = {(line.get_color(), line.get_linewidth() == figures.TRUTH_WIDTH): line for line in ax.get_lines()}
    assert lines[("#d62728", False)].get_linestyle() == "--"  # a, drawn last, lies on b
    assert lines[("#1f77b4", False)].get_linestyle() == "-" and lines[("#2ca02c", False)].get_linestyle() == "-"
    bands = [line.get_color() for line in ax.get_lines() if line.get_linewidth() == figures.TRUTH_WIDTH]
    assert sorted(bands) == sorted(["#d62728", "#2ca02c"])
    ax = Figure().subplots()
    figures._panel(ax, ["a", "b"], layout, main, truth, "truth", (0.0, 1.0))
    bands = [line.get_color() for line in ax.get_lines() if line.get_linewidth() == figures.TRUTH_WIDTH]
    assert bands == [figures.TRUTH_COLOUR]


def test_the_column_preset_is_one_column_wide():
    assert figures.PRESETS["column"].width == pytest.approx(3.5) and figures.PRESETS["page"].width == figures.WIDTH
