"""The compiled rigid-body algorithms (ftc_mj/fast/rigid.py) against their NumPy definition
(ftc_mj/robot/nominal/algorithms.py), bit for bit, and both against MuJoCo's forward pass, to rounding."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj import fast
from ftc_mj.fast.rigid import RigidTree
from ftc_mj.robot.nominal import MuJoCoNominal, TreeNominal, nominal_batch, rigid_body_model, scale_masses
from ftc_mj.robot.nominal.algorithms import evaluate_tree

MODELS = Path(__file__).resolve().parents[2] / "models"

#: A tree with what the shipped arms lack: a slide joint, a branch, jointless bodies with mass welded between
#: jointed ones (one with jointed children, one after a jointed sibling's subtree), rotated body and inertia
#: frames, joint anchors off the body origin, reference positions (qpos0) and armature.
TREE = """
<mujoco>
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="base" pos="0.1 0 0.2" quat="0.9 0.1 0.3 0.2">
      <inertial pos="0 0 0.1" mass="3" diaginertia="0.1 0.2 0.3"/>
      <body name="a" pos="0 0.1 0.3" quat="0.7 0.7 0 0">
        <joint name="a" type="hinge" axis="0.3 0.4 0.8" pos="0.05 0 -0.02" ref="0.4" armature="0.02"/>
        <inertial pos="0.1 0.02 0" quat="0.8 0 0.6 0" mass="2" diaginertia="0.02 0.03 0.04"/>
        <body name="a_weld" pos="0.3 0 0" quat="0.5 0.5 0.5 0.5">
          <inertial pos="0 0.05 0" mass="0.7" diaginertia="0.01 0.005 0.008"/>
          <body name="b" pos="0 0 0.2">
            <joint name="b" type="slide" axis="1 0.2 0" ref="-0.1" armature="0.1"/>
            <inertial pos="0.02 0 0.01" mass="1.2" diaginertia="0.01 0.01 0.02"/>
          </body>
          <body name="c" pos="0.1 -0.1 0" quat="0.9 0 0 0.4">
            <joint name="c" type="hinge" axis="0 1 0" pos="0 0 0.03"/>
            <inertial pos="0.2 0 0" mass="0.9" diaginertia="0.004 0.02 0.02"/>
            <body name="c_weld" pos="0.4 0 0">
              <inertial pos="0 0 0" quat="0.6 0 0 0.8" mass="0.3" diaginertia="0.001 0.002 0.003"/>
              <body name="d" pos="0.05 0 0">
                <joint name="d" type="hinge" axis="1 0 0"/>
                <inertial pos="0 0.03 0" mass="0.4" diaginertia="0.001 0.001 0.001"/>
              </body>
            </body>
          </body>
        </body>
        <body name="a_tip" pos="0.1 0.2 0">
          <inertial pos="0 0 0.05" mass="0.25" diaginertia="0.002 0.002 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _models() -> dict[str, mujoco.MjModel]:
    models = {name: mujoco.MjModel.from_xml_path(str(MODELS / name))
              for name in ("puma560.xml", "two_link.xml", "ur5e.xml")}
    models["tree"] = mujoco.MjModel.from_xml_string(TREE)
    return models


def _evaluate(tree: RigidTree, scale: np.ndarray, q: np.ndarray, qd: np.ndarray, applied: np.ndarray,
              with_velocity: bool = True) -> dict[str, np.ndarray]:
    points, n = q.shape
    out = {"M": np.zeros((points, len(tree.sparse_row))), "qLD": np.zeros((points, len(tree.sparse_row))),
           "qLDiagInv": np.zeros((points, n)), "qacc": np.zeros((points, n)), "qfrc_bias": np.zeros((points, n))}
    tree.evaluate(*tree.scaled(scale), q, qd, applied, out["M"], out["qLD"], out["qLDiagInv"], out["qacc"],
                  out["qfrc_bias"], with_velocity)
    return out


@pytest.mark.parametrize("name", ["puma560.xml", "two_link.xml", "ur5e.xml", "tree"])
def test_the_compiled_algorithms_give_mujocos_forward_pass_to_rounding(name):
    """M (MuJoCo's sparse layout), its factorisation L'DL, C qd + G and M^-1 (applied - C qd - G) equal
    ``mj_forward``'s on the rigid-body copy at random states, with a mass scale per point, to 1e-12 of each
    quantity's size: the same model, other rounding."""
    model = rigid_body_model(_models()[name])
    tree = RigidTree.from_model(model)
    assert tree is not None
    rng = np.random.default_rng(5)
    points, n = 12, model.nv
    q, qd = rng.uniform(-3.0, 3.0, (points, n)), rng.normal(size=(points, n)) * 3
    applied, scale = rng.normal(size=(points, n)) * 10, rng.uniform(0.5, 2.0, points)
    got = _evaluate(tree, scale, q, qd, applied)
    for point in range(points):
        scaled = rigid_body_model(_models()[name])
        scale_masses(lambda field: getattr(scaled, field)[None], np.array([scale[point]]))
        data = mujoco.MjData(scaled)
        data.qpos[:], data.qvel[:], data.qfrc_applied[:] = q[point], qd[point], applied[point]
        mujoco.mj_forward(scaled, data)
        for field, values in got.items():
            expected = getattr(data, field)
            np.testing.assert_allclose(values[point], expected, rtol=0, atol=1e-12 * np.abs(expected).max(),
                                       err_msg=f"{name} {field} at point {point}")
        assert np.abs(data.qfrc_bias).max() > 0.1 and np.abs(data.qvel).max() > 0.1  # the terms really act


def test_numpys_sine_and_cosine_are_the_c_librarys():
    """The one condition of the bit-for-bit agreement below: NumPy's float64 sin and cos give the C library's
    bits (what Python's ``math`` and the compiled kernel, Numba's SVML off, call), over the angles a joint
    takes and small ones; where a NumPy build uses SIMD versions of its own, this fails first and says why."""
    rng = np.random.default_rng(3)
    angles = np.concatenate([rng.uniform(-7.0, 7.0, 20000), rng.normal(scale=1e-4, size=2000), [0.0, -0.0, np.pi]])
    np.testing.assert_array_equal(np.sin(angles), [math.sin(a) for a in angles])
    np.testing.assert_array_equal(np.cos(angles), [math.cos(a) for a in angles])


@pytest.mark.parametrize("name", ["puma560.xml", "two_link.xml", "ur5e.xml", "tree"])
def test_the_kernel_gives_its_numpy_definitions_bits(name):
    """The compiled kernel equals ``evaluate_tree`` bit for bit in every output: random states and mass
    scales, points at rest and at -0.0, large angles and speeds, a NaN point (its own row NaN, no other),
    points past ``velocity_points`` (M alone), C^T qd and G at a random subset of points (the others' rows
    left as they were)."""
    model = rigid_body_model(_models()[name])
    tree = RigidTree.from_model(model)
    rng = np.random.default_rng(11)
    points, n, nM = 40, model.nv, model.nM
    q, qd = rng.uniform(-4.0, 4.0, (points, n)), rng.normal(size=(points, n)) * 3
    q[:3], qd[:3], q[3] = 0.0, 0.0, -0.0
    q[4], qd[4] = 1e3, -50.0
    q[5, 0] = np.nan
    applied, scale = rng.normal(size=(points, n)) * 10, rng.uniform(0.5, 2.0, points)
    wanted = rng.uniform(size=points) < 0.5
    wanted[5] = True
    outputs = []
    for run in (lambda arguments: tree.evaluate(*arguments[0], **arguments[1]),
                lambda arguments: evaluate_tree(*tree.arguments(*arguments[0], **arguments[1]))):
        out = [np.zeros((points, nM)), np.zeros((points, nM)), np.zeros((points, n)), np.zeros((points, n)),
               np.zeros((points, n))]
        terms = [np.full((points, n), 7.0), np.full((points, n), 7.0)]
        run(((*tree.scaled(scale), q, qd, applied, *out, True, wanted, *terms), {"velocity_points": points - 6}))
        outputs.append(out + terms)
    for field, compiled, numpy in zip(("M", "qLD", "qLDiagInv", "qacc", "bias", "C^T qd", "G"), *outputs):
        np.testing.assert_array_equal(numpy, compiled, err_msg=f"{name} {field}")
        finite = np.isfinite(compiled).all(axis=1)
        assert not finite[5] and finite[np.arange(points) != 5].all(), field
    computed = wanted & (np.arange(points) < points - 6)
    assert (outputs[0][5][~computed] == 7.0).all() and (outputs[0][5][computed] != 7.0).all()


def test_the_nominal_batch_runs_the_definition_with_the_fast_paths_off():
    """The switch chooses the algorithms' implementation, not another model: with the fast paths off the
    nominal batch is still the rigid-body algorithms (NumPy's), with the same bits as the compiled one, its
    M at the readings too."""
    model = mujoco.MjModel.from_xml_path(str(MODELS / "ur5e.xml"))
    rng = np.random.default_rng(12)
    scale, rows = rng.uniform(0.8, 1.2, 5), rng.uniform(0.8, 1.2, 3)
    q, qd = rng.uniform(-3.0, 3.0, (5, 6)), rng.normal(size=(5, 6))
    results = []
    for enabled in (True, False):
        with fast.switched(enabled):
            batch = nominal_batch(model, scale, 2, momentum_points=np.ones(5, bool), mass_points=rows)
        assert isinstance(batch, TreeNominal)
        mass = batch.mass_at_readings(None)
        batch.qpos[:5], batch.qvel[:5] = q, qd  # the Psi points (the rows' M-only points after them)
        mass.prepare(q[:3] * 0.5, None)
        batch.evaluate()
        mass.evaluate()
        results.append((batch.qacc, batch.mass_matrices(), batch.coriolis_transpose, batch.gravity, mass.M,
                        mass.factor))
    for compiled, numpy in zip(*results):
        np.testing.assert_array_equal(numpy, compiled)


def test_the_welded_bodies_count_a_jointless_body_inside_the_tree_counts_in_its_carrier():
    """The synthetic tree has four joints over eight bodies: the jointless base is welded to the world (no
    node), the jointless bodies inside the tree to their carriers, whose masses they add to (``a_tip`` comes
    after the subtree of ``a_weld`` in body order and still joins node 0)."""
    model = mujoco.MjModel.from_xml_string(TREE)
    tree = RigidTree.from_model(model)
    assert tree.n == 4
    np.testing.assert_array_equal(tree.parent, [-1, 0, 0, 2])
    np.testing.assert_allclose(tree.mass, [2.0 + 0.7 + 0.25, 1.2, 0.9 + 0.3, 0.4])
    np.testing.assert_array_equal(tree.hinge, [True, False, True, True])


def test_a_points_numbers_do_not_depend_on_the_other_points():
    """A point's bits are those of its evaluation alone, wherever it sits among how many points: a batch member
    gets its single run's bits."""
    model = rigid_body_model(mujoco.MjModel.from_xml_path(str(MODELS / "puma560.xml")))
    tree = RigidTree.from_model(model)
    rng = np.random.default_rng(6)
    q, qd, applied = rng.uniform(-3, 3, (37, 3)), rng.normal(size=(37, 3)), rng.normal(size=(37, 3))
    scale = rng.uniform(0.5, 2.0, 37)
    many = _evaluate(tree, scale, q, qd, applied)
    for point in (0, 17, 36):
        alone = _evaluate(tree, scale[point:point + 1], q[point:point + 1], qd[point:point + 1],
                          applied[point:point + 1])
        for field in many:
            np.testing.assert_array_equal(alone[field][0], many[field][point])


def test_the_kernel_refuses_a_scratch_buffer_of_another_length():
    """The working arrays are views of the caller's buffer, unchecked inside the kernel: a buffer that is not
    ``scratch_size(n)`` long is refused before anything is written."""
    from ftc_mj.fast.rigid import evaluate, scratch_size

    model = rigid_body_model(mujoco.MjModel.from_xml_path(str(MODELS / "puma560.xml")))
    tree = RigidTree.from_model(model)
    q = np.zeros((2, 3))
    buffers = [np.zeros((2, len(tree.sparse_row))) for _ in range(2)] + [np.zeros((2, 3)) for _ in range(3)]
    arguments = tree.arguments(*tree.scaled(np.ones(2)), q, q, q, *buffers, True)
    assert len(arguments[-1]) == scratch_size(3)
    evaluate(arguments)  # its own buffer: fine
    for length in (scratch_size(3) - 1, scratch_size(3) + 1):
        with pytest.raises(ValueError, match="scratch_size"):
            evaluate((*arguments[:-1], np.zeros(length)))


def test_mass_only_gives_the_same_M_and_factor_and_no_velocity_terms():
    model = rigid_body_model(mujoco.MjModel.from_xml_string(TREE))
    tree = RigidTree.from_model(model)
    rng = np.random.default_rng(7)
    q, qd, applied = rng.uniform(-3, 3, (5, 4)), rng.normal(size=(5, 4)), rng.normal(size=(5, 4))
    whole, mass_only = (_evaluate(tree, np.ones(5), q, qd, applied, with_velocity) for with_velocity in (True, False))
    for field in ("M", "qLD", "qLDiagInv"):
        np.testing.assert_array_equal(mass_only[field], whole[field])
    assert not mass_only["qacc"].any() and not mass_only["qfrc_bias"].any()


@pytest.mark.parametrize("xml", [
    '<body><joint type="ball"/><geom size="0.1" mass="1"/></body>',
    '<body><joint type="hinge"/><joint type="hinge" axis="1 0 0"/><geom size="0.1" mass="1"/></body>',
    '<body gravcomp="1"><joint type="hinge"/><geom size="0.1" mass="1"/></body>',
])
def test_what_the_kernels_do_not_cover_is_declined_and_the_nominal_batch_uses_mujoco(xml):
    """A ball joint, two joints in one body, gravity compensation: no tree; the nominal batch then evaluates the
    points on MuJoCo's own batch, and still gives Psi."""
    model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{xml}</worldbody></mujoco>")
    assert RigidTree.from_model(rigid_body_model(model)) is None
    batch = nominal_batch(model, np.ones(2), nthread=1)
    assert isinstance(batch, MuJoCoNominal)
    batch.qvel[:] = 0.5
    batch.evaluate()
    assert np.isfinite(batch.qacc).all()


def test_the_panda_with_coupled_fingers_is_declined():
    """Menagerie's panda as shipped couples its fingers by a tendon and an equality: MuJoCo evaluates it."""
    model = rigid_body_model(mujoco.MjModel.from_xml_path(str(MODELS / "panda.xml")))
    assert RigidTree.from_model(model) is None


@pytest.mark.parametrize("name", ["puma560.xml", "two_link.xml", "ur5e.xml", "tree"])
def test_the_momentum_terms_equal_mujocos_and_are_a_points_own(name):
    """C(q, qd)^T qd and G(q) of the compiled kernel (the subtree momenta) equal the MuJoCo backend's (cdof_dot
    and cinert) to rounding, with a mass scale per point, the synthetic tree's slide joint, branch and welded
    bodies included; G equals MuJoCo's bias at rest; a point's bits are its own alone."""
    model = rigid_body_model(_models()[name])
    tree = RigidTree.from_model(model)
    rng = np.random.default_rng(14)
    points, n = 9, model.nv
    q, qd = rng.uniform(-3.0, 3.0, (points, n)), rng.normal(size=(points, n)) * 3
    scale = rng.uniform(0.5, 2.0, points)

    def terms(rows: slice) -> tuple[np.ndarray, np.ndarray]:
        count = len(range(points)[rows])
        out = _evaluate(tree, scale[rows], q[rows], qd[rows], np.zeros((count, n)))
        transpose, gravity = np.zeros((count, n)), np.zeros((count, n))
        tree.evaluate(*tree.scaled(scale[rows]), q[rows], qd[rows], np.zeros((count, n)), *out.values(), True,
                      np.ones(count, bool), transpose, gravity)
        return transpose, gravity

    transpose, gravity = terms(slice(None))
    reference = MuJoCoNominal(model, scale, 1, momentum_points=np.ones(points, bool))
    reference.qpos[:], reference.qvel[:] = q, qd
    reference.evaluate()
    for got, expected in ((transpose, reference.coriolis_transpose), (gravity, reference.gravity)):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    at_rest = _evaluate(tree, scale, q, np.zeros((points, n)), np.zeros((points, n)))["qfrc_bias"]
    np.testing.assert_allclose(gravity, at_rest, rtol=0, atol=1e-12 * np.abs(at_rest).max())
    assert np.abs(transpose).max() > 0.1
    alone = terms(slice(4, 5))
    np.testing.assert_array_equal(alone[0][0], transpose[4])
    np.testing.assert_array_equal(alone[1][0], gravity[4])


FIRST_CALL = """
import mujoco, numpy as np
from ftc_mj.robot.nominal import rigid_body_model
from ftc_mj.fast.rigid import RigidTree
model = rigid_body_model(mujoco.MjModel.from_xml_path({model!r}))
tree = RigidTree.from_model(model)
n, points = model.nv, 1
mass, first, inertia, armature = tree.scaled(np.ones(points))
q, qd, applied = np.zeros((points, n)), np.zeros((points, n)), np.zeros((points, n))
out = [np.zeros((points, len(tree.sparse_row))), np.zeros((points, len(tree.sparse_row))), np.zeros((points, n)),
       np.zeros((points, n)), np.zeros((points, n))]
tree.evaluate(mass, first, inertia, armature, q, qd, applied, *out, True)
"""


@pytest.mark.slow  # a subprocess
def test_the_first_compilation_is_announced_once_and_cached(tmp_path):
    """An empty cache (a fresh NUMBA_CACHE_DIR): one line on stderr naming the cache; the next process loads
    the cached kernel and says nothing."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    code = FIRST_CALL.format(model=str(MODELS / "puma560.xml"))

    def stderr() -> list[str]:
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        return [line for line in done.stderr.splitlines() if line.strip()]

    first = stderr()
    assert len(first) == 1 and first[0].startswith("compiling the rigid-body model (first run on this machine")
    assert str(tmp_path) in first[0]
    assert any(tmp_path.rglob("*.nbi"))
    assert stderr() == []
