"""Checks for plugin authors: a method's batch gives each member's single run, bit for bit.

The engine runs ``members`` copies of a method at once, and member k of a batch must give the bits it gives
alone (:class:`ftc_mj.methods.plugin.Method`'s contract; ``docs/explanation/batching.md``).
:func:`assert_batch_equals_single` checks that for any observer or controller plugin, as the engine builds
it: each member's gains validated by the plugin's ``Config`` and stacked into ``(members, n)`` arrays, the
batch and each member alone (a batch of one) driven by the same random inputs period after period, every
state array compared member by member::

    from ftc_mj.testing import assert_batch_equals_single

    def test_a_member_of_a_batch_is_its_single_run():
        assert_batch_equals_single(MyObserver, [dict(bandwidth=20.0), dict(bandwidth=40.0), dict(bandwidth=80.0)])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import SimpleNamespace

import numpy as np

from ftc_mj.engine.batching import stack
from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.plugin import Method
from ftc_mj.robot.nominal import matvec


def assert_batch_equals_single(plugin: type[Method], gains_per_member: Sequence[Mapping[str, object]],
                               n_joints: int = 3, dt: float = 1e-3, periods: int = 200, seed: int = 0) -> None:
    """Run ``plugin`` as a batch of ``len(gains_per_member)`` members (member k with gains
    ``gains_per_member[k]``, as a scenario file would write them) and each member alone, on the same random
    inputs for ``periods`` control periods; raise AssertionError, naming the attribute, member and period,
    where a member's array differs from its single run's in any bit (NaN equal to NaN).

    Compared after every call: every array attribute of the method with the member axis first (its estimates,
    the controller's ``tau`` and ``sliding``, internal states) and its ``signals``. The inputs: measured
    positions that wander with steps of every scale and exact zeros; for an observer the nominal model's Psi
    and M(q) (symmetric, positive definite, each member its own) and a command; for a controller a reference
    (one row shared by the members, as the engine's) and an observer's estimates. Use a number of members
    other than ``n_joints`` (a transposed axis then fails)."""
    members = len(gains_per_member)
    if members < 2:
        raise ValueError("assert_batch_equals_single: give the gains of two members or more")
    configs = [plugin.Config.model_validate(dict(gains), context={"n_joints": n_joints})
               for gains in gains_per_member]
    batch = plugin(stack(configs, n_joints), n_joints, dt, members)
    alone = [plugin(stack([config], n_joints), n_joints, dt, 1) for config in configs]
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(members, n_joints))
    if isinstance(batch, Observer):
        for method, rows in _each(batch, alone):
            method.reset(q[rows], np.zeros((len(q[rows]), n_joints)))
    else:
        for method, _ in _each(batch, alone):
            method.reset()
    _assert_members(batch, alone, "reset", -1)
    for k in range(periods):
        q = q + _steps(rng, members, n_joints)
        model, observer = _model(rng, members, n_joints), _estimates(rng, members, n_joints)
        if isinstance(batch, Observer):
            tau = rng.normal(size=(members, n_joints))
            for method, rows in _each(batch, alone):
                method.update(k * dt, q[rows], _rows(model, rows))
            _assert_members(batch, alone, "update", k)
            for method, rows in _each(batch, alone):
                method.advance(tau[rows], _rows(model, rows))
            _assert_members(batch, alone, "advance", k)
        elif isinstance(batch, Controller):
            reference = rng.normal(size=(3, n_joints))
            taus = [(method.compute(k * dt, *reference, q[rows], _rows(observer, rows), _rows(model, rows)).copy(),
                     rows) for method, rows in _each(batch, alone)]
            for member in range(members):
                np.testing.assert_array_equal(taus[0][0][member], taus[member + 1][0][0],
                                              err_msg=f"tau, member {member}, period {k}")
            _assert_members(batch, alone, "compute", k)
        else:
            raise TypeError(f"{plugin.__name__} is neither an Observer nor a Controller")


def _each(batch: Method, alone: list[Method]) -> list[tuple[Method, slice]]:
    """The batch with all rows, then each member alone with its row."""
    return [(batch, slice(None))] + [(method, slice(member, member + 1)) for member, method in enumerate(alone)]


def _steps(rng: np.random.Generator, members: int, n: int) -> np.ndarray:
    """A period's change of the readings: every scale from 1e-7 to 1, some exact zeros."""
    steps = rng.normal(size=(members, n)) * 10.0 ** rng.integers(-7, 1, size=(members, n))
    steps[rng.random((members, n)) < 0.1] = 0.0
    return steps


def _model(rng: np.random.Generator, members: int, n: int) -> SimpleNamespace:
    """A period's nominal model (the :class:`~ftc_mj.robot.nominal.StepModel` a method sees), each member's own."""
    a = rng.normal(size=(members, n, n))
    model = SimpleNamespace(M=a @ a.transpose(0, 2, 1) + n * np.eye(n), psi_hat=rng.normal(size=(members, n)),
                            coriolis_transpose=rng.normal(size=(members, n)), gravity=rng.normal(size=(members, n)),
                            qd_measured=None, command=rng.normal(size=(members, n)))
    model.psi_control = model.psi_hat
    return model


def _estimates(rng: np.random.Generator, members: int, n: int) -> SimpleNamespace:
    """An observer's estimates as a controller reads them."""
    return SimpleNamespace(q_hat=rng.normal(size=(members, n)), qd_hat=rng.normal(size=(members, n)),
                           luaf_hat=rng.normal(size=(members, n)), injection=rng.normal(size=(members, n)))


def _rows(values: SimpleNamespace, rows: slice) -> SimpleNamespace:
    """The members ``rows`` of a model or of estimates, with the model's calls on those members alone."""
    chosen = SimpleNamespace(**{name: value[rows] if isinstance(value, np.ndarray) else value
                                for name, value in vars(values).items()})
    if hasattr(values, "M"):
        chosen.control_velocity = lambda qd_hat: qd_hat
        chosen.apply_M = lambda vector, out: matvec(chosen.M, vector, out)
        # M^-1 tau stands in as a function of tau alone, each member's own, element by element.
        chosen.command_acceleration = lambda tau: chosen.command + 0.5 * tau
        chosen.solve_M = lambda vector: chosen.command * vector
    return chosen


def _assert_members(batch: Method, alone: list[Method], call: str, period: int) -> None:
    """Every member-first array of the batch, and each signal, against each member's single run."""
    members, single = len(alone), vars(alone[0])
    names = [name for name, value in vars(batch).items()
             if isinstance(value, np.ndarray) and isinstance(single.get(name), np.ndarray)
             and value.shape == (members, *single[name].shape[1:]) and single[name].shape[:1] == (1,)]
    for member, method in enumerate(alone):
        for name in names:
            np.testing.assert_array_equal(getattr(batch, name)[member], getattr(method, name)[0],
                                          err_msg=f"{name}, member {member}, after {call} of period {period}")
        for name, values in batch.signals.items():
            np.testing.assert_array_equal(values[member], method.signals[name][0],
                                          err_msg=f"signal {name}, member {member}, after {call} of period {period}")
