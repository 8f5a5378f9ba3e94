"""Classical independent-joint PID (lecture 2.1): each joint a SISO servo, no model.

The gains here are torque gains (N m/rad, N m s/rad, N m/(rad s)), not the 1/s^2 ... of the
computed-torque servo: without the model there is no unit mass to normalise by.
"""
from robot_control import validation
from robot_control.laws.servo import check_finite, gain_arrays


def independent_joint(q, qd, q_d, qd_d, gains, int_E=None):
    """tau = Kp E + Kv Ed + Ki int_E per joint; E = q_d - q, Ed = qd_d - qd, all (n,)."""
    q = validation.vector('q', q)
    n = q.shape[0]
    E = validation.vector('q_d', q_d, n) - q
    Ed = validation.vector('qd_d', qd_d, n) - validation.vector('qd', qd, n)
    kp, kv, ki = gain_arrays(gains, n)
    tau = kp * E + kv * Ed
    if int_E is not None:
        tau = tau + ki * validation.vector('int_E', int_E, n)
    return check_finite('tau', tau)
