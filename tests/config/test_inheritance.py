"""Scenario inheritance (ftc_mj.config.inheritance) and its use by load_scenario: the merge rules, chains,
refused chains, errors naming the file that wrote the value, and path fields written in a base."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.config.inheritance import MAX_DEPTH, Provenance, merge, resolve_bases
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
PUMA_YAML = ROOT / "scenarios" / "puma_fault.yaml"


def write(path: Path, data: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def puma(**changes) -> dict:
    """puma_fault.yaml's content with an absolute model path (so that it can be written anywhere)."""
    data = yaml.safe_load(PUMA_YAML.read_text(encoding="utf-8"))
    data["robot"]["model"] = str(ROOT / "models" / "puma560.xml")
    data.update(changes)
    return data


# --------------------------------------------------------------------------------------------------
# the merge rules


def test_mappings_merge_key_by_key_lists_and_scalars_replace_null_removes(tmp_path):
    write(tmp_path / "base.yaml", {"a": {"x": 1, "y": {"deep": 2, "kept": 3}}, "b": [1, 2, 3], "c": 4, "d": 5})
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "a": {"y": {"deep": 20}, "z": 6}, "b": [9],
                                            "c": "four", "d": None, "e": {"new": 7}})
    raw = resolve_bases(child).raw
    assert raw == {"a": {"x": 1, "y": {"deep": 20, "kept": 3}, "z": 6}, "b": [9], "c": "four", "e": {"new": 7}}
    assert list(raw) == ["a", "b", "c", "e"]  # the base's order, new keys after


def test_null_removes_inside_a_mapping_and_a_mapping_replaces_a_scalar():
    base = {"a": {"x": 1, "y": 2}, "s": 3}
    assert merge(base, {"a": {"x": None, "missing": None}, "s": {"now": "a mapping", "gone": None}}, "f") == {
        "a": {"y": 2}, "s": {"now": "a mapping"}}


def test_a_file_without_base_is_read_as_written_nulls_included(tmp_path):
    path = write(tmp_path / "plain.yaml", {"a": None, "b": {"c": None}})
    assert resolve_bases(path).raw == {"a": None, "b": {"c": None}}


def test_a_chain_of_three_files_applies_each_over_its_base(tmp_path):
    write(tmp_path / "grand.yaml", {"a": 1, "b": 1, "c": 1, "m": {"x": 1}})
    write(tmp_path / "sub" / "parent.yaml", {"base": "../grand.yaml", "b": 2, "c": 2, "m": {"y": 2}})
    child = write(tmp_path / "child.yaml", {"base": "sub/parent.yaml", "c": 3, "m": {"x": 3}})
    resolved = resolve_bases(child)
    assert resolved.raw == {"a": 1, "b": 2, "c": 3, "m": {"x": 3, "y": 2}}
    files = {key: resolved.provenance.file_of(key) for key in [("a",), ("b",), ("c",), ("m", "x"), ("m", "y")]}
    assert files == {("a",): os.path.normpath(tmp_path / "sub" / "../grand.yaml"),
                     ("b",): os.path.normpath(tmp_path / "sub" / "parent.yaml"), ("c",): str(child),
                     ("m", "x"): str(child), ("m", "y"): os.path.normpath(tmp_path / "sub" / "parent.yaml")}


def test_provenance_looks_a_path_up_by_its_longest_recorded_prefix():
    provenance = Provenance("child.yaml")
    provenance.record((), {"terms": [{"value": 1}], "m": {"x": 1}}, "base.yaml")
    assert provenance.file_of(("terms", 0, "value")) == "base.yaml"  # inside a list its file wrote
    assert provenance.file_of(("m", "x")) == "base.yaml"
    assert provenance.file_of(("m", "missing")) == "child.yaml"  # nobody wrote it: the file asked for
    provenance.claim(("terms", "0"), "child.yaml")  # e.g. --set terms.0.value=2
    assert provenance.file_of(("terms", 0, "value")) == "child.yaml"
    assert provenance.file_of(("terms", 1)) == "base.yaml"


# --------------------------------------------------------------------------------------------------
# chains refused


def test_a_cycle_is_refused_naming_the_file_and_base(tmp_path):
    write(tmp_path / "a.yaml", {"base": "b.yaml", "x": 1})
    b = write(tmp_path / "b.yaml", {"base": "a.yaml", "y": 1})
    with pytest.raises(InputError) as info:
        resolve_bases(tmp_path / "a.yaml")
    assert (info.value.file, info.value.field) == (str(b), "base")
    assert "cycle" in info.value.problem and "\n" not in str(info.value)


def test_a_file_that_is_its_own_base_is_a_cycle(tmp_path):
    path = write(tmp_path / "self.yaml", {"base": "./self.yaml"})
    with pytest.raises(InputError, match="cycle") as info:
        resolve_bases(path)
    assert (info.value.file, info.value.field) == (str(path), "base")


def test_a_missing_base_names_the_resolved_path(tmp_path):
    path = write(tmp_path / "child.yaml", {"base": "../elsewhere/none.yaml", "x": 1})
    with pytest.raises(InputError) as info:
        resolve_bases(path)
    assert (info.value.file, info.value.field) == (str(path), "base")
    assert str((tmp_path / ".." / "elsewhere" / "none.yaml").resolve()) in info.value.problem


@pytest.mark.parametrize("base", [3, "", None, ["a.yaml"]])
def test_a_base_that_is_not_a_path_is_refused(tmp_path, base):
    path = write(tmp_path / "child.yaml", {"base": base})
    with pytest.raises(InputError, match="must be the path") as info:
        resolve_bases(path)
    assert info.value.field == "base"


def test_the_chain_depth_is_bounded(tmp_path):
    write(tmp_path / "f0.yaml", {"level": 0})
    for k in range(1, MAX_DEPTH + 1):
        write(tmp_path / f"f{k}.yaml", {"base": f"f{k - 1}.yaml", "level": k})
    assert resolve_bases(tmp_path / f"f{MAX_DEPTH - 1}.yaml").raw == {"level": MAX_DEPTH - 1}  # 16 files
    with pytest.raises(InputError, match=f"more than {MAX_DEPTH}") as info:
        resolve_bases(tmp_path / f"f{MAX_DEPTH}.yaml")
    assert info.value.field == "base"


def test_a_base_with_invalid_yaml_names_the_base(tmp_path):
    base = tmp_path / "broken.yaml"
    base.write_text("a: [1, 2\n", encoding="utf-8")
    child = write(tmp_path / "child.yaml", {"base": "broken.yaml"})
    with pytest.raises(InputError, match="invalid YAML") as info:
        resolve_bases(child)
    assert info.value.file == str(base)


# --------------------------------------------------------------------------------------------------
# load_scenario on a base


def test_load_scenario_validates_the_merged_content_and_keeps_it_as_raw(tmp_path):
    write(tmp_path / "base.yaml", puma())
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "name": "child", "duration": 2.0,
                                            "variants": {"nftsmc": None, "nftsmc_sosmo": None},
                                            "parameters": {"zeta": 1.0}, "figures": None})
    scenario = load_scenario(child)
    assert (scenario.name, scenario.spec.duration) == ("child", 2.0)
    assert [v.name for v in scenario.variants] == ["proposed", "nftsmc_tosmo"]
    assert scenario.spec.parameters == {"fault_scale": 1.0, "zeta": 1.0}
    assert "base" not in scenario.written() and scenario.written()["variants"].keys() == {"proposed", "nftsmc_tosmo"}


def test_set_and_assignments_apply_after_the_merge(tmp_path):
    write(tmp_path / "base.yaml", puma())
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "seed": 3})
    scenario = load_scenario(child, overrides=["seed=5"], assignments={"parameters.zeta": 0.5})
    assert (scenario.spec.seed, scenario.spec.parameters["zeta"]) == (5, 0.5)
    assert scenario.written()["seed"] == 5


def test_a_bad_value_is_reported_against_the_file_that_wrote_it(tmp_path):
    base = write(tmp_path / "bases" / "base.yaml", puma(control_dt=-1.0))
    child = write(tmp_path / "child.yaml", {"base": "bases/base.yaml", "duration": 2.0})
    with pytest.raises(InputError) as info:
        load_scenario(child)
    assert (info.value.file, info.value.field) == (str(base), "control_dt")
    # The child's own bad value names the child; one it fixes is not reported at all.
    write(child, {"base": "bases/base.yaml", "control_dt": 0.001, "duration": -2.0})
    with pytest.raises(InputError) as info:
        load_scenario(child)
    assert (info.value.file, info.value.field) == (str(child), "duration")


def test_a_bad_value_deep_in_a_merged_mapping_names_its_file(tmp_path):
    base = write(tmp_path / "base.yaml", puma())
    base_data = puma()
    base_data["variants"]["proposed"]["observer"]["gains"]["gamma"] = "fast"
    write(base, base_data)
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "variants": {"proposed": {"observer": {
        "gains": {"D": 20.0}}}}})
    with pytest.raises(InputError) as info:
        load_scenario(child)
    assert info.value.file == str(base)
    assert info.value.field.startswith("variants.proposed.observer.gains")


def test_an_unknown_key_names_the_file_that_wrote_it(tmp_path):
    write(tmp_path / "base.yaml", puma())
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "metrics": {"window_begin": 1.0}})
    with pytest.raises(InputError, match="unknown key") as info:
        load_scenario(child)
    assert (info.value.file, info.value.field) == (str(child), "metrics.window_begin")


def test_a_set_override_is_reported_against_the_file_asked_for(tmp_path):
    write(tmp_path / "base.yaml", puma())
    child = write(tmp_path / "child.yaml", {"base": "base.yaml"})
    with pytest.raises(InputError) as info:
        load_scenario(child, overrides=["control_dt=-1"])
    assert (info.value.file, info.value.field) == (str(child), "control_dt")


def test_a_compile_error_in_a_base_value_names_the_base(tmp_path):
    """The compiler (not the schema) refuses a model file the base names: the base wrote it."""
    base = write(tmp_path / "base.yaml", puma())
    data = puma()
    data["robot"]["model"] = "no_such_model.xml"
    write(base, data)
    child = write(tmp_path / "child.yaml", {"base": "base.yaml", "name": "child"})
    with pytest.raises(InputError, match="not found") as info:
        load_scenario(child)
    assert (info.value.file, info.value.field) == (str(base), "robot.model")


# --------------------------------------------------------------------------------------------------
# path fields written in a base


def test_a_relative_model_path_in_a_base_in_another_folder_keeps_naming_its_file(tmp_path):
    """The base, in shared/bases/, names its model relative to itself; the child, two folders away, does
    not have that file beside it and still gets the base's model."""
    (tmp_path / "shared" / "models").mkdir(parents=True)
    model = tmp_path / "shared" / "models" / "arm.xml"
    model.write_bytes((ROOT / "models" / "puma560.xml").read_bytes())
    data = puma()
    data["robot"]["model"] = "../models/arm.xml"
    write(tmp_path / "shared" / "bases" / "base.yaml", data)
    child = write(tmp_path / "work" / "deep" / "child.yaml", {"base": "../../shared/bases/base.yaml",
                                                              "name": "child"})
    scenario = load_scenario(child)
    assert scenario.model_path == model.resolve()
    assert (child.parent / scenario.written()["robot"]["model"]).resolve() == model.resolve()


def test_a_model_path_the_child_writes_stays_relative_to_the_child(tmp_path):
    (tmp_path / "models").mkdir()
    model = tmp_path / "models" / "mine.xml"
    model.write_bytes((ROOT / "models" / "puma560.xml").read_bytes())
    write(tmp_path / "elsewhere" / "base.yaml", puma())
    child = write(tmp_path / "child.yaml", {"base": "elsewhere/base.yaml", "robot": {"model": "models/mine.xml"}})
    assert load_scenario(child).model_path == model.resolve()


def test_package_and_absolute_model_names_in_a_base_are_left_alone(tmp_path):
    data = puma()
    data["robot"]["model"] = "package://some-package/robot.urdf"
    write(tmp_path / "a" / "base.yaml", data)
    child = write(tmp_path / "child.yaml", {"base": "a/base.yaml"})
    assert resolve_bases(child, ["robot.model"]).raw["robot"]["model"] == "package://some-package/robot.urdf"
    write(tmp_path / "a" / "base.yaml", puma())
    assert resolve_bases(child, ["robot.model"]).raw["robot"]["model"] == str(ROOT / "models" / "puma560.xml")


def test_the_shipped_fault_scenarios_share_puma_faults_model_through_two_bases():
    path = ROOT / "scenarios" / "faults" / "puma_bias.yaml"
    scenario = load_scenario(path, duration=0.1)
    assert scenario.model_path == (ROOT / "models" / "puma560.xml").resolve()
    assert scenario.written()["robot"]["model"] == "../../models/puma560.xml"
