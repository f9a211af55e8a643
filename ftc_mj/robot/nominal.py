"""The controller's nominal model: M(q) and Psi(q, qd) = -M^-1 (C qd + G) from the MJCF (eq. (5.2)), at many
evaluation points at once (:class:`NominalBatch`), and what one control period hands the plugins
(:class:`StepModel`).

The model is a private rigid-body copy of the robot's MjModel (:func:`rigid_body_model`), so evaluating it at
an estimated state never touches the simulation. ``mass_scale`` scales every body's mass and inertia (and the
joint armature) of the copy, which gives a controlled model mismatch (the scenario's ``nominal`` section,
:class:`NominalSpec`). Two implementations evaluate it, chosen once by :func:`nominal_batch`: MuJoCo's own
batch (:class:`MuJoCoNominal`, the definition) and, with the fast paths on (:mod:`ftc_mj.fast`), the compiled
rigid-body algorithms (:class:`CompiledNominal`, equal to MuJoCo's to rounding).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache, partial
from typing import Protocol

import mujoco
import numpy as np
from mujoco.batch import Batch

from ftc_mj import fast
from ftc_mj.config.types import PositiveFloat, Strict
from ftc_mj.fast.crossovers import PAIRED_COLUMNS, POINTS_PER_THREAD
from ftc_mj.fast.kernels import bound
from ftc_mj.fast.matrices import gather, matvec_in_pairs
from ftc_mj.fast.rigid import RigidTree, evaluation, solve_factored
from ftc_mj.robot.friction import FrictionSpec


def matvec(matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Row by row, ``out[r] = matrices[r] @ vectors[r]`` (``(rows, n, n)`` by ``(rows, n)``): the definition is
    ``np.einsum("rij,rj->ri")``, each row summed alone (the same bits whatever the number of rows); with the
    fast paths on and at most :data:`~ftc_mj.fast.crossovers.PAIRED_COLUMNS` joints, its accelerator
    :func:`~ftc_mj.fast.matrices.matvec_in_pairs`."""
    if matrices.shape[-1] <= PAIRED_COLUMNS and fast.enabled():
        matvec_in_pairs(matrices, vectors, out)
        return out
    return np.einsum("rij,rj->ri", matrices, vectors, out=out)


class MatvecSite:
    """:func:`matvec` at one call site, past Numba's dispatcher once its matrices, vectors and output are the
    arrays of the call before (the same objects): a loop that maps the same buffers every period then pays the
    compiled function's call alone (:func:`~ftc_mj.fast.kernels.bound`). The caller compares the arrays
    with :attr:`matrices`, :attr:`vectors`, :attr:`out` inline (a method call would cost what it saves) and
    calls :attr:`call` (no arguments: it is bound to those arrays) where they are the same, :meth:`new` where
    not; a caller whose own buffers never change need compare only the others. The same bits either way."""

    __slots__ = ("matrices", "vectors", "out", "call", "_seen")

    def __init__(self) -> None:
        #: The arrays :attr:`call` is bound to (None: none yet), and the bound call.
        self.matrices: np.ndarray | None = None
        self.vectors: np.ndarray | None = None
        self.out: np.ndarray | None = None
        self.call: Callable[[], None] = _unbound
        self._seen: tuple[np.ndarray, np.ndarray] | None = None

    def new(self, matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> np.ndarray:
        """:func:`matvec` of arrays other than the bound call's; where the vectors and output are those of the
        last call too, the compiled product is bound to these arrays for the next calls (fast paths on)."""
        seen, self._seen = self._seen, (vectors, out)
        if (seen is not None and seen[0] is vectors and seen[1] is out and matrices.shape[-1] <= PAIRED_COLUMNS
                and fast.enabled() and all(type(a) is np.ndarray for a in (matrices, vectors, out))):
            self.matrices, self.vectors, self.out = matrices, vectors, out
            self.call = bound(matvec_in_pairs, matrices, vectors, out)
        return matvec(matrices, vectors, out)


def _unbound() -> None:
    raise RuntimeError("MatvecSite.call before MatvecSite.new bound it")


#: The nominal quantities beyond M and Psi that an observer may declare in ``needs``
#: (:attr:`~ftc_mj.methods.observers.base.Observer.needs`): the engine then has the nominal batch evaluate them
#: at that observer's points (``momentum_points`` of :func:`nominal_batch`) and hands them to it as the
#: :class:`StepModel` attributes of the same names. C(q, qd)^T qd and G(q), the generalized momentum observer's
#: beta = G - C^T qd (De Luca and Mattone, ICRA 2005), are evaluated together.
NEEDS = frozenset({"coriolis_transpose", "gravity"})


class NominalSpec(Strict):
    #: Scales masses, inertias and armature of the controller's model (1 = exact model).
    mass_scale: PositiveFloat = 1.0
    #: Joint friction and damping, the model file's own by default (:mod:`ftc_mj.robot.friction`).
    friction: FrictionSpec = FrictionSpec()


class StepModel:
    r"""Nominal quantities of one control period for a block of members, computed once and shared by the
    observer and the controller (views of the engine's batched evaluation, :class:`NominalBatch`): the terms of
    the plant (5.2), :math:`\ddot q = \Psi(q, \dot q) + M(q)^{-1} \tau + \Delta` with
    :math:`\Psi = -M^{-1} (C \dot q + G + F)`.

    Attributes:
        M: :math:`M(x_1)` at the measured position, ``(members, n, n)``.
        psi_hat: :math:`\Psi(\hat x_1, \hat x_2)` at the observer's state estimate, ``(members, n)``: what the
            observers integrate.
        psi_control: :math:`\Psi` at the state the controller uses. With a tachometer reading ``qd_measured`` (a
            robot with tachometers whose chapter feeds the controller the measured velocity, Chapter 2:
            :math:`H(x)` of (2.25), (2.32)) it is :math:`\Psi(x_1, x_2)` at the readings; otherwise it is
            ``psi_hat`` itself (the same array).
        qd_measured: the tachometer readings the controller uses, or None when it uses the estimate
            :math:`\hat x_2`.
        coriolis_transpose: :math:`C(q, \dot q)^T \dot q` at the observer's state estimate (the point of
            ``psi_hat``), ``(members, n)``, with C the Coriolis matrix for which :math:`\dot M - 2C` is
            skew-symmetric; only for an observer that declares it in ``needs`` (:data:`NEEDS`), else None.
        gravity: :math:`G(q)` at the observer's estimate, ``(members, n)``; only where declared in ``needs``,
            else None.
        friction: the nominal joint friction :math:`F(\dot q)` at the observer's point
            (:mod:`ftc_mj.robot.friction`), ``(members, n)``, already inside ``psi_hat``; None where the nominal
            model has none.
    """

    def __init__(self, M: np.ndarray, factor: np.ndarray, diagonal_inverse: np.ndarray, psi_hat: np.ndarray,
                 solver: SparseSolver, psi_control: np.ndarray | None = None,
                 qd_measured: np.ndarray | None = None, command: np.ndarray | None = None,
                 coriolis_transpose: np.ndarray | None = None, gravity: np.ndarray | None = None,
                 friction: np.ndarray | None = None):
        r"""``command``: where the engine puts :math:`M(x_1)^{-1} \tau` of the period's command once the
        controllers have run, solved for every row of its batch at once (see :meth:`command_acceleration`); None:
        solved on demand. ``coriolis_transpose``, ``gravity``: the nominal batch's rows of these quantities at the
        observer's points, or None."""
        self.M, self.psi_hat = M, psi_hat
        self.psi_control = psi_hat if psi_control is None else psi_control
        self.qd_measured = qd_measured
        self.coriolis_transpose, self.gravity = coriolis_transpose, gravity
        self.friction = friction
        self._factor, self._diagonal_inverse, self._solver = factor, diagonal_inverse, solver
        self._solution = np.zeros(psi_hat.shape)
        self._command = command
        self._apply = MatvecSite()

    def control_velocity(self, observer_qd_hat: np.ndarray) -> np.ndarray:
        r"""The velocity :math:`x_2` the controller uses: the tachometer reading or the observer's
        :math:`\hat x_2`."""
        return observer_qd_hat if self.qd_measured is None else self.qd_measured

    def solve_M(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1)^{-1} v` per member (v the ``vector``), as ``mj_solveM`` computes it. Returns an internal
        buffer (no allocation per step): valid until the next call."""
        return self._solver.solve(self._factor, self._diagonal_inverse, vector, self._solution)

    def command_acceleration(self, tau: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1)^{-1} \tau` for the command ``tau`` of this period (what an observer integrates in
        :meth:`~ftc_mj.methods.observers.base.Observer.advance`, e.g. eq. (5.6)). In the engine it was solved
        for every row at once after the controllers ran (the same bits as :meth:`solve_M`); elsewhere it is
        solved here. Valid until the next call or period."""
        return self.solve_M(tau) if self._command is None else self._command

    def apply_M(self, vector: np.ndarray, out: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1) v` per member (v the ``vector``), into ``out``."""
        site = self._apply
        if vector is site.vectors and out is site.out and self.M is site.matrices:
            site.call()
            return out
        return site.new(self.M, vector, out)


#: What the nominal model leaves out of MuJoCo's forward dynamics: constraints (joint limits, contacts,
#: friction loss), passive forces, actuators and sensors. What remains is qacc = M(q)^-1 (qfrc_applied - C(q, qd) qd -
#: G(q)), the rigid-body model of eq. (5.2).
_RIGID_BODY_ONLY = (
    mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    | mujoco.mjtDisableBit.mjDSBL_CONTACT
    | mujoco.mjtDisableBit.mjDSBL_SPRING
    | mujoco.mjtDisableBit.mjDSBL_DAMPER
    | mujoco.mjtDisableBit.mjDSBL_ACTUATION
    | mujoco.mjtDisableBit.mjDSBL_SENSOR
)
_ACCELERATION_STAGE = int(mujoco.mjtStage.mjSTAGE_ACC)
_POSITION_STAGE = int(mujoco.mjtStage.mjSTAGE_POS)
#: Joints :func:`rigid_body_model` rebuilds (a robot arm's); a model with others keeps its plain copy.
_REBUILT_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
#: Random states at which a rebuilt rigid-body model must give the plain copy's numbers bit for bit.
_CHECK_STATES = 8


def rigid_body_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A private copy of ``model`` that computes the rigid-body model of eq. (5.2) alone: constraints, passive
    forces, actuators and sensors disabled (:data:`_RIGID_BODY_ONLY`).

    Where it can, the copy is rebuilt from the kinematic tree and inertias alone: bodies (frames, masses,
    inertias, gravity compensation) and hinge or slide joints (axes, anchors, reference positions, armature),
    without geoms, sites, cameras, lights, sensors or actuators, which the nominal model never uses but MuJoCo
    would still place at every evaluation (a sixth of a forward pass on the PUMA560). The rebuilt copy must
    give the plain copy's M, factorisation, C qd + G and acceleration under an applied force bit for bit at
    random states; where it does not, or the model has what is not rebuilt (other joints, tendons, equality
    constraints, flexes, mocap bodies), the plain copy is returned."""
    full = copy.deepcopy(model)
    full.opt.disableflags |= int(_RIGID_BODY_ONLY)
    if (model.ntendon or model.neq or model.nflex or model.nmocap
            or not np.isin(model.jnt_type, _REBUILT_JOINTS).all()):
        return full
    spec = mujoco.MjSpec()
    spec.option.gravity = model.opt.gravity
    bodies = [spec.worldbody]
    for b in range(1, model.nbody):
        body = bodies[model.body_parentid[b]].add_body(
            pos=model.body_pos[b], quat=model.body_quat[b], mass=model.body_mass[b], ipos=model.body_ipos[b],
            iquat=model.body_iquat[b], inertia=model.body_inertia[b], explicitinertial=True,
            gravcomp=model.body_gravcomp[b])
        bodies.append(body)
        for joint in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            body.add_joint(type=mujoco.mjtJoint(model.jnt_type[joint]), axis=model.jnt_axis[joint],
                           pos=model.jnt_pos[joint], ref=model.qpos0[model.jnt_qposadr[joint]],
                           armature=model.dof_armature[model.jnt_dofadr[joint]])
    try:
        rigid = spec.compile()
    except ValueError:
        return full
    rigid.opt.disableflags, rigid.opt.enableflags = full.opt.disableflags, full.opt.enableflags
    return rigid if _same_dynamics(full, rigid) else full


def _same_dynamics(model: mujoco.MjModel, other: mujoco.MjModel) -> bool:
    """Whether two models give the same M, factorisation, bias and acceleration, bit for bit, at random states."""
    if (other.nq, other.nv, other.nM) != (model.nq, model.nv, model.nM):
        return False
    data, other_data = mujoco.MjData(model), mujoco.MjData(other)
    rng = np.random.default_rng(0)
    for _ in range(_CHECK_STATES):
        q, qd, force = rng.uniform(-np.pi, np.pi, model.nq), rng.normal(size=model.nv), rng.normal(size=model.nv)
        for m, d in ((model, data), (other, other_data)):
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, qd, force
            mujoco.mj_forward(m, d)
        if not all(np.array_equal(getattr(data, name), getattr(other_data, name))
                   for name in ("M", "qLD", "qLDiagInv", "qfrc_bias", "qacc")):
            return False
    return True


def scale_masses(fields: Callable[[str], np.ndarray], mass_scale: np.ndarray) -> None:
    """Multiply masses, inertias and joint armature by ``mass_scale`` (one per simulation), in place.

    ``fields(name)`` gives a model field with the simulations on its first axis (``Batch.expand``)."""
    scale = np.asarray(mass_scale, dtype=float)
    for name in ("body_mass", "body_inertia", "dof_armature"):
        values = fields(name)
        values *= scale.reshape((-1,) + (1,) * (values.ndim - 1))


class DenseMass:
    """Dense ``(rows, n, n)`` copies of MuJoCo's sparse joint-space inertia ``M`` (lower triangle, CSR)."""

    def __init__(self, model: mujoco.MjModel, rows: int):
        n = model.nv
        # For every dense entry, the sparse entry that holds it (or a zero appended after the last one).
        index = np.full((n, n), model.nM)
        for i in range(n):
            start = model.M_rowadr[i]
            for j in range(model.M_rownnz[i]):
                column = model.M_colind[start + j]
                index[i, column] = index[column, i] = start + j
        self._index = index.reshape(-1)
        # A chain's M has no structural zero: every dense entry is taken straight from the sparse values.
        self._padded = np.zeros((rows, model.nM + 1)) if np.any(self._index == model.nM) else None
        self.out = np.zeros((rows, n, n))
        self._flat = self.out.reshape(rows, n * n)
        #: The sparse values last filled from, and the gather bound to them (the definition ``numpy.take``; with the
        #: fast paths on, its accelerator :func:`~ftc_mj.fast.matrices.gather`).
        self._source: np.ndarray | None = None
        self._gather: Callable[[], None] = lambda: None

    def update(self, sparse: np.ndarray) -> np.ndarray:
        """Fill from the sparse values ``(rows, nM)`` and return the dense matrices."""
        if sparse is not self._source:  # callers fill from the same live buffer every period: bound once
            self._source = sparse
            values = sparse if self._padded is None else self._padded
            if fast.enabled():
                self._gather = bound(gather, values, self._index, self._flat)
            else:
                self._gather = partial(values.take, self._index, 1, self._flat)
        if self._padded is not None:  # a tree: gather from the values with a zero appended
            self._padded[:, :-1] = sparse
        self._gather()
        return self.out


class SparseSolver:
    """M(q)^-1 v for many rows at once with MuJoCo's own factorisation ``qLD``, ``qLDiagInv`` of each row: the
    operations of ``mj_solveM`` in its order (:func:`solve_sparse`; with the fast paths on, its accelerator
    :func:`~ftc_mj.fast.rigid.solve_factored`), so each row's answer is bit for bit what ``mj_solveM`` gives on
    one MjData (tested), in one call whatever the batch size. The model is the one whose sparsity the factors
    have (any mass scale: only the structure is used)."""

    def __init__(self, model: mujoco.MjModel):
        # The rows with entries left of the diagonal, in order, and those entries (address in qLD, column),
        # row after row: mj_solveM's loops over the sparse structure, flattened.
        rows, starts, addresses, columns = [], [0], [], []
        for i in range(model.nv):
            first = model.M_rowadr[i]
            entries = [(int(first + j), int(model.M_colind[first + j])) for j in range(model.M_rownnz[i] - 1)]
            if entries:
                rows.append(i)
                addresses += [address for address, _ in entries]
                columns += [column for _, column in entries]
                starts.append(len(addresses))
        self._structure = tuple(np.asarray(values, dtype=np.int64) for values in (rows, starts, addresses, columns))
        self._n = model.nv

    @property
    def structure(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The flattened sparse structure :func:`solve_sparse` takes after ``out``: the rows
        with entries left of the diagonal, their entries' starts, addresses in qLD and columns."""
        return self._structure

    def solve(self, factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out = M^-1 vector`` per row, from the rows' ``qLD`` ``(rows, nM)`` and ``qLDiagInv`` ``(rows, n)``;
        ``vector`` is ``(rows, n)`` or one ``(n,)`` for every row."""
        if vector.ndim == 1:
            vector = np.broadcast_to(vector, (len(out), self._n))
        (solve_factored if fast.enabled() else solve_sparse)(factor, diagonal_inverse, vector, out,
                                                              *self._structure)
        return out

    def bound(self, factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray,
              out: np.ndarray) -> Callable[[], None]:
        """:meth:`solve` of these buffers (``vector`` ``(rows, n)``), as a call without arguments (with the fast
        paths on, past Numba's dispatcher: :func:`~ftc_mj.fast.kernels.bound`): for a loop that solves the same
        buffers every period."""
        if fast.enabled():
            return bound(solve_factored, factor, diagonal_inverse, vector, out, *self._structure)
        return partial(solve_sparse, factor, diagonal_inverse, vector, out, *self._structure)


def solve_sparse(factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray, out: np.ndarray,
                 rows: np.ndarray, starts: np.ndarray, addresses: np.ndarray, columns: np.ndarray) -> None:
    """The definition of :class:`SparseSolver`'s solve: ``out[r] = M_r^-1 vector[r]`` from MuJoCo's
    factorisation M = L' D L of each row r (``qLD`` ``(rows, nM)``, ``qLDiagInv``), with ``mj_solveM``'s
    operations in its order, on every row at once: x <- L'^-1 x from the last row up, x <- D^-1 x, x <- L^-1 x
    from the first row down, each sparse dot product summed as ``mju_dotSparse`` sums it (four lanes over whole
    groups of four, added as (0 + 2) + (1 + 3), then the rest; fewer than four from the left). The structure
    is :attr:`SparseSolver.structure`."""
    out[...] = vector
    for k in range(len(rows) - 1, -1, -1):  # x <- L'^-1 x
        x_i = out[:, rows[k]].copy()
        for e in range(starts[k], starts[k + 1]):
            out[:, columns[e]] -= factor[:, addresses[e]] * x_i
    out *= diagonal_inverse  # x <- D^-1 x
    for k in range(len(rows)):  # x <- L^-1 x
        first, count = int(starts[k]), int(starts[k + 1] - starts[k])
        term = lambda e: factor[:, addresses[e]] * out[:, columns[e]]  # noqa: E731
        whole = count - count % 4
        if whole:
            lanes = [term(first + lane) for lane in range(4)]
            for j in range(4, whole, 4):
                for lane in range(4):
                    lanes[lane] += term(first + j + lane)
            dot = lanes[0] + lanes[2]
            dot += lanes[1] + lanes[3]
        else:
            dot, whole = term(first), 1
        for j in range(whole, count):
            dot += term(first + j)
        out[:, rows[k]] -= dot


class NominalBatch(Protocol):
    """The controller side's model of many evaluation points at once (eq. (5.2)).

    Each point is an evaluation point: set its ``qpos``, ``qvel`` and ``applied`` (``(points, n)``), call
    :meth:`evaluate`, and its ``qacc`` is M(q)^-1 (applied - C(q, qd) qd - G(q)) and :meth:`mass_matrices` is
    M(q), with M's factorisation in MuJoCo's sparse layout (``factor``, ``diagonal_inverse``; solved by
    :class:`SparseSolver`). With ``applied`` = 0 the acceleration is Psi(q, qd) of eq. (5.2). A point's mass
    scale is its own. A ``mass_only`` batch holds points where only M(q) is wanted: no velocity terms, no
    ``qacc``. A point's numbers do not depend on the number of points, so a batch member gets its single run's
    bits. Made by :func:`nominal_batch`.

    Where the batch was made with ``momentum_points``, :meth:`evaluate` also gives C(q, qd)^T qd and G(q)
    (:data:`NEEDS`) at least at those points, in ``coriolis_transpose`` and ``gravity``; else these are None.
    """

    qpos: np.ndarray
    qvel: np.ndarray
    applied: np.ndarray
    #: MuJoCo's factorisation of M at each point (``qLD``, ``qLDiagInv``), from the last :meth:`evaluate`.
    factor: np.ndarray
    diagonal_inverse: np.ndarray
    #: ``(points, n)`` C(q, qd)^T qd and G(q) from the last :meth:`evaluate`, or None (no ``momentum_points``).
    coriolis_transpose: np.ndarray | None
    gravity: np.ndarray | None

    @property
    def mass_from_plant(self) -> bool:
        """Whether M(q) of a MuJoCo plant of the same model at the same position is this model's M(q) and
        factorisation bit for bit, so that a caller may take it from the plant instead of evaluating it."""

    @property
    def qacc(self) -> np.ndarray:
        """``(points, n)``: M^-1 (applied - C qd - G) at each point, from the last :meth:`evaluate` (not in a
        ``mass_only`` batch)."""

    def evaluate(self) -> None:
        """Forward dynamics at every point (positions, velocities and applied forces as set), or M alone in a
        ``mass_only`` batch."""

    def mass_matrices(self) -> np.ndarray:
        """``(points, n, n)``: M(q) at each point, from the last :meth:`evaluate` (an internal buffer)."""


def nominal_batch(model: mujoco.MjModel, mass_scale: np.ndarray, nthread: int,
                  mass_only: bool = False, momentum_points: np.ndarray | None = None,
                  mass_points: np.ndarray | None = None) -> NominalBatch:
    """The nominal model of ``model`` at ``len(mass_scale)`` points, one mass scale each: the compiled
    rigid-body algorithms where the robot is a tree of hinge and slide joints (every shipped scenario's; not
    Menagerie's Panda with its coupled fingers) and the fast paths are on, MuJoCo's own batch (``nthread``
    threads) otherwise.

    ``momentum_points``: a ``(points,)`` mask of the points where C(q, qd)^T qd and G(q) are wanted as well
    (:data:`NEEDS`), or None: nowhere, at no cost. ``mass_points``: the mass scales of M-only points the
    compiled model evaluates in the same call (its ``at_readings``); MuJoCo's batch ignores them."""
    rigid = rigid_body_model(model)
    mass_scale = np.asarray(mass_scale, dtype=float)
    tree = RigidTree.from_model(rigid) if fast.enabled() else None
    if tree is None:
        return MuJoCoNominal(rigid, mass_scale, nthread, mass_only, momentum_points)
    return CompiledNominal(tree, rigid, mass_scale, mass_only, momentum_points, nthread, mass_points)


@lru_cache(maxsize=None)
def _threads(count: int) -> ThreadPoolExecutor:
    """A pool of ``count`` threads, made once per process and shared by every batch."""
    return ThreadPoolExecutor(max_workers=count, thread_name_prefix="ftc_mj-nominal")


class CompiledNominal(NominalBatch):
    """:class:`NominalBatch` by the compiled algorithms of :mod:`ftc_mj.fast.rigid`: about a quarter of
    MuJoCo's forward pass per point and equal to it to rounding (1e-15), not bit for bit."""

    #: It rounds otherwise than MuJoCo: it evaluates its own M.
    mass_from_plant = False

    def __init__(self, tree: RigidTree, model: mujoco.MjModel, mass_scale: np.ndarray, mass_only: bool = False,
                 momentum_points: np.ndarray | None = None, nthread: int = 1, mass_points: np.ndarray | None = None):
        """``model``: the rigid-body model whose tree ``tree`` is (for M's sparse layout). ``nthread`` > 1: the
        points are cut into as many slices (at least :data:`POINTS_PER_THREAD` each), evaluated at once on
        threads (the kernel releases the GIL); a point's numbers come from its inputs alone, so its bits are
        the same however the points are cut. ``mass_points``: the mass scales of more points, after these,
        where only M is wanted (M at the readings, evaluated in the same call: :attr:`at_readings`)."""
        velocity_points, n = 0 if mass_only else len(mass_scale), model.nv
        extra = np.zeros(0) if mass_points is None else np.asarray(mass_points, dtype=float)
        points = len(mass_scale) + len(extra)
        self._tree, self._inertias = tree, tree.scaled(np.concatenate([np.asarray(mass_scale, dtype=float), extra]))
        self.qpos, self.qvel, self.applied = np.zeros((points, n)), np.zeros((points, n)), np.zeros((points, n))
        self._qacc, self._bias = np.zeros((points, n)), np.zeros((points, n))
        self._sparse_M = np.zeros((points, model.nM))
        self.factor, self.diagonal_inverse = np.zeros((points, model.nM)), np.ones((points, n))
        self._dense = DenseMass(model, points)
        self._momentum_points = _momentum_points(momentum_points, len(mass_scale), mass_only)
        self.coriolis_transpose = self.gravity = None
        if self._momentum_points is not None:
            self._momentum_points = np.concatenate([self._momentum_points, np.zeros(len(extra), dtype=np.bool_)])
            self.coriolis_transpose, self.gravity = np.zeros((points, n)), np.zeros((points, n))
        #: The M-only points (views), or None.
        self.at_readings = None if mass_points is None else MassPoints(self, model, slice(len(mass_scale), points))
        threads = max(1, min(nthread, len(mass_scale) // POINTS_PER_THREAD))
        # Each thread's kernel calls, their arguments (views) made once. One thread: one call over every point.
        # More: each an equal share of the points with velocity terms and one of the M-only points (cheaper
        # per point), so that no thread waits for another.
        if threads == 1:
            self._tasks = [[evaluation(self._arguments(slice(0, points), velocity_points))]]
        else:
            self._tasks = [[evaluation(self._arguments(part, velocity_points))
                            for part in (_share(0, len(mass_scale), t, threads), _share(len(mass_scale), points, t,
                                                                                        threads))
                            if part.stop > part.start]
                           for t in range(threads)]
        # Threads from the second call on: the first may compile the kernel (and say so), once.
        self._pool: ThreadPoolExecutor | None = None
        self._threads = threads - 1

    def _arguments(self, points: slice, velocity_points: int) -> tuple:
        """The kernel's arguments for the points ``points`` (of which those before ``velocity_points`` have the
        velocity terms)."""
        cut = lambda array: None if array is None else array[points]  # noqa: E731
        return self._tree.arguments(
            *(array[points] for array in self._inertias), self.qpos[points], self.qvel[points],
            self.applied[points], self._sparse_M[points], self.factor[points], self.diagonal_inverse[points],
            self._qacc[points], self._bias[points], True, cut(self._momentum_points),
            cut(self.coriolis_transpose), cut(self.gravity),
            velocity_points=min(max(velocity_points - points.start, 0), points.stop - points.start))

    def evaluate(self) -> None:
        pool = self._pool
        if pool is None:  # one thread, or the first call
            for task in self._tasks:
                _run(task)
            if self._threads:
                self._pool = _threads(self._threads)
            return
        first, *others = self._tasks
        pending = [pool.submit(_run, task) for task in others]
        _run(first)  # the first thread's share on the calling thread, meanwhile
        for future in pending:
            future.result()

    @property
    def qacc(self) -> np.ndarray:
        return self._qacc

    def mass_matrices(self) -> np.ndarray:
        return self._dense.update(self._sparse_M)


def _share(start: int, stop: int, part: int, parts: int) -> slice:
    """Part ``part`` of ``parts`` near-equal consecutive parts of ``start:stop``."""
    bounds = np.linspace(start, stop, parts + 1).astype(int)
    return slice(int(bounds[part]), int(bounds[part + 1]))


def _run(task: list[Callable[[], None]]) -> None:
    """One thread's kernel calls."""
    for call in task:
        call()


class MassPoints:
    """The M-only points of a :class:`CompiledNominal` (its ``mass_points``): views of its arrays, evaluated by
    its :meth:`~CompiledNominal.evaluate`. Set ``qpos`` before it; :meth:`mass_matrices` after."""

    def __init__(self, batch: CompiledNominal, model: mujoco.MjModel, points: slice):
        self.qpos, self.qvel, self.applied = batch.qpos[points], batch.qvel[points], batch.applied[points]
        self.factor, self.diagonal_inverse = batch.factor[points], batch.diagonal_inverse[points]
        self._sparse_M = batch._sparse_M[points]
        self._dense = DenseMass(model, points.stop - points.start)

    def mass_matrices(self) -> np.ndarray:
        """``(points, n, n)``: M(q) at each point, from the batch's last evaluation (an internal buffer)."""
        return self._dense.update(self._sparse_M)


class MuJoCoNominal(NominalBatch):
    """:class:`NominalBatch` on a private :class:`mujoco.batch.Batch`, one simulation per point, evaluated by
    MuJoCo itself (its forward pass up to the acceleration, or the position stage for a ``mass_only`` batch)."""

    #: MuJoCo's own numbers: a plant of the same model at the same position has the same M, bit for bit.
    mass_from_plant = True
    #: No M-only points of its own: M at the readings is a batch apart or the plant's.
    at_readings = None

    def __init__(self, model: mujoco.MjModel, mass_scale: np.ndarray, nthread: int, mass_only: bool = False,
                 momentum_points: np.ndarray | None = None):
        """``model``: the rigid-body model (:func:`rigid_body_model`). With ``momentum_points``, C^T qd and G
        are computed at every point (:class:`MuJoCoMomentumTerms`)."""
        self.batch = Batch(model, len(mass_scale), nthread=nthread)
        if np.any(mass_scale != 1.0):
            scale_masses(self.batch.expand, mass_scale)
            self.batch.set_const()
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.applied = self.batch.bind("qfrc_applied")
        self._qacc, self._sparse_M = self.batch.bind("qacc"), self.batch.bind("M")
        self.factor, self.diagonal_inverse = self.batch.bind("qLD"), self.batch.bind("qLDiagInv")
        self._stage = _POSITION_STAGE if mass_only else _ACCELERATION_STAGE
        self._dense = DenseMass(model, len(mass_scale))
        self._terms = None
        self.coriolis_transpose = self.gravity = None
        if _momentum_points(momentum_points, len(mass_scale), mass_only) is not None:
            self._terms = MuJoCoMomentumTerms(model, self.batch)
            self.coriolis_transpose, self.gravity = self._terms.coriolis_transpose, self._terms.gravity

    def evaluate(self) -> None:
        self.batch.forward(stage=self._stage)
        if self._terms is not None:
            self._terms.evaluate()

    @property
    def qacc(self) -> np.ndarray:
        return self._qacc

    def mass_matrices(self) -> np.ndarray:
        return self._dense.update(self._sparse_M)


def _momentum_points(momentum_points: np.ndarray | None, points: int, mass_only: bool) -> np.ndarray | None:
    """The mask of the points that want C^T qd and G, checked; None where none does."""
    if momentum_points is None:
        return None
    mask = np.asarray(momentum_points, dtype=np.bool_)
    if mask.shape != (points,):
        raise ValueError(f"momentum_points: a mask of the {points} points, not of shape {mask.shape}")
    if mass_only and mask.any():
        raise ValueError("momentum_points: a mass-only batch has no velocity terms")
    return np.ascontiguousarray(mask) if mask.any() else None


#: MuJoCo's 10-number body inertia ``cinert`` (I_xx, I_yy, I_zz, I_xy, I_xz, I_yz, m c_x, m c_y, m c_z, m, in
#: the com-based frame) as the 6 x 6 spatial inertia that ``mju_mulInertVec`` applies: the entry of ``cinert``
#: (10: zero) and its sign, row by row.
_INERTIA_ENTRY = np.array([[0, 3, 4, 10, 8, 7], [3, 1, 5, 8, 10, 6], [4, 5, 2, 7, 6, 10],
                           [10, 8, 7, 9, 10, 10], [8, 10, 6, 10, 9, 10], [7, 6, 10, 10, 10, 9]])
_INERTIA_SIGN = np.array([[1, 1, 1, 1, -1, 1], [1, 1, 1, 1, 1, -1], [1, 1, 1, -1, 1, 1],
                          [1, 1, -1, 1, 1, 1], [-1, 1, 1, 1, 1, 1], [1, -1, 1, 1, 1, 1]], dtype=float)


class MuJoCoMomentumTerms:
    """C(q, qd)^T qd and G(q) on a :class:`mujoco.batch.Batch` after its forward pass, from MuJoCo's com-based
    quantities, by the formulas of :mod:`ftc_mj.fast.rigid`: (C^T qd)_i = cdof_dot_i' h_i, h_i the spatial
    momentum ``cinert cvel`` summed over the subtree of dof i's body (``cdof_dot`` = cvel x cdof is dS_i/dt for a
    hinge or slide joint), and G_i = cdof_i' (I^c a_0), the subtree's inertia times a_0 = [0; -gravity].

    Hinge and slide joints only: for a ball or free joint's rotational dofs MuJoCo's ``cdof_dot`` is taken with
    the parent's velocity, which gives the right cdof_dot qd but not each axis' own derivative."""

    def __init__(self, model: mujoco.MjModel, batch: Batch):
        if not np.isin(model.jnt_type, _REBUILT_JOINTS).all():
            raise ValueError("C^T qd and G: the nominal model must have hinge and slide joints only")
        self._cinert, self._cvel = batch.bind("cinert"), batch.bind("cvel")
        self._cdof, self._cdof_dot = batch.bind("cdof"), batch.bind("cdof_dot")
        points, bodies, n = batch.nsim, model.nbody, model.nv
        self._parents = [(b, int(model.body_parentid[b])) for b in range(bodies - 1, 0, -1)
                         if model.body_parentid[b] > 0]
        self._dof_body = model.dof_bodyid.astype(np.intp)
        self._entry = _INERTIA_ENTRY.reshape(-1)
        self._sign = _INERTIA_SIGN.reshape(-1)
        self._at_rest = np.zeros(6)
        self._at_rest[3:] = -model.opt.gravity
        self._extended = np.zeros((points, bodies, 11))  # cinert and a zero
        self._spatial = np.zeros((points, bodies, 36))
        self._momentum = np.zeros((points, bodies, 6))  # I v, then summed over subtrees
        self._weight = np.zeros((points, bodies, 6))  # I a_0, then summed over subtrees
        self._gathered = np.zeros((points, n, 6))
        self.coriolis_transpose, self.gravity = np.zeros((points, n)), np.zeros((points, n))

    def evaluate(self) -> None:
        """From the batch's last forward pass (its velocity stage at least)."""
        self._extended[..., :10] = self._cinert
        spatial = self._extended.take(self._entry, axis=2, out=self._spatial)
        spatial *= self._sign
        spatial = spatial.reshape(spatial.shape[:2] + (6, 6))
        momentum, weight = self._momentum, self._weight
        np.einsum("pbij,pbj->pbi", spatial, self._cvel, out=momentum)
        np.einsum("pbij,j->pbi", spatial, self._at_rest, out=weight)
        for body, parent in self._parents:  # children before their parents
            momentum[:, parent] += momentum[:, body]
            weight[:, parent] += weight[:, body]
        gathered = momentum.take(self._dof_body, axis=1, out=self._gathered)
        np.einsum("pik,pik->pi", self._cdof_dot, gathered, out=self.coriolis_transpose)
        gathered = weight.take(self._dof_body, axis=1, out=self._gathered)
        np.einsum("pik,pik->pi", self._cdof, gathered, out=self.gravity)


def at_rest(batch: NominalBatch, points: np.ndarray) -> None:
    """Put ``points`` (a mask or indices) of ``batch`` at rest, q = qd = 0 with no applied force: where a
    stopped row's estimate may hold NaN or inf."""
    batch.qpos[points] = 0.0
    batch.qvel[points] = 0.0
    batch.applied[points] = 0.0
