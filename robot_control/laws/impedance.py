"""Cartesian impedance in operational space, with a null-space posture for redundant arms.

    tau = J^T (Lambda (xdd_d - Jdot qd) + K E + D Ed + F_ff) + C qd + g + N^T M qdd_0

E = x_d [-] x the task error of the target (orientation on SO(3), robot_control.models: task
difference), each part bounded by max_pose_error; Ed = xd_d - xd; K = diag(stiffness) (N/m, N m/rad);
D the damping (N s/m, N m s/rad), by default D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2), which is
2 zeta sqrt(lambda k) on an axis whose inertia lambda is decoupled (zeta = 1: critical); F_ff a
feed-forward wrench (N, N m, the robot on its environment); qdd_0 = Kp0 (q_posture - q) - Kv0 qd the
posture acceleration, N^T = I - J^T Jbar^T the dynamically consistent null-space projector. With
the model's C qd and g compensated, the closed loop under an external wrench F on the tip is

    Lambda Edd + D Ed + K E = -(F_ff + F),

so at rest the tip settles at x = x_d + K^-1 (F + F_ff) from its target, and a moving target
(x_d, xd_d, xdd_d) is followed with E = 0. It is the operational-space law of
robot_control.laws.operational_space with F' = xdd_d and the wrench K E + D Ed + F_ff:

    tau = rnea(q, qd, qdd_0) + J^T (Lambda (xdd_d - Jdot qd - J qdd_0) + K E + D Ed + F_ff).

The designed stiffness (the law in the controller, cartesian_stiffness empty) is DESIGN_STIFFNESS capped
per task axis, every tick, so that each axis stays stable at the control period dt:

    K_i = min(K_design_i, w_max^2 / (Lambda^-1)_ii),   w_max = 0.1 pi / (dt max(1, zeta)).

Why: axis i alone is the double integrator lambda e'' = -K e - D e' with w^2 = K / lambda, D / lambda =
2 zeta w, its torque computed from the state at t_k and held for dt. Exactly discretized, the error's
characteristic polynomial is z^2 + (w^2 dt^2 / 2 + 2 zeta w dt - 2) z + (w^2 dt^2 / 2 - 2 zeta w dt + 1),
and the Jury test gives stability iff zeta w dt < 1 (with zeta <= 1, also w dt < 4 zeta); with the
command one tick late (a real-time loop) the bound is w dt < 0.43 at zeta = 1 (numerically). w_max dt =
pi / 10, a tenth of the Nyquist frequency pi / dt (divided by zeta above 1), stays inside both: its
poles' radius is 0.79 (0.84 one tick late) against e^(-w dt) = 0.73 of the continuous loop, so the
damping designed is close to the damping got. The axis' inertia is 1 / (Lambda^-1)_ii = 1 / (J M^-1 J^T)_ii,
the inertia it has while the other axes move freely, not Lambda_ii (the one with them held, larger):
w_i^2 = K_i (Lambda^-1)_ii are the diagonal of K^1/2 Lambda^-1 K^1/2, whose eigenvalues are the squared
frequencies of the coupled modes; its largest is at most m times the largest diagonal entry. Measured
in-process (World, 1 ms): the xArm7's rz axis at 100 N m/rad (w = 849 rad/s, w dt = 0.85) saturated
joint 7 in 1547 of 3000 ticks; capped (13.7 N m/rad) none; its fastest coupled mode over 200 poses
stayed below 1.7 w_max.
"""
import dataclasses
import functools
import math

import numpy as np

from robot_control import validation
from robot_control.laws.base import Errors, Law
from robot_control.laws.operational_space import (Posture, _inertia_roots, _inverse_task_inertia,
                                                  _operational_space, _posture_acceleration, _task_inertia,
                                                  check_law_fits, check_task_dimension, posture_gains)
from robot_control.param_table import Row, gt, gt_eq, size
from robot_control.validation import ArgumentError

#: the six axes of a pose, in the order of cartesian_stiffness and cartesian_damping
POSE_AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')
ROTATION_AXES = ('rx', 'ry', 'rz')
#: the designed stiffness before its cap (module docstring): x, y, z N/m; rx, ry, rz N m/rad
DESIGN_STIFFNESS = (1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0)
#: the cap of a designed axis' frequency, as a fraction of the Nyquist frequency pi / dt
NYQUIST_FRACTION = 0.1


def rotation_mask(axes):
    """m bools, a tuple: True on the orientation axes among the task `axes`."""
    return tuple(a in ROTATION_AXES for a in axes)


def _damping(root, k, zeta):
    """D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2), (m, m): root = Lambda^1/2 (m, m), k = K^1/2 (m,) the
    diagonal of K^1/2."""
    return zeta * (root * k + k[:, None] * root)


def max_frequency(dt, zeta):
    """w_max = NYQUIST_FRACTION pi / (dt max(1, zeta)), rad/s: the highest closed-loop frequency of a designed
    axis at the control period dt (s, > 0) with damping ratio zeta (>= 0); module docstring."""
    return NYQUIST_FRACTION * math.pi / (dt * max(1.0, zeta))


def _capped_stiffness(K, inverse_inertia, w_max):
    """K_i = min(K_i, w_max^2 / (Lambda^-1)_ii), (m,): K (m,), inverse_inertia (m,) the diagonal of Lambda^-1
    (1/kg, 1/(kg m^2)), w_max rad/s."""
    return np.minimum(K, w_max * w_max / inverse_inertia)


def check_task_axes(name, values, axes):
    """ArgumentError naming `name` when the six values (x, y, z, rx, ry, rz) set a non-zero rotation entry that
    the task `axes` do not have: a position task space leaves the orientation free, so a rotational
    stiffness (or damping) there would be dropped without a word."""
    dropped = [f'{a} = {v:g}' for a, v in zip(POSE_AXES, values) if a in ROTATION_AXES and a not in axes and v]
    if dropped:
        raise ArgumentError(name, f'{", ".join(dropped)} act on the orientation, which the task space '
                                  f'{list(axes)} does not hold: set task_space pose (an arm of 6 or more '
                                  'joints), or 0 there')


def _bounded(E, rotation, limits):
    """E with its translation part and its rotation part (`rotation`: m bools, True on the rotation axes)
    each scaled down to a norm of at most limits = (m, rad)."""
    trans = rot = 0.0
    for e, on_rotation in zip(E.tolist(), rotation):      # m <= 6 floats: cheaper than numpy's reductions
        if on_rotation:
            rot += e * e
        else:
            trans += e * e
    scale_t = limits[0] / math.sqrt(trans) if trans > limits[0] ** 2 else 1.0
    scale_r = limits[1] / math.sqrt(rot) if rot > limits[1] ** 2 else 1.0
    if scale_t == 1.0 and scale_r == 1.0:
        return E.copy()
    return E * np.where(rotation, scale_r, scale_t)


def _impedance(model, q, qd, J, Jdot_qd, E, Ed, xdd_d, K, D, F_ff, qdd_0, Lambda):
    """tau (n,) = rnea(q, qd, qdd_0) + J^T (Lambda (xdd_d - Jdot qd - J qdd_0) + K E + D Ed + F_ff); checked
    arrays, J full rank, Lambda its task inertia, D (m, m), F_ff (m,) or None (no feed-forward wrench)."""
    wrench = K * E + D @ Ed
    return _operational_space(model, q, qd, J, Jdot_qd, xdd_d, wrench if F_ff is None else wrench + F_ff, qdd_0,
                              Lambda)


def axis_values(name, values, axes):
    """The entries of a six-value parameter (x, y, z, rx, ry, rz) for the task `axes`, (m,) >= 0."""
    values = validation.vector(name, values, 6)
    if min(values.tolist()) < 0.0:
        raise ArgumentError(name, f'expected values >= 0, got {values.tolist()}')
    index = _pose_index(tuple(axes))
    if index is None:
        unknown = [a for a in axes if a not in POSE_AXES]
        raise ArgumentError(name, f'the task axes {unknown} are not among {list(POSE_AXES)}')
    return values[index]


@functools.lru_cache(maxsize=64)
def _pose_index(axes):
    """The index array of the task `axes` (a tuple) in POSE_AXES, or None when one is not a pose axis."""
    if any(a not in POSE_AXES for a in axes):
        return None
    return np.array([POSE_AXES.index(a) for a in axes], dtype=np.intp)


def impedance(model, q, qd, x_d, xd_d, xdd_d, stiffness, damping_ratio=1.0, damping=None, F_ff=None,
              q_posture=None, k_posture=(25.0, 10.0), max_pose_error=(np.inf, np.inf)):
    """tau (n,): Cartesian impedance toward the target (x_d, xd_d, xdd_d), each (m,) in the model's task space.

    stiffness: six values (x, y, z N/m; rx, ry, rz N m/rad), the model's task axes taken by name;
    damping: six values (N s/m, N m s/rad) or None for the design of damping_ratio (module docstring);
    F_ff (m,) N, N m or None; q_posture (n,) the null-space target (None: damping only); k_posture
    (Kp0 1/s^2, Kv0 1/s); max_pose_error (m, rad) bounds E. ArgumentError naming the bad argument."""
    n, m = model.n, model.task_dim
    q, qd = validation.vectors(n, q=q, qd=qd)
    x_d, xd_d, xdd_d = validation.vectors(m, x_d=x_d, xd_d=xd_d, xdd_d=xdd_d)
    K = axis_values('stiffness', stiffness, model.task_axes)
    ratio = validation.scalar('damping_ratio', damping_ratio, nonnegative=True)
    F_ff = None if F_ff is None else validation.vector('F_ff', F_ff, m)
    q_posture = q if q_posture is None else validation.vector('q_posture', q_posture, n)
    kp0, kv0 = posture_gains(k_posture, n)
    limits = validation.limit_vector('max_pose_error', max_pose_error, 2)
    x, J, Jdot_qd = model._task(q, qd)
    check_task_dimension(J)
    if damping is None:
        Lambda, root = _task_inertia(model, q, J, root=True)
        D = _damping(root, np.sqrt(K), ratio)
    else:
        Lambda, D = _task_inertia(model, q, J), np.diag(axis_values('damping', damping, model.task_axes))
    E = _bounded(model._task_difference(x_d, x), rotation_mask(model.task_axes), limits)
    qdd_0 = _posture_acceleration(q, qd, q_posture, kp0, kv0)
    return validation.result('tau', _impedance(model, q, qd, J, Jdot_qd, E, xd_d - J @ qd, xdd_d, K, D, F_ff, qdd_0,
                                               Lambda))


#: the impedance law's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row('cartesian_stiffness', 'double_array', (),
        'impedance: stiffness K along x, y, z (N/m) and about rx, ry, rz (N m/rad); the task axes take theirs '
        '(rx, ry, rz must be 0 in a position task space); empty = designed: 1000 N/m, 100 N m/rad, each axis '
        'capped at the frequency 0.1 pi / (control_period max(1, cartesian_damping_ratio))',
        [size(6, 'pose axis', empty_ok=True), gt_eq(0)]),
    Row('cartesian_damping_ratio', 'double', 1.0, 'impedance: damping ratio, dimensionless, of the designed '
        'damping D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2) (Lambda: the operational-space inertia); 1 = critical',
        [gt_eq(0)]),
    Row('cartesian_damping', 'double_array', (), 'impedance: explicit damping along x, y, z (N s/m) and '
        'rx, ry, rz (N m s/rad); empty = designed from cartesian_damping_ratio',
        [size(6, 'pose axis', empty_ok=True), gt_eq(0)]),
    Row('max_pose_error', 'double_array', (0.1, 0.5), 'impedance (and hybrid toward a target_pose): largest '
        'position (m) and rotation (rad) error fed to the law', [size(2, 'bound'), gt(0)]),
    Row('control_period', 'double', 0.001, 'period of the joint_states the controller answers (the '
        "bridge's control_period), s: the designed gains of the impedance law are kept stable at this rate",
        [gt(0)]),
)
_DEFAULTS = {row.name: row.default for row in PARAM_ROWS}


@dataclasses.dataclass(frozen=True)
class ImpedanceParams:
    """The impedance law's parameters (PARAM_ROWS), checked: cartesian_stiffness six values >= 0 (x, y, z
    N/m; rx, ry, rz N m/rad) or empty for the design (module docstring); cartesian_damping six values >= 0
    (N s/m, N m s/rad) or empty for the design of cartesian_damping_ratio (>= 0); max_pose_error (m, rad) > 0,
    the bounds of the task error; control_period (s, > 0): the period of the states the controller answers, at
    which the designed stiffness stays stable (max_frequency); posture: the null-space posture
    (robot_control.laws.operational_space)."""

    cartesian_stiffness: tuple = _DEFAULTS['cartesian_stiffness']
    cartesian_damping_ratio: float = _DEFAULTS['cartesian_damping_ratio']
    cartesian_damping: tuple = _DEFAULTS['cartesian_damping']
    max_pose_error: tuple = _DEFAULTS['max_pose_error']
    control_period: float = _DEFAULTS['control_period']
    posture: Posture = Posture()

    def __post_init__(self):
        set_ = functools.partial(object.__setattr__, self)
        for name in ('cartesian_stiffness', 'cartesian_damping'):
            values = getattr(self, name)
            values = () if values is None else values
            set_(name, tuple(validation.vector(name, values, 6).tolist()) if len(values) else ())
        set_('cartesian_damping_ratio', validation.scalar('cartesian_damping_ratio', self.cartesian_damping_ratio,
                                                          nonnegative=True))
        limits = validation.vector('max_pose_error', self.max_pose_error, 2)
        if min(limits.tolist()) <= 0.0:
            raise ArgumentError('max_pose_error', f'expected two positive bounds (m, rad), got {limits.tolist()}')
        set_('max_pose_error', tuple(limits.tolist()))
        set_('control_period', validation.scalar('control_period', self.control_period, positive=True))


class Impedance(Law):
    """The registry's 'impedance': the target is ~/target_pose once one came (at rest), else the joint
    reference seen in the task space (fk(q_d), J qd_d, J qdd_d + Jdot qd_d), which holds the pose at
    activation; the joint reference is also the null-space posture target. Without an explicit
    cartesian_stiffness the stiffness is designed (module docstring: DESIGN_STIFFNESS capped per axis at
    w_max each tick); explicit values are used as given. ArgumentError naming cartesian_stiffness or
    cartesian_damping for a rotation entry a position task space would drop."""

    name = 'impedance'
    tracks = 'task'
    needs_task_space = True
    param_rows = PARAM_ROWS
    Params = ImpedanceParams
    parts = (Posture,)

    def __init__(self, config):
        super().__init__(config)
        model = self.model
        check_law_fits(self.name, model)
        params = config.law_params
        for name in ('cartesian_stiffness', 'cartesian_damping'):
            check_task_axes(name, getattr(params, name), model.task_axes)
        stiffness = params.cartesian_stiffness
        self.K = axis_values('cartesian_stiffness', stiffness or DESIGN_STIFFNESS, model.task_axes)
        self.K_root = np.sqrt(self.K)
        explicit = params.cartesian_damping
        self.D = np.diag(axis_values('cartesian_damping', explicit, model.task_axes)) if explicit else None
        self.ratio = params.cartesian_damping_ratio
        self.w_max = None if stiffness else max_frequency(params.control_period, self.ratio)
        self.rotation = rotation_mask(model.task_axes)
        self.limits = params.max_pose_error
        self.kp0, self.kv0 = params.posture.gains(model.n)

    @property
    def reference_names(self):
        return self.model.task_axes

    def errors(self, state, ref):
        """The target (the task target, or the joint reference in the task space) and E, Ed toward it."""
        target = ref.target if ref.target is not None else self.model._task_motion(ref.q_d, ref.qd_d, ref.qdd_d)
        x_d, xd_d, _ = target
        return Errors(target, _bounded(self.model._task_difference(x_d, state.x), self.rotation, self.limits),
                      xd_d - state.xd)

    def torque(self, state, ref, err, int_E):
        w, V = _inverse_task_inertia(self.model, state.q, state.J)
        K, K_root = self.K, self.K_root
        if self.w_max is not None:
            K = _capped_stiffness(K, (V * V) @ w, self.w_max)
            K_root = np.sqrt(K)
        if self.D is None:
            Lambda, root = _inertia_roots(w, V, root=True)
            D = _damping(root, K_root, self.ratio)
        else:
            Lambda, D = _inertia_roots(w, V), self.D
        qdd_0 = _posture_acceleration(state.q, state.qd, ref.q_d, self.kp0, self.kv0)
        return _impedance(self.model, state.q, state.qd, state.J, state.Jdot_qd, err.E, err.Ed, err.ref[2], K, D,
                          ref.wrench, qdd_0, Lambda)
