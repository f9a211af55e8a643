"""Fused laws: accelerators of a method's NumPy law, its element-wise arithmetic in a few compiled kernels, its
powers left to NumPy.

A law written in NumPy (the definition: every plugin's ``update``, ``advance`` or ``compute``) pays NumPy's
cost per call whatever the size, some fifteen calls per law and period; on a single run's row that is most of
the law's cost (``benchmarks/fused_laws.py`` prints both). The laws the shipped
scenarios run most therefore have an accelerator here: the TOSMO and high-speed TOSMO, eqs. (3.11), (5.6);
the SOSMO, (4.37); the NFTSMC, (5.15)-(5.27). Each does the law's operations in the law's order.

**The same numbers.** Addition, subtraction, multiplication, division, ``sqrt``, ``abs``, ``copysign`` and the
sign are exact IEEE operations, compiled here without fast-math (no fused multiply-add, no reassociation).
Fractional powers are not exact between libraries, so an accelerator keeps every ``power`` a NumPy call on
operands of the law's types and shapes (:mod:`ftc_mj.methods.primitives` explains why those decide NumPy's
kernel) and fuses the arithmetic around it. ``tests/fast/test_fused_laws.py`` checks each accelerator member by
member against its NumPy law on random states (equal bits are what it finds; the tolerance it states is
one ulp of the larger magnitude).

**Which objects.** An accelerator is registered for a method class (:func:`register`) and serves instances of
that class exactly: a subclass runs the NumPy law, so that its overrides are honoured, unless it registers an
accelerator itself. A method asks for its accelerator once, when it is built (:func:`accelerator`); it gets
none with the fast paths off, for standalone ``(n,)`` states, or where a gain is not a ``(members, n)`` array.
Each kernel is bound (:func:`~ftc_mj.fast.kernels.bound`: checked once, called past Numba's dispatcher) to the
accelerator's and the method's own buffers and to the arrays from outside it was last handed (readings,
reference rows, the nominal model's): each call compares those with the ones bound (``is``) and binds the
kernel again where one is another object, so that an array is read as the type it was compiled for. The
engine hands the same objects every period (its buffers), so it binds once per run; a caller that hands new
arrays at every call (a view of another row each period) pays a binding per call, the typing of every
argument (``benchmarks/fused_laws.py`` shows what binding once saves), and should keep buffers as the
engine does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Protocol

import numba
import numpy as np
from numba.extending import overload

from ftc_mj import fast
from ftc_mj.fast.kernels import WITHOUT_RUNTIME, bound, cache_folder, cache_is_cold


class Observed(Protocol):
    """What an observer accelerator runs in place of the law's ``update`` and ``advance``."""

    def update(self, q_meas: np.ndarray, model: object) -> None: ...

    def advance(self, tau: np.ndarray, model: object) -> None: ...


#: The accelerator of each method class (exactly that class): a function of the method giving the accelerator,
#: or None where it does not apply.
_REGISTRY: dict[type, Callable[[object], object | None]] = {}


def register(method_class: type, make: Callable[[object], object | None]) -> None:
    """``make(method)`` accelerates instances of ``method_class`` (not of its subclasses: each registers its own,
    or runs its NumPy law)."""
    _REGISTRY[method_class] = make


def unregister(method_class: type) -> None:
    """``method_class`` runs its NumPy law from now on (instances built later)."""
    _REGISTRY.pop(method_class, None)


@contextmanager
def without_accelerators() -> Iterator[None]:
    """Methods built inside run their NumPy laws, every other fast path as the switch says (what
    ``benchmarks/fused_laws.py`` compares in one process)."""
    global _REGISTRY
    registry, _REGISTRY = _REGISTRY, {}
    try:
        yield
    finally:
        _REGISTRY = registry


def accelerator(method: object, *gains: object) -> object | None:
    """The accelerator registered for ``method``'s class, made for it, or None: the fast paths off, no
    accelerator registered for that class exactly, standalone states (not ``(members, n)``), or a gain of
    ``gains`` not a ``(members, n)`` array (the kernels index every gain per member and joint)."""
    make = _REGISTRY.get(type(method))
    shape = method.shape
    if (make is None or not fast.enabled() or len(shape) != 2
            or not all(type(gain) is np.ndarray and gain.shape == shape for gain in gains)):
        return None
    law = make(method)
    if law is not None:
        kernels = type(law).kernels
        fast.announce_compilation(f"the fused {type(law).__name__.removesuffix('Law')} law",
                                  any(cache_is_cold(kernel, __file__) for kernel in kernels), cache_folder(kernels[0]))
    return law


def kernel(function: Callable) -> numba.core.registry.CPUDispatcher:
    """The decorator of every fused kernel: compiled without fast-math, NumPy's semantics for division, cached
    on disk, without Numba's runtime (a fused kernel allocates nothing)."""
    return numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)(function)


class _Site:
    """A kernel bound to the accelerator's and the method's own buffers ``fixed`` and to the arrays from outside
    of its last call (:func:`~ftc_mj.fast.kernels.bound`); :meth:`bind` binds it to others. Its caller compares
    the arrays it is handed with :attr:`outside` (``is``, one per array) and calls :meth:`bind` where one
    differs, then :attr:`call`."""

    def __init__(self, kernel: numba.core.registry.CPUDispatcher, *fixed: object, outside: int):
        self.kernel, self.fixed = kernel, fixed
        #: The ``outside`` arrays from outside the kernel is bound to (None before the first call, which binds).
        self.outside: tuple = (None,) * outside
        self.call: Callable[[], None] = self._unbound

    def bind(self, *outside: np.ndarray | bool) -> None:
        """Bind the kernel to ``outside`` (after the own buffers): arrays, checked once
        (:func:`~ftc_mj.fast.kernels.bound`), or flags."""
        for position, value in enumerate(outside):
            if type(value) is not np.ndarray and type(value) is not bool:
                raise TypeError(f"{self.kernel.__name__}: argument {len(self.fixed) + position} must be a "
                                f"numpy.ndarray, not {type(value).__name__}")
        self.call = bound(self.kernel, *self.fixed, *outside)
        self.outside = outside

    @staticmethod
    def _unbound() -> None:
        raise RuntimeError("a fused kernel called before it was bound")


def _euler_period(site: _Site, psi_hat: np.ndarray, command: np.ndarray) -> None:
    """An observer's Euler period through ``site``, bound to the model's Psi and M^-1 u of this call."""
    outside = site.outside
    if psi_hat is not outside[0] or command is not outside[1]:
        site.bind(psi_hat, command)
    site.call()


def entry(values: np.ndarray, member: int, joint: int) -> float:
    """``values[member, joint]`` as NumPy broadcasting reads it: a row ``(n,)`` (the reference shared by every
    member), a row per member ``(members, n)``, or a single row ``(1, n)`` for every member. In a kernel its
    compiled form (below) is used, one per number of dimensions."""
    if values.ndim == 1:
        return float(values[joint])
    return float(values[min(member, values.shape[0] - 1), joint])


@overload(entry, inline="always")
def _entry(values, member, joint):  # noqa: ANN001, ANN202 (Numba's typing)
    """:func:`entry` compiled for the array type at hand."""
    if values.ndim == 1:
        return lambda values, member, joint: values[joint]
    return lambda values, member, joint: values[min(member, values.shape[0] - 1), joint]


@numba.njit(cache=True, inline="always")
def sign(x: float) -> float:
    """``np.sign``: -1, 0 or 1, zero (positive) for both zeros, NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0 if x == 0.0 else x


@numba.njit(cache=True, inline="always")
def _euler_state(psi_hat: np.ndarray, command: np.ndarray, injection: np.ndarray, q_hat_rate: np.ndarray,
                 dt: float, q_hat: np.ndarray, qd_hat: np.ndarray, i: int, j: int) -> None:
    """One Euler period of an observer's x1_hat, x2_hat at member i, joint j: x1_hat += dt x1_hat' and
    x2_hat += dt ((Psi + M^-1 u) + injection), in the NumPy laws' order of operations."""
    qdd_hat = (psi_hat[i, j] + command[i, j]) + injection[i, j]
    q_hat[i, j] += dt * q_hat_rate[i, j]
    qd_hat[i, j] += dt * qdd_hat


# ------------------------------------------------------------------------------------- TOSMO, (3.11) and (5.6)


class TOSMOLaw:
    """The accelerator of :class:`~ftc_mj.methods.observers.tosmo.TOSMO` (``linear`` False) and of the
    high-speed TOSMO (``linear`` True: the Gamma terms, Gamma its ``config.gamma``)."""

    def __init__(self, method: object, linear: bool):
        self.method, self.linear = method, linear
        shape = method.shape
        self.error, self.sign, self.q_hat_rate = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        #: |x1~| raised to 2/3 and to 1/3, stacked for one call of NumPy's pow (the same bits as two calls).
        self.powers = np.zeros((2, *shape))
        self.exponents = np.stack([np.full(shape, 2 / 3), np.full(shape, 1 / 3)])
        self.luaf_step = method.dt * method.k3  # as the law's: dt k3
        gamma = method.config.gamma if linear else method.k1  # unread without the linear terms
        magnitude, magnitude_third = self.powers
        m = method
        self.errors = _Site(_tosmo_errors, m.q_hat, self.error, self.sign, magnitude, magnitude_third, outside=1)
        self.corrections = _Site(_tosmo_injection, self.error, magnitude, magnitude_third, m.k1, m.k2, gamma, linear,
                                 m.qd_hat, m.luaf_hat, self.q_hat_rate, m.injection, outside=0)
        self.advance_state = _Site(_tosmo_advance, m.injection, self.q_hat_rate, float(m.dt), self.luaf_step,
                                   self.sign, m.q_hat, m.qd_hat, m.luaf_hat, outside=2)

    def update(self, q_meas: np.ndarray, model: object) -> None:
        errors = self.errors
        if q_meas is not errors.outside[0]:
            errors.bind(q_meas)
            self.corrections.bind()  # bound with the first (its arrays are all the law's own)
        errors.call()
        np.power(self.powers, self.exponents, self.powers)  # as signed_power raises them
        self.corrections.call()

    def advance(self, tau: np.ndarray, model: object) -> None:
        _euler_period(self.advance_state, model.psi_hat, model.command_acceleration(tau))


@kernel
def _tosmo_errors(q_hat, error, sign_, magnitude, magnitude_third, q_meas):  # noqa: ANN001, ANN202
    """x1~ = x1 - x1_hat, its sign, and |x1~| twice (to be raised to 2/3 and 1/3)."""
    for i in range(error.shape[0]):
        for j in range(error.shape[1]):
            e = q_meas[i, j] - q_hat[i, j]
            error[i, j] = e
            sign_[i, j] = sign(e)
            magnitude[i, j] = magnitude_third[i, j] = abs(e)


@kernel
def _tosmo_injection(error, power, power_third, k1, k2, gamma, linear, qd_hat, luaf_hat,  # noqa: ANN001, ANN202
                     q_hat_rate, injection):
    """The first line of (5.6) less the estimate (into ``q_hat_rate``) and the injection of the second, from
    |x1~|^(2/3) and |x1~|^(1/3); with ``linear`` the Gamma terms, else the TOSMO (3.11)."""
    for i in range(error.shape[0]):
        for j in range(error.shape[1]):
            e = error[i, j]
            position_correction = k1[i, j] * np.copysign(power[i, j], e)
            if linear:
                position_correction = position_correction + gamma[i, j] * e
            q_hat_rate[i, j] = qd_hat[i, j] + position_correction
            velocity_correction = k2[i, j] * np.copysign(power_third[i, j], e)
            if linear:
                velocity_correction = velocity_correction + gamma[i, j] * position_correction
            injection[i, j] = velocity_correction + luaf_hat[i, j]


@kernel
def _tosmo_advance(injection, q_hat_rate, dt, luaf_step, sign_, q_hat, qd_hat,  # noqa: ANN001, ANN202
                   luaf_hat, psi_hat, command):
    """One Euler period of (5.6): x1_hat, x2_hat and the LUaF estimate (5.13)."""
    for i in range(q_hat.shape[0]):
        for j in range(q_hat.shape[1]):
            _euler_state(psi_hat, command, injection, q_hat_rate, dt, q_hat, qd_hat, i, j)
            luaf_hat[i, j] += luaf_step[i, j] * sign_[i, j]


TOSMOLaw.kernels = (_tosmo_errors, _tosmo_injection, _tosmo_advance)


# ------------------------------------------------------------------------------------------------ SOSMO, (4.37)


class SOSMOLaw:
    """The accelerator of :class:`~ftc_mj.methods.observers.sosmo.SOSMO` (the power 1/2 is sqrt in both, as
    ``signed_power`` takes it)."""

    def __init__(self, method: object):
        m = self.method = method
        self.q_hat_rate = np.zeros(method.shape)
        self.update_state = _Site(_sosmo_update, m.q_hat, m.qd_hat, m.k1, m.k2, self.q_hat_rate, m.injection,
                                  outside=1)
        self.advance_state = _Site(_sosmo_advance, m.injection, self.q_hat_rate, float(m.dt), m.filter_weight,
                                   m.q_hat, m.qd_hat, m.luaf_hat, outside=2)

    def update(self, q_meas: np.ndarray, model: object) -> None:
        update_state = self.update_state
        if q_meas is not update_state.outside[0]:
            update_state.bind(q_meas)
        update_state.call()

    def advance(self, tau: np.ndarray, model: object) -> None:
        _euler_period(self.advance_state, model.psi_hat, model.command_acceleration(tau))


@kernel
def _sosmo_update(q_hat, qd_hat, k1, k2, q_hat_rate, injection, q_meas):  # noqa: ANN001, ANN202
    """The first line of (4.37) (into ``q_hat_rate``) and the injection k2 sign(x1~) of the second."""
    for i in range(q_hat.shape[0]):
        for j in range(q_hat.shape[1]):
            error = q_meas[i, j] - q_hat[i, j]
            q_hat_rate[i, j] = qd_hat[i, j] + k1[i, j] * np.copysign(np.sqrt(abs(error)), error)
            injection[i, j] = k2[i, j] * sign(error)


@kernel
def _sosmo_advance(injection, q_hat_rate, dt, filter_weight, q_hat, qd_hat, luaf_hat, psi_hat,  # noqa: ANN001, ANN202
                   command):
    """One Euler period of (4.37) and the LUaF filter's exact step."""
    for i in range(q_hat.shape[0]):
        for j in range(q_hat.shape[1]):
            _euler_state(psi_hat, command, injection, q_hat_rate, dt, q_hat, qd_hat, i, j)
            luaf_hat[i, j] += filter_weight[i, j] * (injection[i, j] - luaf_hat[i, j])


SOSMOLaw.kernels = (_sosmo_update, _sosmo_advance)


# ------------------------------------------------------------------------------------- NFTSMC, (5.15)-(5.27)


class NFTSMCLaw:
    """The accelerator of :class:`~ftc_mj.methods.controllers.nftsmc.NFTSMC`'s ``compute``: e_dot, the bases
    |e|, |e_dot| and e (stacked), their powers |e|^g1, |e_dot|^g2 and e^3 (stacked: one NumPy call, NumPy's
    pow per element), and -u."""

    def __init__(self, method: object):
        self.method = method
        c, shape = method.config, method.shape
        self.error_rate, self.negative_u = np.zeros(shape), np.zeros(shape)
        self.bases, self.powers = np.zeros((3, *shape)), np.zeros((3, *shape))
        self.exponents = np.stack([np.broadcast_to(g, shape) for g in (c.gamma1, c.gamma2, 3.0)])
        m, (magnitude, magnitude_rate, e), (power, power_rate, cube) = method, self.bases, self.powers
        self.error = e
        self.errors = _Site(_nftsmc_errors, e, self.error_rate, magnitude, magnitude_rate, outside=4)
        self.negative_control = _Site(_nftsmc_negative_control, e, self.error_rate, power, power_rate, cube, c.beta1,
                                      c.beta2, c.beta3, c.beta4, float(m.dt), m.integral, m.sliding, self.negative_u,
                                      outside=5)

    def compute(self, q_ref: np.ndarray, qd_ref: np.ndarray, qdd_ref: np.ndarray, q_meas: np.ndarray,
                observer: object, model: object) -> np.ndarray:
        m, errors, negative_control = self.method, self.errors, self.negative_control
        velocity = model.control_velocity(observer.qd_hat)
        bound_to = errors.outside
        if (q_meas is not bound_to[0] or q_ref is not bound_to[1] or velocity is not bound_to[2]
                or qd_ref is not bound_to[3]):
            errors.bind(q_meas, q_ref, velocity, qd_ref)
        errors.call()
        np.power(self.bases, self.exponents, self.powers)  # as signed_power and e**3 raise them
        compensation = m.observer_compensation(observer)
        compensate = compensation is not None
        if not compensate:
            compensation = self.error  # read by no period: any array of the law's shape
        psi_control, gain = model.psi_control, m.switching_gain()
        bound_to = negative_control.outside
        if (qdd_ref is not bound_to[0] or psi_control is not bound_to[1] or compensation is not bound_to[2]
                or compensate is not bound_to[3] or gain is not bound_to[4]):
            negative_control.bind(qdd_ref, psi_control, compensation, compensate, gain)
        negative_control.call()
        return model.apply_M(self.negative_u, out=m.tau)


@kernel
def _nftsmc_errors(e, e_dot, magnitude, magnitude_rate, q_meas, q_ref, velocity, qd_ref):  # noqa: ANN001, ANN202
    """e = x1 - x_d, e_dot = x2 - xd_d and their magnitudes (to be raised to gamma1, gamma2)."""
    for i in range(e.shape[0]):
        for j in range(e.shape[1]):
            error = q_meas[i, j] - entry(q_ref, i, j)
            error_rate = velocity[i, j] - entry(qd_ref, i, j)
            e[i, j], e_dot[i, j] = error, error_rate
            magnitude[i, j], magnitude_rate[i, j] = abs(error), abs(error_rate)


@kernel
def _nftsmc_negative_control(e, e_dot, power, power_rate, cube, beta1, beta2, beta3, beta4,  # noqa: ANN001, ANN202
                             dt, integral, sliding, negative_u, qdd_ref, psi_control, compensation, compensate, gain):
    """The surface (5.15) and -u = xdd_d - (Psi + A) - u_c - (bound + mu) sign(s) of (5.25)-(5.27), in the
    law's order of operations."""
    for i in range(e.shape[0]):
        for j in range(e.shape[1]):
            a = (beta1[i, j] * np.copysign(power[i, j], e[i, j]) + beta2[i, j] * np.copysign(power_rate[i, j],
                                                                                             e_dot[i, j])
                 + beta3[i, j] * e[i, j] + beta4[i, j] * cube[i, j])
            s = e_dot[i, j] + integral[i, j]
            sliding[i, j] = s
            integral[i, j] += dt * a
            value = entry(qdd_ref, i, j) - (psi_control[i, j] + a)
            if compensate:
                value -= compensation[i, j]
            negative_u[i, j] = value - gain[i, j] * sign(s)


NFTSMCLaw.kernels = (_nftsmc_errors, _nftsmc_negative_control)
