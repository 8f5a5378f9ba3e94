"""PD/PID computed-torque control (lecture 2.2.2, "Non-linear Control of Robot").

tau = alpha v + beta with alpha = M(q), beta = C(q, qd) qd + g(q) and the servo law
v = qdd_d + Kv Ed + Kp E (+ Ki int E); with a perfect model the closed loop is qdd = v and
every joint obeys e'' + kv e' + kp e (+ ki int e) = 0.
"""
from robot_control import validation
from robot_control.laws.servo import check_finite, servo


def computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains, int_E=None):
    """tau = M(q) v + C(q, qd) qd + g(q), v = qdd_d + Kv Ed + Kp E + Ki int_E; vectors (n,), SI units."""
    n = model.n
    q = model.check_q(q)
    qd = validation.vector('qd', qd, n)
    E = validation.vector('q_d', q_d, n) - q
    Ed = validation.vector('qd_d', qd_d, n) - qd
    v = servo(validation.vector('qdd_d', qdd_d, n), E, Ed, gains, int_E)
    tau = model.M(q) @ v + model.C_qd(q, qd) + model.g(q)
    return check_finite('tau', tau)
