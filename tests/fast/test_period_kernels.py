"""The per-period kernels of the loop against their NumPy definitions, each on random and edge-case inputs
(NaN, infinities, a stopped row, one joint, rows that are not a multiple of the members): the sensor effects
(ftc_mj.fast.sensors against ftc_mj.effects.sensors.measure), the plant's bounds check (ftc_mj.fast.plant against
ftc_mj.engine.plant.within), the sparse solve (ftc_mj.fast.rigid.solve_factored against
ftc_mj.robot.nominal.solve_sparse and MuJoCo's mj_solveM) and the truths' solve (ftc_mj.fast.truths against
ftc_mj.engine.truths.record). Stated tolerance: none (each does the definition's IEEE operations in its order)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.effects.sensors import measure
from ftc_mj.engine.plant import within
from ftc_mj.engine.truths import record
from ftc_mj.fast import plant as fast_plant
from ftc_mj.fast import sensors as fast_sensors
from ftc_mj.fast import truths as fast_truths
from ftc_mj.fast.rigid import solve_factored
from ftc_mj.robot.nominal import SparseSolver, solve_sparse

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ["models/puma560.xml", "models/two_link.xml"]


@pytest.mark.parametrize(("rows", "members", "n"), [(6, 3, 3), (5, 5, 1), (1, 1, 6)])
@pytest.mark.parametrize("edge", [False, True], ids=["random", "nan-inf-stuck"])
def test_the_sensor_pass_is_its_definition(rows: int, members: int, n: int, edge: bool) -> None:
    rng = np.random.default_rng(rows * 7 + n)
    source, offsets = rng.normal(size=(rows, n)), rng.normal(size=(members, n)) * 1e-3
    resolution = np.where(rng.random(n) < 0.5, 2 * np.pi / 4096, 0.0)
    quantised = resolution > 0
    inverse_step = np.divide(1.0, resolution, out=np.zeros(n), where=quantised)
    stuck = rng.random(n) < 0.3 if edge else np.zeros(n, dtype=bool)
    if edge:
        source[0, 0], source[-1, -1] = np.nan, np.inf
    last = rng.normal(size=(rows, n))
    for offset in (True, False):
        outs, lasts = [np.full((rows, n), 7.0) for _ in range(2)], [last.copy() for _ in range(2)]
        for function, out, kept in zip((measure, fast_sensors.measure), outs, lasts):
            function(source, offsets, offset, bool(quantised.any()), inverse_step, resolution, quantised, stuck,
                     kept, out)
        np.testing.assert_array_equal(outs[0], outs[1])
        np.testing.assert_array_equal(lasts[0], lasts[1])


@pytest.mark.parametrize("case", ["within", "position", "velocity", "nan", "stopped-row-beyond"])
def test_the_bounds_check_is_its_definition(case: str) -> None:
    rng = np.random.default_rng(3)
    qpos, qvel, alive = rng.uniform(-1, 1, (4, 3)), rng.uniform(-5, 5, (4, 3)), np.ones(4, dtype=bool)
    if case == "position":
        qpos[2, 1] = 1.5
    elif case == "velocity":
        qvel[0, 0] = -7.0
    elif case == "nan":
        qvel[3, 2] = np.nan
    elif case == "stopped-row-beyond":
        qpos[1] = np.inf
        alive[1] = False
    expected = within(qpos, qvel, alive, 1.0, 6.0)
    assert fast_plant.within(qpos, qvel, alive, 1.0, 6.0) == expected
    assert expected == (case in ("within", "stopped-row-beyond"))


def factored(path: str, rows: int) -> tuple[mujoco.MjModel, list[mujoco.MjData], np.ndarray, np.ndarray]:
    """``rows`` MjData of the robot at random states, factorised; their qLD and qLDiagInv stacked."""
    model = mujoco.MjModel.from_xml_path(str(ROOT / path))
    rng = np.random.default_rng(model.nv)
    datas = []
    for _ in range(rows):
        data = mujoco.MjData(model)
        data.qpos[:] = rng.uniform(-np.pi, np.pi, model.nq)
        mujoco.mj_forward(model, data)
        datas.append(data)
    return (model, datas, np.array([d.qLD.copy() for d in datas]),
            np.array([d.qLDiagInv.copy() for d in datas]))


@pytest.mark.parametrize("path", [*ROBOTS, "models/panda.xml", "models/ur5e.xml"])
def test_the_sparse_solve_is_its_definition_and_mujocos(path: str) -> None:
    model, datas, factor, diagonal_inverse = factored(path, 5)
    solver = SparseSolver(model)
    rng = np.random.default_rng(1)
    vector = rng.normal(size=(5, model.nv)) * 10.0 ** rng.integers(-5, 5, (5, model.nv))
    vector[2, 0] = np.nan
    defined, compiled = np.full_like(vector, 7.0), np.full_like(vector, -7.0)
    solve_sparse(factor, diagonal_inverse, vector, defined, *solver.structure)
    solve_factored(factor, diagonal_inverse, vector, compiled, *solver.structure)
    np.testing.assert_array_equal(compiled, defined)
    for row, data in enumerate(datas):
        if row == 2:
            continue  # NaN in: NaN out, compared above
        mujocos = np.empty((1, model.nv))
        mujoco.mj_solveM(model, data, mujocos, vector[row:row + 1])
        np.testing.assert_array_equal(defined[row], mujocos[0])


@pytest.mark.parametrize("scaled", [False, True])
@pytest.mark.parametrize("fault", [False, True])
def test_the_truths_solve_is_its_definition(scaled: bool, fault: bool) -> None:
    model, _, factor, diagonal_inverse = factored(ROBOTS[0], 4)
    solver = SparseSolver(model)
    rng = np.random.default_rng(2)
    steps, n = 3, model.nv
    tau, bias = rng.normal(size=(4, n)), rng.normal(size=(4, n))
    scale = rng.uniform(0.8, 1.2, (4, 1))
    fault_torque = rng.normal(size=(steps, 4, n))
    results = []
    for function in (record, fast_truths.record):
        force, luaf, acceleration = np.zeros((4, n)), np.full((steps, 4, n), 7.0), np.full((steps, 4, n), 7.0)
        function(factor, diagonal_inverse, tau, bias, scale, scaled, force, luaf, fault_torque, acceleration,
                 *solver.structure, 1, fault)
        results.append((force, luaf, acceleration))
    for defined, compiled in zip(*results):
        np.testing.assert_array_equal(compiled, defined)
    assert (results[0][2][1] != 7.0).all() == fault
