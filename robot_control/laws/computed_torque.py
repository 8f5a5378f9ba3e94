"""PD/PID computed-torque control (lecture 2.2.2, "Non-linear Control of Robot").

tau = alpha v + beta with alpha = M(q), beta = C(q, qd) qd + g(q) and the servo law
v = qdd_d + Kv Ed + Kp E (+ Ki int E); with a perfect model the closed loop is qdd = v and
every joint obeys e'' + kv e' + kp e (+ ki int e) = 0. M v + C qd + g is the inverse dynamics
at qdd = v: one RNEA call for a URDF model, a few float operations for a closed form.
"""
from robot_control import validation
from robot_control.laws.servo import check_finite, servo, servo_gains
from robot_control.validation import all_finite, finite, is_vector


def computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains, int_E=None):
    """tau = M(q) v + C(q, qd) qd + g(q), v = qdd_d + Kv Ed + Kp E + Ki int_E; vectors (n,), SI units."""
    n = model.n
    g = servo_gains(gains, n)
    if (g is not None and is_vector(q, n) and is_vector(qd, n) and is_vector(q_d, n) and is_vector(qd_d, n)
            and is_vector(qdd_d, n) and (int_E is None or is_vector(int_E, n))
            and all_finite(q, qd, q_d, qd_d, qdd_d) and (int_E is None or finite(int_E))):
        tau = torque_of_errors(model, q, qd, qdd_d, q_d - q, qd_d - qd, g, int_E)
        if tau is not None:
            return tau
    return _computed_torque_checked(model, q, qd, q_d, qd_d, qdd_d, gains, int_E)


def torque_of_errors(model, q, qd, qdd_d, E, Ed, gains, int_E=None):
    """The law on checked arrays and errors E = q_d - q, Ed = qd_d - qd, gains (kp, kv, ki): M v + C qd + g,
    v = qdd_d + Kv Ed + Kp E (+ Ki int_E); None when v or tau is not finite (an overflow: the checked
    law names it)."""
    kp, kv, ki = gains
    v = qdd_d + kv * Ed + kp * E
    if int_E is not None:
        v = v + ki * int_E
    if finite(v):
        tau = model._inverse_dynamics(q, qd, v)
        if finite(tau):
            return tau
    return None


def _computed_torque_checked(model, q, qd, q_d, qd_d, qdd_d, gains, int_E):
    """computed_torque with every argument checked: the ValueError names the first bad one."""
    n = model.n
    q = model.check_q(q)
    qd = validation.vector('qd', qd, n)
    E = validation.vector('q_d', q_d, n) - q
    Ed = validation.vector('qd_d', qd_d, n) - qd
    v = servo(validation.vector('qdd_d', qdd_d, n), E, Ed, gains, int_E)
    return check_finite('tau', model._inverse_dynamics(q, qd, v))
