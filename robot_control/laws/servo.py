"""The servo portion of the partitioned law (lecture 2.2.1) and the integral of the error.

Notation: E = q_d - q, Ed = qd_d - qd, int E = the running integral of E. Gains are the diagonals
of Kp, Kv, Ki, each (n,), read from any object with attributes kp, kv, ki (robot_control.gains
.ServoGains); ki may be absent or None (no integral action).
"""
import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.validation import ArgumentError, all_finite, finite, is_vector


def bool_mask(name, value, n):
    """`value` as a bool (n,) array, or ValueError naming `name` (wrong length or not booleans)."""
    a = np.asarray(value)
    if a.dtype != np.bool_:
        raise ArgumentError(name, f'expected a boolean mask, got dtype {a.dtype}')
    if a.shape != (n,):
        raise ArgumentError(name, f'expected length {n}, got shape {a.shape}')
    return a


def limit_vector(name, value, n):
    """A per-entry positive bound, (n,) array; a scalar is broadcast, +inf means unbounded."""
    if is_vector(value, n) and (value > 0.0).all():   # NaN fails the comparison
        return value
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected a number or {n} numbers, got {value!r}') from exc
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ArgumentError(name, f'expected a scalar or length {n}, got shape {a.shape}')
    if np.any(np.isnan(a)) or not np.all(a > 0.0):
        raise ArgumentError(name, f'expected positive bounds (inf allowed), got {a.tolist()}')
    return a


def per_entry(name, value, k):
    """A finite scalar broadcast to (k,), or a finite (k,) array, or ValueError naming `name`."""
    a = validation.vector(name, value)
    if a.shape[0] == 1 and k != 1:
        return np.full(k, a[0])
    return validation.vector(name, a, k)


def vectors(n, **named):
    """Each named value as a finite float64 (n,) array, in order; ValueError names the first bad one.

    One batched finiteness check on the fast path; validation.vector() words the error.
    """
    try:
        arrays = [np.asarray(value, dtype=float) for value in named.values()]
    except (TypeError, ValueError):
        arrays = None
    if arrays is None or not (all(a.shape == (n,) for a in arrays) and np.isfinite(np.concatenate(arrays)).all()):
        arrays = [validation.vector(name, value, n) for name, value in named.items()]
    return arrays


def servo_gains(gains, n):
    """(kp, kv, ki) of a ServoGains of n entries (checked when it was made), else None: the fast path."""
    if type(gains) is ServoGains and gains.kp.shape[0] == n:
        return gains.kp, gains.kv, gains.ki
    return None


def gain_arrays(gains, n, name='gains'):
    """(kp, kv, ki) from `gains`, each a finite non-negative (n,) array; a missing ki is zeros."""
    kp, kv = getattr(gains, 'kp', None), getattr(gains, 'kv', None)
    if kp is None or kv is None:
        raise ArgumentError(name, f'expected an object with kp, kv, ki (ServoGains), got {gains!r}')
    ki = getattr(gains, 'ki', None)
    ki = np.zeros(n) if ki is None else ki
    out = vectors(n, **{f'{name}.kp': kp, f'{name}.kv': kv, f'{name}.ki': ki})
    for attr, a in zip(('kp', 'kv', 'ki'), out):
        if (a < 0.0).any():
            raise ArgumentError(f'{name}.{attr}', f'expected non-negative gains, got {a.tolist()}')
    return tuple(out)


def check_finite(name, value):
    """Return `value` if every entry is finite; else ValueError naming `name` (an overflow upstream)."""
    if not np.isfinite(value).all():
        raise ArgumentError(name, f'non-finite result {np.asarray(value).tolist()} from finite inputs')
    return value


class Integral:
    """int E dt by explicit Euler, value (n,): value_i += E_i dt unless held, then |value_i| <= limit_i.

    `limit` (scalar or (n,), > 0, inf allowed) clamps the integral; the `hold` mask of update()
    freezes entries (conditional-integration anti-windup: pass the saturation mask of saturate()).
    """

    def __init__(self, n, limit=np.inf):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ArgumentError('n', f'expected a positive integer, got {n!r}')
        self._limit = limit_vector('limit', limit, int(n)).copy()
        self._neg_limit = -self._limit
        self._value = np.zeros(int(n))
        self._new = np.zeros(int(n))        # scratch of update()
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
        new = np.clip(validation.vector('value', value, self.n), -self._limit, self._limit)
        self._value[:] = new

    def update(self, E, dt, hold=None):
        """value += E dt on entries not held, clamp to +-limit; E (n,), dt in s (>= 0). Returns value."""
        n = self._value.shape[0]
        # dt <= 1 s: E dt cannot overflow; anything else (and any failure) takes the checked path
        if (is_vector(E, n) and finite(E) and isinstance(dt, float) and 0.0 <= dt <= 1.0
                and (hold is None or (type(hold) is np.ndarray and hold.dtype == np.bool_ and hold.shape == (n,)))):
            new = self._new
            np.multiply(E, dt, out=new)
            if hold is not None:
                np.copyto(new, 0.0, where=hold)
            new += self._value
            np.minimum(new, self._limit, out=new)
            np.maximum(new, self._neg_limit, out=new)
            if finite(new):
                self._value[:] = new
                return self.value
        return self._update_checked(E, dt, hold)

    def _update_checked(self, E, dt, hold):
        E = validation.vector('E', E, self.n)
        dt = validation.scalar('dt', dt, nonnegative=True)
        held = np.zeros(self.n, bool) if hold is None else bool_mask('hold', hold, self.n)
        with np.errstate(over='ignore', invalid='ignore'):  # overflow is reported below
            new = np.clip(self._value + np.where(held, 0.0, E * dt), -self._limit, self._limit)
        check_finite('E', new)
        self._value[:] = new
        return self.value


def servo(qdd_d, E, Ed, gains, int_E=None):
    """v = qdd_d + Kv Ed + Kp E + Ki int_E, all (n,); Kp in 1/s^2, Kv in 1/s, Ki in 1/s^3."""
    n = qdd_d.shape[0] if type(qdd_d) is np.ndarray and qdd_d.ndim == 1 else -1
    g = servo_gains(gains, n)
    if (g is not None and is_vector(qdd_d, n) and is_vector(E, n) and is_vector(Ed, n)
            and (int_E is None or is_vector(int_E, n))
            and all_finite(qdd_d, E, Ed) and (int_E is None or finite(int_E))):
        kp, kv, ki = g
        v = qdd_d + kv * Ed + kp * E
        if int_E is not None:
            v = v + ki * int_E
        if finite(v):  # else an overflow: the checked path names it
            return v
    return _servo_checked(qdd_d, E, Ed, gains, int_E)


def _servo_checked(qdd_d, E, Ed, gains, int_E):
    qdd_d = validation.vector('qdd_d', qdd_d)
    n = qdd_d.shape[0]
    E, Ed = vectors(n, E=E, Ed=Ed)
    kp, kv, ki = gain_arrays(gains, n)
    v = qdd_d + kv * Ed + kp * E
    if int_E is not None:
        v = v + ki * validation.vector('int_E', int_E, n)
    return check_finite('v', v)
