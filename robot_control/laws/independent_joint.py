"""Classical independent-joint PID (lecture 2.1): each joint a SISO servo, no model.

The gains here are torque gains (N m/rad, N m s/rad, N m/(rad s)), not the 1/s^2 ... of the
computed-torque servo: without the model there is no unit mass to normalise by.
"""
import numpy as np

from robot_control import validation
from robot_control.laws.base import Law
from robot_control.laws.servo import MotionServo, MotionServoParams, servo_gains


def _independent_joint(E, Ed, gains, int_E=None):
    """tau = Kp E + Kv Ed (+ Ki int E) per joint; checked (n,) arrays."""
    tau = gains.kp * E + gains.kv * Ed
    if int_E is not None:
        tau = tau + gains.ki * int_E
    return tau


def independent_joint(q, qd, q_d, qd_d, gains, int_E=None):
    """tau = Kp E + Kv Ed + Ki int_E per joint; E = q_d - q, Ed = qd_d - qd, all (n,).

    ArgumentError naming the first bad argument, or `tau` when finite inputs overflow."""
    q_d = validation.vector('q_d', q_d)
    n = q_d.shape[0]
    q, qd, qd_d = validation.vectors(n, q=q, qd=qd, qd_d=qd_d)
    gains = servo_gains('gains', gains, n)
    int_E = validation.optional_vector('int_E', int_E, n)
    return validation.result('tau', _independent_joint(q_d - q, qd_d - qd, gains, int_E))


class IndependentJoint(Law):
    """The registry's 'independent_joint': the joint reference, torque gains, no model."""

    name = 'independent_joint'
    parts = (MotionServo,)
    Params = MotionServoParams
    torque_gains = True

    def __init__(self, config):
        super().__init__(config)
        self.gains = self.motion_gains
        self.check_servo_gains('kp', self.gains, self.model.n)

    def torque(self, state, ref, err, int_E):
        return _independent_joint(err.E, err.Ed, self.gains, int_E)

    def integral_map(self, state, ref, err):
        """B = diag(ki)."""
        return np.diag(self.gains.ki)
