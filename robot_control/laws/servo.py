"""The servo portion of the partitioned law (lecture 2.2.1) and the integral of the error.

    v = qdd_d + Kv Ed + Kp E (+ Ki int E),   E = q_d - q,  Ed = qd_d - qd.

Gains are the diagonals of Kp, Kv, Ki, each (n,), held by robot_control.gains.ServoGains (checked
when it is made). With a unit-mass plant (qdd = v) every entry obeys e'' + kv e' + kp e (+ ki int e) = 0.
The same servo acts on forces in force control: there E = f_d - f and the result is divided by k_e.
"""
import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.validation import ArgumentError


def _servo(qdd_d, E, Ed, gains, int_E=None):
    """v = qdd_d + Kv Ed + Kp E (+ Ki int_E), (n,); checked arrays and ServoGains of n entries."""
    v = qdd_d + gains.kv * Ed + gains.kp * E
    if int_E is not None:
        v = v + gains.ki * int_E
    return v


def servo(qdd_d, E, Ed, gains, int_E=None):
    """v = qdd_d + Kv Ed + Kp E + Ki int_E, all (n,); Kp in 1/s^2, Kv in 1/s, Ki in 1/s^3.

    Checked: ArgumentError naming the first bad argument, or `v` when finite inputs overflow."""
    qdd_d = validation.vector('qdd_d', qdd_d)
    n = qdd_d.shape[0]
    E, Ed = validation.vectors(n, E=E, Ed=Ed)
    gains = servo_gains('gains', gains, n)
    int_E = validation.optional_vector('int_E', int_E, n)
    return validation.result('v', _servo(qdd_d, E, Ed, gains, int_E))


def servo_gains(name, gains, n):
    """`gains` as ServoGains of n entries: a ServoGains, or any object with kp, kv (and ki) (n,) each,
    finite and >= 0; ki None or absent means zeros. ArgumentError naming `name`.kp, ... otherwise."""
    kp, kv = getattr(gains, 'kp', None), getattr(gains, 'kv', None)
    if kp is None or kv is None:
        raise ArgumentError(name, f'expected an object with kp, kv, ki (ServoGains), got {gains!r}')
    if type(gains) is ServoGains and gains.n == n:
        return gains
    ki = getattr(gains, 'ki', None)
    arrays = validation.vectors(n, **{f'{name}.kp': kp, f'{name}.kv': kv,
                                      f'{name}.ki': np.zeros(n) if ki is None else ki})
    for attr, a in zip(('kp', 'kv', 'ki'), arrays):
        if (a < 0.0).any():
            raise ArgumentError(f'{name}.{attr}', f'expected non-negative gains, got {a.tolist()}')
    return ServoGains(*arrays)


class Integral:
    """int E dt by explicit Euler, value (n,): value_i += E_i dt unless held, then |value_i| <= limit_i.

    `limit` (scalar or (n,), > 0, inf allowed) clamps the integral; the `hold` mask of update()
    freezes entries (conditional-integration anti-windup: pass the saturation mask of saturate()).
    """

    def __init__(self, n, limit=np.inf):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ArgumentError('n', f'expected a positive integer, got {n!r}')
        self._limit = validation.limit_vector('limit', limit, int(n)).copy()
        self._value = np.zeros(int(n))
        self._view = self._value.view()     # what `value` hands out: read-only
        self._view.flags.writeable = False

    @property
    def n(self):
        """Number of integrated entries."""
        return self._value.shape[0]

    @property
    def limit(self):
        """Clamp |value_i| <= limit_i, (n,) (read-only copy)."""
        return self._limit.copy()

    @property
    def value(self):
        """Current int E dt, (n,), units of E times s (read-only view)."""
        return self._view

    def reset(self):
        """Set the integral to zero."""
        self._value[:] = 0.0

    def preset(self, value):
        """Set the integral to `value` (clamped), e.g. for bumpless switching between laws."""
        self._value[:] = np.clip(validation.vector('value', value, self.n), -self._limit, self._limit)

    def update(self, E, dt, hold=None):
        """value += E dt on entries not held, clamp to +-limit; E (n,), dt in s (>= 0). Returns value.

        Checked: ArgumentError naming E, dt or hold; the value is unchanged then."""
        E = validation.vector('E', E, self.n)
        dt = validation.scalar('dt', dt, nonnegative=True)
        if hold is not None:
            hold = validation.bool_mask('hold', hold, self.n)
        with np.errstate(over='ignore', invalid='ignore'):   # an overflow is named below
            new = self._integrated(E, dt, hold)
        self._value[:] = validation.result('E', new)
        return self.value

    def _update(self, E, dt, hold=None):
        """update() on checked arguments (E finite (n,), 0 <= dt, hold None or bool (n,))."""
        self._value[:] = self._integrated(E, dt, hold)
        return self.value

    def _integrated(self, E, dt, hold):
        """clip(value + E dt, -limit, limit), with E dt = 0 on held entries."""
        step = E * dt
        if hold is not None:
            step[hold] = 0.0
        return np.clip(self._value + step, -self._limit, self._limit)
