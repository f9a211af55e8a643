"""The controller's nominal model (its batches, :func:`~ftc_mj.robot.nominal.nominal_batch`; the tests' single-state
oracle ``NominalModel``) and the per-period quantities (``StepModel``) on the PUMA560.

The reference values are computed independently, each on a fresh MjData with ``mj_forward`` and ``mj_fullM``:
M(q), and C(q, qd) qd + G(q) = qfrc_bias. The check values of shared/reference/puma560.md give Psi at the
check states to 4 decimals.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from nominal_oracle import NominalModel, step_model

from ftc_mj.robot.nominal import TreeNominal, MuJoCoNominal, StepModel, nominal_batch, rigid_body_model

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"
CHECK_QD = np.array([0.4, -0.3, 0.9])

# shared/reference/puma560.md: q, M(q) rows, G(q), C(q, qd) qd for qd = (0.4, -0.3, 0.9).
CHECK_VALUES = [
    (
        (0.0, 0.0, 0.0),
        [(3.96863, -0.16266, -0.13891), (-0.16266, 4.45662, 0.37274), (-0.13891, 0.37274, 0.93865)],
        (0.0, 37.48367, 0.24893),
        (-0.25258, -0.03952, 0.09834),
    ),
    (
        (-0.5, -0.5, -0.5),
        [(4.40134, 0.2383, -0.07185), (0.2383, 4.82417, 0.55651), (-0.07185, 0.55651, 0.93865)],
        (0.0, 40.68362, 7.51605),
        (-0.44862, -0.17222, 0.08047),
    ),
    (
        (0.3, -1.1, 0.7),
        [(2.88224, 0.47804, -0.12647), (0.47804, 3.95398, 0.12141), (-0.12647, 0.12141, 0.93865)],
        (0.0, 21.44761, 3.64533),
        (-0.37678, -0.16373, 0.07229),
    ),
]


def load() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(PUMA))


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load()


def reference_dynamics(m: mujoco.MjModel, q, qd) -> tuple[np.ndarray, np.ndarray]:
    """(M(q), C(q, qd) qd + G(q)) on a fresh MjData."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    d.qvel[:] = qd
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return M, d.qfrc_bias.copy()


def random_states(count: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-np.pi, np.pi, 3), rng.uniform(-2.0, 2.0, 3)) for _ in range(count)]


def test_psi_equals_minus_M_inverse_bias(model):
    nominal = NominalModel(model)
    for q, qd in random_states(10) + [(np.array(row[0]), CHECK_QD) for row in CHECK_VALUES]:
        M, bias = reference_dynamics(model, q, qd)
        np.testing.assert_allclose(nominal.psi(q, qd), -np.linalg.solve(M, bias), rtol=0, atol=1e-10)
        np.testing.assert_allclose(nominal.mass_matrix(q), M, rtol=0, atol=1e-10)
        np.testing.assert_allclose(nominal.bias(q, qd), bias, rtol=0, atol=1e-10)
        np.testing.assert_allclose(nominal.gravity(q), reference_dynamics(model, q, np.zeros(3))[1], atol=1e-10)


def test_psi_writes_into_out(model):
    nominal = NominalModel(model)
    q, qd = random_states(1, seed=3)[0]
    out = np.full(3, np.nan)
    assert nominal.psi(q, qd, out=out) is out
    np.testing.assert_allclose(out, nominal.psi(q, qd), rtol=0, atol=0)


@pytest.mark.parametrize("q, M_rows, G, Cqd", CHECK_VALUES)
def test_psi_matches_the_reference_check_values(model, q, M_rows, G, Cqd):
    """Psi from the toolbox's check values (rounded to 5 decimals) agrees to 4 decimals.

    Measured max deviation: 1.9e-5, 1.2e-5, 1.5e-5 at the three check states."""
    expected = -np.linalg.solve(np.array(M_rows), np.array(G) + np.array(Cqd))
    np.testing.assert_allclose(NominalModel(model).psi(np.array(q), CHECK_QD), expected, rtol=0, atol=5e-5)


def test_mass_scale_doubles_M_armature_included_and_G(model):
    nominal, doubled = NominalModel(model), NominalModel(model, mass_scale=2.0)
    np.testing.assert_array_equal(doubled.model.dof_armature, 2.0 * model.dof_armature)
    assert np.all(model.dof_armature > 0)  # so the check above is not vacuous
    for q, qd in random_states(5, seed=1):
        np.testing.assert_allclose(doubled.mass_matrix(q), 2.0 * nominal.mass_matrix(q), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(doubled.gravity(q), 2.0 * nominal.gravity(q), rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(doubled.bias(q, qd), 2.0 * nominal.bias(q, qd), rtol=1e-12, atol=1e-10)
        # Psi = -M^-1 (C qd + G) is invariant under a uniform mass scale.
        np.testing.assert_allclose(doubled.psi(q, qd), nominal.psi(q, qd), rtol=0, atol=1e-10)


def test_nominal_never_modifies_the_callers_model():
    m = load()
    fields = ("body_mass", "body_inertia", "dof_armature", "body_ipos", "qpos0", "opt.gravity")

    def snapshot():
        out = {}
        for field in fields:
            obj = m
            for part in field.split("."):
                obj = getattr(obj, part)
            out[field] = np.array(obj, copy=True)
        return out

    before = snapshot()
    nominal = NominalModel(m, mass_scale=2.0)
    batch = nominal_batch(m, np.array([2.0, 0.5]), nthread=1)
    for q, qd in random_states(3, seed=2):
        nominal.psi(q, qd)
        nominal.mass_matrix(q)
        step_model(nominal, q, q + 0.1, qd).solve_M(qd[None])
        batch.qpos[:], batch.qvel[:] = q, qd
        batch.evaluate()
    assert nominal.model is not m
    after = snapshot()
    for field in fields:
        np.testing.assert_array_equal(after[field], before[field], err_msg=field)
    # And the copy is private in the other direction too: changing the caller's model changes nothing.
    q, qd = random_states(1, seed=5)[0]
    psi_before = nominal.psi(q, qd).copy()
    m.body_mass[:] *= 3.0
    np.testing.assert_array_equal(nominal.psi(q, qd), psi_before)


def test_step_model_solves_with_M_at_the_measured_position(model):
    """psi_hat is evaluated at (q_hat, qd_hat) but M, solve_M and apply_M must be those of q_meas."""
    nominal = NominalModel(model)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q_meas, q_hat = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-np.pi, np.pi, 3)
        qd_hat = rng.uniform(-2.0, 2.0, 3)
        step = step_model(nominal, q_meas, q_hat, qd_hat)
        M_meas, _ = reference_dynamics(model, q_meas, np.zeros(3))
        M_hat, bias_hat = reference_dynamics(model, q_hat, qd_hat)
        assert np.abs(M_meas - M_hat).max() > 1e-2  # the two states really differ
        np.testing.assert_allclose(step.M[0], M_meas, rtol=0, atol=1e-10)
        np.testing.assert_allclose(step.psi_hat[0], -np.linalg.solve(M_hat, bias_hat), rtol=0, atol=1e-10)
        for v in rng.normal(size=(3, 3)):
            np.testing.assert_allclose(step.solve_M(v[None])[0], np.linalg.solve(M_meas, v), rtol=0, atol=1e-10)
            np.testing.assert_allclose(step.apply_M(v[None], np.zeros((1, 3)))[0], M_meas @ v, rtol=0, atol=1e-10)


@pytest.mark.usefixtures("fast_paths")
def test_nominal_batch_is_the_single_state_model_at_every_point(model):
    """Each point of the engine's batched evaluation (the compiled rigid-body algorithms on the PUMA560): qacc
    with no applied force is Psi of NominalModel (MuJoCo on one MjData) to rounding, M its dense M; with an
    applied force f, M^-1 (f - bias); a point's mass scale is its own. Five points, three joints."""
    scales = np.array([1.0, 1.0, 2.0, 0.5, 1.0])
    batch = nominal_batch(model, scales, nthread=2)
    assert isinstance(batch, TreeNominal)  # not MuJoCo's batch
    rng = np.random.default_rng(9)
    q, qd, applied = rng.uniform(-np.pi, np.pi, (5, 3)), rng.uniform(-2.0, 2.0, (5, 3)), rng.normal(size=(5, 3))
    applied[:2] = 0.0
    batch.qpos[:], batch.qvel[:], batch.applied[:] = q, qd, applied
    batch.evaluate()
    mass = batch.mass_matrices()
    for point, scale in enumerate(scales):
        single = NominalModel(model, mass_scale=scale)
        np.testing.assert_allclose(mass[point], single.mass_matrix(q[point]), rtol=0, atol=1e-12)
        if point < 2:
            np.testing.assert_allclose(batch.qacc[point], single.psi(q[point], qd[point]), rtol=1e-13, atol=1e-13)
        else:
            expected = np.linalg.solve(single.mass_matrix(q[point]), applied[point] - single.bias(q[point], qd[point]))
            np.testing.assert_allclose(batch.qacc[point], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", ["puma560.xml", "ur5e.xml", "panda.xml", "two_link.xml"])
def test_sparse_solver_is_mj_solveM_bit_for_bit(name):
    """The engine's batched M^-1 v repeats mj_solveM's operations on MuJoCo's own factorisation: each row's
    answer is exactly what one MjData gives (so observers solve as they did on one MjData), for any number of
    rows, also for rows of four or more entries (mju_dotSparse sums those in four lanes), and with one vector
    for every row."""
    from ftc_mj.robot.nominal import SparseSolver

    model = mujoco.MjModel.from_xml_path(str(PUMA.parent / name))
    nv = model.nv
    rng = np.random.default_rng(12)
    rows = 7
    q, v = rng.uniform(-np.pi, np.pi, (rows, model.nq)), rng.normal(size=(rows, nv)) * 10
    data = mujoco.MjData(model)
    factors, diagonals, expected = [], [], []
    for row in range(rows):
        data.qpos[:] = q[row]
        mujoco.mj_fwdPosition(model, data)
        factors.append(data.qLD.copy())
        diagonals.append(data.qLDiagInv.copy())
        solution = np.zeros((1, nv))
        mujoco.mj_solveM(model, data, solution, v[row:row + 1].copy())
        expected.append(solution[0])
    for many in (1, 2, 40):
        for count in sorted({1, 4, 5, many * rows}):
            out = np.zeros((count, nv))
            tiled = [np.tile(x, (many, 1))[:count] for x in (factors, diagonals, v, expected)]
            SparseSolver(model).solve(*tiled[:3], out)
            np.testing.assert_array_equal(out, tiled[3])
    out = np.zeros((3, nv))  # one vector for every row
    SparseSolver(model).solve(np.tile(factors[0], (3, 1)), np.tile(diagonals[0], (3, 1)), v[0], out)
    np.testing.assert_array_equal(out, np.tile(expected[0], (3, 1)))


def test_dense_mass_fills_every_entry_from_the_sparse_values():
    """DenseMass gives mj_fullM's matrices, for a chain (every entry stored) and for a tree with structural
    zeros (the panda's two fingers)."""
    from ftc_mj.robot.nominal import DenseMass

    for name in ("puma560.xml", "panda.xml"):
        model = mujoco.MjModel.from_xml_path(str(PUMA.parent / name))
        data = mujoco.MjData(model)
        rng = np.random.default_rng(4)
        sparse, expected = [], []
        for _ in range(3):
            data.qpos[:] = rng.uniform(-1.0, 1.0, model.nq)
            mujoco.mj_fwdPosition(model, data)
            full = np.zeros((model.nv, model.nv))
            mujoco.mj_fullM(model, data, full)
            sparse.append(data.M.copy())
            expected.append(full)
        dense = DenseMass(model, 3)
        live = np.array(sparse)
        np.testing.assert_array_equal(dense.update(live), np.array(expected))
        # The same buffer refilled in place (a plant's, every period), then another buffer.
        live[:] = live[::-1]
        np.testing.assert_array_equal(dense.update(live), np.array(expected[::-1]))
        np.testing.assert_array_equal(dense.update(np.array(sparse[1:] + sparse[:1])),
                                      np.array(expected[1:] + expected[:1]))


def test_step_model_on_measured_velocity_evaluates_the_controllers_psi_at_the_readings(model):
    """With a tachometer reading the controller's Psi is Psi(q_meas, qd_meas) and its velocity the reading; the
    observers' psi_hat stays at (q_hat, qd_hat). Without it the controller's Psi is psi_hat itself."""
    rng = np.random.default_rng(7)
    q_meas, q_hat = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-np.pi, np.pi, 3)
    qd_meas, qd_hat = rng.uniform(-2.0, 2.0, 3), rng.uniform(-2.0, 2.0, 3)
    measured = step_model(NominalModel(model), q_meas, q_hat, qd_hat, qd_meas)
    M_hat, bias_hat = reference_dynamics(model, q_hat, qd_hat)
    M_meas, bias_meas = reference_dynamics(model, q_meas, qd_meas)
    np.testing.assert_allclose(measured.psi_hat[0], -np.linalg.solve(M_hat, bias_hat), rtol=0, atol=1e-10)
    np.testing.assert_allclose(measured.psi_control[0], -np.linalg.solve(M_meas, bias_meas), rtol=0, atol=1e-10)
    assert np.abs(measured.psi_control - measured.psi_hat).max() > 1e-2
    np.testing.assert_array_equal(measured.control_velocity(qd_hat[None]), qd_meas[None])
    np.testing.assert_allclose(measured.M[0], M_meas, rtol=0, atol=1e-10)  # M(x1) kept for solve_M
    estimated = step_model(NominalModel(model), q_meas, q_hat, qd_hat)
    assert estimated.psi_control is estimated.psi_hat
    assert estimated.control_velocity(qd_hat) is qd_hat


@pytest.mark.parametrize("name", ["puma560.xml", "ur5e.xml", "two_link.xml"])
def test_rigid_body_model_keeps_the_tree_and_drops_what_the_nominal_model_never_uses(name):
    """The nominal batch's model is rebuilt from bodies, joints and inertias alone (no geoms, sites, sensors,
    actuators) and gives the full model's M, factorisation and Psi (constraints, passive forces and actuators
    off) bit for bit at states other than those it was checked at when it was built."""
    from ftc_mj.robot.nominal.rigid_copy import _RIGID_BODY_ONLY, rigid_body_model

    full = mujoco.MjModel.from_xml_path(str(PUMA.parent / name))
    rigid = rigid_body_model(full)
    assert (rigid.ngeom, rigid.nsite, rigid.nsensor, rigid.nu) == (0, 0, 0, 0)
    assert (rigid.nbody, rigid.nv) == (full.nbody, full.nv)
    assert rigid.opt.disableflags & int(_RIGID_BODY_ONLY) == int(_RIGID_BODY_ONLY)
    assert full.ngeom > 0 and full.opt.disableflags & int(_RIGID_BODY_ONLY) != int(_RIGID_BODY_ONLY)  # untouched
    plain = mujoco.MjModel.from_xml_path(str(PUMA.parent / name))
    plain.opt.disableflags |= int(_RIGID_BODY_ONLY)
    data, rigid_data = mujoco.MjData(plain), mujoco.MjData(rigid)
    rng = np.random.default_rng(31)
    for _ in range(20):
        q, qd, force = rng.uniform(-3.0, 3.0, full.nq), rng.normal(size=full.nv) * 2, rng.normal(size=full.nv) * 5
        for m, d in ((plain, data), (rigid, rigid_data)):
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, qd, force
            mujoco.mj_forward(m, d)
        for field in ("M", "qLD", "qLDiagInv", "qfrc_bias", "qacc"):
            np.testing.assert_array_equal(getattr(rigid_data, field), getattr(data, field), err_msg=field)
        assert np.abs(data.qfrc_bias).max() > 0.1  # gravity and velocity terms really act


def test_rigid_body_model_of_a_model_it_does_not_rebuild_is_a_plain_copy():
    """A ball joint, or Menagerie's panda as it comes (its fingers coupled by a tendon and an equality), is not
    rebuilt: the plain copy (geoms kept), with the rigid-body flags."""
    from ftc_mj.robot.nominal.rigid_copy import _RIGID_BODY_ONLY, rigid_body_model

    xml = """<mujoco><worldbody><body><joint type="ball"/><geom size="0.1" mass="1"/>
             <body pos="0 0 -0.5"><joint type="hinge"/><geom size="0.1" mass="1"/></body></body></worldbody></mujoco>"""
    for model in (mujoco.MjModel.from_xml_string(xml), mujoco.MjModel.from_xml_path(str(PUMA.parent / "panda.xml"))):
        copy_ = rigid_body_model(model)
        assert copy_ is not model and copy_.ngeom == model.ngeom > 0
        assert copy_.opt.disableflags & int(_RIGID_BODY_ONLY) == int(_RIGID_BODY_ONLY)


def test_a_mass_only_batch_gives_M_and_its_factorisation_as_a_whole_evaluation(model):
    """The engine evaluates the points where only M is wanted (at the measured positions) without the velocity
    terms: their M, qLD and qLDiagInv are those of a whole evaluation at the same position, bit for bit, and
    no acceleration is computed. Five points of three joints."""
    rng = np.random.default_rng(3)
    q, qd = rng.uniform(-np.pi, np.pi, (5, 3)), rng.uniform(-2.0, 2.0, (5, 3))
    scales = np.array([1.0, 1.5, 0.8, 1.5, 0.8])
    mass_only, whole = nominal_batch(model, scales, nthread=1, mass_only=True), nominal_batch(model, scales, nthread=1)
    for batch in (mass_only, whole):
        batch.qpos[:], batch.qvel[:] = q, qd
        batch.evaluate()
    np.testing.assert_array_equal(mass_only.mass_matrices(), whole.mass_matrices())
    np.testing.assert_array_equal(mass_only.factor, whole.factor)
    np.testing.assert_array_equal(mass_only.diagonal_inverse, whole.diagonal_inverse)
    assert not np.any(mass_only.qacc == whole.qacc)  # no acceleration where only M is wanted


def test_command_acceleration_is_solved_on_demand_or_read_from_the_engines_buffer(model):
    """Outside the engine M(x1)^-1 tau is solved when asked (as solve_M); in the engine the StepModel reads
    the buffer the loop filled for every row at once."""
    nominal = NominalModel(model)
    rng = np.random.default_rng(8)
    q, qd, tau = rng.uniform(-1.0, 1.0, 3), rng.uniform(-1.0, 1.0, 3), rng.normal(size=(1, 3)) * 20
    step = step_model(nominal, q, q, qd)
    np.testing.assert_array_equal(step.command_acceleration(tau), step.solve_M(tau).copy())
    buffer = np.full((1, 3), 7.0)
    shared = StepModel(step.M, step._factor, step._diagonal_inverse, step.psi_hat, step._solver, command=buffer)
    assert shared.command_acceleration(tau) is buffer


def _trajectory(model: mujoco.MjModel, steps: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """q(t_k), qd(t_k) of a passive swing under gravity and a sinusoidal torque, from a non-zero velocity,
    integrated by RK4 at ``dt`` on the rigid-body copy (no limits, contacts or damping: a smooth motion)."""
    rigid = rigid_body_model(model)
    rigid.opt.integrator, rigid.opt.timestep = int(mujoco.mjtIntegrator.mjINT_RK4), dt
    data = mujoco.MjData(rigid)
    n = rigid.nv
    data.qpos[:] = np.linspace(-0.6, 0.8, n)
    data.qvel[:] = np.linspace(1.5, -1.0, n)
    q, qd = np.empty((steps, n)), np.empty((steps, n))
    for k in range(steps):
        q[k], qd[k] = data.qpos, data.qvel
        data.qfrc_applied[:] = 5.0 * np.sin(7.0 * k * dt + np.arange(n))
        mujoco.mj_step(rigid, data)
    return q, qd


def _mass(model: mujoco.MjModel, q: np.ndarray) -> np.ndarray:
    """Dense M(q) at each row of ``q``, by MuJoCo."""
    rigid = rigid_body_model(model)
    data, out = mujoco.MjData(rigid), np.zeros((len(q), rigid.nv, rigid.nv))
    for k, position in enumerate(q):
        data.qpos[:] = position
        mujoco.mj_forward(rigid, data)
        mujoco.mj_fullM(rigid, data, out[k])
    return out


@pytest.mark.usefixtures("fast_paths")
@pytest.mark.parametrize("backend", ["compiled", "mujoco"])
@pytest.mark.parametrize("name", ["puma560.xml", "ur5e.xml"])
def test_coriolis_transpose_is_the_derivative_of_M_along_a_trajectory_less_C_qd(name, backend):
    """C(q, qd)^T qd = Mdot qd - C qd (Mdot = C + C^T) along a simulated motion: Mdot qd from M at the
    neighbouring samples, (M(q_(k+1)) - M(q_(k-1))) / (2 dt) qd_k, whose error is dt^2 / 6 |d^3 M / dt^3 qd|
    (bounded from the third differences of M at the samples) plus RK4's O(dt^4); C qd = bias(q, qd) - bias(q, 0)
    from MuJoCo. G(q) is MuJoCo's bias at rest. Both backends, the PUMA560 (3 joints) and the UR5e (6)."""
    model = mujoco.MjModel.from_xml_path(str(PUMA.parent / name))
    dt, steps = 5e-4, 600
    q, qd = _trajectory(model, steps, dt)
    points = steps - 4  # samples 2 .. steps - 3: two neighbours on each side for the third difference
    if backend == "compiled":
        batch = nominal_batch(model, np.ones(points), 1, momentum_points=np.ones(points, bool))
        assert isinstance(batch, TreeNominal)
    else:
        batch = MuJoCoNominal(rigid_body_model(model), np.ones(points), 1, momentum_points=np.ones(points, bool))
    inner = slice(2, steps - 2)
    batch.qpos[:], batch.qvel[:] = q[inner], qd[inner]
    batch.evaluate()
    M = _mass(model, q)
    central = (M[3:-1] - M[1:-3]) / (2 * dt)  # Mdot at the inner samples
    third = (M[4:] - 2 * M[3:-1] + 2 * M[1:-3] - M[:-4]) / (2 * dt**3)  # d^3 M / dt^3
    mdot_qd = np.einsum("kij,kj->ki", central, qd[inner])
    rigid = rigid_body_model(model)
    data = mujoco.MjData(rigid)
    c_qd, gravity = np.empty((points, rigid.nv)), np.empty((points, rigid.nv))
    for k in range(points):
        data.qpos[:], data.qvel[:] = q[k + 2], 0.0
        mujoco.mj_forward(rigid, data)
        gravity[k] = data.qfrc_bias
        data.qvel[:] = qd[k + 2]
        mujoco.mj_forward(rigid, data)
        c_qd[k] = data.qfrc_bias - gravity[k]
    expected = mdot_qd - c_qd
    scale = np.abs(expected).max()
    bound = 2 * dt**2 / 6 * np.abs(np.einsum("kij,kj->ki", third, qd[inner])).max() + 1e-9 * scale
    assert bound < 1e-3 * scale and scale > 0.1  # the tolerance is far below the quantity, which is not small
    np.testing.assert_allclose(batch.coriolis_transpose, expected, rtol=0, atol=bound)
    np.testing.assert_allclose(batch.gravity, gravity, rtol=0, atol=1e-12 * np.abs(gravity).max())
    assert np.abs(c_qd).max() > 0.1 and np.abs(expected - c_qd).max() > 0.1  # C^T qd is not C qd


@pytest.mark.usefixtures("fast_paths")
def test_the_momentum_terms_are_computed_only_where_asked_and_change_nothing_else(model):
    """Without ``momentum_points`` the batch has no C^T qd or G and costs nothing more; with a mask, only the
    masked points are written, and M, the factorisation and Psi keep their bits; a mass-only batch refuses a
    mask. Both backends give the same numbers to rounding."""
    rng = np.random.default_rng(12)
    q, qd = rng.uniform(-np.pi, np.pi, (4, 3)), rng.uniform(-2.0, 2.0, (4, 3))
    mask = np.array([True, False, True, True])
    plain = nominal_batch(model, np.ones(4), 1)
    asked = nominal_batch(model, np.ones(4), 1, momentum_points=mask)
    mujoco_batch = MuJoCoNominal(rigid_body_model(model), np.ones(4), 1, momentum_points=mask)
    assert plain.coriolis_transpose is None and plain.gravity is None
    for batch in (plain, asked, mujoco_batch):
        batch.qpos[:], batch.qvel[:] = q, qd
        batch.evaluate()
    for name in ("qacc", "factor", "diagonal_inverse"):
        np.testing.assert_array_equal(getattr(asked, name), getattr(plain, name))
    np.testing.assert_array_equal(asked.mass_matrices(), plain.mass_matrices())
    assert not asked.coriolis_transpose[1].any() and not asked.gravity[1].any()
    for name in ("coriolis_transpose", "gravity"):
        np.testing.assert_allclose(getattr(asked, name)[mask], getattr(mujoco_batch, name)[mask], rtol=0, atol=1e-12)
    assert nominal_batch(model, np.ones(4), 1, momentum_points=np.zeros(4, bool)).coriolis_transpose is None
    with pytest.raises(ValueError, match="mass-only"):
        nominal_batch(model, np.ones(4), 1, mass_only=True, momentum_points=mask)
    with pytest.raises(ValueError, match="a mask of the 4 points"):
        nominal_batch(model, np.ones(4), 1, momentum_points=np.ones(3, bool))


def test_the_mujoco_momentum_terms_of_a_point_do_not_depend_on_the_other_points(model):
    """MuJoCo's backend computes C^T qd and G on the whole batch with array operations: a point's bits are its
    own alone. It declines joints it does not cover (a ball joint)."""
    rng = np.random.default_rng(13)
    q, qd, scale = rng.uniform(-3, 3, (7, 3)), rng.normal(size=(7, 3)), rng.uniform(0.5, 2.0, 7)
    many = MuJoCoNominal(rigid_body_model(model), scale, 1, momentum_points=np.ones(7, bool))
    many.qpos[:], many.qvel[:] = q, qd
    many.evaluate()
    for point in (0, 4, 6):
        alone = MuJoCoNominal(rigid_body_model(model), scale[point:point + 1], 1, momentum_points=np.ones(1, bool))
        alone.qpos[:], alone.qvel[:] = q[point], qd[point]
        alone.evaluate()
        np.testing.assert_array_equal(alone.coriolis_transpose[0], many.coriolis_transpose[point])
        np.testing.assert_array_equal(alone.gravity[0], many.gravity[point])
    ball = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint type="ball"/><geom size="0.1" mass="1"/></body></worldbody></mujoco>')
    with pytest.raises(ValueError, match="hinge and slide joints only"):
        nominal_batch(ball, np.ones(2), 1, momentum_points=np.ones(2, bool))


@pytest.mark.usefixtures("fast_paths")
@pytest.mark.parametrize("kind", ["psi", "mass_only", "psi and M-only points"])
def test_compiled_points_cut_over_threads_keep_their_bits(model, kind):
    """With threads the compiled batch cuts its points into shares evaluated at once (an equal share of the
    points with velocity terms and of the M-only points per thread): every output keeps the bits of the
    one-thread batch, the momentum terms included, and each share writes only its own points."""
    from ftc_mj.fast.crossovers import POINTS_PER_THREAD
    mass_only = kind == "mass_only"
    psi_points = 3 * POINTS_PER_THREAD + 5
    rng = np.random.default_rng(21)
    scale = rng.uniform(0.8, 1.2, psi_points)
    extra = rng.uniform(0.8, 1.2, 2 * POINTS_PER_THREAD + 1) if kind == "psi and M-only points" else None
    points = psi_points + (0 if extra is None else len(extra))
    q, qd, applied = (rng.uniform(-np.pi, np.pi, (points, 3)), rng.uniform(-2.0, 2.0, (points, 3)),
                      rng.normal(size=(points, 3)))
    mask = None if mass_only else rng.uniform(size=psi_points) < 0.5
    one, three = (nominal_batch(model, scale, threads, mass_only=mass_only, momentum_points=mask, mass_points=extra)
                  for threads in (1, 3))
    assert isinstance(three, TreeNominal) and len(three._tasks) == 3 and len(one._tasks) == 1
    assert [len(task) for task in three._tasks] == [1 if extra is None else 2] * 3 and len(one._tasks[0]) == 1
    for batch in (one, three):  # the first call on the calling thread (it may compile), the second on threads
        batch.qpos[:], batch.qvel[:], batch.applied[:] = -q, qd, applied
        batch.evaluate()
        batch.qpos[:] = q
        batch.evaluate()
    assert three._pool is not None and one._pool is None
    names = ("factor", "diagonal_inverse") + (() if mass_only else ("qacc", "coriolis_transpose", "gravity"))
    for name in names:
        np.testing.assert_array_equal(getattr(three, name), getattr(one, name))
    np.testing.assert_array_equal(three.mass_matrices(), one.mass_matrices())
    assert np.all(three.factor != 0, axis=1).any() and np.all(three.diagonal_inverse != 1.0, axis=1).all()


@pytest.mark.parametrize("n", [3, 9])
def test_a_matvec_site_gives_matvecs_bits_and_binds_only_arrays_seen_twice(n):
    """A call site's product is matvec's whatever it is called with: its own buffers (bound to them from their
    second call on), a new output each call (never bound), another layout after the buffers (a strided view:
    matvec again, then bound to it). Beyond PAIRED_COLUMNS it never binds."""
    from ftc_mj import fast
    from ftc_mj.fast.crossovers import PAIRED_COLUMNS
    from ftc_mj.robot.nominal import MatvecSite, matvec

    binds = n <= PAIRED_COLUMNS and fast.enabled()
    generator = np.random.default_rng(n)
    matrices, vectors = generator.standard_normal((6, n, n)), generator.standard_normal((6, n))
    out, expected = np.empty((6, n)), np.empty((6, n))
    site = MatvecSite()
    calls = []
    for step in range(3):
        vectors += 1.0
        matvec(matrices, vectors, expected)
        if vectors is site.vectors and out is site.out and matrices is site.matrices:
            site.call()
            calls.append("bound")
        else:
            site.new(matrices, vectors, out)
            calls.append("new")
        np.testing.assert_array_equal(out, expected)
    assert calls == (["new", "new", "bound"] if binds else ["new"] * 3)
    for step in range(3):  # a new output each call: matvec each time
        fresh = np.full((6, n), np.nan)
        site.new(matrices, vectors, fresh)
        np.testing.assert_array_equal(fresh, expected)
        assert site.out is not fresh
    strided_matrices, strided = matrices[::2], vectors[::2]
    short_out, short_expected = np.empty((3, n)), np.empty((3, n))
    matvec(strided_matrices, strided, short_expected)
    for step in range(2):
        site.new(strided_matrices, strided, short_out)
        np.testing.assert_array_equal(short_out, short_expected)
    assert (site.vectors is strided) == binds
    short_out[...] = np.nan
    site.call() if binds else site.new(strided_matrices, strided, short_out)
    np.testing.assert_array_equal(short_out, short_expected)


def test_step_model_apply_m_is_matvec_at_every_call():
    """StepModel.apply_M on the same buffers (compiled from the second call), on new ones, and back."""
    from ftc_mj.robot.nominal import matvec

    generator = np.random.default_rng(5)
    M = generator.standard_normal((4, 3, 3))
    model = StepModel(M=M, factor=np.zeros((4, 6)), diagonal_inverse=np.ones((4, 3)),
                      psi_hat=np.zeros((4, 3)), solver=None)
    vector, out = generator.standard_normal((4, 3)), np.empty((4, 3))
    for outputs in ([out] * 3, [np.empty((4, 3)) for _ in range(2)], [out] * 2):
        for target in outputs:
            vector *= 1.5
            M += 0.25  # the model's M is a live buffer
            assert model.apply_M(vector, out=target) is target
            np.testing.assert_array_equal(target, matvec(M, vector, np.empty((4, 3))))
