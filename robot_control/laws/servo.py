"""The servo portion of the partitioned law (lecture 2.2.1).

    v = qdd_d + Kv Ed + Kp E (+ Ki int E),   E = q_d - q,  Ed = qd_d - qd.

Gains are the diagonals of Kp, Kv, Ki, each (n,), held by robot_control.gains.ServoGains (checked
when it is made). With a unit-mass plant (qdd = v) every entry obeys e'' + kv e' + kp e (+ ki int e) = 0.
The same servo acts on forces in force control: there E = f_d - f and the result is divided by k_e.

A law with this motion servo declares it (Law.parts = (MotionServo,)): its gains kp, kv, ki are then the
law's parameters (PARAM_ROWS, listed once in the controller's parameter table), held by its Params
(field `motion_servo`).
"""
import dataclasses

import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.param_table import Row, custom, gt_eq
from robot_control.validation import ArgumentError

#: the motion servo's gains, as the parameters name them
GAIN_NAMES = ('kp', 'kv', 'ki')

#: the motion servo's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row('kp', 'double_array', (), 'explicit Kp diagonal (empty = designed): 1/s^2 (computed torque, hybrid '
        'motion axes) or N m/rad, N/m (independent_joint)',
        [custom('empty, or one per joint (hybrid: per task or motion axis)'), gt_eq(0)]),
    Row('kv', 'double_array', (), 'explicit Kv diagonal (empty = designed): 1/s or N m s/rad, N s/m',
        [custom('empty, or as many as kp needs'), gt_eq(0)]),
    Row('ki', 'double_array', (), 'explicit Ki diagonal (empty = designed), used when integral: '
        '1/s^3 or N m/(rad s), N/(m s)', [custom('empty, or as many as kp needs'), gt_eq(0)]),
)


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


@dataclasses.dataclass(frozen=True, eq=False)
class MotionServo:
    """The motion servo's gains (PARAM_ROWS), shared by the laws that declare it (Law.parts): kp (1/s^2, or
    N m/rad for torque gains), kv (1/s), ki (1/s^3; empty = zeros), each (n,) >= 0, as many as the law
    takes (one per joint; hybrid: per task or motion axis, which the law checks). Held as read-only arrays
    and as `gains`, ServoGains (None when kp, kv, ki are all empty: the controller's parameter layer
    writes the designed ones). ArgumentError naming kp, kv or ki."""

    kp: np.ndarray = ()
    kv: np.ndarray = ()
    ki: np.ndarray = ()
    gains: ServoGains = dataclasses.field(default=None, init=False, repr=False)

    param_rows = PARAM_ROWS
    field = 'motion_servo'     # the name a law's Params holds it under

    def __post_init__(self):
        given = [np.size(getattr(self, name)) for name in GAIN_NAMES]
        gains = ServoGains(self.kp, self.kv, self.ki if given[2] else None) if any(given) else None
        for name in GAIN_NAMES:
            object.__setattr__(self, name, np.zeros(0) if gains is None else getattr(gains, name))
        object.__setattr__(self, 'gains', gains)

    def _key(self):
        return tuple(tuple(getattr(self, name).tolist()) for name in GAIN_NAMES)

    def __eq__(self, other):
        return isinstance(other, MotionServo) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def fitted(self, model):
        """The same gains: the law checks their number."""
        return self


@dataclasses.dataclass(frozen=True)
class MotionServoParams:
    """The parameters of a law whose only parameters are the motion servo's gains (MotionServo)."""

    motion_servo: MotionServo = MotionServo()


def gain_params(gains):
    """The motion servo's parameters (kp, kv, ki) of ServoGains `gains` (None: none): what a law's parameters
    (ControllerConfig.law_params) take, e.g. robot_control.gains.design(...).gains(n)."""
    return {} if gains is None else {name: getattr(gains, name) for name in GAIN_NAMES}
