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
import numpy as np

from robot_control import validation
from robot_control.laws.base import Law
from robot_control.laws.operational_space import (_operational_space, _posture_acceleration, _task_inertia,
                                                  check_jacobian, posture_gains)
from robot_control.validation import ArgumentError

#: the six axes of a pose, in the order of cartesian_stiffness and cartesian_damping
POSE_AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')
ROTATION_AXES = ('rx', 'ry', 'rz')


def _damping(Lambda, K, zeta):
    """D = zeta (Lambda^1/2 K^1/2 + K^1/2 Lambda^1/2), (m, m): Lambda (m, m) symmetric positive definite, K (m,)."""
    w, V = np.linalg.eigh(Lambda)
    root = (V * np.sqrt(w)) @ V.T
    k = np.sqrt(K)
    return zeta * (root * k + k[:, None] * root)


def _bounded(E, rotation, limits):
    """E with its translation part and its rotation part (mask `rotation`) each scaled down to a norm of
    at most limits = (m, rad)."""
    out = E.copy()
    for part, limit in ((~rotation, limits[0]), (rotation, limits[1])):
        norm = np.linalg.norm(E[part])
        if norm > limit:
            out[part] *= limit / norm
    return out


def _impedance(model, q, qd, J, Jdot_qd, E, Ed, xdd_d, K, D, F_ff, qdd_0, Lambda):
    """tau (n,) = rnea(q, qd, qdd_0) + J^T (Lambda (xdd_d - Jdot qd - J qdd_0) + K E + D Ed + F_ff); checked
    arrays, J full rank, Lambda its task inertia, D (m, m)."""
    return _operational_space(model, q, qd, J, Jdot_qd, xdd_d, K * E + D @ Ed + F_ff, qdd_0, Lambda)


def axis_values(name, values, axes):
    """The entries of a six-value parameter (x, y, z, rx, ry, rz) for the task `axes`, (m,) >= 0."""
    values = validation.vector(name, values, 6)
    if min(values.tolist()) < 0.0:
        raise ArgumentError(name, f'expected values >= 0, got {values.tolist()}')
    unknown = [a for a in axes if a not in POSE_AXES]
    if unknown:
        raise ArgumentError(name, f'the task axes {unknown} are not among {list(POSE_AXES)}')
    return np.array([values[POSE_AXES.index(a)] for a in axes])


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
    F_ff = np.zeros(m) if F_ff is None else validation.vector('F_ff', F_ff, m)
    q_posture = q if q_posture is None else validation.vector('q_posture', q_posture, n)
    kp0, kv0 = posture_gains(k_posture, n)
    limits = validation.limit_vector('max_pose_error', max_pose_error, 2)
    x, J, Jdot_qd = model._task(q, qd)
    check_jacobian(J)
    Lambda = _task_inertia(model, q, J)
    D = _damping(Lambda, K, ratio) if damping is None else np.diag(axis_values('damping', damping, model.task_axes))
    E = _bounded(model._task_difference(x_d, x), np.isin(model.task_axes, ROTATION_AXES), limits)
    qdd_0 = _posture_acceleration(q, qd, q_posture, kp0, kv0)
    return validation.result('tau', _impedance(model, q, qd, J, Jdot_qd, E, xd_d - J @ qd, xdd_d, K, D, F_ff, qdd_0,
                                               Lambda))


class Impedance(Law):
    """The registry's 'impedance': the target is ~/target_pose once one came (at rest), else the joint
    reference seen in the task space (fk(q_d), J qd_d, J qdd_d + Jdot qd_d), which holds the pose at
    activation; the joint reference is also the null-space posture target."""

    name = 'impedance'
    tracks = 'task'
    needs_task_space = True

    def __init__(self, config):
        super().__init__(config)
        model = self.model
        if model.task_dim > model.n:
            raise ArgumentError('law', f'impedance needs task dimension <= joints; the model has {model.task_dim} '
                                       f'task axes and {model.n} joints')
        self.K = axis_values('cartesian_stiffness', config.cartesian_stiffness, model.task_axes)
        explicit = config.cartesian_damping
        self.D = None if explicit is None else np.diag(axis_values('cartesian_damping', explicit, model.task_axes))
        self.ratio = config.cartesian_damping_ratio
        self.rotation = np.isin(model.task_axes, ROTATION_AXES)
        self.limits = config.max_pose_error
        self.kp0, self.kv0 = (np.full(model.n, g) for g in config.posture_gains)

    @classmethod
    def servo_sizes(cls, model, force_axes):
        return ()

    @property
    def integral_dim(self):
        return 0

    @property
    def reference_names(self):
        return self.model.task_axes

    def errors(self, tick):
        """The target (the task target, or the joint reference in the task space) and E, Ed toward it."""
        target = tick.target if tick.target is not None else self.model._task_motion(tick.q_d, tick.qd_d,
                                                                                      tick.qdd_d)
        x_d, xd_d, _ = target
        tick.ref = target
        tick.E = _bounded(self.model._task_difference(x_d, tick.x), self.rotation, self.limits)
        tick.Ed = xd_d - tick.xd

    def torque(self, tick, int_E):
        check_jacobian(tick.J)
        Lambda = _task_inertia(self.model, tick.q, tick.J)
        D = _damping(Lambda, self.K, self.ratio) if self.D is None else self.D
        F_ff = tick.wrench if tick.wrench is not None else np.zeros(self.model.task_dim)
        qdd_0 = _posture_acceleration(tick.q, tick.qd, tick.q_d, self.kp0, self.kv0)
        return _impedance(self.model, tick.q, tick.qd, tick.J, tick.Jdot_qd, tick.E, tick.Ed, tick.ref[2], self.K, D,
                          F_ff, qdd_0, Lambda)
