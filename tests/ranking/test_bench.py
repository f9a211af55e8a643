"""A tiny bench end to end (one robot, two observers and a pair, a few runs of 0.8 s): the leaderboard's
files, and a second bench with one more entry, a third-party observer registered for this test only, that
simulates that entry alone and reuses every run of the first."""

from __future__ import annotations

import copy
import json
from typing import ClassVar

import numpy as np
import pyarrow.parquet as pq
import pytest

import tiny_suite
from ftc_mj.ranking import execute
from ftc_mj.ranking.entries import load_bench
from ftc_mj.cli.bench import main
from ftc_mj.methods import observers, registry
from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer

#: campaigns, calibrations, tunings and benchmarks of closed-loop runs
pytestmark = pytest.mark.slow


class LinearObserverConfig(GainConfig):
    bandwidth: PositiveJoints


class LinearObserver(Observer):
    """A third-party observer as a plugin author writes it: a linear extended-state observer with its three
    poles at -bandwidth (gains 3w, 3w^2, w^3)."""

    name: ClassVar[str] = "test_linear"
    Config: ClassVar[type[LinearObserverConfig]] = LinearObserverConfig

    def __init__(self, config: LinearObserverConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        w = config.bandwidth
        self.l1, self.l2, self.l3 = 3.0 * w, 3.0 * w**2, w**3
        self._error = np.zeros(self.shape)

    def update(self, t: float, q_meas: np.ndarray, model) -> None:
        np.subtract(q_meas, self.q_hat, out=self._error)
        self.injection[:] = self.luaf_hat + self.l2 * self._error

    def advance(self, tau: np.ndarray, model) -> None:
        qdd_hat = model.psi_hat + model.command_acceleration(tau) + self.injection
        self.q_hat += self.dt * (self.qd_hat + self.l1 * self._error)
        self.qd_hat += self.dt * qdd_hat
        self.luaf_hat += self.dt * self.l3 * self._error


@pytest.fixture(scope="module")
def plugin():
    """The test observer registered as a plugin while the module's tests run (the bench runs in this process:
    --workers 1)."""
    with pytest.MonkeyPatch.context() as patch:
        registry._discover.cache_clear()
        patch.setitem(observers.BUILTIN, LinearObserver.name, LinearObserver)
        yield LinearObserver.name
    registry._discover.cache_clear()


@pytest.fixture(scope="module")
def benches(tmp_path_factory, plugin):
    """The first bench, then the same with the third-party entry added, into one output directory."""
    folder = tmp_path_factory.mktemp("bench")
    out = folder / "out"
    first = tiny_suite.write(folder)
    assert main([str(first), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    before = {p: p.stat().st_mtime_ns for p in (out / "runs").rglob("parts/*.parquet")}
    board = pq.read_table(out / "leaderboard.parquet").to_pylist()
    more = copy.deepcopy(tiny_suite.entries())
    more["diagnosis"]["third_party"] = {"type": plugin, "gains_from": "its author's bandwidth",
                                        "gains": {"puma560": {"bandwidth": 40.0}}}
    second = tiny_suite.write(folder, more, name="more.yaml")
    assert main([str(second), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    return out, before, board


def test_the_leaderboard_files(benches):
    out, _, board = benches
    for name in ("leaderboard.md", "leaderboard.csv", "leaderboard.parquet", "bench.json", "figures/roc.png",
                 "figures/ranked.png"):
        assert (out / name).is_file(), name
    text = (out / "leaderboard.md").read_text()
    assert "## Diagnosis: puma560" in text and "## Tracking: puma560" in text and "Chapter 5" in text
    info = json.loads((out / "bench.json").read_text())
    assert info["suite"] == "tiny" and set(info["versions"]) == {"ftc_mj", "mujoco", "numpy"}
    entries = {(row["task"], row["entry"]) for row in board}
    assert entries == {("diagnosis", "hs_tosmo"), ("diagnosis", "tosmo"), ("tracking", "proposed")}
    auc = [row for row in board if row["score"] == "auc"]
    assert all(0.0 <= row["low"] <= row["value"] <= row["high"] <= 1.0 for row in auc)


def test_one_more_entry_simulates_that_entry_alone(benches):
    out, before, board = benches
    after = {p: p.stat().st_mtime_ns for p in (out / "runs").rglob("parts/*.parquet")}
    assert all(after[p] == before[p] for p in before)  # the first bench's runs are not simulated again
    new = set(after) - set(before)
    manifests = {json.loads((p.parents[2] / "entries.json").read_text())["protocol"]: p for p in new}
    assert manifests
    for part in new:  # only the third-party observer's campaigns are new
        entries = json.loads((part.parents[2] / "entries.json").read_text())["entries"]
        assert list(entries.values()) == ["third_party"]
        assert "diagnosis" in part.parts
    suite = tiny_suite.suite()
    expected = suite["tiers"]["quick"]["healthy_runs"] + 2 * suite["tiers"]["quick"]["fault_runs"]
    # One row per run for the reference loop and one for its one monitor.
    assert sum(pq.read_table(p).num_rows for p in new) == 2 * expected
    again = pq.read_table(out / "leaderboard.parquet").to_pylist()
    assert [row for row in again if row["entry"] != "third_party"] == board  # the same scores, reused
    assert {row["entry"] for row in again if row["task"] == "diagnosis"} == {"hs_tosmo", "tosmo", "third_party"}
    assert "`third_party` | test_linear" in (out / "leaderboard.md").read_text()


def test_a_third_run_simulates_nothing(benches):
    out, _, _ = benches
    bench = load_bench(out.parent / "more.yaml")
    done, chunks = execute.plan(bench, "quick", out)
    assert chunks == [] and len(done) == 2 * len(bench.entries)  # healthy and faulty populations
