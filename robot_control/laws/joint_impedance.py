"""Joint impedance: a joint stiffness and damping in N m/rad, N m s/rad, with the model as feed-forward.

    tau = M(q) qdd_d + C(q, qd) qd + g(q) + K E + D Ed (+ Ki int E),   E = q_d - q,  Ed = qd_d - qd,

K = diag(joint_stiffness) (N m/rad, N/m on a prismatic joint), D = diag of the damping (N m s/rad,
N s/m): explicit, or designed per joint from the diagonal of the joint-space inertia at this tick,
D_i = 2 zeta sqrt(K_i M_ii(q)) (zeta = 1: critical), Ki = diag(ki) (N m/(rad s), N/(m s)). The model
terms M qdd_d + C qd + g are the inverse dynamics at the reference acceleration (one RNEA call for a
URDF model). With a perfect model the closed loop is M Edd + (C + D) Ed + K E = -tau_ext, so

  - a motion is tracked with E = 0: the model carries the reference's torque;
  - an unmodelled torque d (friction, a payload, a push) leaves the steady error E = -d / K_i per joint
    (K_i in N m/rad), whatever the joint's inertia; the integral drives it to zero with a time constant
    of about K_i / ki_i.

Computed torque (robot_control.laws.computed_torque) scales its servo by M(q): its stiffness against
the same torque is M_ii kp, small on a light joint (a wrist) however stiff the arm's proximal joints
are. Here the stiffness is what is asked for on every joint, as on Franka's joint impedance example or
KUKA FRI's joint impedance mode.

Without the model terms this is the lecture's independent-joint PD (robot_control.laws.independent_joint,
tau = Kp E + Kv Ed + Ki int E with torque gains): joint impedance is that servo around the inverse
dynamics of the reference.
"""
import dataclasses
import functools

import numpy as np

from robot_control import validation
from robot_control.laws.base import Law
from robot_control.param_table import Row, custom, gt_eq, not_empty
from robot_control.validation import ArgumentError

#: the integral time of the default ki: ki = K / INTEGRAL_TIME (s)
INTEGRAL_TIME = 1.0


def _joint_impedance(model, q, qd, qdd_d, E, Ed, K, D, ki=None, int_E=None):
    """tau = M(q) qdd_d + C(q, qd) qd + g(q) + K E + D Ed (+ ki int_E), (n,); checked (n,) arrays."""
    tau = model._inverse_dynamics(q, qd, qdd_d) + K * E + D * Ed
    if int_E is not None:
        tau = tau + ki * int_E
    return tau


def _designed_damping(K, M_diag, zeta):
    """D_i = 2 zeta sqrt(K_i M_ii), (n,): K (n,), M_diag (n,) the diagonal of M(q)."""
    return 2.0 * zeta * np.sqrt(K * M_diag)


def per_joint(name, value, n):
    """`value` (a number, one value for every joint, or n values), (n,) >= 0; ArgumentError naming `name`."""
    a = validation.per_entry(name, value, n)
    if min(a.tolist()) < 0.0:
        raise ArgumentError(name, f'expected values >= 0, got {a.tolist()}')
    return a


def joint_impedance(model, q, qd, q_d, qd_d, qdd_d, K, D=None, damping_ratio=1.0, ki=None, int_E=None):
    """tau (n,) = M(q) qdd_d + C(q, qd) qd + g(q) + K (q_d - q) + D (qd_d - qd) + ki int_E.

    Vectors (n,), SI units. K: stiffness per joint (a number for every joint or (n,)), N m/rad or N/m,
    >= 0; D: damping likewise, N m s/rad or N s/m, or None for D_i = 2 damping_ratio sqrt(K_i M_ii(q));
    ki: integral gain likewise, N m/(rad s), None for K / (1 s); int_E (n,) rad s or None (no integral).
    ArgumentError naming the first bad argument, or `tau` when finite inputs overflow."""
    n = model.n
    q, qd, q_d, qd_d, qdd_d = validation.vectors(n, q=q, qd=qd, q_d=q_d, qd_d=qd_d, qdd_d=qdd_d)
    K = per_joint('K', K, n)
    ratio = validation.scalar('damping_ratio', damping_ratio, nonnegative=True)
    D = _designed_damping(K, np.diag(model._M(q)), ratio) if D is None else per_joint('D', D, n)
    ki = K / INTEGRAL_TIME if ki is None else per_joint('ki', ki, n)
    int_E = validation.optional_vector('int_E', int_E, n)
    return validation.result('tau', _joint_impedance(model, q, qd, qdd_d, q_d - q, qd_d - qd, K, D, ki, int_E))


_PER_JOINT = 'one value (every joint) or one per joint'

#: the joint impedance law's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row('joint_stiffness', 'double_array', (100.0,), 'joint_impedance: stiffness K per joint, N m/rad (N/m on a '
        'prismatic joint); the steady error under an unmodelled torque d is d / K', [not_empty(), custom(_PER_JOINT),
                                                                                    gt_eq(0)]),
    Row('joint_damping_ratio', 'double', 1.0, 'joint_impedance: damping ratio zeta, dimensionless, of the designed damping '
        'D_i = 2 zeta sqrt(K_i M_ii(q)) (M_ii: the joint-space inertia at each tick); 1 = critical', [gt_eq(0)]),
    Row('joint_damping', 'double_array', (), 'joint_impedance: explicit damping D per joint, N m s/rad (N s/m); '
        'empty = designed from joint_damping_ratio', [custom(f'empty, {_PER_JOINT}'), gt_eq(0)]),
    Row('joint_ki', 'double_array', (), 'joint_impedance: integral gain per joint, used when integral, N m/(rad s) '
        f'(N/(m s)); empty = K / ({INTEGRAL_TIME:g} s): a constant disturbance\'s error dies out in about '
        f'{INTEGRAL_TIME:g} s', [custom(f'empty, {_PER_JOINT}'), gt_eq(0)]),
)
_DEFAULTS = {row.name: row.default for row in PARAM_ROWS}


def _values(name, value, empty_ok):
    """`value` as a tuple of finite numbers >= 0 (one or more; empty when empty_ok), ArgumentError naming `name`."""
    value = () if value is None else value
    if not len(value) and empty_ok:
        return ()
    a = validation.vector(name, value)
    if not a.shape[0] or min(a.tolist()) < 0.0:
        raise ArgumentError(name, f'expected {_PER_JOINT}, each >= 0, got {a.tolist()}')
    return tuple(a.tolist())


@dataclasses.dataclass(frozen=True)
class JointImpedanceParams:
    """The joint impedance law's parameters (PARAM_ROWS), checked: joint_stiffness (N m/rad), joint_damping
    (N m s/rad; empty: designed from joint_damping_ratio >= 0) and joint_ki (N m/(rad s); empty: K / 1 s),
    each one value for every joint or one per joint (the number of joints is checked with the model)."""

    joint_stiffness: tuple = _DEFAULTS['joint_stiffness']
    joint_damping_ratio: float = _DEFAULTS['joint_damping_ratio']
    joint_damping: tuple = _DEFAULTS['joint_damping']
    joint_ki: tuple = _DEFAULTS['joint_ki']

    def __post_init__(self):
        set_ = functools.partial(object.__setattr__, self)
        set_('joint_stiffness', _values('joint_stiffness', self.joint_stiffness, empty_ok=False))
        set_('joint_damping', _values('joint_damping', self.joint_damping, empty_ok=True))
        set_('joint_ki', _values('joint_ki', self.joint_ki, empty_ok=True))
        set_('joint_damping_ratio', validation.scalar('joint_damping_ratio', self.joint_damping_ratio,
                                                      nonnegative=True))


class JointImpedance(Law):
    """The registry's 'joint_impedance': the joint reference, the law's own K, D, ki (N m/rad ...); an
    integral per joint when integral is on (ki = joint_ki), no kp/kv/ki servo gains."""

    name = 'joint_impedance'
    param_rows = PARAM_ROWS
    Params = JointImpedanceParams

    def __init__(self, config):
        super().__init__(config)
        n, params = self.model.n, config.law_params
        self.K = per_joint('joint_stiffness', params.joint_stiffness, n)
        self.D = per_joint('joint_damping', params.joint_damping, n) if params.joint_damping else None
        self.ratio = params.joint_damping_ratio
        self.ki = per_joint('joint_ki', params.joint_ki, n) if params.joint_ki else self.K / INTEGRAL_TIME
        self._D_tick = self.D if self.D is not None else np.zeros(n)     # the damping of the last tick

    @property
    def integral_dim(self):
        """One integral entry per joint."""
        return self.model.n

    def integral_gains(self):
        """(ki, D of the last tick): the anti-windup's tracking time constant is sqrt(D / ki)."""
        if not self.config.integral:
            return np.zeros(self.model.n), np.zeros(self.model.n)
        return self.ki, self._D_tick

    def damping(self, q):
        """D (n,) at q: explicit, or 2 zeta sqrt(K_i M_ii(q))."""
        if self.D is not None:
            return self.D
        return _designed_damping(self.K, np.diag(self.model._M(q)), self.ratio)

    def torque(self, state, ref, err, int_E):
        self._D_tick = D = self.damping(state.q)
        return _joint_impedance(self.model, state.q, state.qd, ref.qdd_d, err.E, err.Ed, self.K, D, self.ki, int_E)

    def integral_map(self, state, ref, err):
        """B = diag(ki): the integral enters as ki int E."""
        return np.diag(self.ki)
