"""1-DOF force control (lecture section 3) and the spring model of the environment.

Plant: m xdd + f = tau, f = k_e (x - x_e) the force the robot exerts on the environment
(> 0 when pressing in +x). Law: tau = alpha v + beta with alpha = m, beta = f and the force servo
v = (1/k_e)(fdd_d + kv Ef_dot + kp Ef), Ef = f_d - f; with fdd = k_e xdd the closed loop is
Ef'' + kv Ef' + kp Ef = 0.
"""
import math

import numpy as np

from robot_control import validation
from robot_control.laws.servo import check_finite, per_entry, servo, servo_gains
from robot_control.validation import ArgumentError, all_finite, finite, is_vector


def force_1dof(m, f, fdot, f_d, fd_d, fdd_d, k_e, gains, int_Ef=None):
    """tau = m v + f, v = (fdd_d + kv (fd_d - fdot) + kp (f_d - f) + ki int_Ef) / k_e; returns (1,) N.

    m in kg (> 0), forces in N, rates in N/s and N/s^2, k_e in N/m (> 0); gains kp, kv, ki each (1,).
    """
    g = servo_gains(gains, 1)
    if (g is not None and isinstance(m, float) and isinstance(k_e, float) and 0.0 < m < math.inf
            and 0.0 < k_e < math.inf and is_vector(f, 1) and is_vector(fdot, 1) and is_vector(f_d, 1)
            and is_vector(fd_d, 1) and is_vector(fdd_d, 1) and (int_Ef is None or is_vector(int_Ef, 1))
            and all_finite(f, fdot, f_d, fd_d, fdd_d) and (int_Ef is None or finite(int_Ef))):
        kp, kv, ki = g
        v = fdd_d + kv * (fd_d - fdot) + kp * (f_d - f)
        if int_Ef is not None:
            v = v + ki * int_Ef
        tau = m * (v / k_e) + f
        if finite(tau):  # else an overflow: the checked path names it
            return tau
    return _force_1dof_checked(m, f, fdot, f_d, fd_d, fdd_d, k_e, gains, int_Ef)


def _force_1dof_checked(m, f, fdot, f_d, fd_d, fdd_d, k_e, gains, int_Ef):
    m = validation.scalar('m', m, positive=True)
    k_e = validation.scalar('k_e', k_e, positive=True)
    f = validation.vector('f', f, 1)
    Ef = validation.vector('f_d', f_d, 1) - f
    Ef_dot = validation.vector('fd_d', fd_d, 1) - validation.vector('fdot', fdot, 1)
    if int_Ef is not None:
        int_Ef = validation.vector('int_Ef', int_Ef, 1)
    v = servo(validation.vector('fdd_d', fdd_d, 1), Ef, Ef_dot, gains, int_Ef) / k_e
    return check_finite('tau', m * v + f)


def spring_force(x, xd, x_e, k_e, sign=0.0):
    """Model feedback (lecture 3.1): f = k_e (x - x_e), fdot = k_e xd, elementwise over (k,) axes.

    x, xd in m and m/s; x_e (m) and k_e (N/m, > 0) scalars or (k,). sign = 0: the lecture's
    bilateral spring; sign = +1 / -1: a unilateral contact pressed by moving in +x / -x, f and fdot
    are zero where sign (x - x_e) <= 0. f is signed along the axis (pressing in -x gives f < 0).
    """
    x = validation.vector('x', x)
    k = x.shape[0]
    xd = validation.vector('xd', xd, k)
    x_e = per_entry('x_e', x_e, k)
    k_e = per_entry('k_e', k_e, k)
    if not np.all(k_e > 0.0):
        raise ArgumentError('k_e', f'expected positive stiffness, got {k_e.tolist()}')
    sign = per_entry('sign', sign, k)
    if not np.all(np.isin(sign, (-1.0, 0.0, 1.0))):
        raise ArgumentError('sign', f'expected -1, 0 or +1 per axis, got {sign.tolist()}')
    contact = (sign == 0.0) | (sign * (x - x_e) > 0.0)
    f = np.where(contact, k_e * (x - x_e), 0.0)
    fdot = np.where(contact, k_e * xd, 0.0)
    return check_finite('f', f), check_finite('fdot', fdot)
