"""Closed loops with a perfect model, integrated by fixed-step RK4: the error obeys the designed equation.

The plant is the model's own forward dynamics (plus a disturbance or a contact spring where the
lecture has one); laws are evaluated inside every RK4 stage (continuous-time control) unless a
test says zero-order hold. Critically damped PD (zeta = 1, w_n = 6: kp = 36, kv = 12) has
e(t) = (e0 + (ed0 + w_n e0) t) exp(-w_n t).
"""
import math

import numpy as np
import pytest

from robot_control.gains import ServoGains, design, pd_steady_state_error
from robot_control.laws import Integral, computed_torque, force_1dof, hybrid, spring_force
from robot_control.models import make_model
from support.loops import critically_damped, integrate, joint_space_loop, rk4_step

W_N = 6.0
PD = ServoGains.uniform(2, W_N ** 2, 2 * W_N)
DT = 1e-3


def quintic(q0, q1, T, t):
    """Rest-to-rest quintic from q0 to q1 in T s: (q, qd, qdd) at time t (held after T)."""
    s = min(max(t / T, 0.0), 1.0)
    d = np.asarray(q1) - np.asarray(q0)
    return (q0 + d * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5), d * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / T,
            d * (60 * s - 180 * s ** 2 + 120 * s ** 3) / T ** 2)


def sinusoid(center, amp, w, t):
    """center + amp sin(w t) and its two derivatives."""
    return (center + amp * np.sin(w * t), amp * w * np.cos(w * t), -amp * w * w * np.sin(w * t))


REFERENCES = {
    'polar_two_link': lambda t: tuple(np.array(a) for a in zip(quintic(0.2, 1.2, 2.0, t),
                                                              sinusoid(0.6, 0.15, 2.0, t))),
    'planar_two_link': lambda t: tuple(np.array(a) for a in zip(sinusoid(0.3, 0.5, 1.5, t),
                                                               quintic(0.8, 1.6, 1.5, t))),
}


@pytest.mark.parametrize('name', sorted(REFERENCES))
def test_pd_computed_torque_error_is_the_critically_damped_solution(name):
    model, reference = make_model(name), REFERENCES[name]
    e0, ed0 = np.array([0.05, -0.04]), np.array([0.3, 0.2])
    q_d0, qd_d0, _ = reference(0.0)
    ts, ys = integrate(joint_space_loop(model, reference, PD), np.concatenate([q_d0 - e0, qd_d0 - ed0]), 3.0)
    E = np.array([reference(t)[0] for t in ts]) - ys[:, :2]
    err = np.max(np.abs(E - critically_damped(e0, ed0, W_N, ts)))
    assert err < 1e-6, f'max |e - e_analytic| = {err:.3g}'
    assert np.max(np.abs(E)) > 0.04  # the error was there to decay


def disturbed_1dof_zoh(gains, d, t_end, model):
    """m xdd + b xd + k x^3 + d = tau, tau held over each 1 ms step; the integral by Integral (Euler)."""
    integ, y, x_d = Integral(1), np.array([0.2, 0.0]), np.array([0.2])
    zero = np.zeros(1)
    for _ in range(int(round(t_end / DT))):
        q, qd = y[:1], y[1:]
        tau = computed_torque(model, q, qd, x_d, zero, zero, gains, integ.value)
        y = rk4_step(lambda t, s: np.concatenate([s[1:], model.forward_dynamics(s[:1], s[1:], tau - d)]), 0.0, y, DT)
        integ.update(x_d - y[:1], DT)
    return (x_d - y[:1])[0]


def test_pd_steady_state_error_under_constant_disturbance_is_d_over_m_kp():
    model, d = make_model('mass_spring_cubic', m=2.0, b=0.5, k=100.0), 3.0
    e_ss = disturbed_1dof_zoh(ServoGains.uniform(1, 36.0, 12.0), d, 6.0, model)
    predicted = pd_steady_state_error(d, 2.0, 36.0)
    assert predicted == pytest.approx(d / (2.0 * 36.0))
    assert e_ss == pytest.approx(predicted, rel=0.01)


def test_pid_drives_the_constant_disturbance_error_to_zero():
    model, d = make_model('mass_spring_cubic', m=2.0, b=0.5, k=100.0), 3.0
    dsg = design(zeta=1.0, omega_n=W_N, integral=True)
    roots = np.roots([1.0, dsg.kv, dsg.kp, dsg.ki])  # s^3 + kv s^2 + kp s + ki: triple root at -w_n
    np.testing.assert_allclose(roots.real, -W_N, atol=1e-3)
    e_ss = disturbed_1dof_zoh(dsg.gains(1), d, 8.0, model)
    assert abs(e_ss) < 1e-6, e_ss


def _cubic_loop(model, law):
    reference = lambda t: tuple(np.array([a]) for a in sinusoid(0.0, 0.5, 2.0, t))  # noqa: E731

    def rhs(t, y):
        tau = law(y[:1], y[1:], *reference(t))
        return np.concatenate([y[1:], model.forward_dynamics(y[:1], y[1:], tau)])
    ts, ys = integrate(rhs, np.array([0.0, 1.0]), 4.0)
    return np.max(np.abs(np.array([reference(t)[0][0] for t in ts]) - ys[:, 0]))


def test_partitioned_law_makes_the_cubic_spring_a_unit_mass_and_linear_pd_does_not():
    """alpha = m, beta = b xd + k x^3: a sine is tracked exactly; a PD without k x^3 lags visibly."""
    model = make_model('mass_spring_cubic', m=1.0, b=0.5, k=100.0)
    g1 = ServoGains.uniform(1, 36.0, 12.0)
    partitioned = _cubic_loop(model, lambda q, qd, *ref: computed_torque(model, q, qd, *ref, g1))

    def linear_pd(q, qd, q_d, qd_d, qdd_d):  # alpha = m, beta = b xd: the cubic spring left uncancelled
        return model.m * (qdd_d + 12.0 * (qd_d - qd) + 36.0 * (q_d - q)) + model.b * qd
    linear = _cubic_loop(model, linear_pd)
    assert partitioned < 1e-6, partitioned
    assert linear > 1e-2, linear


def test_force_1dof_error_obeys_ef_dd_plus_kv_ef_d_plus_kp_ef():
    """m xdd + f = tau, f = k_e (x - x_e) (in contact), f_d(t) = 10 + 2 sin 3t: e_f is critically damped."""
    m, k_e, x_e = 1.5, 1000.0, 0.1
    g1 = ServoGains.uniform(1, 36.0, 12.0)
    f_ref = lambda t: sinusoid(10.0, 2.0, 3.0, t)  # noqa: E731

    def rhs(t, y):
        f, fdot = spring_force(y[:1], y[1:], x_e, k_e)
        tau = force_1dof(m, f, fdot, *f_ref(t), k_e, g1)
        return np.array([y[1], (tau[0] - f[0]) / m])
    y0 = np.array([0.105, 0.0])
    ts, ys = integrate(rhs, y0, 3.0)
    Ef = np.array([f_ref(t)[0] for t in ts]) - k_e * (ys[:, 0] - x_e)
    ef0, efd0 = f_ref(0.0)[0] - 5.0, f_ref(0.0)[1] - 0.0
    err = np.max(np.abs(Ef - critically_damped(np.array([ef0]), np.array([efd0]), W_N, ts)[:, 0]))
    assert err < 1e-6, f'max |e_f - analytic| = {err:.3g} N'


# -- hybrid on the lecture's Cartesian robots --------------------------------------------------
HYBRID = {  # model, force axis, x_e on that axis, k_e, start q0
    'cartesian_xy': (np.array([True, False]), 0.3, 1000.0, np.array([0.305, 0.0])),
    'cartesian_xyz': (np.array([False, True, False]), 0.3, 1000.0, np.array([0.0, 0.305, 0.1])),
}
G_T, G_N = 36.0, 400.0  # motion w_n = 6, force w_n = 20 (critically damped)


def hybrid_run(name, x_ref, f_ref, t_end=2.0):
    """Closed loop M qdd + g + f_e = tau, f_e = k_e (x_N - x_e) on the force axis: (t, q, f on that axis)."""
    axes, x_e, k_e, q0 = HYBRID[name]
    model = make_model(name)
    m = model.n
    gT, gN = ServoGains.uniform(m, G_T, 2 * math.sqrt(G_T)), ServoGains.uniform(m, G_N, 2 * math.sqrt(G_N))

    def rhs(t, y):
        q, qd = y[:m], y[m:]
        f, fdot = spring_force(q, qd, x_e, k_e)
        f, fdot = np.where(axes, f, 0.0), np.where(axes, fdot, 0.0)
        tau = hybrid(model, q, qd, *x_ref(t), *f_ref(t), f, fdot, axes, k_e, gT, gN)
        return np.concatenate([qd, model.forward_dynamics(q, qd, tau - f)])  # J = I: J^T f_e = f_e
    ts, ys = integrate(rhs, np.concatenate([q0, np.zeros(m)]), t_end, dt=2e-3)
    return ts, ys[:, :m], k_e * (ys[:, np.argmax(axes)] - x_e)


def _x_ref(name, step=0.0):
    q0 = HYBRID[name][3]
    goal = q0 + np.where(HYBRID[name][0], 0.0, 0.2)

    def ref(t):
        x, xd, xdd = quintic(q0, goal, 1.5, t)
        return x + (step if t >= 1.0 else 0.0) * ~HYBRID[name][0], xd, xdd
    return ref


def _f_ref(m, step=0.0):
    return lambda t: (np.full(m, 10.0 + (step if t >= 1.0 else 0.0)), np.zeros(m), np.zeros(m))


@pytest.mark.parametrize('name', sorted(HYBRID))
def test_hybrid_force_and_motion_subspaces_do_not_interfere(name):
    axes = HYBRID[name][0]
    m = axes.shape[0]
    ts, q_a, f_a = hybrid_run(name, _x_ref(name), _f_ref(m))
    _, q_b, f_b = hybrid_run(name, _x_ref(name), _f_ref(m, step=5.0))  # a step in the force reference
    _, q_c, f_c = hybrid_run(name, _x_ref(name, step=0.05), _f_ref(m))  # a step in the motion reference
    assert np.max(np.abs(f_b - f_a)) > 4.0 and np.max(np.abs(q_c - q_a)[:, ~axes]) > 0.04  # the steps acted
    assert np.max(np.abs(q_b - q_a)[:, ~axes]) < 1e-9  # motion axes unchanged by the force step
    assert np.max(np.abs(f_c - f_a)) < 1e-9  # force unchanged by the motion step
    # and each subspace follows its own error equation: motion tracked from zero error, force from 5 N off
    x_d = np.array([_x_ref(name)(t)[0] for t in ts])
    assert np.max(np.abs(x_d - q_a)[:, ~axes]) < 1e-6
    e_f = critically_damped(np.array([5.0]), np.array([0.0]), math.sqrt(G_N), ts)[:, 0]
    assert np.max(np.abs((10.0 - f_a) - e_f)) < 1e-6


def _pid_loop(reference, gains):
    """y = [q, qd, int E] of a unit mass under the PID servo v = qdd_d + Kv Ed + Kp E + Ki int E."""
    def rhs(t, y):
        q_d, qd_d, qdd_d = reference(t)
        E, Ed = q_d - y[0], qd_d - y[1]
        return np.array([y[1], qdd_d + gains.kv[0] * Ed + gains.kp[0] * E + gains.ki[0] * y[2], E])
    return rhs


@pytest.mark.parametrize('zeta, overshoot', [(1.0, 0.249), (1.5, 0.173), (2.0, 0.136)])
def test_pid_set_point_step_overshoots_through_the_integral_zero_and_a_smooth_reference_does_not(zeta, overshoot):
    """The designed PID (real poles at -w_n twice and -w_n) has the zero -ki/kp = -w_n / (1 + 2 zeta)
    from the set point: a step of q_d from rest overshoots (about 25 % at zeta = 1) although no pole
    is complex. The demo's quintic moves (robot_control.trajectory) follow without overshoot."""
    g = design(zeta, 12.0, integral=True).gains(1)
    assert -g.ki[0] / g.kp[0] == pytest.approx(-W_N / (1 + 2 * zeta))
    _, step = integrate(_pid_loop(lambda t: (1.0, 0.0, 0.0), g), [0.0, 0.0, 0.0], 3.0, dt=1e-4)
    assert step[:, 0].max() - 1.0 == pytest.approx(overshoot, abs=0.002)
    _, smooth = integrate(_pid_loop(lambda t: tuple(np.atleast_1d(a)[0] for a in quintic(0.0, 1.0, 1.0, t)), g),
                          [0.0, 0.0, 0.0], 3.0, dt=1e-4)
    assert smooth[:, 0].max() - 1.0 < 1e-9 and smooth[-1, 0] == pytest.approx(1.0, abs=1e-9)
