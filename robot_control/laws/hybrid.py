"""Hybrid position/force control (lecture 3.1) in operational space.

Task space X = fk(q), (m,), split by the bool mask `force_axes` into motion axes x_T and force
axes x_N. The servo F' = [F_T; F_N],

    F_T = xdd_Td + K_Tv Ed_T + K_Tp E_T,          E_T = x_Td - x_T,
    F_N = K_e^-1 (fdd_d + K_Nv Ed_N + K_Np E_N),  E_N = f_d - f,

is the servo law of every other law, per task axis, with K_e = 1 on the motion axes. The model
portion is the operational-space law (robot_control.laws.operational_space): for the lecture's
Cartesian robots it is tau = M_x F' + C_x + g_x + f_e; for an articulated, redundant arm
tau = J^T (Lambda F' + mu + p + f_e) + N^T tau_0, with the posture servo acting in the null space.

Force sign: f is the force the robot exerts on the environment, signed along each task axis, and
f_e = f on the force axes, 0 on the motion axes. With f = K_e (x_N - x_e) and K_e > 0 this holds
whichever side the robot presses from: pressing down on a table (-z) gives f_z < 0, so pushing
with 10 N is f_d = -10 N on z.
"""
import dataclasses

import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.laws.base import Errors, Law
from robot_control.laws.force_task import ForceTask
from robot_control.laws.operational_space import (Posture, _operational_space, _posture_acceleration, _task_inertia,
                                                  check_law_fits, check_task_dimension, posture_gains)
from robot_control.laws.servo import MotionServo, _servo, servo_gains
from robot_control.validation import ArgumentError


def _hybrid_errors(dx, xd, xd_d, xdd_d, f, fdot, f_d, fd_d, fdd_d, force):
    """Per task axis (m,): the reference acceleration (xdd_d or fdd_d) and the errors E = dx (the task
    error x_d - x, from the model for orientation axes) or f_d - f, Ed = xd_d - xd or fd_d - fdot, on
    the motion or force axes. dx, xd, xd_d, xdd_d (m,) (their force-axis entries unused); f, fdot, f_d,
    fd_d, fdd_d (k,) on the force axes, whose indices among the m are `force` (k,)."""
    Ed = xd_d - xd
    Ed[force] = fd_d - fdot
    return _on_axes(xdd_d, force, fdd_d), _on_axes(dx, force, f_d - f), Ed


def _on_axes(values, index, part):
    """A copy of `values` (m,) with its entries at `index` (k,) set to `part` (k,)."""
    out = values.copy()
    out[index] = part
    return out


def _hybrid_servo(acc, E, Ed, gains, K_e, int_E=None):
    """F' (m,) m/s^2 = (acc + Kv Ed + Kp E (+ Ki int E)) / K_e per axis, K_e = 1 on the motion axes."""
    return _servo(acc, E, Ed, gains, int_E) / K_e


def axis_gains(gains_T, gains_N, axes):
    """ServoGains over all m task axes: gains_T on the motion axes, gains_N on the force axes, each
    given per axis of its subspace or per all m axes (entries off the subspace ignored); None when the
    subspace is empty."""
    m = axes.shape[0]
    out = [np.zeros(m), np.zeros(m), np.zeros(m)]
    for name, gains, subspace in (('gains_T', gains_T, ~axes), ('gains_N', gains_N, axes)):
        k = int(np.count_nonzero(subspace))
        if not k:
            continue
        if gains is None:
            raise ArgumentError(name, f'gains required for {k} axes')
        size = k if np.size(getattr(gains, 'kp', ())) == k and k != m else m
        g = servo_gains(name, gains, size)
        for full, part in zip(out, (g.kp, g.kv, g.ki)):
            full[subspace] = part if size == k else part[subspace]
    return ServoGains._of_checked(*out)


def _stiffness(axes, K_e):
    """The diagonal of K_e over all m axes: K_e on the force axes (> 0), 1 on the motion axes."""
    if not (K_e[axes] > 0.0).all():
        raise ArgumentError('K_e', f'expected positive stiffness on the force axes, got {K_e.tolist()}')
    return np.where(axes, K_e, 1.0)


def hybrid_error(x, x_d, f, f_d, force_axes):
    """E (m,): E_T = x_d - x on the motion axes, E_N = f_d - f on the force axes (m and N)."""
    x = validation.vector('x', x)
    x_d, f, f_d = validation.vectors(x.shape[0], x_d=x_d, f=f, f_d=f_d)
    return np.where(validation.bool_mask('force_axes', force_axes, x.shape[0]), f_d - f, x_d - x)


def hybrid_servo(x, xd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, force_axes, K_e, gains_T, gains_N, int_E=None):
    """F' (m,) in m/s^2: F_T = xdd_d + K_Tv Ed_T + K_Tp E_T (+ K_Ti int E_T), F_N = K_e^-1 (fdd_d + ...).

    All task vectors (m,) (entries of the other subspace ignored but must be finite; a position task
    space: E = x_d - x, for orientation axes use hybrid(), which asks the model); K_e in N/m,
    scalar or (m,); gains_T / gains_N: kp, kv, ki per selected axis or per all m axes (None when that
    subspace is empty); int_E (m,) the integral of hybrid_error().
    """
    x = validation.vector('x', x)
    m = x.shape[0]
    xd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot = validation.vectors(
        m, xd=xd, x_d=x_d, xd_d=xd_d, xdd_d=xdd_d, f_d=f_d, fd_d=fd_d, fdd_d=fdd_d, f=f, fdot=fdot)
    axes = validation.bool_mask('force_axes', force_axes, m)
    K_e = _stiffness(axes, validation.per_entry('K_e', K_e, m))
    gains = axis_gains(gains_T, gains_N, axes)
    int_E = validation.optional_vector('int_E', int_E, m)
    force = np.flatnonzero(axes)
    acc, E, Ed = _hybrid_errors(x_d - x, xd, xd_d, xdd_d, f[force], fdot[force], f_d[force], fd_d[force],
                                fdd_d[force], force)
    return validation.result('F', _hybrid_servo(acc, E, Ed, gains, K_e, int_E))


def hybrid(model, q, qd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, force_axes, K_e, gains_T, gains_N,
           q_posture=None, k_posture=(25.0, 10.0), int_E=None):
    """tau (n,) = J^T (Lambda F' + mu + p + f_e) + N^T tau_0: hybrid position/force control.

    x = fk(q), xd = J qd; F' as hybrid_servo(); f_e = f on the force axes, 0 elsewhere; the
    posture qdd_0 = Kp0 (q_posture - q) - Kv0 qd (k_posture = (Kp0, Kv0); q_posture None: damping
    only) acts in the null space of redundant arms (m < n). Units: m, N, s; f signed (module doc).
    """
    n, m = model.n, model.task_dim
    q, qd = validation.vectors(n, q=q, qd=qd)
    x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot = validation.vectors(
        m, x_d=x_d, xd_d=xd_d, xdd_d=xdd_d, f_d=f_d, fd_d=fd_d, fdd_d=fdd_d, f=f, fdot=fdot)
    axes = validation.bool_mask('force_axes', force_axes, m)
    K_e = _stiffness(axes, validation.per_entry('K_e', K_e, m))
    gains = axis_gains(gains_T, gains_N, axes)
    q_posture = q if q_posture is None else validation.vector('q_posture', q_posture, n)
    kp0, kv0 = posture_gains(k_posture, n)
    int_E = validation.optional_vector('int_E', int_E, m)
    x, J, Jdot_qd = model._task(q, qd)
    check_task_dimension(J)
    Lambda = _task_inertia(model, q, J)
    force = np.flatnonzero(axes)
    acc, E, Ed = _hybrid_errors(model._task_difference(x_d, x), J @ qd, xd_d, xdd_d, f[force], fdot[force],
                                f_d[force], fd_d[force], fdd_d[force], force)
    F = validation.result('F', _hybrid_servo(acc, E, Ed, gains, K_e, int_E))
    qdd_0 = _posture_acceleration(q, qd, q_posture, kp0, kv0)
    return validation.result('tau', _operational_space(model, q, qd, J, Jdot_qd, F, np.where(axes, f, 0.0), qdd_0,
                                                       Lambda))


@dataclasses.dataclass(frozen=True)
class HybridParams:
    """The hybrid law's parameters: its motion servo's gains (robot_control.laws.servo.MotionServo), its force
    setup with the force servo's gains (robot_control.laws.force_task.ForceTask) and its null-space posture
    (robot_control.laws.operational_space.Posture)."""

    motion_servo: MotionServo = MotionServo()
    force_task: ForceTask = ForceTask()
    posture: Posture = Posture()


class Hybrid(Law):
    """The registry's 'hybrid': motion axes follow fk of the joint reference, force axes the force
    reference; the joint reference is also the null-space posture target."""

    name = 'hybrid'
    tracks = 'task'
    needs_task_space = True
    parts = (MotionServo, ForceTask, Posture)
    Params = HybridParams

    def __init__(self, config):
        super().__init__(config)
        task = self.force_task
        model, m, k = self.model, self.model.task_dim, len(task.force_axes)
        check_law_fits(self.name, model)
        self.axes = task.mask
        self.force = np.flatnonzero(self.axes)                 # the force axes' indices among the task axes
        self._zeros = np.zeros(m)
        self._zeros.flags.writeable = False
        self._no_force = (self._zeros[:0],) * 5                 # f, fdot, f_d, fd_d, fdd_d without force axes
        motion, gains = m - k, self.motion_gains
        if motion and getattr(gains, 'n', None) not in (m, motion):
            raise ArgumentError('kp', f'expected {m} gains (one per task axis) or {motion} (one per motion axis) '
                                      f'for law hybrid, got {getattr(gains, "n", gains)}')
        self.gains = axis_gains(gains if motion else None, task.gains, self.axes)
        K_e = np.ones(m)
        K_e[self.axes] = task.k_e
        self.K_e = K_e
        self.kp0, self.kv0 = config.law_params.posture.gains(model.n)

    @classmethod
    def servo_sizes(cls, model, force_axes):
        """One per task axis (designed), or one per motion axis."""
        m, k = model.task_dim, len(force_axes)
        return (m, m - k) if 0 < k < m else (m,)

    @property
    def integral_dim(self):
        return self.model.task_dim

    @property
    def reference_names(self):
        return self.model.task_axes

    def integral_gains(self):
        m = self.model.task_dim
        if not self.config.integral:
            return np.zeros(m), np.zeros(m)
        return self.gains.ki.copy(), self.gains.kv.copy()

    def errors(self, state, ref):
        """Motion axes: the task target (~/target_pose) once one came, else the joint reference in the task
        space, x_d = fk(q_d), xd_d = J(q_d) qd_d, xdd_d = J(q_d) qdd_d + Jdot qd_d; force axes: the force
        reference; then the errors of _hybrid_errors (force: f_e, the measured force on the force axes)."""
        force = self.force
        target = ref.target
        x_d, xd_d, xdd_d = target if target is not None else self.model._task_motion(ref.q_d, ref.qd_d, ref.qdd_d)
        f, fdot, f_d, fd_d, fdd_d = (state.f, state.fdot, ref.f_d, ref.fd_d, ref.fdd_d) if force.size else \
            self._no_force
        acc, E, Ed = _hybrid_errors(self.model._task_difference(x_d, state.x), state.xd, xd_d, xdd_d, f, fdot,
                                    f_d, fd_d, fdd_d, force)
        return Errors((_on_axes(x_d, force, f_d), _on_axes(xd_d, force, fd_d), acc), E, Ed,
                      _on_axes(self._zeros, force, f))

    def torque(self, state, ref, err, int_E):
        Lambda = _task_inertia(self.model, state.q, state.J)
        F = _hybrid_servo(err.ref[2], err.E, err.Ed, self.gains, self.K_e, int_E)
        qdd_0 = _posture_acceleration(state.q, state.qd, ref.q_d, self.kp0, self.kv0)
        return _operational_space(self.model, state.q, state.qd, state.J, state.Jdot_qd, F, err.force, qdd_0, Lambda)

    def integral_map(self, state, ref, err):
        """B = J^T Lambda diag(ki / K_e): the integral enters F' as Ki int E / K_e."""
        Lambda = _task_inertia(self.model, state.q, state.J)
        return (state.J.T @ Lambda) * (self.gains.ki / self.K_e)

    def freeze(self, E, saturated, tau):
        """The task-space integral drives every joint: hold it whole while any joint saturates."""
        return np.full(self.integral_dim, bool(saturated.any()))
