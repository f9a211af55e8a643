"""Suite v2's runs, reduced in the worker to what window scoring needs: per run, estimator and joint, the
envelope of the held residual (its largest value over each block of :data:`BLOCK` seconds), beside the run's
status and the torque its fault put on the plant.

The residual of an entry is its diagnoser's fault estimate in torque space (the LUaF estimate times M(q_meas),
less its mean over the protocol's baseline window: :class:`~ftc_mj.analysis.diagnosis.Diagnosis`). Held for the
persistence (the smallest |residual| over the last ``persistence`` samples), it alarms at a threshold c iff
held > c, so that the envelope holds every alarm decision at every threshold to one block: a window's peak, the
first block over c (the delay) and the alarms raised (re-arming upcrossings) are read off it after calibration
(:mod:`ftc_mj.ranking.calibrated`).

Three reference rows are the benchmark's own, computed by the same reduction from the engine's truth, which no
plugin sees (:data:`SANITY`):

* ``oracle_fault``: the true fault torque on the plant (``fault_torque``) plus white noise of
  ``oracle_noise`` x the robot's smallest residual unit: a perfect fault detector;
* ``oracle_luaf``: the true lumped uncertainty and fault in the diagnosis space, M_nom(q) (qdd - Psi -
  M_nom^-1 tau) with the run's nominal model (the plant's rigid-body model, masses scaled by the run's mass
  scale), M evaluated every :data:`MASS_EVERY` samples: a perfect LUaF estimator;
* ``null``: unit white noise, independent of everything: a useless detector (AUC 1/2).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from ftc_mj.campaign.execute import Task, compiled_scenario, frozen
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import run_batch
from ftc_mj.results import VariantResult
from ftc_mj.robot.nominal import rigid_body_model

#: The reference rows computed from the engine's truth (never plugins; no bench entry may take these names).
SANITY = ("oracle_fault", "oracle_luaf", "null")
#: The envelope's block [s]: the resolution of delays and of re-armed alarms.
BLOCK = 0.005
#: oracle_luaf's M(q) is evaluated every this many samples and held between (M changes over tens of ms).
MASS_EVERY = 5


@dataclass(frozen=True)
class Reduction:
    """What the worker keeps of a v2 diagnosis batch (plain data, sent to the worker with the batch)."""

    #: The entries' names: the reference variant's monitors, in order.
    entries: tuple[str, ...]
    #: oracle_fault's noise standard deviation [N m].
    oracle_noise: float
    #: The samples a block holds.
    block_samples: int


def held(residual: np.ndarray, samples: int) -> np.ndarray:
    """The smallest |residual| over the last ``samples`` samples, ``(N, n)`` (NaN before ``samples`` are in):
    an alarm at c held for the persistence is raised at sample k iff held[k] > c."""
    magnitude = np.abs(residual)
    if samples <= 1:
        return magnitude
    out = np.full_like(magnitude, np.nan)
    if len(magnitude) >= samples:
        out[samples - 1:] = np.lib.stride_tricks.sliding_window_view(magnitude, samples, axis=0).min(axis=-1)
    return out


def envelope(values: np.ndarray, block: int, blocks: int) -> np.ndarray:
    """The largest value of each block of ``block`` samples, ``(blocks, n)`` float32; NaN where a block holds no
    finite value (before the persistence is in, after a run stopped)."""
    n = values.shape[1]
    padded = np.full((blocks * block, n), np.nan)
    kept = min(len(values), blocks * block)
    padded[:kept] = values[:kept]
    shaped = padded.reshape(blocks, block, n)
    finite = np.isfinite(shaped).any(axis=1)
    out = np.where(finite, np.nanmax(np.where(np.isfinite(shaped), shaped, -np.inf), axis=1), np.nan)
    return out.astype(np.float32)


def baseline_removed(signal: np.ndarray, t: np.ndarray, baseline: tuple[float, float] | None) -> np.ndarray:
    """``signal`` less its mean over the baseline window [start, end) (as the diagnoser's fault estimate)."""
    if baseline is None:
        return signal
    inside = (t >= baseline[0]) & (t < baseline[1])
    if not inside.any():
        return signal
    return signal - signal[inside].mean(axis=0)


def mass_products(model: mujoco.MjModel, q: np.ndarray, vectors: np.ndarray, every: int = MASS_EVERY) -> np.ndarray:
    """M(q_k) v_k for every sample k, ``(N, n)``, with M evaluated at every ``every``-th sample and held."""
    data = mujoco.MjData(model)
    n = q.shape[1]
    out = np.empty_like(vectors)
    full = np.zeros((model.nv, model.nv))
    for start in range(0, len(q), every):
        data.qpos[:n] = q[start]
        mujoco.mj_fwdPosition(model, data)
        mujoco.mj_fullM(model, data, full)
        stop = min(start + every, len(q))
        out[start:stop] = vectors[start:stop] @ full[:n, :n].T
    return out


def _residuals(result: VariantResult, reduction: Reduction, rigid: mujoco.MjModel, mass_scale: float, seed: int,
               baseline: tuple[float, float] | None) -> dict[str, np.ndarray]:
    """Each estimator's residual ``(N, n)``: the entries' fault estimates and the sanity rows'."""
    out = {}
    for monitor in result.monitors:
        name = monitor.name.split(".", 1)[1]
        out[name] = monitor.diagnosis.fault_estimate if monitor.diagnosis is not None else monitor.luaf_hat
    t, shape = result.t, result.t.shape + (result.q_true.shape[1],)
    noise = np.random.default_rng([seed, 1]).standard_normal(shape)
    fault = result.fault_torque if result.fault_torque is not None else np.zeros(shape)
    out["oracle_fault"] = baseline_removed(fault + reduction.oracle_noise * noise, t, baseline)
    finite = np.nan_to_num(result.luaf_true)
    luaf = mass_scale * mass_products(rigid, np.nan_to_num(result.q_true), finite)
    out["oracle_luaf"] = baseline_removed(luaf, t, baseline)
    out["null"] = baseline_removed(np.random.default_rng([seed, 2]).standard_normal(shape), t, baseline)
    return out


def run_windows(task: Task, reduction: Reduction) -> dict[str, Any]:
    """Simulate one batch of a v2 diagnosis population; its reduction (:func:`save` writes it)."""
    scenario = compiled_scenario(task.scenario, task.variants, task.duration, frozen(task.structure))
    members = members_from_overrides(scenario, [member for _, _, member in task.runs])
    diagnoser = scenario.diagnoser
    persistence = max(1, diagnoser.persistence) if diagnoser is not None else 1
    baseline = diagnoser.baseline if diagnoser is not None else None
    rigid = rigid_body_model(scenario.model)
    steps = len(scenario.times)
    blocks = -(-steps // reduction.block_samples)
    names = reduction.entries + SANITY
    count, n = len(task.runs), scenario.n_joints
    kept = {name: np.full((count, blocks, n), np.nan, dtype=np.float32) for name in names}
    effect = np.zeros((count, n))
    diverged_at = np.full(count, np.nan)

    def keep(member: int, results: list[VariantResult]) -> None:
        result = results[0]
        values = task.runs[member][2]
        residuals = _residuals(result, reduction, rigid, float(values.get("nominal.mass_scale", 1.0)),
                               int(values["seed"]), baseline)
        for name in names:
            kept[name][member] = envelope(held(residuals[name], persistence), reduction.block_samples, blocks)
        if result.fault_torque is not None:
            effect[member] = np.nan_to_num(np.nanmax(held(result.fault_torque, persistence), axis=0, initial=0.0))
        if result.status != "ok":
            diverged_at[member] = result.diverged_at if result.diverged_at is not None else 0.0

    run_batch(scenario, members, memory_budget=task.memory_budget, nthread=task.nthread, on_result=keep)
    return {"run": np.array([index for index, _, _ in task.runs]), "run_id": np.array([i for _, i, _ in task.runs]),
            "seed": np.array([int(values["seed"]) for _, _, values in task.runs]),
            "diverged_at": diverged_at, "fault_effect": effect,
            **{f"envelope/{name}": values for name, values in kept.items()}}


def save(reduced: dict[str, Any]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **reduced)
    return buffer.getvalue()


def load(data: Any) -> dict[str, np.ndarray]:
    with np.load(data, allow_pickle=False) as archive:
        return {name: archive[name] for name in archive.files}
