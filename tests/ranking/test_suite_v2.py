"""Suite v2's file and its bad input: disjoint seeded populations (checked), biases in residual units, the sanity
rows' names reserved, a tuning on scoring seeds refused, a fault case that would not act refused; each refusal
one line ``FILE: FIELD: PROBLEM``, exit 2, nothing written."""

from __future__ import annotations

import copy

import pytest
import yaml

from ftc_mj.cli.bench import main
from ftc_mj.config.errors import InputError
from ftc_mj.ranking.entries import load_bench
from ftc_mj.ranking.suite import load_suite, seed_ranges
from reduced_v2 import reduced_suite

ROOT = load_suite("v2").path.parents[3]


def test_v2_populations_are_disjoint_and_v1_is_superseded():
    suite = load_suite("v2")
    ranges = sorted(seed_ranges(suite.spec).values(), key=lambda r: r.start)
    assert all(a.stop <= b.start for a, b in zip(ranges, ranges[1:]))
    assert suite.calibrated and suite.populations("diagnosis") == ("calibrate", "healthy", "faults")
    assert load_suite("v1").spec.superseded_by == "v2" and not load_suite("v1").calibrated
    bench = load_bench()
    assert bench.suite.version == "v2"
    assert dict((e.name, e.reads) for e in bench.of("diagnosis"))["momentum"] == ("encoders", "tachometers", "torque")


def test_biases_are_sized_in_residual_units():
    suite = load_suite("v2")
    cases = suite.fault_cases("ur5e", "diagnosis")
    unit = suite.spec.robots["ur5e"].residual_unit[0]
    offsets = [c["set"]["actuator_faults"][0]["offset"] for c in cases
               if c["values"]["kind"] == "bias" and c["values"]["fault_joint"] == 2]
    assert offsets == pytest.approx([size * unit for size in suite.spec.faults.bias])


def write(folder, suite: dict, bench: dict | None = None) -> str:
    (folder / "suite.yaml").write_text(yaml.safe_dump(suite, sort_keys=False))
    bench = bench or {"suite": "suite.yaml", "diagnosis": {"momentum": {
        "gains_from": "design rule", "gains": {robot: {"K": 100.0} for robot in suite["robots"]}}}}
    (folder / "bench.yaml").write_text(yaml.safe_dump(bench, sort_keys=False))
    return str(folder / "bench.yaml")


def refused(capsys, argv: list[str], out) -> str:
    assert main(argv + ["--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert not out.exists()
    return err


def test_overlapping_seeds_are_refused(tmp_path, capsys):
    suite = reduced_suite()
    suite["populations"]["healthy"]["seed"] = suite["populations"]["calibrate"]["seed"] + 5
    err = refused(capsys, [write(tmp_path, suite)], tmp_path / "out")
    assert "suite.yaml" in err and "populations.healthy.seed" in err and "overlap" in err


@pytest.mark.parametrize("name", ["oracle_fault", "oracle_mine", "null"])
def test_entries_named_as_the_sanity_rows_are_refused(tmp_path, capsys, name):
    suite = reduced_suite()
    bench = {"suite": "suite.yaml", "diagnosis": {name: {
        "type": "momentum", "gains_from": "design rule", "gains": {robot: {"K": 100.0} for robot in suite["robots"]}}}}
    err = refused(capsys, [write(tmp_path, suite, bench)], tmp_path / "out")
    assert f"bench.yaml: diagnosis.{name}: " in err and "sanity rows" in err


def test_a_tuning_on_scoring_seeds_is_refused(tmp_path, capsys):
    suite = reduced_suite()
    scenario = ROOT / "scenarios" / "puma_fault.yaml"
    campaign = {"name": "on_scored_seeds", "scenario": str(scenario), "variants": ["proposed"],
                "seed": suite["populations"]["faults"]["seed"], "samples": {
                    "runs": 4, "fields": {"nominal.mass_scale": {"uniform": [0.9, 1.1]}}}}
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(campaign, sort_keys=False))
    tuning = {"name": "tuned", "campaign": "campaign.yaml", "variant": "proposed", "conditions": 2, "held_out": 2,
              "gains": {"variants.proposed.observer.gains.D": {"low": 5.0, "high": 50.0}},
              "cost": {"weights": {"rms_error_converged": 1.0}}}
    (tmp_path / "tuning.yaml").write_text(yaml.safe_dump(tuning, sort_keys=False))
    bench = {"suite": "suite.yaml", "diagnosis": {"momentum": {
        "gains_from": "tuned", "tuned_with": "tuning.yaml",
        "gains": {robot: {"K": 100.0} for robot in suite["robots"]}}}}
    err = refused(capsys, [write(tmp_path, suite, bench)], tmp_path / "out")
    assert "bench.yaml: diagnosis.momentum.tuned_with: " in err and "faults seeds" in err


@pytest.mark.slow
def test_a_fault_that_would_not_act_is_refused(tmp_path, capsys):
    """v1's saturation at 0.8 of the peak torque puts nothing on the PUMA560's plant."""
    suite = reduced_suite()
    suite["robots"] = {"puma560": suite["robots"]["puma560"]}
    suite["faults"] = {"bias_relative_to": "residual_unit", "bias": [1.0], "saturation": [0.8]}
    err = refused(capsys, [write(tmp_path, suite)], tmp_path / "out")
    assert "suite.yaml: faults.saturation: saturation_0.8_j2_t1.5 would put 0 N m on puma560's plant" in err


def test_v1_bench_files_still_load():
    suite = copy.deepcopy(load_suite("v1").spec)
    assert suite.calibration is None and suite.populations == {}
    with pytest.raises(InputError):
        load_suite("v3")
