"""The controller's nominal model: M(q) and Psi(q, qd) = -M^-1 (C qd + G) from the MJCF (eq. (5.2)), at many
evaluation points at once (:class:`~ftc_mj.robot.nominal.batch.NominalBatch`), M at the readings, and what one
control period hands the plugins (:class:`~ftc_mj.robot.nominal.step.StepModel`).

The model is a private rigid-body copy of the robot's MjModel (:mod:`~ftc_mj.robot.nominal.rigid_copy`), so
evaluating it at an estimated state never touches the simulation. ``mass_scale`` scales every body's mass and
inertia (and the joint armature) of the copy, which gives a controlled model mismatch (the scenario's
``nominal`` section, :mod:`~ftc_mj.robot.nominal.section`). :func:`nominal_batch` chooses, once, what evaluates
it: for a kinematic tree of hinge and slide joints (every shipped robot) the rigid-body algorithms
(:mod:`~ftc_mj.robot.nominal.tree`), compiled with the fast paths on and their NumPy definition
(:mod:`~ftc_mj.robot.nominal.algorithms`) with them off, the same bits either way and equal to MuJoCo's forward
pass to rounding; for any other model MuJoCo's own batch (:mod:`~ftc_mj.robot.nominal.mujoco_batch`).

The modules, one concept each: ``batch`` (what every implementation offers), ``tree``, ``algorithms`` and
``mujoco_batch`` (the implementations), ``readings`` (M at the readings, as an implementation gives it),
``rigid_copy``, ``matrices`` (M v, dense copies of the sparse M), ``solve`` (M^-1 v as ``mj_solveM``), ``step``
(the period's :class:`~ftc_mj.robot.nominal.step.StepModel`) and ``section`` (the scenario's section). The
names used elsewhere are importable from the package itself.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ftc_mj.fast.rigid import RigidTree
from ftc_mj.robot.nominal.batch import MassAtReadings, NominalBatch, PlantMassSource, at_rest
from ftc_mj.robot.nominal.matrices import DenseMass, MatvecSite, matvec
from ftc_mj.robot.nominal.mujoco_batch import MuJoCoMomentumTerms, MuJoCoNominal
from ftc_mj.robot.nominal.readings import MassBatch, MassPoints, PlantMass
from ftc_mj.robot.nominal.rigid_copy import rigid_body_model, scale_masses
from ftc_mj.robot.nominal.section import NominalSpec
from ftc_mj.robot.nominal.solve import SparseSolver, solve_sparse
from ftc_mj.robot.nominal.step import NEEDS, StepModel
from ftc_mj.robot.nominal.tree import TreeNominal

__all__ = ["NEEDS", "DenseMass", "MassAtReadings", "MassBatch", "MassPoints", "MatvecSite", "MuJoCoMomentumTerms",
           "MuJoCoNominal", "NominalBatch", "NominalSpec", "PlantMass", "PlantMassSource", "SparseSolver",
           "StepModel", "TreeNominal", "at_rest", "matvec", "nominal_batch", "rigid_body_model", "scale_masses",
           "solve_sparse"]


def nominal_batch(model: mujoco.MjModel, mass_scale: np.ndarray, nthread: int,
                  mass_only: bool = False, momentum_points: np.ndarray | None = None,
                  mass_points: np.ndarray | None = None) -> NominalBatch:
    """The nominal model of ``model`` at ``len(mass_scale)`` points, one mass scale each: the rigid-body
    algorithms (:class:`TreeNominal`) where the robot is a tree of hinge and slide joints (every shipped
    scenario's; not Menagerie's Panda with its coupled fingers), MuJoCo's own batch (``nthread`` threads)
    otherwise.

    ``momentum_points``: a ``(points,)`` mask of the points where C(q, qd)^T qd and G(q) are wanted as well
    (:data:`NEEDS`), or None: nowhere, at no cost. ``mass_points``: the mass scales of the rows whose M at the
    readings :meth:`~NominalBatch.mass_at_readings` gives (the rigid-body algorithms evaluate them in the same
    call as the points), or None: not wanted."""
    rigid = rigid_body_model(model)
    mass_scale = np.asarray(mass_scale, dtype=float)
    tree = RigidTree.from_model(rigid)
    if tree is None:
        return MuJoCoNominal(rigid, mass_scale, nthread, mass_only, momentum_points, mass_points)
    return TreeNominal(tree, rigid, mass_scale, mass_only, momentum_points, nthread, mass_points)
