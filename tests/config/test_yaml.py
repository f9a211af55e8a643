"""The bounded YAML loader (:mod:`ftc_mj.config.yaml`) and the input-file checks (:mod:`ftc_mj.config.paths`):
alias bombs, deep nesting, self-containing anchors, oversized and special files are one InputError naming the
file (and ``line N``) before anything is constructed; anchors, aliases and merge keys of normal files work."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from ftc_mj.config import yaml as loader
from ftc_mj.config.errors import InputError
from ftc_mj.config.yaml import MAX_FILE_BYTES, MAX_NESTING, apply_override, read_yaml_mapping

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted([*ROOT.glob("scenarios/**/*.yaml"), *ROOT.glob("campaigns/*.yaml"), *ROOT.glob("tuning/*.yaml")])


def bomb(levels: int = 9) -> str:
    """Ten to the ``levels`` values from ``levels`` lines ("billion laughs")."""
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, levels)]
    return "name: x\n" + "\n".join(lines) + "\n"


def refusal(tmp_path: Path, text: str) -> InputError:
    path = tmp_path / "f.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as caught:
        read_yaml_mapping(path, "a scenario")
    assert caught.value.file == str(path)
    return caught.value


def test_alias_bomb_is_refused_while_composing(tmp_path):
    error = refusal(tmp_path, bomb())
    assert "aliases expanded" in error.problem
    assert error.field.startswith("line ")


def test_alias_bomb_inside_a_mapping_value_and_a_merge_key(tmp_path):
    text = bomb(7).replace("name: x\n", "").replace("\n", "\n  ")
    assert "aliases expanded" in refusal(tmp_path, "description:\n  " + text + "\n").problem
    merges = "base: &b {" + ", ".join(f"k{i}: [{', '.join(['1'] * 100)}]" for i in range(100)) + "}\n"
    merges += "".join(f"m{i}: {{<<: *b}}\n" for i in range(40))
    assert "aliases expanded" in refusal(tmp_path, merges).problem


@pytest.mark.parametrize("opening, closing", [("[", "]"), ("{a: ", "}")])
def test_deep_nesting_is_refused_without_recursion(tmp_path, opening, closing):
    depth = 20 * MAX_NESTING
    error = refusal(tmp_path, "x: " + opening * depth + "1" + closing * depth + "\n")
    assert f"nested more than {MAX_NESTING} deep" in error.problem
    assert error.field == "line 1"


def test_nesting_up_to_the_bound_loads(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text("x: " + "[" * (MAX_NESTING - 1) + "1" + "]" * (MAX_NESTING - 1) + "\n")
    node = read_yaml_mapping(path, "a scenario")["x"]
    for _ in range(MAX_NESTING - 2):
        node = node[0]
    assert node == [1]


def test_an_alias_inside_its_own_anchor_is_refused(tmp_path):
    assert "contains itself" in refusal(tmp_path, "x: &a [1, *a]\n").problem
    assert "contains itself" in refusal(tmp_path, "x: &a {k: *a}\n").problem


def test_a_file_larger_than_the_bound_is_refused(tmp_path):
    error = refusal(tmp_path, "name: " + "x" * (MAX_FILE_BYTES + 1) + "\n")
    assert "larger than" in error.problem


def test_the_node_bound_counts_plain_values_too(tmp_path, monkeypatch):
    monkeypatch.setattr(loader, "MAX_NODES", 1000)
    error = refusal(tmp_path, "x: [" + ", ".join(["1"] * 1000) + "]\n")
    assert "more than 1000 values" in error.problem
    path = tmp_path / "g.yaml"
    path.write_text("x: [" + ", ".join(["1"] * 990) + "]\n")
    assert len(read_yaml_mapping(path, "a scenario")["x"]) == 990


@pytest.mark.parametrize("special, problem", [("/dev/zero", "not a regular file"), ("/dev/null", "not a regular file"),
                                              ("DIR", "is a directory")])
def test_special_files_are_refused_without_reading(tmp_path, special, problem):
    path = tmp_path if special == "DIR" else Path(special)
    if not path.exists():
        pytest.skip(f"no {special} here")
    with pytest.raises(InputError, match=problem):
        read_yaml_mapping(path, "a scenario")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_a_named_pipe_is_refused_without_waiting_for_a_writer(tmp_path):
    pipe = tmp_path / "pipe.yaml"
    os.mkfifo(pipe)
    with pytest.raises(InputError, match="not a regular file"):
        read_yaml_mapping(pipe, "a scenario")


def test_normal_anchors_aliases_and_merge_keys_still_work(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text("gains: &g {k1: 1.0, k2: 2.0}\n"
                    "a: {observer: {type: tosmo, gains: *g}}\n"
                    "b: {observer: {type: tosmo, gains: {<<: *g, k2: 3.0}}}\n"
                    "list: &l [1, 2]\nagain: *l\n")
    raw = read_yaml_mapping(path, "a scenario")
    assert raw["a"]["observer"]["gains"] == {"k1": 1.0, "k2": 2.0}
    assert raw["b"]["observer"]["gains"] == {"k1": 1.0, "k2": 3.0}
    assert raw["again"] == [1, 2]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_shipped_file_loads_as_pyyaml_loads_it(path):
    assert read_yaml_mapping(path, "a file") == yaml.safe_load(path.read_text(encoding="utf-8"))


def test_duplicate_keys_are_still_refused(tmp_path):
    error = refusal(tmp_path, "name: a\nname: b\n")
    assert "duplicate key" in error.problem and error.field == "line 2"


def test_a_set_value_is_bounded_too():
    raw: dict = {}
    with pytest.raises(InputError, match="nested more than"):
        apply_override(raw, "x=" + "[" * 1000 + "]" * 1000, "s.yaml")
    with pytest.raises(InputError, match="contains itself"):
        apply_override(raw, "x=&a [*a]", "s.yaml")
    apply_override(raw, "x=[1, {a: 2}]", "s.yaml")
    assert raw == {"x": [1, {"a": 2}]}


def test_the_bounds_are_the_loaders():
    assert issubclass(loader._UniqueKeyLoader, yaml.SafeLoader)
