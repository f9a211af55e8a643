"""The rigid-body algorithms of the nominal model in NumPy, every evaluation point at once: the definition that
:mod:`ftc_mj.fast.rigid` accelerates, and what the nominal model runs with the fast paths off.

The algorithms, their conventions and the formulas of C(q, qd)^T qd and G(q) are those of :mod:`ftc_mj.fast.rigid`
(kinematics, recursive Newton-Euler with qdd = 0 and the base at -gravity, composite rigid bodies, MuJoCo's
L'DL factorisation of M and its solve, eq. (5.2)); each point's numbers come out of the same IEEE operations in
the same order as the compiled kernel's (every sum from the left, no fused multiply-add), so the two give the
same bits, not only the same numbers to rounding (tested on every shipped robot): switching the fast paths off
moves no result. The one outside dependency is ``sin`` and ``cos``: NumPy's and the compiled kernel's (the C
library's, Numba's SVML off: :mod:`ftc_mj.fast`) agree bit for bit where NumPy does not use SIMD versions of
its own for float64, which the conformance test checks.

The arithmetic runs over the points (arrays with the points first) and, where the recursion allows, over the
joints too; a loop over the joints remains where a joint needs its parent's result (the kinematic chain,
Newton-Euler's forward and backward passes, the factorisation and the solve). So a point's numbers come from its
inputs alone, whatever the number of points, as the kernel's do. It allocates its working arrays at each call
and pays NumPy's cost per operation on a few points: with the fast paths off a run is slower, not different
(``benchmarks/switch_off.py`` measures both).
"""

from __future__ import annotations

import numpy as np

#: The components of a cross product a x b: (a[_NEXT] * b[_LAST] - a[_LAST] * b[_NEXT]), component by component.
_NEXT, _LAST = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis (3), each component as the kernel's ``_cross`` computes it."""
    return a[..., _NEXT] * b[..., _LAST] - a[..., _LAST] * b[..., _NEXT]


def _matvec(matrix: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``matrix @ vector`` over the last axes (``(..., 3, 3)`` by ``(..., 3)``), summed from the left."""
    return (matrix[..., 0] * vector[..., None, 0] + matrix[..., 1] * vector[..., None, 1]
            + matrix[..., 2] * vector[..., None, 2])


def _matmul(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``left @ right`` over the last two axes (3 x 3), summed from the left."""
    return (left[..., 0, None] * right[..., None, 0, :] + left[..., 1, None] * right[..., None, 1, :]
            + left[..., 2, None] * right[..., None, 2, :])


def _apply_inertia(m: np.ndarray, h: np.ndarray, inertia: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """I motion for spatial inertias (mass ``m``, first moment ``h``, rotational inertia about the origin) over
    the leading axes, motion = [w; v]: [I w + h x v; m v - h x w], in the kernel's order."""
    w, v = motion[..., :3], motion[..., 3:]
    return np.concatenate([_matvec(inertia, w) + _cross(h, v), m[..., None] * v + -1.0 * _cross(h, w)], axis=-1)


def _dot6(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a . b`` of 6-vectors over the last axis, summed from the left from 0.0 (the kernel's ``total``)."""
    total = 0.0 + a[..., 0] * b[..., 0]
    for k in range(1, 6):
        total = total + a[..., k] * b[..., k]
    return total


def evaluate_tree(parent, offset_position, offset_rotation, hinge, axis, anchor, reference, gravity, sparse_row,
                  sparse_column, mass, first_moment, inertia, armature, qpos, qvel, applied, sparse_M, factor,
                  diagonal_inverse, qacc, bias, velocity_points, momentum_points, coriolis_transpose,
                  gravity_torque, scratch=None) -> None:  # noqa: ANN001
    """The compiled kernel's computation (``ftc_mj.fast.rigid._evaluate``; the arguments of
    :meth:`~ftc_mj.fast.rigid.RigidTree.arguments`, ``scratch`` unused) at every point at once: kinematics and
    each node's inertia in world coordinates, Newton-Euler (the first ``velocity_points`` points), composite
    inertias, C^T qd and G where ``momentum_points`` asks, M, L'DL and the solve, into the output arrays."""
    points, n = qpos.shape
    displacement = qpos - reference
    turn = _turns(axis, np.sin(displacement), 1.0 - np.cos(displacement))
    rotation, position = np.empty((points, n, 3, 3)), np.empty((points, n, 3))
    world_axis, world_anchor = np.empty((points, n, 3)), np.empty((points, n, 3))
    for i in range(n):  # the kinematic chain, parents first
        up = parent[i]
        if up < 0:  # (3, 3) and (3,): broadcast over the points below
            before, place = offset_rotation[i], offset_position[i]
        else:
            before = _matmul(rotation[:, up], offset_rotation[i])
            rotation_up, offset = rotation[:, up], offset_position[i]
            place = (position[:, up] + rotation_up[..., 0] * offset[0] + rotation_up[..., 1] * offset[1]
                     + rotation_up[..., 2] * offset[2])
        world_axis[:, i] = _matvec(before, axis[i])
        if hinge[i]:  # the body turns by the angle about its axis, through the anchor
            world_anchor[:, i] = place + _matvec(before, anchor[i])
            rotation[:, i] = _matmul(before, turn[:, i])
            position[:, i] = world_anchor[:, i] - _matvec(rotation[:, i], anchor[i])
        else:  # it moves along its axis
            rotation[:, i] = before
            position[:, i] = place + world_axis[:, i] * displacement[:, i, None]
    # Each joint's motion subspace S in world coordinates [w; v at the origin].
    subspace = np.zeros((points, n, 6))
    hinges, slides = np.flatnonzero(hinge), np.flatnonzero(~hinge)
    subspace[:, hinges, :3] = world_axis[:, hinges]
    subspace[:, hinges, 3:] = _cross(world_anchor[:, hinges], world_axis[:, hinges])
    subspace[:, slides, 3:] = world_axis[:, slides]
    # Each node's inertia in world coordinates about the world origin (the kernel's comments), every node at once.
    d = position
    h = _matvec(rotation, first_moment)
    c_inertia = _matmul(rotation, _matmul(inertia, np.swapaxes(rotation, -1, -2)))
    dd = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]
    dh = d[..., 0] * h[..., 0] + d[..., 1] * h[..., 1] + d[..., 2] * h[..., 2]
    shift = (-mass[..., None, None] * d[..., None, :] * d[..., :, None] - h[..., :, None] * d[..., None, :]
             - d[..., :, None] * h[..., None, :])
    diagonal = np.arange(3)
    shift[..., diagonal, diagonal] += (mass * dd + 2.0 * dh)[..., None]
    c_inertia += shift
    c_mass, c_first = mass.copy(), mass[..., None] * d + h
    moving = slice(0, velocity_points)
    if velocity_points:
        # Newton-Euler, forward: velocities, and accelerations with qdd = 0 and the base at -gravity.
        column = subspace[moving] * qvel[moving, :, None]
        velocity = np.empty((velocity_points, n, 6))
        for i in range(n):
            up = parent[i]
            velocity[:, i] = (0.0 if up < 0 else velocity[:, up]) + column[:, i]
        # + V x S qd (motion cross product: [w x a_w; w x a_v + v x a_w]), each node's share at once, then added
        # down the tree in the kernel's order.
        w, v = velocity[..., :3], velocity[..., 3:]
        turning, carried, swept = _cross(w, column[..., :3]), _cross(w, column[..., 3:]), _cross(v, column[..., :3])
        acceleration = np.empty((velocity_points, n, 6))
        for i in range(n):
            up = parent[i]
            if up < 0:
                acceleration[:, i, :3] = 0.0
                acceleration[:, i, 3:] = -gravity
            else:
                acceleration[:, i] = acceleration[:, up]
            acceleration[:, i, :3] += turning[:, i]
            acceleration[:, i, 3:] += carried[:, i]
            acceleration[:, i, 3:] += swept[:, i]
        own = (c_mass[moving], c_first[moving], c_inertia[moving])
        force, momentum = _apply_inertia(*own, acceleration), _apply_inertia(*own, velocity)
        force[..., :3] += _cross(w, momentum[..., :3])
        force[..., :3] += _cross(v, momentum[..., 3:])
        force[..., 3:] += _cross(w, momentum[..., 3:])
    # Backward: Newton-Euler's joint forces, and the composite inertias for the CRBA (the subtrees' momenta summed
    # in ``momentum`` as the kernel sums them in its ``subtree_momentum``).
    for i in range(n - 1, -1, -1):
        up = parent[i]
        if up >= 0:
            if velocity_points:
                force[:, up] += force[:, i]
                momentum[:, up] += momentum[:, i]
            c_mass[:, up] += c_mass[:, i]
            c_first[:, up] += c_first[:, i]
            c_inertia[:, up] += c_inertia[:, i]
    if velocity_points:
        bias[moving] = _dot6(subspace[moving], force)
    if len(momentum_points):
        # C^T qd = (V_i x S_i)' h_i and G_i = S_i' I^c_i a_0 where asked (ftc_mj.fast.rigid's docstring).
        wanted = np.flatnonzero(momentum_points[moving])
        w, v, s = velocity[wanted, :, :3], velocity[wanted, :, 3:], subspace[wanted]
        turning = np.concatenate([0.0 + _cross(w, s[..., :3]), 0.0 + _cross(w, s[..., 3:]) + _cross(v, s[..., :3])],
                                 axis=-1)
        coriolis_transpose[wanted] = _dot6(turning, momentum[wanted])
        base = np.zeros((len(wanted), n, 6))
        base[..., 3:] = -gravity
        weight = _apply_inertia(c_mass[wanted], c_first[wanted], c_inertia[wanted], base)
        gravity_torque[wanted] = _dot6(s, weight)
    # Composite rigid bodies: M[i, j] = S_j' (I^c_i S_i) along i's ancestors j.
    column = _apply_inertia(c_mass, c_first, c_inertia, subspace)
    rows, columns = _ancestor_pairs(parent)
    dense = np.zeros((points, n, n))
    dense[:, rows, columns] = _dot6(subspace[:, columns], column[:, rows])
    diagonal = np.arange(n)
    dense[:, diagonal, diagonal] += armature
    sparse_M[...] = dense[:, sparse_row, sparse_column]
    # M = L' D L, from the last row up (mj_factorM's order).
    for k in range(n - 1, -1, -1):
        inverse = 1.0 / dense[:, k, k]
        j = parent[k]
        while j >= 0:
            scaled = dense[:, k, j] * inverse
            i = j
            while i >= 0:
                dense[:, j, i] -= scaled * dense[:, k, i]
                i = parent[i]
            dense[:, k, j] = scaled
            j = parent[j]
    factor[...] = dense[:, sparse_row, sparse_column]
    diagonal_inverse[...] = 1.0 / dense[:, diagonal, diagonal]
    if velocity_points:
        # qacc = M^-1 (applied - bias): x <- L'^-1 x, x <- D^-1 x, x <- L^-1 x.
        rhs = applied[moving] - bias[moving]
        for i in range(n - 1, -1, -1):
            j = parent[i]
            while j >= 0:
                rhs[:, j] -= dense[moving, i, j] * rhs[:, i]
                j = parent[j]
        rhs *= diagonal_inverse[moving]
        for i in range(n):
            j = parent[i]
            while j >= 0:
                rhs[:, i] -= dense[moving, i, j] * rhs[:, j]
                j = parent[j]
        qacc[moving] = rhs


def _turns(axis: np.ndarray, s: np.ndarray, c1: np.ndarray) -> np.ndarray:
    """Rodrigues' rotation of every joint at every point, ``(points, n, 3, 3)``, by the angles whose sine is ``s``
    and versine ``c1`` (``(points, n)``) about the unit axes ``axis`` ``(n, 3)``, entry by entry as the kernel
    writes it (a slide joint's is unused)."""
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    turn = np.empty(s.shape + (3, 3))
    turn[..., 0, 0] = 1.0 - c1 * (y * y + z * z)
    turn[..., 1, 1] = 1.0 - c1 * (x * x + z * z)
    turn[..., 2, 2] = 1.0 - c1 * (x * x + y * y)
    turn[..., 0, 1] = c1 * x * y - s * z
    turn[..., 1, 0] = c1 * x * y + s * z
    turn[..., 0, 2] = c1 * x * z + s * y
    turn[..., 2, 0] = c1 * x * z - s * y
    turn[..., 1, 2] = c1 * y * z - s * x
    turn[..., 2, 1] = c1 * y * z + s * x
    return turn


def _ancestor_pairs(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (i, j) with j = i or an ancestor of i: M's entries of a tree."""
    rows, columns = [], []
    for i in range(len(parent)):
        j = i
        while j >= 0:
            rows.append(i)
            columns.append(j)
            j = parent[j]
    return np.array(rows), np.array(columns)
