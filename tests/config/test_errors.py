"""The one-line error of a failed validation (:mod:`ftc_mj.config.errors`): an unknown key is the mistake to
name first, with the closest key its place knows."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT / "scenarios" / "puma_fault.yaml"


def _error(tmp_path: Path, text: str) -> InputError:
    path = tmp_path / "s.yaml"
    path.write_text(f"base: {BASE}\n{text}")
    with pytest.raises(InputError) as caught:
        load_scenario(path)
    return caught.value


@pytest.mark.parametrize(("text", "field", "suggestion"), [
    ("durration: 3.0\n", "durration", "'duration'"),
    ("variants:\n  proposed:\n    observer: {type: hs_tosmo, gainz: {D: 22}}\n", "variants.proposed.observer.gainz",
     "'gains'"),
    ("diagnosis:\n  threshhold: {k: 5}\n", "diagnosis.threshhold", "'threshold'"),
])
def test_an_unknown_key_is_named_with_the_closest_known_one(tmp_path, text, field, suggestion):
    error = _error(tmp_path, text)
    assert error.field == field and error.problem.startswith("unknown key") and suggestion in error.problem, error


def test_no_suggestion_where_nothing_is_close(tmp_path):
    error = _error(tmp_path, "zzzz: 1\n")
    assert error.field == "zzzz" and error.problem == "unknown key", error


def test_the_unknown_key_comes_before_the_value_it_leaves_missing(tmp_path):
    raw = yaml.safe_load(BASE.read_text())
    raw["robot"]["model"] = str((BASE.parent / raw["robot"]["model"]).resolve())
    raw["variantz"] = raw.pop("variants")  # the required variants section is now missing too
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(InputError) as caught:
        load_scenario(path)
    assert caught.value.field == "variantz" and "did you mean 'variants'" in caught.value.problem
    assert caught.value.problem.endswith("; also variants: required field is missing"), caught.value.problem


def test_a_duration_beyond_any_count_of_periods_says_so(tmp_path):
    error = _error(tmp_path, "duration: 1.0e+308\n")
    assert error.field == "duration" and "too long" in error.problem and "inf" not in error.problem, error


def test_every_problem_is_listed_with_its_suggestion_up_to_a_few(tmp_path):
    """Three misspelt keys and a bad value: all four in the one line, each unknown key with its closest key;
    a fifth problem is counted, not listed."""
    text = ("durration: 3.0\ncontrol_dt: -1\ndiagnosis:\n  threshhold: {k: 5}\n"
            "variants:\n  proposed:\n    observer: {type: hs_tosmo, gainz: {D: 22}}\n")
    error = _error(tmp_path, text)
    line = str(error)
    assert "\n" not in line and line.startswith(str(tmp_path / "s.yaml") + ": ")
    for field, suggestion in (("durration", "'duration'"), ("diagnosis.threshhold", "'threshold'"),
                              ("variants.proposed.observer.gainz", "'gains'")):
        assert f"{field}: unknown key (did you mean {suggestion}?)" in line, line
    assert "control_dt: " in line and line.count("; also ") == 1 and line.count("; ") == 3, line
    error = _error(tmp_path, text + "zzzz: 1\n")
    assert str(error).endswith("(and 1 more problem)"), error
