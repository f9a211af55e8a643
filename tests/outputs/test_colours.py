"""One colour per variant everywhere: the colours read back from the files a run and a campaign leave (the
recording's layout and series lines, the PNG figures' pixels, the campaign's figures) agree per variant, follow
the scenario's declared order whichever variants run, and a variant's own ``colour`` is kept."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ftc_mj.cli.figures import main as figures_main
from ftc_mj.cli.run import main as run_main
from ftc_mj.outputs.palette import COLOURS, assign_colours, declared_colours, parse_colour

#: closed-loop runs and a campaign drawn as figures
pytestmark = pytest.mark.slow

ROOT = Path(__file__).parents[2]
SCENARIO = ROOT / "scenarios" / "puma_fault.yaml"
CAMPAIGN = ROOT / "campaigns" / "ch5_monte_carlo.yaml"
#: The Chapter 5 variants' colours, as in the dissertation's figures (the scenario's declared order).
EXPECTED = {"proposed": COLOURS["red"], "nftsmc_tosmo": COLOURS["blue"], "nftsmc_sosmo": COLOURS["green"],
            "nftsmc": COLOURS["black"]}


def _rgb(code: str) -> tuple[int, int, int]:
    return tuple(int(code[i:i + 2], 16) for i in (1, 3, 5))


def _pixels(path: Path, code: str, rows: slice = slice(None), alpha: float = 1.0) -> int:
    """Pixels of ``code`` (drawn with ``alpha`` on white: within 2 levels of the blend)."""
    image = np.asarray(Image.open(path).convert("RGB"))[rows].astype(int)
    target = np.round(alpha * np.array(_rgb(code)) + (1 - alpha) * 255)
    return int(np.all(np.abs(image - target) <= (0 if alpha == 1 else 2), axis=-1).sum())


def _series_colours(path: Path, entity: str) -> dict[str, str]:
    """The line colours a recording's static SeriesLines give each variant of one entity."""
    from rerun.chunk import RrdReader

    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static and chunk.entity_path == entity:
            batch = chunk.to_record_batch()
            if "SeriesLines:colors" in batch.schema.names:
                names = batch.column("SeriesLines:names").to_pylist()[0]
                colours = batch.column("SeriesLines:colors").to_pylist()[0]
                return {n: f"#{c >> 8:06x}" for n, c in zip(names, colours)}
    raise KeyError(entity)


@pytest.fixture(scope="module")
def run_files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two of the four variants, the later declared one first: its colour must stay its own."""
    folder = tmp_path_factory.mktemp("colours")
    rrd = folder / "run.rrd"
    assert run_main([str(SCENARIO), "--duration", "0.3", "--variant", "nftsmc_sosmo", "proposed", "--out", str(rrd),
                     "--quiet"]) == 0
    assert figures_main([str(rrd), "--out", str(folder / "figures"), "--only", "fig5_6_tracking_error"]) == 0
    return folder


def test_variants_a_figure_does_not_list_are_named(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rrd = tmp_path / "run.rrd"
    assert run_main([str(SCENARIO), "--duration", "0.02", "--out", str(rrd), "--quiet"]) == 0
    capsys.readouterr()
    assert figures_main([str(rrd), "--out", str(tmp_path / "f"), "--only", "fig5_3_velocity_error", "--dpi",
                         "30"]) == 0
    captured = capsys.readouterr()
    assert captured.err.strip() == "fig5_3_velocity_error: not shown (not in its variants): nftsmc"
    assert captured.out.strip() == str(tmp_path / "f" / "fig5_3_velocity_error.png")


def test_assignment_by_declared_order_and_pinned_colours() -> None:
    assert assign_colours(["a", "b", "c"]) == {"a": COLOURS["red"], "b": COLOURS["blue"], "c": COLOURS["green"]}
    # b's own colour is red: a takes the next free one, c too.
    assert assign_colours(["a", "b", "c"], {"b": "red"}) == {"a": COLOURS["blue"], "b": COLOURS["red"],
                                                             "c": COLOURS["green"]}
    assert declared_colours({"x": {"monitors": {"m": {}}}, "y": {"colour": "#ABCDEF"}}) == {
        "x": COLOURS["red"], "x.m": COLOURS["blue"], "y": "#abcdef"}
    with pytest.raises(ValueError, match="not a colour"):
        parse_colour("mauve")


def test_the_recording_keeps_the_declared_colours(run_files: Path) -> None:
    from ftc_mj.outputs.recording import read_layout

    rrd = run_files / "run.rrd"
    layout = {s.name: s.color for s in read_layout(rrd).variants}
    assert layout == {v: EXPECTED[v] for v in ("nftsmc_sosmo", "proposed")}
    assert _series_colours(rrd, "/tracking_error/joint1") == layout


def test_the_png_legend_swatches_have_the_exact_colours(run_files: Path) -> None:
    png = run_files / "figures" / "fig5_6_tracking_error.png"
    height = Image.open(png).height
    legend = slice(int(height * 0.9), None)  # the legend below the axes
    for variant in ("nftsmc_sosmo", "proposed"):
        assert _pixels(png, EXPECTED[variant], legend) >= 20, variant
    assert _pixels(png, EXPECTED["nftsmc_tosmo"]) == 0  # not run: not drawn
    # Every opaque legend colour (the onset marker's grey too) survives the PNG's 64-colour palette.
    from ftc_mj.outputs import figures
    from ftc_mj.outputs.recording import read_entities, read_layout

    layout = read_layout(run_files / "run.rrd")
    figure = next(f for f in layout.figures if f.name == "fig5_6_tracking_error")
    drawn = figures.draw(figure, layout, read_entities(run_files / "run.rrd", set(figures.entities_of(figure, layout))))
    for rgb in figures.legend_colours(drawn):
        assert _pixels(png, "#%02x%02x%02x" % rgb, legend) >= 20, rgb


def test_the_campaign_figures_use_the_run_colours(tmp_path: Path) -> None:
    from ftc_mj.campaign import execute
    from ftc_mj.campaign.summary import read, write_report

    out = tmp_path / "campaign"
    execute.execute(execute.load(CAMPAIGN, 2, duration=0.3), out, workers=1)
    written = write_report(out)
    results = read(out)
    assert results.colours == EXPECTED
    box = next(p for p in written if p.name.startswith("box_"))
    metric = box.stem.removeprefix("box_")


    def box_height(variant: str) -> float:
        values = results.of(variant, f"{metric}.1").astype(float)
        values = values[np.isfinite(values)]
        return float(np.subtract(*np.percentile(values, [75, 25]))) if values.size else 0.0

    shown = [v for v in EXPECTED if box_height(v) > 0]  # a box of no height shows no face
    assert "proposed" in shown and len(shown) >= 2
    for variant in shown:
        assert _pixels(box, EXPECTED[variant], alpha=0.6) >= 20, variant  # the boxes' faces
