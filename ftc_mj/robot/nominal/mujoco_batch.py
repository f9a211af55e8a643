"""The nominal model evaluated by MuJoCo itself, on a private :class:`mujoco.batch.Batch`
(:class:`MuJoCoNominal`): for a robot the rigid-body algorithms do not cover (Menagerie's Panda with its
coupled fingers), and the reference the algorithms are tested against."""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco.batch import Batch

from ftc_mj.robot.nominal.batch import MassAtReadings, NominalBatch, PlantMassSource, checked_momentum_points
from ftc_mj.robot.nominal.matrices import DenseMass
from ftc_mj.robot.nominal.readings import MassBatch, PlantMass
from ftc_mj.robot.nominal.rigid_copy import REBUILT_JOINTS, scale_masses

_ACCELERATION_STAGE = int(mujoco.mjtStage.mjSTAGE_ACC)
_POSITION_STAGE = int(mujoco.mjtStage.mjSTAGE_POS)


class MuJoCoNominal(NominalBatch):
    """:class:`NominalBatch` on a private :class:`mujoco.batch.Batch`, one simulation per point, evaluated by
    MuJoCo itself (its forward pass up to the acceleration, or the position stage for a ``mass_only`` batch)."""

    def __init__(self, model: mujoco.MjModel, mass_scale: np.ndarray, nthread: int, mass_only: bool = False,
                 momentum_points: np.ndarray | None = None, mass_points: np.ndarray | None = None):
        """``model``: the rigid-body model (:func:`~ftc_mj.robot.nominal.rigid_copy.rigid_body_model`). With
        ``momentum_points``, C^T qd and G are computed at every point (:class:`MuJoCoMomentumTerms`).
        ``mass_points``: the rows' mass scales, for :meth:`mass_at_readings` (a batch of their own)."""
        self._model, self._nthread, self._mass_points = model, nthread, mass_points
        self.batch = Batch(model, len(mass_scale), nthread=nthread)
        if np.any(mass_scale != 1.0):
            scale_masses(self.batch.expand, mass_scale)
            self.batch.set_const()
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.applied = self.batch.bind("qfrc_applied")
        self.qacc, self._sparse_M = self.batch.bind("qacc"), self.batch.bind("M")
        self.factor, self.diagonal_inverse = self.batch.bind("qLD"), self.batch.bind("qLDiagInv")
        self._stage = _POSITION_STAGE if mass_only else _ACCELERATION_STAGE
        self._dense = DenseMass(model, len(mass_scale))
        self._terms = None
        self.coriolis_transpose = self.gravity = None
        if checked_momentum_points(momentum_points, len(mass_scale), mass_only) is not None:
            self._terms = MuJoCoMomentumTerms(model, self.batch)
            self.coriolis_transpose, self.gravity = self._terms.coriolis_transpose, self._terms.gravity

    def evaluate(self) -> None:
        self.batch.forward(stage=self._stage)
        if self._terms is not None:
            self._terms.evaluate()

    def mass_matrices(self) -> np.ndarray:
        return self._dense.update(self._sparse_M)

    def mass_at_readings(self, plant: PlantMassSource | None) -> MassAtReadings:
        """The plant's M(q) where given (MuJoCo's own numbers: the same M and factorisation, bit for bit, at no
        extra evaluation), else a mass-only batch of the rows, evaluated after this one."""
        if plant is not None:
            return PlantMass(plant)
        if self._mass_points is None:
            raise ValueError("M at the readings: the nominal batch was made without mass_points")
        return MassBatch(MuJoCoNominal(self._model, np.asarray(self._mass_points, dtype=float), self._nthread,
                                       mass_only=True))



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
        if not np.isin(model.jnt_type, REBUILT_JOINTS).all():
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

