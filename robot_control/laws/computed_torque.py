"""PD/PID computed-torque control (lecture 2.2.2, "Non-linear Control of Robot").

tau = alpha v + beta with alpha = M(q), beta = C(q, qd) qd + g(q) and the servo law
v = qdd_d + Kv Ed + Kp E (+ Ki int E); with a perfect model the closed loop is qdd = v and
every joint obeys e'' + kv e' + kp e (+ ki int e) = 0. M v + C qd + g is the inverse dynamics
at qdd = v: one RNEA call for a URDF model, the lecture's terms for a closed form.
"""
from robot_control import validation
from robot_control.laws.base import Law
from robot_control.laws.servo import MotionServo, MotionServoParams, _servo, servo_gains


def _computed_torque(model, q, qd, qdd_d, E, Ed, gains, int_E=None):
    """tau = M(q) v + C(q, qd) qd + g(q),  v = qdd_d + Kv Ed + Kp E (+ Ki int E); checked (n,) arrays."""
    v = _servo(qdd_d, E, Ed, gains, int_E)
    return model._inverse_dynamics(q, qd, v)


def computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains, int_E=None):
    """tau = M(q) v + C(q, qd) qd + g(q), v = qdd_d + Kv Ed + Kp E + Ki int_E, E = q_d - q, Ed = qd_d - qd.

    Vectors (n,), SI units; gains: ServoGains (1/s^2, 1/s, 1/s^3). ArgumentError naming the first bad
    argument, or `tau` when finite inputs overflow."""
    q, qd, q_d, qd_d, qdd_d = validation.vectors(model.n, q=q, qd=qd, q_d=q_d, qd_d=qd_d, qdd_d=qdd_d)
    gains = servo_gains('gains', gains, model.n)
    int_E = validation.optional_vector('int_E', int_E, model.n)
    return validation.result('tau', _computed_torque(model, q, qd, qdd_d, q_d - q, qd_d - qd, gains, int_E))


class ComputedTorque(Law):
    """The registry's 'computed_torque': the joint reference, Kp, Kv, Ki in 1/s^2, 1/s, 1/s^3."""

    name = 'computed_torque'
    parts = (MotionServo,)
    Params = MotionServoParams

    def __init__(self, config):
        super().__init__(config)
        self.gains = self.motion_gains
        self.check_servo_gains('kp', self.gains, self.model.n)

    def torque(self, state, ref, err, int_E):
        return _computed_torque(self.model, state.q, state.qd, ref.qdd_d, err.E, err.Ed, self.gains, int_E)

    def integral_map(self, state, ref, err):
        """B = M(q) diag(ki): the integral enters as M Ki int E."""
        return self.model._M(state.q) * self.gains.ki
