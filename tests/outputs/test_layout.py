"""The scenario's figures section: strict validation (one line naming the file and the field), the defaults,
the --variant selection, and the layout's JSON round trip."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ftc_mj.outputs.layout import Layout, data_range, variant_styles
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

SCENARIO = Path(__file__).parents[2] / "scenarios" / "puma_fault.yaml"


def write(tmp_path: Path, figures: object, drop: str | None = None) -> Path:
    raw = yaml.safe_load(SCENARIO.read_text())
    raw["robot"]["model"] = str((SCENARIO.parent / raw["robot"]["model"]).resolve())
    raw["figures"] = figures
    if drop:
        del raw[drop]
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_shipped_figures_compile() -> None:
    scenario = load_scenario(SCENARIO)
    names = [f.name for f in scenario.figures]
    assert names == ["fig5_3_velocity_error", "fig5_4_luaf", "fig5_5_luaf_error", "fig5_6_tracking_error",
                     "fig5_7_torque"]
    tracking = scenario.figures[3]
    assert tracking.variants == ("proposed", "nftsmc_tosmo", "nftsmc_sosmo", "nftsmc")
    assert tracking.joints == (0, 1, 2) and tracking.unit == "rad" and tracking.zoom == (5.0, None)
    assert tracking.shown_in_zoom() == ("proposed", "nftsmc_tosmo")


def test_variant_selection_drops_what_did_not_run() -> None:
    scenario = load_scenario(SCENARIO, variants=["nftsmc"])
    assert [f.name for f in scenario.figures] == ["fig5_6_tracking_error", "fig5_7_torque"]
    assert all(f.variants == ("nftsmc",) for f in scenario.figures)


def test_defaults_without_a_section(tmp_path: Path) -> None:
    scenario = load_scenario(write(tmp_path, [], drop="figures"))
    assert [f.quantity for f in scenario.figures] == ["tracking_error", "velocity_error", "luaf", "luaf_error",
                                                      "torque", "residual", "fault_estimate"]
    assert scenario.figures[0].zoom == (5.0, None)  # metrics.window_start
    assert scenario.figures[1].zoom == (2.0, None)  # metrics.estimation_window_start
    assert scenario.figures[-1].companion == ("fault_acceleration", "injected")  # diagnosis in acceleration space


@pytest.mark.parametrize(("figures", "field", "problem"), [
    ([{"name": "a", "quantity": "speed"}], "figures.0", "unknown quantity 'speed'"),
    ([{"name": "a", "quantity": "torque", "variants": ["proposed", "nope"]}], "figures.0.variants.1",
     "unknown variant 'nope'"),
    ([{"name": "a", "quantity": "torque"}, {"name": "a", "quantity": "sliding"}], "figures.1.name", "used twice"),
    ([{"name": "a", "quantity": "torque", "zoom": {"start": 5.0, "end": 2.0}}], "figures.0.zoom", "must be after"),
    ([{"name": "a", "quantity": "torque", "zoom": {"start": 5.0, "range": [1.0, -1.0]}}], "figures.0.zoom",
     "upper limit"),
    ([{"name": "a", "quantity": "torque", "zoom": {"start": 5.0, "range": [1.0]}}], "figures.0.zoom.range", ""),
    ([{"name": "a", "quantity": "torque", "variants": ["nftsmc"], "zoom": {"start": 1.0, "variants": ["proposed"]}}],
     "figures.0.zoom.variants.0", "not one of the figure's variants"),
    ([{"name": "a", "quantity": "torque", "joints": ["elbow"]}], "figures.0.joints.0", "unknown joint 'elbow'"),
    ([{"name": "a", "quantity": "torque", "joints": [4]}], "figures.0.joints.0", "does not exist"),
    ([{"name": "a/b", "quantity": "torque"}], "figures.0.name", "pattern"),
    ([{"name": "a", "quantity": "torque", "colour": "red"}], "figures.0.colour", "unknown key"),
    ([{"name": "a", "quantity": "torque", "window": {"start": -1.0, "end": 2.0}}], "figures.0.window.start", ""),
    ({"name": "a"}, "figures", ""),
])
def test_bad_figures_are_one_line_errors(tmp_path: Path, figures: object, field: str, problem: str) -> None:
    path = write(tmp_path, figures)
    with pytest.raises(InputError) as caught:
        load_scenario(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {field}"), message
    assert problem in message and "\n" not in message


def test_a_short_run_keeps_its_figures(tmp_path: Path) -> None:
    """Spans beyond a shortened run are no error: the figure shows what the run has."""
    scenario = load_scenario(SCENARIO, duration=0.5)
    assert len(scenario.figures) == 5 and scenario.figures[3].zoom == (5.0, None)


def test_layout_round_trip_and_styles() -> None:
    scenario = load_scenario(SCENARIO)
    names = ["proposed", "nftsmc_tosmo", "proposed.sosmo"]
    layout = Layout(scenario="s", duration=3.0, fault_onsets=[1.0], joints=["a", "b", "c"],
                    variants=variant_styles(names, monitors={"proposed.sosmo"}), samples={n: 3000 for n in names},
                    figures=scenario.figures)
    again = Layout.from_json(layout.to_json())
    assert again == layout
    assert [s.dash for s in again.variants] == ["solid", "solid", "dashed"]  # monitors dashed
    assert len({s.color for s in again.variants}) == 3 and again.variants[0].color == "#d62728"


def test_data_range() -> None:
    import numpy as np

    assert data_range(np.array([[np.nan, -1.0], [3.0, np.inf]])) == pytest.approx((-1.2, 3.2))
    assert data_range(np.array([np.nan])) is None
    low, high = data_range(np.zeros(4))
    assert low < 0 < high
