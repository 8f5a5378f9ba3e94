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
"""
import dataclasses
import functools
import math

import numpy as np

from robot_control import validation
from robot_control.laws.base import Errors, Law
from robot_control.laws.operational_space import (_operational_space, _posture_acceleration, _task_inertia,
                                                  check_law_fits, check_task_dimension, posture_gains)
from robot_control.param_table import Row, gt, gt_eq, size
from robot_control.validation import ArgumentError

#: the six axes of a pose, in the order of cartesian_stiffness and cartesian_damping
POSE_AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')
ROTATION_AXES = ('rx', 'ry', 'rz')


def rotation_mask(axes):
    """m bools, a tuple: True on the orientation axes among the task `axes`."""
    return tuple(a in ROTATION_AXES for a in axes)


def _damping(root, k, zeta):
    """D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2), (m, m): root = Lambda^1/2 (m, m), k = K^1/2 (m,) the
    diagonal of K^1/2."""
    return zeta * (root * k + k[:, None] * root)


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
    Row('cartesian_stiffness', 'double_array', (1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0),
        'impedance: stiffness K along x, y, z (N/m) and about rx, ry, rz (N m/rad); the task axes take theirs',
        [size(6, 'pose axis'), gt_eq(0)]),
    Row('cartesian_damping_ratio', 'double', 1.0, 'impedance: damping ratio, dimensionless, of the designed '
        'damping D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2) (Lambda: the operational-space inertia); 1 = critical',
        [gt_eq(0)]),
    Row('cartesian_damping', 'double_array', (), 'impedance: explicit damping along x, y, z (N s/m) and '
        'rx, ry, rz (N m s/rad); empty = designed from cartesian_damping_ratio',
        [size(6, 'pose axis', empty_ok=True), gt_eq(0)]),
    Row('max_pose_error', 'double_array', (0.1, 0.5), 'impedance (and hybrid toward a target_pose): largest '
        'position (m) and rotation (rad) error fed to the law', [size(2, 'bound'), gt(0)]),
)
_DEFAULTS = {row.name: row.default for row in PARAM_ROWS}


@dataclasses.dataclass(frozen=True)
class ImpedanceParams:
    """The impedance law's parameters (PARAM_ROWS), checked: cartesian_stiffness six values >= 0 (x, y, z
    N/m; rx, ry, rz N m/rad); cartesian_damping six values >= 0 (N s/m, N m s/rad) or empty for the design
    of cartesian_damping_ratio (>= 0); max_pose_error (m, rad) > 0, the bounds of the task error."""

    cartesian_stiffness: tuple = _DEFAULTS['cartesian_stiffness']
    cartesian_damping_ratio: float = _DEFAULTS['cartesian_damping_ratio']
    cartesian_damping: tuple = _DEFAULTS['cartesian_damping']
    max_pose_error: tuple = _DEFAULTS['max_pose_error']

    def __post_init__(self):
        set_ = functools.partial(object.__setattr__, self)
        set_('cartesian_stiffness', tuple(validation.vector('cartesian_stiffness', self.cartesian_stiffness, 6).tolist()))
        damping = () if self.cartesian_damping is None else self.cartesian_damping
        set_('cartesian_damping', tuple(validation.vector('cartesian_damping', damping, 6).tolist()) if len(damping)
             else ())
        set_('cartesian_damping_ratio', validation.scalar('cartesian_damping_ratio', self.cartesian_damping_ratio,
                                                          nonnegative=True))
        limits = validation.vector('max_pose_error', self.max_pose_error, 2)
        if min(limits.tolist()) <= 0.0:
            raise ArgumentError('max_pose_error', f'expected two positive bounds (m, rad), got {limits.tolist()}')
        set_('max_pose_error', tuple(limits.tolist()))


class Impedance(Law):
    """The registry's 'impedance': the target is ~/target_pose once one came (at rest), else the joint
    reference seen in the task space (fk(q_d), J qd_d, J qdd_d + Jdot qd_d), which holds the pose at
    activation; the joint reference is also the null-space posture target."""

    name = 'impedance'
    tracks = 'task'
    needs_task_space = True
    motion_servo = False
    param_rows = PARAM_ROWS
    Params = ImpedanceParams

    def __init__(self, config):
        super().__init__(config)
        model = self.model
        check_law_fits(self.name, model)
        params = config.law_params
        self.K = axis_values('cartesian_stiffness', params.cartesian_stiffness, model.task_axes)
        self.K_root = np.sqrt(self.K)
        explicit = params.cartesian_damping
        self.D = np.diag(axis_values('cartesian_damping', explicit, model.task_axes)) if explicit else None
        self.ratio = params.cartesian_damping_ratio
        self.rotation = rotation_mask(model.task_axes)
        self.limits = params.max_pose_error
        self.kp0, self.kv0 = (np.full(model.n, g) for g in config.posture_gains)

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
        if self.D is None:
            Lambda, root = _task_inertia(self.model, state.q, state.J, root=True)
            D = _damping(root, self.K_root, self.ratio)
        else:
            Lambda, D = _task_inertia(self.model, state.q, state.J), self.D
        qdd_0 = _posture_acceleration(state.q, state.qd, ref.q_d, self.kp0, self.kv0)
        return _impedance(self.model, state.q, state.qd, state.J, state.Jdot_qd, err.E, err.Ed, err.ref[2], self.K, D,
                          ref.wrench, qdd_0, Lambda)
