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
    assert colours.count(layout.style("proposed").color) == 2  # estimate and its ground truth
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
