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
from collections.abc import Sequence
from typing import Literal

import numpy as np

from ftc_mj.effects.profiles import Profile, ProfileSpec, compile_profile
from ftc_mj.spec import expressions
from ftc_mj.spec.expressions import SCALAR_ROWS
from ftc_mj.spec.errors import InputError
from ftc_mj.spec.schema import (ExpressionText, NonNegativeFloat, ParameterName, PositiveFloat, Strict,
                                parse_expression, per_joint)


class TermSpec(Strict):
    """A friction, disturbance or fault term: per-joint expressions of t, q1..qn, qd1..qn."""

    kind: Literal["friction", "disturbance", "fault"]
    space: Literal["torque", "acceleration"]
    sign: Literal[1, -1]
    value: list[ExpressionText]
    onset: NonNegativeFloat | None = None
    #: Evolution rate of 1 - exp(-rate (t - onset)), one number or one per joint, or the name of one of the
    #: scenario's ``parameters`` (then each member of a batch may have its own rate); abrupt when absent.
    rate: PositiveFloat | list[PositiveFloat] | ParameterName | None = None
    #: Any time profile of :mod:`ftc_mj.effects.profiles` (instead of ``onset`` and ``rate``).
    profile: ProfileSpec | None = None
    name: str | None = None


@dataclass
class CompiledTerm:
    """A plant term ready for the loop."""

    name: str
    kind: str
    space: str
    sign: float
    function: expressions.StateFunction
    #: None: always on.
    time_profile: Profile | None
    #: Joints whose value is not identically zero (a fault "on joint 1" has zeros elsewhere).
    joints: np.ndarray
    #: The parameter that holds the evolution rate (per member), or None (the profile's own, if any).
    rate_parameter: str | None = None

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
                function=expressions.StateFunction(exprs, n, parameters),
                time_profile=_term_profile(term, file, field, n, parameters),
                joints=np.array([expr.is_zero is not True for expr in exprs]),
                rate_parameter=term.rate if isinstance(term.rate, str) else None,
            )
        )
    return terms


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


class PlantTerms:
    """Friction, disturbance and fault terms of every row, evaluated on the true states.

    Every term's expressions are compiled into one function (:class:`~ftc_mj.spec.expressions.StateFunction`),
    called once per period for all rows. Attributes after :meth:`apply`, ``(rows, n)``: ``fault`` (the fault
    terms' sum, each in its own space), ``fault_force`` (their generalized force, acceleration-space ones through
    the true M(q)); ``fault_active``: whether a fault term is on (profiles depend on time only, so for every row
    alike).
    """

    def __init__(self, terms: list[CompiledTerm], rows: int, n_joints: int, parameters: np.ndarray,
                 parameter_names: Sequence[str] = ()):
        self.terms = terms
        shape = (rows, n_joints)
        #: torque, acceleration, fault, fault force and fault acceleration sums, zeroed at once each period.
        self._sums = np.zeros((5,) + shape)
        self.torque, self.acceleration, self.fault, self.fault_force, self._fault_acceleration = self._sums
        self.fault_active = False
        self._mapped = np.zeros(shape)
        self._parameters = np.asarray(parameters, dtype=float).reshape(rows, -1)
        names = list(parameter_names)
        #: Per term with a rate parameter, each row's rate, ``(rows, 1)`` (the same for every joint).
        self._rates = {index: self._parameters[:, names.index(term.rate_parameter)][:, None].copy()
                       for index, term in enumerate(terms) if term.rate_parameter is not None}
        #: Their weights 1 - exp(-rate (t - onset)), written in place each period.
        self._rate_weights = {index: np.empty_like(rates) for index, rates in self._rates.items()}
        self._function = expressions.StateFunction([e for term in terms for e in term.function.exprs], n_joints,
                                                   list(parameter_names))
        self._values = np.zeros((rows, len(terms) * n_joints))
        self._blocks = [self._values[:, i * n_joints:(i + 1) * n_joints] for i in range(len(terms))]
        self.needs_mass = any(term.space == "acceleration" for term in terms)
        self._has_acceleration_fault = any(term.space == "acceleration" and term.kind == "fault" for term in terms)

    def apply(self, t: float, qpos: np.ndarray, qvel: np.ndarray, mass: np.ndarray | None, out: np.ndarray) -> None:
        """Write the sum of all terms at time ``t`` and the true states into ``out`` (``qfrc_applied``).

        ``t`` is the loop's k * control_dt: MuJoCo's ``data.time`` accumulates rounding (after 40000 steps
        of 0.25 ms it is 9.99999999999937), which would start a fault due at 10 s one period late. ``mass``
        is the true M(q) of each row at the sample instant, needed with acceleration-space terms."""
        active = []  # (term, its index, sign times the profile's weight) of the terms on at t
        for index, term in enumerate(self.terms):
            weight = term.profile(t)
            if weight is not None:
                if index in self._rates:  # each row's incipient profile, as Profile.weight computes it
                    weight = self._rate_weights[index]  # (-rate) * elapsed == rate * (-elapsed), bit for bit
                    np.multiply(self._rates[index], -(t - term.onset), out=weight)
                    np.exp(weight, out=weight)
                    np.subtract(1.0, weight, out=weight)
                active.append((term, index, term.sign * weight))
        self.fault_active = any(term.kind == "fault" for term, _, _ in active)
        if active:
            self._function.evaluate(t, qpos, qvel, self._parameters, self._values)
        if len(self._values) <= SCALAR_ROWS:
            self._sum_rows(active)
        else:
            self._sum_columns(active)
        np.copyto(out, self.torque)
        if self.needs_mass:
            out += _times(mass, self.acceleration, self._mapped)
        if self._has_acceleration_fault and self.fault_active:
            self.fault_force += _times(mass, self._fault_acceleration, self._mapped)

    def _sum_columns(self, active: list) -> None:
        """The sums of the terms on, from zero, term by term in the file's order."""
        self._sums[:] = 0.0
        for term, index, factor in active:
            value = self._blocks[index]
            value *= factor
            acceleration = term.space == "acceleration"
            (self.acceleration if acceleration else self.torque)[:] += value
            if term.kind == "fault":
                self.fault += value
                (self._fault_acceleration if acceleration else self.fault_force)[:] += value

    def _sum_rows(self, active: list) -> None:
        """:meth:`_sum_columns` on Python floats, row by row: the same operations in the same order (the same
        bits), without NumPy's per-call cost on a few rows."""
        n = self._sums.shape[-1]
        plan = []
        for term, index, factor in active:
            acceleration = term.space == "acceleration"
            targets = [_ACCELERATION if acceleration else _TORQUE]
            if term.kind == "fault":
                targets += [_FAULT, _FAULT_ACCELERATION if acceleration else _FAULT_FORCE]
            if not isinstance(factor, np.ndarray):  # one for every joint and row
                factors = [[factor] * n] * len(self._values)
            elif factor.ndim == 1:  # per joint
                factors = [factor.tolist()] * len(self._values)
            else:  # per row, (rows, 1)
                factors = [[f] * n for f in factor[:, 0].tolist()]
            plan.append((index * n, factors, targets))
        joints = range(n)
        for row, values in enumerate(self._values.tolist()):
            sums = [[0.0] * n for _ in range(5)]
            for offset, factors, targets in plan:
                factor = factors[row]
                scaled = [values[offset + j] * factor[j] for j in joints]
                for target in targets:
                    total = sums[target]
                    for j in joints:
                        total[j] += scaled[j]
            self._sums[:, row] = sums


#: Rows of PlantTerms._sums.
_TORQUE, _ACCELERATION, _FAULT, _FAULT_FORCE, _FAULT_ACCELERATION = range(5)


def _times(matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Row by row, ``matrices[r] @ vectors[r]``."""
    return np.einsum("rij,rj->ri", matrices, vectors, out=out)
