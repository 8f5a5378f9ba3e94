"""Friction compensation, added to every law's torque before saturation.

    tau_f = Fc tanh(v / v_s) + Fv v    per joint,

Fc the Coulomb friction (N m, N on a prismatic joint), Fv the viscous friction (N m s/rad, N s/m),
v_s > 0 the velocity (rad/s, m/s) over which the Coulomb term turns from -Fc to Fc (tanh: smooth
through v = 0, 76 % of Fc at v = v_s, 99.5 % at 3 v_s), and v either the reference velocity qd_d
(feed-forward: smooth, no chatter from a noisy measured velocity; what a tracking arm uses) or the
measured qd. With the friction of the joints Fc sign(qd) + Fv qd cancelled, a law sees the plant its
model describes. Fc = Fv = 0 on every joint: off (the configuration holds None, the tick adds nothing).
"""
import dataclasses

import numpy as np

from robot_control import validation
from robot_control.laws.joint_impedance import per_joint
from robot_control.param_table import Row, custom, gt, gt_eq, one_of
from robot_control.validation import ArgumentError

#: the velocity v the compensation is a function of
VELOCITY_SOURCES = ('reference', 'measured')
PREFIX = 'friction_compensation.'


def _friction_torque(v, Fc, Fv, v_s):
    """tau_f = Fc tanh(v / v_s) + Fv v, (n,): v, Fc, Fv (n,), v_s > 0."""
    return Fc * np.tanh(v / v_s) + Fv * v


def friction_compensation(v, coulomb, viscous, velocity_threshold):
    """tau_f (n,) = Fc tanh(v / v_s) + Fv v: v (n,) rad/s or m/s; coulomb Fc, viscous Fv a number for every
    joint or (n,), >= 0 (N m, N m s/rad); velocity_threshold v_s > 0 (rad/s). ArgumentError naming the
    bad argument."""
    v = validation.vector('v', v)
    n = v.shape[0]
    Fc, Fv = per_joint('coulomb', coulomb, n), per_joint('viscous', viscous, n)
    v_s = validation.scalar('velocity_threshold', velocity_threshold, positive=True)
    return validation.result('tau_f', _friction_torque(v, Fc, Fv, v_s))


_PER_JOINT = 'empty, one value (every joint) or one per joint'

#: the compensation's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row(PREFIX + 'coulomb', 'double_array', (), 'friction compensation (every law): Coulomb friction Fc per joint, '
        'N m (N); tau_f = Fc tanh(v / v_s) + Fv v is added to the law\'s torque; empty = 0',
        [custom(_PER_JOINT), gt_eq(0)]),
    Row(PREFIX + 'viscous', 'double_array', (), 'friction compensation: viscous friction Fv per joint, N m s/rad '
        '(N s/m); empty = 0 (Fc = Fv = 0: off)', [custom(_PER_JOINT), gt_eq(0)]),
    Row(PREFIX + 'velocity_threshold', 'double', 0.01, 'friction compensation: v_s, the velocity over which the '
        'Coulomb term turns from -Fc to Fc (tanh(v / v_s)), rad/s (m/s)', [gt(0)]),
    Row(PREFIX + 'velocity', 'string', 'reference', 'friction compensation: v is the reference velocity qd_d '
        '(feed-forward, smooth) or the measured qd', [one_of(VELOCITY_SOURCES)]),
)


def values_of(values):
    """The compensation's settings {coulomb, viscous, velocity_threshold, velocity} from the controller's
    parameter values (names with the friction_compensation. prefix)."""
    return {row.name[len(PREFIX):]: values[row.name] for row in PARAM_ROWS}


@dataclasses.dataclass(frozen=True)
class FrictionCompensation:
    """tau_f for n joints, checked: coulomb, viscous (n,) >= 0 (N m, N m s/rad), velocity_threshold v_s > 0
    (rad/s), velocity 'reference' or 'measured'. Errors name friction_compensation.<field>."""

    coulomb: tuple
    viscous: tuple
    velocity_threshold: float = 0.01
    velocity: str = 'reference'

    @classmethod
    def of(cls, value, n):
        """A FrictionCompensation for n joints from `value` (a mapping of the fields, coulomb and viscous
        empty, one value or n values; or a FrictionCompensation), or None when it is off (None, or
        Fc = Fv = 0 on every joint). ArgumentError naming friction_compensation.<field>."""
        if value is None or isinstance(value, cls):
            comp = value
        elif hasattr(value, 'keys'):
            unknown = sorted(set(value) - {f.name for f in dataclasses.fields(cls)})
            if unknown:
                raise ArgumentError('friction_compensation', f'{unknown} are not among {list(_fields())}')
            arrays = {name: _joint_values(name, value.get(name, ()), n) for name in ('coulomb', 'viscous')}
            comp = cls(**{**value, **arrays})
        else:
            raise ArgumentError('friction_compensation', f'expected a mapping of {list(_fields())}, got '
                                                         f'{type(value).__name__}')
        if comp is not None and len(comp.coulomb) != n:
            raise ArgumentError(PREFIX + 'coulomb', f'expected {n} values, got {len(comp.coulomb)}')
        return None if comp is None or not any(comp.coulomb + comp.viscous) else comp

    def __post_init__(self):
        n = len(self.coulomb)
        Fc, Fv = (per_joint(PREFIX + name, getattr(self, name), n) for name in ('coulomb', 'viscous'))
        v_s = validation.scalar(PREFIX + 'velocity_threshold', self.velocity_threshold, positive=True)
        if self.velocity not in VELOCITY_SOURCES:
            raise ArgumentError(PREFIX + 'velocity', f'unknown {self.velocity!r}; expected one of '
                                                     f'{list(VELOCITY_SOURCES)}')
        for name, v in (('coulomb', tuple(Fc.tolist())), ('viscous', tuple(Fv.tolist())), ('velocity_threshold', v_s),
                        ('_Fc', Fc), ('_Fv', Fv), ('_measured', self.velocity == 'measured')):
            object.__setattr__(self, name, v)

    def torque(self, state, ref):
        """tau_f (n,) of this tick: v = the measured qd (state) or the reference qd_d (ref)."""
        v = state.qd if self._measured else ref.qd_d
        return _friction_torque(v, self._Fc, self._Fv, self.velocity_threshold)


def _fields():
    return [f.name for f in dataclasses.fields(FrictionCompensation)]


def _joint_values(name, value, n):
    """coulomb or viscous as n values: empty -> zeros, one value -> every joint."""
    value = () if value is None else value
    if isinstance(value, (int, float)):
        value = (value,)
    if not len(value):
        return (0.0,) * n
    return tuple(validation.per_entry(PREFIX + name, value, n).tolist())
