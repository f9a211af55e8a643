"""The nominal model's rigid-body algorithms, compiled: M(q), C(q, qd) qd + G(q), the factorisation of M and
M^-1 (applied - C qd - G) for many evaluation points at once (eq. (5.2)).

A controller's nominal model is a kinematic tree of rigid links, hinge and slide joints and gravity; nothing
else of MuJoCo's forward pass is used (the copy in :func:`~ftc_mj.robot.nominal.rigid_body_model` disables the
rest). MuJoCo's ``mj_forward`` still spends most of a point's cost in the stages and bookkeeping a general
engine needs, and a campaign evaluates two points per row and control period. The textbook algorithms on that
tree, compiled with Numba, take a small fraction of it (the nominal-model phase of ``benchmarks/loop_phases.py``):

- kinematics from the joint positions (MuJoCo's conventions: a hinge turns its body about ``jnt_axis``
  through ``jnt_pos``; a slide moves it along the axis; angles from ``qpos0``);
- the recursive Newton-Euler algorithm with zero joint acceleration and the base accelerated against gravity,
  which gives MuJoCo's ``qfrc_bias`` = C(q, qd) qd + G(q);
- the composite-rigid-body algorithm for M(q) (plus the joint armature);
- M = L' D L in MuJoCo's own sparse layout (``qLD``, ``qLDiagInv``), by ``mj_factorM``'s recursion from the
  last joint up, so that :class:`~ftc_mj.robot.nominal.SparseSolver` solves with it unchanged;
- at the points that ask for them (the generalized momentum observer's terms, which MuJoCo does not give):
  C(q, qd)^T qd and G(q) apart, by the formulas below.

**C^T qd.** With p = M(q) qd the generalized momentum, p_i = S_i' h_i, h_i = sum over the subtree of i of
I_j V_j (each body's spatial momentum, world coordinates). Along a motion with qdd = 0 and no gravity,
dp/dt = Mdot qd, and d(I_j V_j)/dt = I_j A_j + V_j x* I_j V_j, whose sum over the subtree projected on S_i is
Newton-Euler's C qd; the joint axis, fixed in its body, turns with it: dS_i/dt = V_i x S_i. So

    (Mdot qd)_i = (V_i x S_i)' h_i + (C qd)_i

and with Mdot = C + C^T (the skew-symmetry of Mdot - 2C that the momentum observer rests on, De Luca and
Mattone, ICRA 2005), C^T qd = Mdot qd - C qd, i.e. (C^T qd)_i = (V_i x S_i)' h_i per joint i: MuJoCo's
``cdof_dot`` dotted with the subtree's momentum (:class:`~ftc_mj.robot.nominal.MuJoCoMomentumTerms` computes
it so). **G(q)** is Newton-Euler at rest: G_i = S_i' (I^c_i a_0), the composite inertia of i's subtree times
the base acceleration a_0 = [0; -gravity].

Everything is expressed in world coordinates about the world origin (Featherstone's spatial vectors, angular
part first), where composite inertias simply add. Bodies without a joint are welded into the nearest ancestor
that has one (their inertias combined once at construction), so the recursion runs over joints only.

The numbers equal MuJoCo's to rounding (about 1e-15 relative; tested on every shipped robot) but not bit for
bit. Every point is computed by the same compiled code whatever the number of points, so a member of a batch
still gets exactly the bits of its single run.

**First run.** The kernel compiles on its first call on a machine and is cached by Numba: beside this file
when its folder is writable (an editable install), else in the user's cache folder (a read-only install), or
in ``NUMBA_CACHE_DIR`` when set. A call that has to compile says so in one line on stderr
(:func:`ftc_mj.fast.announce_compilation`); ``benchmarks/first_compile.py`` measures what it costs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numba
import numpy as np

from ftc_mj import fast
from ftc_mj.fast.kernels import WITHOUT_RUNTIME, bound, cache_folder, cache_is_cold

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
#: No point asks for the momentum terms: the kernel's arguments when none are wanted (types fixed for Numba).
_NO_POINTS = np.zeros(0, dtype=np.bool_)
_NO_TERMS = np.zeros((0, 0))


@dataclass(frozen=True)
class RigidTree:
    """A model's kinematic tree with one joint per node (node i is dof i), in the arrays the kernels read.

    Frames: a node's ``offset_*`` place its body frame (before its joint moves it) in its parent node's body
    frame, or in the world for a root node. Inertias are the node's welded bodies together, about the node's
    body origin and in its body frame: ``mass``, first moment ``first_moment`` (mass times the centre of mass)
    and ``inertia`` (3 x 3)."""

    parent: np.ndarray  # (n,) int64, -1 for a root
    offset_position: np.ndarray  # (n, 3)
    offset_rotation: np.ndarray  # (n, 3, 3)
    hinge: np.ndarray  # (n,) bool: hinge, else slide
    axis: np.ndarray  # (n, 3) unit, body frame
    anchor: np.ndarray  # (n, 3) body frame
    reference: np.ndarray  # (n,) the joint's qpos0
    armature: np.ndarray  # (n,)
    mass: np.ndarray  # (n,)
    first_moment: np.ndarray  # (n, 3)
    inertia: np.ndarray  # (n, 3, 3)
    gravity: np.ndarray  # (3,)
    #: MuJoCo's sparse layout of M and its factor: for each entry, its row and column.
    sparse_row: np.ndarray  # (nM,) int64
    sparse_column: np.ndarray  # (nM,) int64

    @property
    def n(self) -> int:
        return len(self.parent)

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> RigidTree | None:
        """The tree of ``model`` (its masses as they are), or None where these kernels do not apply: a body with
        more than one joint, a joint other than hinge or slide, gravity compensation, or what the rigid-body
        copy keeps MuJoCo's whole model for (tendons, equality constraints, flexes, mocap bodies)."""
        if (model.ntendon or model.neq or model.nflex or model.nmocap or model.nv == 0 or model.nq != model.nv
                or np.any(model.body_jntnum > 1) or np.any(model.body_gravcomp != 0.0)
                or not np.isin(model.jnt_type, (_HINGE, _SLIDE)).all()):
            return None
        n = model.nv
        node_of_body = np.full(model.nbody, -1)
        # Each body's pose in its carrier's frame: the carrier is the nearest body, itself included, with a
        # joint (world: -1); a jointed body's pose in its own frame is the identity.
        pose_position = np.zeros((model.nbody, 3))
        pose_rotation = np.tile(np.eye(3), (model.nbody, 1, 1))
        parent, offset_position, offset_rotation = np.full(n, -1), np.zeros((n, 3)), np.zeros((n, 3, 3))
        mass, first_moment, inertia = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
        for body in range(1, model.nbody):
            up = model.body_parentid[body]
            rotation = np.zeros(9)
            mujoco.mju_quat2Mat(rotation, model.body_quat[body])
            # The body's frame in its parent's carrier's frame.
            position = pose_position[up] + pose_rotation[up] @ model.body_pos[body]
            rotation = pose_rotation[up] @ rotation.reshape(3, 3)
            if model.body_jntnum[body] == 1:
                joint = model.body_jntadr[body]
                node = model.jnt_dofadr[joint]
                node_of_body[body] = node
                parent[node] = node_of_body[up]
                offset_position[node], offset_rotation[node] = position, rotation
            else:  # welded to its parent's carrier
                node_of_body[body] = node_of_body[up]
                pose_position[body], pose_rotation[body] = position, rotation
            node = node_of_body[body]
            if node < 0 or model.body_mass[body] == 0.0:
                continue
            # The body's inertia about its carrier's origin, in the carrier's frame.
            principal = np.zeros(9)
            mujoco.mju_quat2Mat(principal, model.body_iquat[body])
            frame = pose_rotation[body] @ principal.reshape(3, 3)
            centre = pose_position[body] + pose_rotation[body] @ model.body_ipos[body]
            m = model.body_mass[body]
            mass[node] += m
            first_moment[node] += m * centre
            inertia[node] += (frame * model.body_inertia[body]) @ frame.T + m * (centre @ centre * np.eye(3)
                                                                                - np.outer(centre, centre))
        jointed = node_of_body[model.body_jntnum == 1]
        if np.any(np.diff(jointed) <= 0) or np.any(parent >= np.arange(n)):
            return None  # dofs out of tree order (MuJoCo numbers them in body order; a guard, not expected)
        sparse_row = np.repeat(np.arange(n), model.M_rownnz)
        joints = model.dof_jntid
        return cls(parent=parent.astype(np.int64), offset_position=offset_position,
                   offset_rotation=np.ascontiguousarray(offset_rotation),
                   hinge=model.jnt_type[joints] == _HINGE, axis=model.jnt_axis[joints].copy(),
                   anchor=model.jnt_pos[joints].copy(), reference=model.qpos0[model.jnt_qposadr[joints]].copy(),
                   armature=model.dof_armature.copy(), mass=mass, first_moment=first_moment, inertia=inertia,
                   gravity=model.opt.gravity.copy(), sparse_row=sparse_row.astype(np.int64),
                   sparse_column=model.M_colind.astype(np.int64))

    def scaled(self, mass_scale: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per point ``(points, n, ...)``: mass, first moment, inertia and armature times the point's scale (the
        nominal model's controlled mismatch, as :func:`~ftc_mj.robot.nominal.scale_masses` scales MuJoCo's)."""
        scale = np.asarray(mass_scale, dtype=float)
        return (scale[:, None] * self.mass, scale[:, None, None] * self.first_moment,
                scale[:, None, None, None] * self.inertia, scale[:, None] * self.armature)

    def evaluate(self, *arguments: object, **keywords: object) -> None:
        """The kernel at every point, on :meth:`arguments`' parameters (what it computes is said there)."""
        evaluate(self.arguments(*arguments, **keywords))

    def arguments(self, mass: np.ndarray, first_moment: np.ndarray, inertia: np.ndarray, armature: np.ndarray,
                  qpos: np.ndarray, qvel: np.ndarray, applied: np.ndarray, sparse_M: np.ndarray,
                  factor: np.ndarray, diagonal_inverse: np.ndarray, qacc: np.ndarray, bias: np.ndarray,
                  with_velocity: bool, momentum_points: np.ndarray | None = None,
                  coriolis_transpose: np.ndarray | None = None, gravity: np.ndarray | None = None,
                  velocity_points: int | None = None) -> tuple:
        """The compiled kernel's arguments, for :func:`evaluate` (made once where the same points are evaluated
        every period: the call then skips this wrapper). The kernel computes, at every point: M (sparse), its
        factorisation and, ``with_velocity``, C qd + G into ``bias`` and M^-1 (applied - bias) into ``qacc``.
        The per-point inertias come from :meth:`scaled`.

        ``momentum_points`` (a ``(points,)`` mask, with ``with_velocity``): where C(q, qd)^T qd and G(q) are
        computed as well, into ``coriolis_transpose`` and ``gravity`` ``(points, n)`` (the module docstring);
        the other points' rows are left as they are. None: nowhere (nothing computed, nothing written).
        ``velocity_points``: with ``with_velocity``, only the first that many points have the velocity terms,
        the others M alone (None: every point)."""
        if momentum_points is None:
            momentum_points, coriolis_transpose, gravity = _NO_POINTS, _NO_TERMS, _NO_TERMS
        if not with_velocity:
            velocity_points = 0
        elif velocity_points is None:
            velocity_points = len(qpos)
        return (self.parent, self.offset_position, self.offset_rotation, self.hinge, self.axis, self.anchor,
                self.reference, self.gravity, self.sparse_row, self.sparse_column,
                mass, first_moment, inertia, armature, qpos, qvel, applied,
                sparse_M, factor, diagonal_inverse, qacc, bias, int(velocity_points),
                momentum_points, coriolis_transpose, gravity, np.empty(scratch_size(self.n)))


def scratch_size(n: int) -> int:
    """The length of the kernel's scratch buffer for a tree of ``n`` joints: its working arrays, one call's
    (so each thread's call has its own)."""
    return 9 * n + 3 * n + 4 * 6 * n + n + 3 * n + 9 * n + n * n + n + 6 * n + 45


def evaluate(arguments: tuple) -> None:
    """The compiled kernel on :meth:`RigidTree.arguments`; its first call in a process may compile it (said once)."""
    if not _evaluate.overloads:  # its ``signatures`` builds a list of types per call: dearer than the kernel
        _announce()
    _evaluate(*arguments)


def evaluation(arguments: tuple) -> Callable[[], None]:
    """:func:`evaluate` on ``arguments`` (the same buffers every call) as a call without arguments, past Numba's
    dispatcher (:func:`~ftc_mj.fast.kernels.bound`); it may compile the kernel now (said once)."""
    if not _evaluate.overloads:
        _announce()
    return bound(_evaluate, *arguments)


def _announce() -> None:
    """One line on stderr when the kernel is about to compile (the first run on a machine, or after an update)."""
    fast.announce_compilation("the rigid-body model", cache_is_cold(_evaluate, __file__), cache_folder(_evaluate))


@numba.njit(cache=True, nogil=True)
def _cross(a0: float, a1: float, a2: float, b: np.ndarray, out: np.ndarray, sign: float) -> None:
    """``out`` += sign (a x b). Compiled apart, not inlined by Numba: LLVM inlines a function this small at each
    of its twenty-odd call sites anyway (the same bits and cost per point), while Numba's inlining before typing
    types it again at every site, which made most of the cut kernel's extra first compilation
    (``benchmarks/first_compile.py``)."""
    out[0] += sign * (a1 * b[2] - a2 * b[1])
    out[1] += sign * (a2 * b[0] - a0 * b[2])
    out[2] += sign * (a0 * b[1] - a1 * b[0])


@numba.njit(cache=True, nogil=True, inline="always")
def _row_dot(matrix: np.ndarray, r: int, vector: np.ndarray) -> float:
    """``matrix[r] . vector`` of 3-vectors, summed from the left."""
    return matrix[r, 0] * vector[0] + matrix[r, 1] * vector[1] + matrix[r, 2] * vector[2]


@numba.njit(cache=True, nogil=True, inline="always")
def _apply_inertia(m: float, h: np.ndarray, inertia: np.ndarray, motion: np.ndarray, out: np.ndarray) -> None:
    """``out`` = I motion for a spatial inertia (mass m, first moment h, rotational inertia about the origin),
    motion = [w; v]: [I w + h x v; m v - h x w]."""
    w, v = motion[:3], motion[3:]
    for r in range(3):
        out[r] = inertia[r, 0] * w[0] + inertia[r, 1] * w[1] + inertia[r, 2] * w[2]
        out[3 + r] = m * v[r]
    _cross(h[0], h[1], h[2], v, out[:3], 1.0)
    _cross(h[0], h[1], h[2], w, out[3:], -1.0)


#: The compiled kernel's parts: inlined into :func:`_evaluate` by Numba before typing (``inline="always"``), so
#: that the cut costs no call and passes no array (parts compiled apart cost markedly more per point, as
#: ``benchmarks/rigid_cost.py`` shows against such a version: LLVM does not inline functions this large).
#: Numba types a part again at each of its call sites, so each part has one.
_PART = {"cache": True, "nogil": True, "inline": "always"}


@numba.njit(**_PART)
def _views(scratch: np.ndarray, n: int) -> tuple:
    """The kernel's working arrays: views of the caller's buffer (:func:`scratch_size`), so that it allocates
    nothing."""
    o = 0
    rotation = scratch[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    position = scratch[o:o + 3 * n].reshape((n, 3))
    o += 3 * n
    subspace = scratch[o:o + 6 * n].reshape((n, 6))  # each joint's motion subspace S, world [w; v at the origin]
    o += 6 * n
    velocity = scratch[o:o + 6 * n].reshape((n, 6))
    o += 6 * n
    acceleration = scratch[o:o + 6 * n].reshape((n, 6))
    o += 6 * n
    force = scratch[o:o + 6 * n].reshape((n, 6))
    o += 6 * n
    c_mass = scratch[o:o + n]  # composite inertias, world frame about the origin
    o += n
    c_first = scratch[o:o + 3 * n].reshape((n, 3))
    o += 3 * n
    c_inertia = scratch[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    dense = scratch[o:o + n * n].reshape((n, n))
    o += n * n
    rhs = scratch[o:o + n]
    o += n
    subtree_momentum = scratch[o:o + 6 * n].reshape((n, 6))  # h_i: i's subtree's spatial momenta [angular; linear]
    o += 6 * n
    momentum, column, base = scratch[o:o + 6], scratch[o + 6:o + 12], scratch[o + 12:o + 18]
    before, turn = scratch[o + 18:o + 27].reshape((3, 3)), scratch[o + 27:o + 36].reshape((3, 3))
    world_axis, world_anchor = scratch[o + 36:o + 39], scratch[o + 39:o + 42]
    h = scratch[o + 42:o + 45]  # a node's first moment about its body origin, world axes
    if o + 45 != scratch.shape[0]:  # the views would run past a shorter buffer: unchecked memory
        raise ValueError("the scratch buffer is not scratch_size(n) long")
    return (rotation, position, subspace, velocity, acceleration, force, c_mass, c_first, c_inertia, dense, rhs,
            subtree_momentum, momentum, column, base, before, turn, world_axis, world_anchor, h)


@numba.njit(**_PART)
def _place(i, displacement, up, offset_position, offset_rotation, hinge, axis, anchor, rotation, position,
           subspace, before, turn, world_axis, world_anchor):  # pragma: no cover - compiled
    """Node i's frame in the world (``rotation``, ``position``) and its motion subspace, from its parent's frame,
    its offset and its joint's displacement: a hinge turns the body about its axis through the anchor
    (Rodrigues), a slide moves it along the axis."""
    for r in range(3):
        for c in range(3):
            if up < 0:
                before[r, c] = offset_rotation[i, r, c]
            else:
                before[r, c] = (rotation[up, r, 0] * offset_rotation[i, 0, c]
                                + rotation[up, r, 1] * offset_rotation[i, 1, c]
                                + rotation[up, r, 2] * offset_rotation[i, 2, c])
        if up < 0:
            position[i, r] = offset_position[i, r]
        else:
            position[i, r] = (position[up, r] + rotation[up, r, 0] * offset_position[i, 0]
                              + rotation[up, r, 1] * offset_position[i, 1]
                              + rotation[up, r, 2] * offset_position[i, 2])
    for r in range(3):
        world_axis[r] = _row_dot(before, r, axis[i])
        world_anchor[r] = position[i, r] + _row_dot(before, r, anchor[i])
    if hinge[i]:
        s, c1 = np.sin(displacement), 1.0 - np.cos(displacement)
        x, y, z = axis[i, 0], axis[i, 1], axis[i, 2]
        turn[0, 0] = 1.0 - c1 * (y * y + z * z)
        turn[1, 1] = 1.0 - c1 * (x * x + z * z)
        turn[2, 2] = 1.0 - c1 * (x * x + y * y)
        turn[0, 1] = c1 * x * y - s * z
        turn[1, 0] = c1 * x * y + s * z
        turn[0, 2] = c1 * x * z + s * y
        turn[2, 0] = c1 * x * z - s * y
        turn[1, 2] = c1 * y * z - s * x
        turn[2, 1] = c1 * y * z + s * x
        for r in range(3):
            for c in range(3):
                rotation[i, r, c] = before[r, 0] * turn[0, c] + before[r, 1] * turn[1, c] + before[r, 2] * turn[2, c]
        for r in range(3):
            position[i, r] = world_anchor[r] - _row_dot(rotation[i], r, anchor[i])
        for r in range(3):
            subspace[i, r] = world_axis[r]
        subspace[i, 3] = world_anchor[1] * world_axis[2] - world_anchor[2] * world_axis[1]
        subspace[i, 4] = world_anchor[2] * world_axis[0] - world_anchor[0] * world_axis[2]
        subspace[i, 5] = world_anchor[0] * world_axis[1] - world_anchor[1] * world_axis[0]
    else:
        for r in range(3):
            for c in range(3):
                rotation[i, r, c] = before[r, c]
        for r in range(3):
            position[i, r] += world_axis[r] * displacement
        subspace[i, :3] = 0.0
        for r in range(3):
            subspace[i, 3 + r] = world_axis[r]


@numba.njit(**_PART)
def _world_inertia(m, first_moment, inertia, rotation, d, turn, h, c_inertia, c_first):  # pragma: no cover
    """A node's inertia in world coordinates about the world origin (its mass ``m``, first moment and inertia
    about its body origin in its body frame; its frame ``rotation``, ``d``): R I R' shifted by the position d,
    I_O = R I R' - m [d][d] - [d][h] - [h][d] with h = R h_body, into ``c_inertia`` and ``c_first``."""
    for r in range(3):
        h[r] = _row_dot(rotation, r, first_moment)
    for r in range(3):
        for c in range(3):
            turn[r, c] = (inertia[r, 0] * rotation[c, 0] + inertia[r, 1] * rotation[c, 1]
                          + inertia[r, 2] * rotation[c, 2])
    for r in range(3):
        for c in range(3):
            c_inertia[r, c] = rotation[r, 0] * turn[0, c] + rotation[r, 1] * turn[1, c] + rotation[r, 2] * turn[2, c]
    # -[a][b] = (a . b) E - b a'; the shift is m(-[d][d]) + (-[d][h]) + (-[h][d]).
    dd, dh = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], d[0] * h[0] + d[1] * h[1] + d[2] * h[2]
    for r in range(3):
        for c in range(3):
            shift = -m * d[c] * d[r] - h[r] * d[c] - d[r] * h[c]
            if r == c:
                shift += m * dd + 2.0 * dh
            c_inertia[r, c] += shift
    for r in range(3):
        c_first[r] = m * d[r] + h[r]


@numba.njit(**_PART)
def _newton_euler_forward(p, n, parent, qvel, gravity, subspace, velocity, acceleration, force, column, momentum,
                          c_mass, c_first, c_inertia, subtree_momentum, with_momentum):  # pragma: no cover
    """Newton-Euler, forward: velocities, accelerations with qdd = 0 and the base at -gravity, and each node's
    force I a + V x* (I V) (its spatial momentum I V kept where ``with_momentum``)."""
    for i in range(n):
        up = parent[i]
        speed = qvel[p, i]
        for k in range(6):
            velocity[i, k] = (0.0 if up < 0 else velocity[up, k]) + subspace[i, k] * speed
            column[k] = subspace[i, k] * speed
        if up < 0:
            acceleration[i, :3] = 0.0
            for r in range(3):
                acceleration[i, 3 + r] = -gravity[r]
        else:
            for k in range(6):
                acceleration[i, k] = acceleration[up, k]
        # + V x S qd (motion cross product: [w x a_w; w x a_v + v x a_w])
        w, v = velocity[i, :3], velocity[i, 3:]
        _cross(w[0], w[1], w[2], column[:3], acceleration[i, :3], 1.0)
        _cross(w[0], w[1], w[2], column[3:], acceleration[i, 3:], 1.0)
        _cross(v[0], v[1], v[2], column[:3], acceleration[i, 3:], 1.0)
        # f = I a + V x* (I V) (force cross product: [w x f_n + v x f_f; w x f_f])
        _apply_inertia(c_mass[i], c_first[i], c_inertia[i], acceleration[i], force[i])
        _apply_inertia(c_mass[i], c_first[i], c_inertia[i], velocity[i], momentum)
        if with_momentum:
            for k in range(6):
                subtree_momentum[i, k] = momentum[k]
        _cross(w[0], w[1], w[2], momentum[:3], force[i, :3], 1.0)
        _cross(v[0], v[1], v[2], momentum[3:], force[i, :3], 1.0)
        _cross(w[0], w[1], w[2], momentum[3:], force[i, 3:], 1.0)


@numba.njit(**_PART)
def _backward(p, n, parent, subspace, force, bias, subtree_momentum, c_mass, c_first, c_inertia, with_velocity,
              with_momentum):  # pragma: no cover - compiled
    """Backward: Newton-Euler's joint forces (C qd + G into ``bias``), each subtree's momentum where
    ``with_momentum``, and the composite inertias for the CRBA."""
    for i in range(n - 1, -1, -1):
        up = parent[i]
        if with_velocity:
            total = 0.0
            for k in range(6):
                total += subspace[i, k] * force[i, k]
            bias[p, i] = total
        if up >= 0:
            if with_velocity:
                for k in range(6):
                    force[up, k] += force[i, k]
            if with_momentum:
                for k in range(6):
                    subtree_momentum[up, k] += subtree_momentum[i, k]
            c_mass[up] += c_mass[i]
            for r in range(3):
                c_first[up, r] += c_first[i, r]
                for c in range(3):
                    c_inertia[up, r, c] += c_inertia[i, r, c]


@numba.njit(**_PART)
def _momentum_terms(p, n, velocity, subspace, subtree_momentum, c_mass, c_first, c_inertia, base, column,
                    coriolis_transpose, gravity_torque):  # pragma: no cover - compiled
    """C^T qd = (V_i x S_i)' h_i and G_i = S_i' I^c_i a_0 (the module docstring) at point p."""
    for i in range(n):
        w, v, s_w, s_v = velocity[i, :3], velocity[i, 3:], subspace[i, :3], subspace[i, 3:]
        column[:] = 0.0  # V_i x S_i = [w x s_w; w x s_v + v x s_w]
        _cross(w[0], w[1], w[2], s_w, column[:3], 1.0)
        _cross(w[0], w[1], w[2], s_v, column[3:], 1.0)
        _cross(v[0], v[1], v[2], s_w, column[3:], 1.0)
        total = 0.0
        for k in range(6):
            total += column[k] * subtree_momentum[i, k]
        coriolis_transpose[p, i] = total
        _apply_inertia(c_mass[i], c_first[i], c_inertia[i], base, column)
        total = 0.0
        for k in range(6):
            total += subspace[i, k] * column[k]
        gravity_torque[p, i] = total


@numba.njit(**_PART)
def _mass_and_factor(p, n, parent, subspace, c_mass, c_first, c_inertia, armature, column, dense, sparse_row,
                     sparse_column, sparse_M, factor, diagonal_inverse):  # pragma: no cover - compiled
    """Composite rigid bodies, M[i, j] = S_j' (I^c_i S_i) along i's ancestors j, into ``sparse_M``; then
    M = L' D L in ``dense`` from the last row up (mj_factorM's order; a tree's structure has no fill-in), into
    ``factor`` and ``diagonal_inverse``."""
    for i in range(n):
        _apply_inertia(c_mass[i], c_first[i], c_inertia[i], subspace[i], column)
        j = i
        while j >= 0:
            total = 0.0
            for k in range(6):
                total += subspace[j, k] * column[k]
            dense[i, j] = total
            j = parent[j]
        dense[i, i] += armature[p, i]
    for entry in range(len(sparse_row)):
        sparse_M[p, entry] = dense[sparse_row[entry], sparse_column[entry]]
    for k in range(n - 1, -1, -1):
        inverse = 1.0 / dense[k, k]
        j = parent[k]
        while j >= 0:
            scaled = dense[k, j] * inverse
            i = j
            while i >= 0:
                dense[j, i] -= scaled * dense[k, i]
                i = parent[i]
            dense[k, j] = scaled
            j = parent[j]
    for entry in range(len(sparse_row)):
        factor[p, entry] = dense[sparse_row[entry], sparse_column[entry]]
    for i in range(n):
        diagonal_inverse[p, i] = 1.0 / dense[i, i]


@numba.njit(**_PART)
def _solve(p, n, parent, applied, bias, diagonal_inverse, dense, rhs, qacc):  # pragma: no cover - compiled
    """qacc = M^-1 (applied - bias) from the factor in ``dense``: x <- L'^-1 x, x <- D^-1 x, x <- L^-1 x."""
    for i in range(n):
        rhs[i] = applied[p, i] - bias[p, i]
    for i in range(n - 1, -1, -1):
        j = parent[i]
        while j >= 0:
            rhs[j] -= dense[i, j] * rhs[i]
            j = parent[j]
    for i in range(n):
        rhs[i] *= diagonal_inverse[p, i]
    for i in range(n):
        j = parent[i]
        while j >= 0:
            rhs[i] -= dense[i, j] * rhs[j]
            j = parent[j]
        qacc[p, i] = rhs[i]


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)
def _evaluate(parent, offset_position, offset_rotation, hinge, axis, anchor, reference, gravity, sparse_row,
              sparse_column, mass, first_moment, inertia, armature, qpos, qvel, applied, sparse_M, factor,
              diagonal_inverse, qacc, bias, velocity_points, momentum_points, coriolis_transpose,
              gravity_torque, scratch):  # pragma: no cover - compiled (tested through its wrapper)
    """:meth:`RigidTree.evaluate` over the points ``p``: kinematics and each node's inertia in world coordinates,
    Newton-Euler (the first ``velocity_points`` points), composite inertias, C^T qd and G where
    ``momentum_points`` asks, M, L'DL and the solve. One point's numbers come from its inputs alone (its working
    arrays, views of ``scratch``, are written before they are read at every point); the momentum terms only add
    outputs, the other quantities are computed as without them."""
    points, n = qpos.shape
    (rotation, position, subspace, velocity, acceleration, force, c_mass, c_first, c_inertia, dense, rhs,
     subtree_momentum, momentum, column, base, before, turn, world_axis, world_anchor, h) = _views(scratch, n)
    base[:3] = 0.0  # a_0 = [0; -gravity]
    for r in range(3):
        base[3 + r] = -gravity[r]
    any_momentum = len(momentum_points) > 0
    for p in range(points):
        with_velocity = p < velocity_points
        with_momentum = with_velocity and any_momentum and momentum_points[p]
        for i in range(n):
            _place(i, qpos[p, i] - reference[i], parent[i], offset_position, offset_rotation, hinge, axis, anchor,
                   rotation, position, subspace, before, turn, world_axis, world_anchor)
            _world_inertia(mass[p, i], first_moment[p, i], inertia[p, i], rotation[i], position[i], turn, h,
                           c_inertia[i], c_first[i])
            c_mass[i] = mass[p, i]
        if with_velocity:
            _newton_euler_forward(p, n, parent, qvel, gravity, subspace, velocity, acceleration, force, column,
                                  momentum, c_mass, c_first, c_inertia, subtree_momentum, with_momentum)
        _backward(p, n, parent, subspace, force, bias, subtree_momentum, c_mass, c_first, c_inertia, with_velocity,
                  with_momentum)
        if with_momentum:
            _momentum_terms(p, n, velocity, subspace, subtree_momentum, c_mass, c_first, c_inertia, base, column,
                            coriolis_transpose, gravity_torque)
        _mass_and_factor(p, n, parent, subspace, c_mass, c_first, c_inertia, armature, column, dense, sparse_row,
                         sparse_column, sparse_M, factor, diagonal_inverse)
        if with_velocity:
            _solve(p, n, parent, applied, bias, diagonal_inverse, dense, rhs, qacc)


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)
def solve_factored(factor, diagonal_inverse, vector, out, rows, starts, addresses, columns):  # noqa: ANN001, ANN201
    """``out[r] = M_r^-1 vector[r]`` from MuJoCo's factorisation M = L' D L of each row r (``qLD``,
    ``qLDiagInv``), with ``mj_solveM``'s operations in its order: x <- L'^-1 x from the last row up, x <- D^-1
    x, x <- L^-1 x from the first row down, each row's sparse dot product summed as ``mju_dotSparse`` sums
    it (four lanes over whole groups of four, added as (0 + 2) + (1 + 3), then the rest; fewer than four from
    the left). The sparse structure is flattened: ``rows`` with entries left of the diagonal, their entries
    ``starts[k]:starts[k + 1]`` of ``addresses`` (in qLD) and ``columns``."""
    for r in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[r, j] = vector[r, j]
        for k in range(len(rows) - 1, -1, -1):  # x <- L'^-1 x
            x_i = out[r, rows[k]]
            for e in range(starts[k], starts[k + 1]):
                out[r, columns[e]] -= factor[r, addresses[e]] * x_i
        for j in range(out.shape[1]):  # x <- D^-1 x
            out[r, j] *= diagonal_inverse[r, j]
        for k in range(len(rows)):  # x <- L^-1 x
            first, count = starts[k], starts[k + 1] - starts[k]
            whole = count - count % 4
            if whole:
                lane0 = factor[r, addresses[first]] * out[r, columns[first]]
                lane1 = factor[r, addresses[first + 1]] * out[r, columns[first + 1]]
                lane2 = factor[r, addresses[first + 2]] * out[r, columns[first + 2]]
                lane3 = factor[r, addresses[first + 3]] * out[r, columns[first + 3]]
                for j in range(4, whole, 4):
                    e = first + j
                    lane0 += factor[r, addresses[e]] * out[r, columns[e]]
                    lane1 += factor[r, addresses[e + 1]] * out[r, columns[e + 1]]
                    lane2 += factor[r, addresses[e + 2]] * out[r, columns[e + 2]]
                    lane3 += factor[r, addresses[e + 3]] * out[r, columns[e + 3]]
                dot = lane0 + lane2
                dot += lane1 + lane3
            else:
                dot, whole = factor[r, addresses[first]] * out[r, columns[first]], 1
            for j in range(whole, count):
                dot += factor[r, addresses[first + j]] * out[r, columns[first + j]]
            out[r, rows[k]] -= dot
