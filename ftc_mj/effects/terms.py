"""Plant terms: friction, disturbance and additive fault terms acting on the true plant.

Sign convention: a term with value f and ``sign`` s enters the true plant as

* ``space: torque``:        M(q) qdd + C(q, qd) qd + G(q) = tau + s f
* ``space: acceleration``:  qdd = M(q)^-1 (tau - C qd - G) + s f    (applied as the torque s M(q) f)

so Chapter 5's (5.1) has friction and disturbance with s = -1 (torque) and the fault with s = +1
(acceleration). A term with an ``onset`` Tf is multiplied per joint by the profile 1 - exp(-rate (t - Tf))
for t >= Tf (abrupt, i.e. a step, when ``rate`` is absent) and is zero before; or by any ``profile`` of
:mod:`ftc_mj.effects.profiles`.

The ``terms`` section (:class:`TermSpec`) is compiled by :func:`compile_terms` into :class:`CompiledTerm`
objects; :class:`PlantTerms` evaluates them on the true state in the loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, partial
from collections.abc import Callable, Sequence
from typing import Literal

import numpy as np
import sympy as sp

from ftc_mj.effects.profiles import Profile, ProfileSpec, compile_profile
from ftc_mj import fast
from ftc_mj.config import expressions
from ftc_mj.config.errors import InputError
from ftc_mj.fast import programs
from ftc_mj.fast import terms as compiled
from ftc_mj.fast.kernels import bound
from ftc_mj.robot.nominal import MatvecSite
from ftc_mj.config.types import (ExpressionText, NonNegativeFloat, ParameterName, PositiveFloat, Strict,
                                parse_expression, per_joint)


class TermSpec(Strict):
    """A friction, disturbance or fault term: per-joint expressions of t, q1..qn, qd1..qn."""

    #: ``friction``, ``disturbance`` or ``fault`` (an additive actuator fault: recorded as the fault signal).
    kind: Literal["friction", "disturbance", "fault"]
    #: ``torque``: M qdd + C qd + G = tau + sign value; ``acceleration``: qdd = M^-1 (tau - C qd - G) + sign value.
    space: Literal["torque", "acceleration"]
    #: The sign the term enters the plant with.
    sign: Literal[1, -1]
    #: One expression of t, q1..qn, qd1..qn and the scenario's ``parameters`` per joint.
    value: list[ExpressionText]
    #: Onset Tf [s]: zero before it; abrupt when absent, unless ``rate`` or ``profile`` says otherwise.
    onset: NonNegativeFloat | None = None
    #: Evolution rate of 1 - exp(-rate (t - onset)), one number or one per joint, or the name of one of the
    #: scenario's ``parameters`` (then each member of a batch may have its own rate); abrupt when absent.
    rate: PositiveFloat | list[PositiveFloat] | ParameterName | None = None
    #: Any time profile of :mod:`ftc_mj.effects.profiles` (instead of ``onset`` and ``rate``).
    profile: ProfileSpec | None = None
    #: A name for the term (default: its kind and index).
    name: str | None = None


@dataclass
class CompiledTerm:
    """A plant term ready for the loop."""

    name: str
    kind: str
    space: str
    sign: float
    #: The value per joint, expressions of t, q1..qn, qd1..qn and the scenario's parameters.
    exprs: list[sp.Expr]
    #: The scenario's parameter names, in the order the expressions' functions take them.
    parameters: tuple[str, ...]
    #: None: always on.
    time_profile: Profile | None
    #: Joints whose value is not identically zero (a fault "on joint 1" has zeros elsewhere).
    joints: np.ndarray
    #: The parameter that holds the evolution rate (per member), or None (the profile's own, if any).
    rate_parameter: str | None = None

    @cached_property
    def function(self) -> expressions.StateFunction:
        """The term's value as a compiled function (on demand: the loop evaluates every term through one
        function of all of them, :func:`terms_function`)."""
        return expressions.StateFunction(self.exprs, len(self.exprs), list(self.parameters))

    @property
    def onset(self) -> float | None:
        return None if self.time_profile is None else self.time_profile.onset

    @property
    def rate(self) -> np.ndarray | None:
        """Per joint, for an incipient profile."""
        return None if self.time_profile is None else self.time_profile.rate

    def profile(self, t: float) -> np.ndarray | float | None:
        """The time profile per joint, e.g. omega(t - Tf) of (5.1): None while off (before the onset), then
        1 - exp(-rate (t - Tf)), or 1 when abrupt (see :class:`~ftc_mj.effects.profiles.Profile`)."""
        return 1.0 if self.time_profile is None else self.time_profile.weight(t)


def compile_terms(specs: list[TermSpec], file: str, n: int, parameters: list[str] = ()) -> list[CompiledTerm]:
    """The ``terms`` section for a robot of ``n`` joints; the expressions may use the named ``parameters``."""
    state_vars = expressions.state_variables(n) + list(parameters)
    terms = []
    for index, term in enumerate(specs):
        field = f"terms.{index}"
        if len(term.value) != n:
            raise InputError(file, f"{field}.value", f"has {len(term.value)} values, the robot has {n} joints")
        exprs = [parse_expression(text, state_vars, file, f"{field}.value.{j}") for j, text in enumerate(term.value)]
        terms.append(
            CompiledTerm(
                name=term.name or f"{term.kind}{index}",
                kind=term.kind,
                space=term.space,
                sign=float(term.sign),
                exprs=exprs,
                parameters=tuple(parameters),
                time_profile=_term_profile(term, file, field, n, parameters),
                joints=np.array([expr.is_zero is not True for expr in exprs]),
                rate_parameter=term.rate if isinstance(term.rate, str) else None,
            )
        )
    return terms


def terms_function(terms: list[CompiledTerm], n: int, parameters: Sequence[str]) -> expressions.StateFunction:
    """Every term's expressions compiled into one function (common subexpressions shared), evaluated once per
    period for all rows: compiled when a scenario loads, not per run."""
    return expressions.StateFunction([e for term in terms for e in term.exprs], n, list(parameters))


def _term_profile(term: TermSpec, file: str, field: str, n: int, parameters: Sequence[str]) -> Profile | None:
    """A plant term's profile: ``profile``, or the dissertation's ``onset`` with an optional ``rate``. A rate
    named by a parameter gives an abrupt profile here; :class:`PlantTerms` multiplies it by each member's
    1 - exp(-rate (t - onset))."""
    if term.profile is not None:
        if term.onset is not None or term.rate is not None:
            raise InputError(file, f"{field}.profile", "give either a profile or onset and rate, not both")
        return compile_profile(term.profile, file, f"{field}.profile", n)
    if term.rate is not None and term.onset is None:
        raise InputError(file, f"{field}.rate", "an evolution rate needs an onset")
    if term.onset is None:
        return None
    if isinstance(term.rate, str):
        if term.rate not in parameters:
            raise InputError(file, f"{field}.rate", f"{term.rate!r} is not one of the scenario's parameters")
        return Profile("abrupt", onset=term.onset)
    rate = None if term.rate is None else per_joint(term.rate, n, file, f"{field}.rate")
    return Profile("abrupt" if rate is None else "incipient", onset=term.onset, rate=rate)


def active_term_sets(on: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct sets of active terms and each sample's set: ``np.unique(on.T, axis=0, return_inverse=True)``
    of ``on`` (``(terms, samples)``, whether each term is on at each sample), the same arrays. Terms switch on
    and off a few times in a run, so only the first sample of each stretch with one set is compared with the
    others (NumPy's unique of rows sorts every sample's row: most of a single run's set-up)."""
    samples = on.shape[1]
    if samples == 0:  # no first sample to compare
        sets, plan_of_sample = np.unique(on.T, axis=0, return_inverse=True)
        return sets, plan_of_sample.reshape(-1)
    starts = np.flatnonzero(np.concatenate(([True], np.any(on[:, 1:] != on[:, :-1], axis=0))))
    sets, plan_of_stretch = np.unique(on.T[starts], axis=0, return_inverse=True)
    return sets, np.repeat(plan_of_stretch.reshape(-1), np.diff(np.append(starts, samples)))


class PlantTerms:
    """Friction, disturbance and fault terms of every row, evaluated on the true states.

    Every term's expressions are compiled into one function (:class:`~ftc_mj.config.expressions.StateFunction`),
    called once per period for all rows. The profiles depend on time only, so which terms are on at each
    sample of the run's grid, and their weights, are worked out before the run: each period then follows the
    plan of its set of active terms (``fault_on``: whether a fault term is on, per sample, for every row alike).
    Attributes after :meth:`apply`, ``(rows, n)``: ``fault`` (the fault terms' sum, each in its own space),
    ``fault_force`` (their generalized force, acceleration-space ones through the true M(q)).
    """

    def __init__(self, terms: list[CompiledTerm], times: np.ndarray, rows: int, n_joints: int,
                 parameters: np.ndarray, parameter_names: Sequence[str] = (),
                 function: expressions.StateFunction | None = None):
        self.terms = terms
        shape = (rows, n_joints)
        #: torque, acceleration, fault, fault force and fault acceleration sums, zeroed at once each period.
        self._sums = np.zeros((5,) + shape)
        self.torque, self.acceleration, self.fault, self.fault_force, self._fault_acceleration = self._sums
        self._mapped = np.zeros(shape)
        #: M(q) of the acceleration sum and of the fault's, each a call site of its own: its vectors and output
        #: are these buffers, so a site is compiled for a period's ``mass`` where it is the array it was
        #: compiled for.
        self._map_acceleration, self._map_fault_acceleration = MatvecSite(), MatvecSite()
        self._parameters = np.asarray(parameters, dtype=float).reshape(rows, -1)
        names = list(parameter_names)
        #: Per term with a rate parameter (a slot each, in file order): each row's rate ``(1, rows)``, the
        #: term's onset and sign; their weights 1 - exp(-rate (t - onset)) (the same for every joint) are
        #: tabulated for :data:`WEIGHT_BLOCK` samples at a time into ``_weights`` ``(slots, block, rows)``,
        #: from the sample ``_block_start`` on: three NumPy calls per block instead of per period.
        rated = [index for index, term in enumerate(terms) if term.rate_parameter]
        self._slots = np.full(len(terms), -1, dtype=np.int64)
        self._slots[rated] = np.arange(len(rated))
        self._rates = [(self._parameters[:, names.index(terms[index].rate_parameter)][None, :].copy(),
                        terms[index].onset, terms[index].sign) for index in rated]
        self._times = np.asarray(times, dtype=float)
        self._weights = np.zeros((max(len(rated), 1), min(WEIGHT_BLOCK, max(len(times), 1)), rows))
        self._block_start = -len(times) - WEIGHT_BLOCK  # no block tabulated yet
        #: :func:`terms_function` of ``terms`` (the scenario's, compiled when it loaded), or compiled here.
        self._function = function or terms_function(terms, n_joints, parameter_names)
        self._values = np.zeros((rows, len(terms) * n_joints))
        #: The true positions and velocities :meth:`apply` last read, and the terms' evaluation of them in time.
        self._state: tuple = (None, None, None)

        # sign x weight of every term at every sample (Profile.evaluate: what Profile.weight gives at each of
        # them), which terms are on, and the plan of each set of active terms.
        times = np.asarray(times, dtype=float)
        profiles = [term.time_profile for term in terms]
        always = np.ones((len(times), n_joints))
        self._factors = np.array([term.sign * (always if profile is None else profile.evaluate(times, n_joints))
                                  for term, profile in zip(terms, profiles)]).reshape(len(terms), len(times), n_joints)
        on = np.array([np.ones(len(times), dtype=bool) if profile is None else profile.active(times)
                       for profile in profiles], dtype=bool).reshape(len(terms), len(times))
        active_sets, plan_of_sample = active_term_sets(on)
        self._plan_of_sample = plan_of_sample.tolist()
        self._plans = [self._plan(np.flatnonzero(active)) for active in active_sets]
        #: Whether a fault term is on at each sample, ``(samples,)``.
        self.fault_on = np.array([plan.fault_active for plan in self._plans], dtype=bool)[plan_of_sample]

    def _plan(self, active: np.ndarray) -> "_Plan":
        """What a period with the terms ``active`` (indices, file order) does: each term, the sums it goes to
        (a row of :data:`_SUMS` flags), and its slot of per-row weights (-1: none)."""
        targets = np.zeros((len(active), len(_SUMS)), dtype=np.bool_)
        for step, index in enumerate(active.tolist()):
            term = self.terms[index]
            acceleration = term.space == "acceleration"
            targets[step, _SUMS.index("acceleration" if acceleration else "torque")] = True
            if term.kind == "fault":
                targets[step, _SUMS.index("fault")] = True
                targets[step, _SUMS.index("fault_acceleration" if acceleration else "fault_force")] = True
        acceleration_terms = [i for i in active.tolist() if self.terms[i].space == "acceleration"]
        acceleration_faults = [i for i in acceleration_terms if self.terms[i].kind == "fault"]
        plan = _Plan(
            terms=active.astype(np.int64),
            slots=self._slots[active],
            targets=targets,
            rated=bool(np.any(self._slots[active] >= 0)),
            fault_active=any(self.terms[i].kind == "fault" for i in active.tolist()),
            maps_acceleration=bool(acceleration_terms),
            maps_fault_acceleration=bool(acceleration_faults),
            # The same terms in the same order: the two sums are the same numbers, and so are their M(q) images.
            same_acceleration_sums=acceleration_terms == acceleration_faults,
        )
        arguments = (self._values, plan.terms, plan.slots, plan.targets, self._factors, self._weights, self._sums)
        if fast.enabled():
            plan.sum_terms = bound(compiled.sum_terms, *arguments, free=(0, 0))
        else:
            plan.sum_terms = partial(sum_terms, *arguments)
        return plan

    def _tabulate_weights(self, k: int) -> None:
        """Each rated term's weights of the samples k, k + 1, ... (a block): each row's incipient profile as
        Profile.weight computes it, element by element (the samples before a term's onset are not read)."""
        elapsed = self._times[k:k + self._weights.shape[1]]
        self._block_start = k
        with np.errstate(all="ignore"):  # before the onset the exponent may overflow: never read
            for slot, (rates, onset, sign) in enumerate(self._rates):
                weight = self._weights[slot, :len(elapsed)]
                # (-rate) * elapsed == rate * (-elapsed), bit for bit; -(t - onset) as the time's own float.
                np.multiply(rates, -(elapsed - onset)[:, None], out=weight)
                np.exp(weight, out=weight)
                # sign (1 - e): e - 1 for sign -1, the same bits (rounding is symmetric under negation).
                if sign > 0:
                    np.subtract(1.0, weight, out=weight)
                else:
                    np.subtract(weight, 1.0, out=weight)

    def maps_acceleration(self, k: int) -> bool:
        """Whether :meth:`apply` at sample ``k`` maps acceleration-space terms through M(q), i.e. needs
        ``mass``."""
        return self._plans[self._plan_of_sample[k]].maps_acceleration

    def apply(self, k: int, t: float, qpos: np.ndarray, qvel: np.ndarray, mass: np.ndarray | None,
              out: np.ndarray) -> None:
        """Write the sum of all terms at sample ``k`` (time ``t``) and the true states into ``out``
        (``qfrc_applied``).

        ``t`` is the loop's k * control_dt: MuJoCo's ``data.time`` accumulates rounding (after 40000 steps
        of 0.25 ms it is 9.99999999999937), which would start a fault due at 10 s one period late. ``mass``
        is the true M(q) of each row at the sample instant, needed where :meth:`maps_acceleration` (else it may be
        None)."""
        plan = self._plans[self._plan_of_sample[k]]
        if len(plan.terms):
            if qpos is not self._state[0] or qvel is not self._state[1]:  # new buffers: their own evaluation
                self._state = (qpos, qvel, programs.evaluation(self._function, qpos, qvel, self._parameters,
                                                               self._values))
            self._state[2](t)
        block = k - self._block_start
        if plan.rated and not 0 <= block < self._weights.shape[1]:
            self._tabulate_weights(k)
            block = 0
        plan.sum_terms(k, block)
        if not plan.maps_acceleration:
            out[...] = self.torque  # an assignment costs half np.copyto's call on a few rows
            return
        mapped, site = self._mapped, self._map_acceleration
        if mass is site.matrices:  # its vectors and output are this object's buffers
            site.call()
        else:
            site.new(mass, self.acceleration, mapped)
        np.add(self.torque, mapped, out=out)
        if plan.maps_fault_acceleration:
            if not plan.same_acceleration_sums:
                site = self._map_fault_acceleration
                if mass is site.matrices:
                    site.call()
                else:
                    site.new(mass, self._fault_acceleration, mapped)
            self.fault_force += mapped


#: Samples of the rate parameters' weights tabulated at once (:meth:`PlantTerms._tabulate_weights`): a block
#: of ``(WEIGHT_BLOCK, rows)`` per rated term.
WEIGHT_BLOCK = 256

#: The sums of :class:`PlantTerms`, in the order of its ``_sums`` buffer.
_SUMS = ("torque", "acceleration", "fault", "fault_force", "fault_acceleration")


@dataclass
class _Plan:
    """A period's work for one set of active terms (:meth:`PlantTerms._plan`)."""

    #: The active terms (indices, the file's order); each one's slot of per-row weights (-1: its weight is
    #: the sample's factor); the sums each is added to, ``(terms, sums)`` flags in the order of :data:`_SUMS`;
    #: whether any has per-row weights.
    terms: np.ndarray
    slots: np.ndarray
    targets: np.ndarray
    rated: bool
    fault_active: bool
    maps_acceleration: bool
    maps_fault_acceleration: bool
    same_acceleration_sums: bool
    #: :func:`sum_terms` on the plant terms' buffers and this plan (with the fast paths on, its accelerator
    #: bound to them), called with the sample and its block of weights.
    sum_terms: Callable[[int, int], None] | None = None


def sum_terms(values: np.ndarray, terms: np.ndarray, slots: np.ndarray, targets: np.ndarray, factors: np.ndarray,
              weights: np.ndarray, sums: np.ndarray, k: int, block: int) -> None:
    """Every sum from zero, then term by term in the file's order: its values ``(rows, terms x n)`` times its
    sign x weight of sample k (``factors`` ``(terms, samples, n)``, or each row's weight of a rate parameter,
    the sample's ``block`` of its slot in ``weights`` ``(slots, block, rows)``), added to each of its sums
    ``(sums, rows, n)``. (Accelerated by :func:`ftc_mj.fast.terms.sum_terms`.)"""
    sums[:] = 0.0
    n = sums.shape[2]
    for step in range(len(terms)):
        term, slot = terms[step], slots[step]
        factor = weights[slot, block][:, None] if slot >= 0 else factors[term, k]
        value = values[:, term * n:(term + 1) * n] * factor
        for target in np.flatnonzero(targets[step]):
            sums[target] += value
