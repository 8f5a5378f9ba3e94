"""Classical independent-joint PID (lecture 2.1): each joint a SISO servo, no model.

The gains here are torque gains (N m/rad, N m s/rad, N m/(rad s)), not the 1/s^2 ... of the
computed-torque servo: without the model there is no unit mass to normalise by.
"""
import numpy as np

from robot_control import validation
from robot_control.laws.servo import check_finite, gain_arrays, servo_gains
from robot_control.validation import all_finite, finite, is_vector


def independent_joint(q, qd, q_d, qd_d, gains, int_E=None):
    """tau = Kp E + Kv Ed + Ki int_E per joint; E = q_d - q, Ed = qd_d - qd, all (n,)."""
    n = q.shape[0] if type(q) is np.ndarray and q.ndim == 1 else -1
    g = servo_gains(gains, n)
    if (g is not None and is_vector(q, n) and is_vector(qd, n) and is_vector(q_d, n) and is_vector(qd_d, n)
            and (int_E is None or is_vector(int_E, n))
            and all_finite(q, qd, q_d, qd_d) and (int_E is None or finite(int_E))):
        kp, kv, ki = g
        tau = kp * (q_d - q) + kv * (qd_d - qd)
        if int_E is not None:
            tau = tau + ki * int_E
        if finite(tau):  # else an overflow: the checked path names it
            return tau
    q = validation.vector('q', q)
    n = q.shape[0]
    E = validation.vector('q_d', q_d, n) - q
    Ed = validation.vector('qd_d', qd_d, n) - validation.vector('qd', qd, n)
    kp, kv, ki = gain_arrays(gains, n)
    tau = kp * E + kv * Ed
    if int_E is not None:
        tau = tau + ki * validation.vector('int_E', int_E, n)
    return check_finite('tau', tau)
