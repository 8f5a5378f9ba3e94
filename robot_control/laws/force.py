"""1-DOF force control (lecture section 3) and the spring model of the environment.

Plant: m xdd + f = tau, f = k_e (x - x_e) the force the robot exerts on the environment
(> 0 when pressing in +x). Law: tau = alpha v + beta with alpha = m, beta = f and the force servo
v = (1/k_e)(fdd_d + kv Ef_dot + kp Ef), Ef = f_d - f; with fdd = k_e xdd the closed loop is
Ef'' + kv Ef' + kp Ef = 0.
"""
import dataclasses

import numpy as np

from robot_control import validation
from robot_control.laws.base import Errors, Law
from robot_control.laws.force_task import ForceTask
from robot_control.laws.servo import _servo, servo_gains
from robot_control.validation import ArgumentError


def _force_1dof(m, f, fdd_d, Ef, Ef_dot, k_e, gains, int_Ef=None):
    """tau = m v + f,  v = (1/k_e)(fdd_d + kv Ef_dot + kp Ef (+ ki int Ef)); checked (1,) arrays."""
    v = _servo(fdd_d, Ef, Ef_dot, gains, int_Ef) / k_e
    return m * v + f


def force_1dof(m, f, fdot, f_d, fd_d, fdd_d, k_e, gains, int_Ef=None):
    """tau = m v + f, v = (fdd_d + kv (fd_d - fdot) + kp (f_d - f) + ki int_Ef) / k_e; returns (1,) N.

    m in kg (> 0), forces in N, rates in N/s and N/s^2, k_e in N/m (> 0); gains kp, kv, ki each (1,).
    ArgumentError naming the first bad argument."""
    m = validation.scalar('m', m, positive=True)
    k_e = validation.scalar('k_e', k_e, positive=True)
    f, fdot, f_d, fd_d, fdd_d = validation.vectors(1, f=f, fdot=fdot, f_d=f_d, fd_d=fd_d, fdd_d=fdd_d)
    gains = servo_gains('gains', gains, 1)
    int_Ef = validation.optional_vector('int_Ef', int_Ef, 1)
    return validation.result('tau', _force_1dof(m, f, fdd_d, f_d - f, fd_d - fdot, k_e, gains, int_Ef))


def _spring_force(x, xd, x_e, k_e, sign):
    """f = k_e (x - x_e), fdot = k_e xd where in contact (sign 0: everywhere; +1 / -1: where
    sign (x - x_e) > 0), 0 elsewhere; checked (k,) arrays."""
    f, fdot = k_e * (x - x_e), k_e * xd
    if np.isscalar(sign) and sign == 0.0:        # the bilateral spring: in contact everywhere
        return f, fdot
    contact = (sign == 0.0) | (sign * (x - x_e) > 0.0)
    return np.where(contact, f, 0.0), np.where(contact, fdot, 0.0)


def spring_force(x, xd, x_e, k_e, sign=0.0):
    """Model feedback (lecture 3.1): f = k_e (x - x_e), fdot = k_e xd, elementwise over (k,) axes.

    x, xd in m and m/s; x_e (m) and k_e (N/m, > 0) scalars or (k,). sign = 0: the lecture's
    bilateral spring; sign = +1 / -1: a unilateral contact pressed by moving in +x / -x, f and fdot
    are zero where sign (x - x_e) <= 0. f is signed along the axis (pressing in -x gives f < 0).
    """
    x = validation.vector('x', x)
    k = x.shape[0]
    xd = validation.vector('xd', xd, k)
    x_e = validation.per_entry('x_e', x_e, k)
    k_e = validation.per_entry('k_e', k_e, k)
    if not np.all(k_e > 0.0):
        raise ArgumentError('k_e', f'expected positive stiffness, got {k_e.tolist()}')
    sign = validation.per_entry('sign', sign, k)
    if not np.all(np.isin(sign, (-1.0, 0.0, 1.0))):
        raise ArgumentError('sign', f'expected -1, 0 or +1 per axis, got {sign.tolist()}')
    f, fdot = _spring_force(x, xd, x_e, k_e, sign)
    return validation.result('f', f), validation.result('fdot', fdot)


@dataclasses.dataclass(frozen=True)
class ForceParams:
    """The force law's parameters: its force setup with the force servo's gains
    (robot_control.laws.force_task.ForceTask)."""

    force_task: ForceTask = ForceTask()


class Force(Law):
    """The registry's 'force': the lecture's 1-DOF force servo on the model's one task axis."""

    name = 'force'
    tracks = 'task'
    needs_task_space = True
    parts = (ForceTask,)
    Params = ForceParams

    def __init__(self, config):
        super().__init__(config)
        model = self.model
        if model.n != 1 or model.task_dim != 1:
            raise ArgumentError('law', f'force is the 1-DOF force servo; the model has {model.n} joints and '
                                       f'{model.task_dim} task axes (use hybrid)')
        task = self.force_task
        if len(task.force_axes) != 1:
            raise ArgumentError('force_axes', f'law force needs its task axis {list(model.task_axes)}, '
                                              f'got {list(task.force_axes)}')
        self.k_e = float(task.k_e[0])
        self.gains = task.gains

    @property
    def integral_dim(self):
        return 1

    @property
    def reference_names(self):
        return self.force_task.force_axes

    def integral_gains(self):
        if not self.config.integral:
            return np.zeros(1), np.zeros(1)
        return np.array(self.gains.ki), np.array(self.gains.kv)

    def errors(self, state, ref):
        np.subtract(ref.f_d, state.f, out=self.E)
        np.subtract(ref.fd_d, state.fdot, out=self.Ed)
        return Errors((ref.f_d, ref.fd_d, ref.fdd_d), self.E, self.Ed)

    def torque(self, state, ref, err, int_E):
        m = self.model._M(state.q)[0, 0]
        return _force_1dof(m, state.f, ref.fdd_d, err.E, err.Ed, self.k_e, self.gains, int_E)

    def integral_map(self, state, ref, err):
        """B = m ki / k_e, (1, 1)."""
        return self.model._M(state.q) * (self.gains.ki / self.k_e)
