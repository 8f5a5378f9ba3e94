"""The servo portion of the partitioned law (lecture 2.2.1).

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
