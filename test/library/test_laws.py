"""Control laws against the lecture's formulas, and their input checks."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from robot_control.gains import ServoGains
from robot_control.laws import (Integral, computed_torque, force_1dof, hybrid, hybrid_error, hybrid_servo,
                                independent_joint, operational_space, saturate, servo, spring_force)
from robot_control.models import make_model

RNG = np.random.default_rng(20261123)


# -- the lecture's worked example -------------------------------------------------------------
def test_polar_example_equals_lecture_overall_control_law():
    """m = 2 kg, g = 9.8, kv = 12, kp = 36 (lecture's example), 100 random states, 1e-12:

    tau = [[2r^2, 0], [0, 2]] v + [4 r rd th1d + 19.6 r cos th1, -2 r th1d^2 + 19.6 sin th1].
    """
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    gains = ServoGains.uniform(2, kp=36.0, kv=12.0)
    for _ in range(100):
        q, q_d = RNG.uniform([-np.pi, 0.1], [np.pi, 1.5], (2, 2))
        qd, qd_d, qdd_d = RNG.uniform(-3.0, 3.0, (3, 2))
        th1, r = q
        v = qdd_d + 12.0 * (qd_d - qd) + 36.0 * (q_d - q)
        lecture = (np.array([[2 * r * r, 0.0], [0.0, 2.0]]) @ v
                   + [4 * r * qd[1] * qd[0] + 19.6 * r * math.cos(th1), -2 * r * qd[0] ** 2 + 19.6 * math.sin(th1)])
        tau = computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains)
        np.testing.assert_allclose(tau, lecture, rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(['polar_two_link', 'planar_two_link', 'single_link', 'mass_spring_cubic']),
       st.integers(0, 2 ** 32 - 1))
def test_computed_torque_makes_the_robot_a_unit_mass(name, seed):
    """With the model itself as the plant, forward_dynamics(computed_torque) = v (qdd = v)."""
    model, rng = make_model(name), np.random.default_rng(seed)
    n = model.n
    q, q_d = rng.uniform(0.2, 1.2, (2, n))
    qd, qd_d, qdd_d, int_E = rng.uniform(-2.0, 2.0, (4, n))
    gains = ServoGains(rng.uniform(1, 100, n), rng.uniform(1, 20, n), rng.uniform(0, 50, n))
    tau = computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains, int_E)
    v = servo(qdd_d, q_d - q, qd_d - qd, gains, int_E)
    np.testing.assert_allclose(model.forward_dynamics(q, qd, tau), v, rtol=1e-9, atol=1e-9)


def test_servo_is_the_lecture_pid_servo_law():
    gains = ServoGains([36.0, 49.0], [12.0, 14.0], [8.0, 3.0])
    v = servo([1.0, -2.0], [0.1, 0.2], [-0.3, 0.4], gains, int_E=[0.5, -0.5])
    np.testing.assert_allclose(v, [1.0 + 12 * -0.3 + 36 * 0.1 + 8 * 0.5, -2.0 + 14 * 0.4 + 49 * 0.2 + 3 * -0.5],
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(servo([1.0, -2.0], [0.1, 0.2], [-0.3, 0.4], gains), v - [4.0, -1.5], atol=1e-14)


def test_independent_joint_pid_is_per_joint_kp_e_plus_kv_ed_plus_ki_int_e():
    gains = ServoGains([100.0, 50.0, 20.0], [10.0, 5.0, 2.0], [30.0, 0.0, 1.0])
    q, qd, q_d, qd_d, int_E = RNG.uniform(-1.0, 1.0, (5, 3))
    tau = independent_joint(q, qd, q_d, qd_d, gains, int_E)
    np.testing.assert_allclose(tau, gains.kp * (q_d - q) + gains.kv * (qd_d - qd) + gains.ki * int_E,
                               rtol=0, atol=1e-13)


# -- Integral, saturation ---------------------------------------------------------------------
def test_integral_accumulates_e_dt_and_resets():
    integ = Integral(2)
    integ.update([1.0, -2.0], 0.01)
    integ.update([3.0, 4.0], 0.02)
    np.testing.assert_allclose(integ.value, [0.07, 0.06], atol=1e-15)
    integ.reset()
    np.testing.assert_array_equal(integ.value, [0.0, 0.0])


def test_integral_clamps_each_entry_to_its_limit():
    integ = Integral(3, limit=[0.5, 1.0, np.inf])
    for _ in range(100):
        value = integ.update([10.0, -10.0, 10.0], 0.01)
    np.testing.assert_allclose(value, [0.5, -1.0, 10.0], atol=1e-12)
    integ.update([-10.0, 10.0, 0.0], 0.01)
    np.testing.assert_allclose(integ.value, [0.4, -0.9, 10.0], atol=1e-12)  # leaves the clamp at once


def test_integral_hold_mask_freezes_those_entries():
    integ = Integral(3)
    integ.update([1.0, 1.0, 1.0], 0.1)
    integ.update([1.0, 1.0, 1.0], 0.1, hold=np.array([False, True, False]))
    np.testing.assert_allclose(integ.value, [0.2, 0.1, 0.2], atol=1e-15)


def test_integral_value_cannot_be_mutated_from_outside_and_preset_clamps():
    integ = Integral(2, limit=1.0)
    with pytest.raises(ValueError):
        integ.value[0] = 5.0
    integ.preset([3.0, -0.25])
    np.testing.assert_array_equal(integ.value, [1.0, -0.25])


@pytest.mark.parametrize('call, name', [
    (lambda i: i.update([1.0], 0.1), '^E:'),
    (lambda i: i.update([1.0, np.nan], 0.1), '^E:'),
    (lambda i: i.update([1.0, 1.0], -0.1), '^dt:'),
    (lambda i: i.update([1.0, 1.0], np.inf), '^dt:'),
    (lambda i: i.update([1.0, 1.0], 0.1, hold=[True]), '^hold:'),
    (lambda i: i.update([1.0, 1.0], 0.1, hold=[1, 0]), '^hold:'),
    (lambda i: i.update([1e308, 1.0], 1e10), '^E:'),
])
def test_integral_bad_input_names_the_argument_and_keeps_the_value(call, name):
    integ = Integral(2)
    integ.update([1.0, 2.0], 0.5)
    with pytest.raises(ValueError, match=name):
        call(integ)
    np.testing.assert_array_equal(integ.value, [0.5, 1.0])


@pytest.mark.parametrize('n, limit', [(0, 1.0), (2.0, 1.0), (2, 0.0), (2, -1.0), (2, np.nan), (2, [1.0, 2.0, 3.0])])
def test_integral_bad_construction_names_the_argument(n, limit):
    with pytest.raises(ValueError, match='^(n|limit):'):
        Integral(n, limit)


def test_saturate_clips_and_reports_the_saturated_joints():
    tau, mask = saturate([5.0, -30.0, 2.0], [10.0, 20.0, np.inf])
    np.testing.assert_array_equal(tau, [5.0, -20.0, 2.0])
    np.testing.assert_array_equal(mask, [False, True, False])
    tau, mask = saturate([5.0, -30.0], 4.0)
    np.testing.assert_array_equal(tau, [4.0, -4.0])
    np.testing.assert_array_equal(mask, [True, True])


@pytest.mark.parametrize('tau, limit, name', [
    ([np.nan, 1.0], 1.0, '^tau:'), ([np.inf, 1.0], 1.0, '^tau:'), ([1.0, 1.0], [1.0], '^limit:'),
    ([1.0, 1.0], 0.0, '^limit:'), ([1.0, 1.0], [1.0, np.nan], '^limit:'), ([1.0, 1.0], 'big', '^limit:'),
])
def test_saturate_bad_input_names_the_argument(tau, limit, name):
    with pytest.raises(ValueError, match=name):
        saturate(tau, limit)


# -- force control ----------------------------------------------------------------------------
def test_force_1dof_is_the_lecture_law():
    """tau = m v + f, v = (1/k_e)(fdd_d + kv (fd_d - fdot) + kp (f_d - f) + ki int e_f)."""
    gains = ServoGains([36.0], [12.0], [10.0])
    m, k_e, f, fdot, f_d, fd_d, fdd_d, int_ef = 1.5, 1000.0, 4.0, 30.0, 10.0, 5.0, -2.0, 0.3
    tau = force_1dof(m, f, fdot, f_d, fd_d, fdd_d, k_e, gains, int_ef)
    v = (fdd_d + 12 * (fd_d - fdot) + 36 * (f_d - f) + 10 * int_ef) / k_e
    assert tau.shape == (1,)
    assert tau[0] == pytest.approx(m * v + f, abs=1e-13)


def test_spring_force_model_feedback_and_unilateral_contact():
    f, fdot = spring_force([0.11, 0.09], [0.2, 0.2], 0.1, 1000.0)
    np.testing.assert_allclose(f, [10.0, -10.0], atol=1e-12)
    np.testing.assert_allclose(fdot, [200.0, 200.0], atol=1e-12)
    f, fdot = spring_force([0.11, 0.09, 0.24, 0.26], [0.2, 0.2, -0.1, -0.1], [0.1, 0.1, 0.25, 0.25],
                           [1e3, 1e3, 2e4, 2e4], sign=[1.0, 1.0, -1.0, -1.0])
    np.testing.assert_allclose(f, [10.0, 0.0, -200.0, 0.0], atol=1e-9)  # pressing down gives f < 0
    np.testing.assert_allclose(fdot, [200.0, 0.0, -2000.0, 0.0], atol=1e-9)


# -- hybrid position/force --------------------------------------------------------------------
def _lecture_hybrid(model, q, qd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, axes, k_e, gT, gN):
    """The lecture's Cartesian form: tau = M_x F' + C_x + g_x + f_e, F' = [F_T; F_N] (J = I, X = q)."""
    F = np.where(axes, (fdd_d + gN.kv * (fd_d - fdot) + gN.kp * (f_d - f)) / k_e,
                 xdd_d + gT.kv * (xd_d - qd) + gT.kp * (x_d - q))
    return model.M(q) @ F + model.C_qd(q, qd) + model.g(q) + np.where(axes, f, 0.0)


@pytest.mark.parametrize('name, axes', [('cartesian_xy', [True, False]), ('cartesian_xyz', [False, True, False])])
def test_hybrid_on_cartesian_robots_is_the_lecture_formula(name, axes):
    model, axes = make_model(name), np.array(axes)
    m = model.n
    gT, gN = ServoGains.uniform(m, 36.0, 12.0), ServoGains.uniform(m, 100.0, 20.0)
    for _ in range(50):
        q, qd, x_d, xd_d, xdd_d = RNG.uniform(-1.0, 1.0, (5, m))
        f_d, fd_d, fdd_d, f, fdot = RNG.uniform(-20.0, 20.0, (5, m))
        args = (x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, axes, 1000.0, gT, gN)
        tau = hybrid(model, q, qd, *args)
        # the operational-space evaluation (M^-1, Lambda) reproduces M_x F' + C_x + g_x + f_e to rounding
        np.testing.assert_allclose(tau, _lecture_hybrid(model, q, qd, *args), rtol=1e-13, atol=1e-12)


def test_hybrid_gains_may_be_given_per_selected_axis():
    model, axes = make_model('cartesian_xyz'), np.array([False, True, False])
    q, qd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot = RNG.uniform(-1.0, 1.0, (10, 3))
    args = (x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, axes, 500.0)
    full = hybrid(model, q, qd, *args, ServoGains([36.0, 0.0, 49.0], [12.0, 0.0, 14.0]),
                  ServoGains([0.0, 100.0, 0.0], [0.0, 20.0, 0.0]))
    subset = hybrid(model, q, qd, *args, ServoGains([36.0, 49.0], [12.0, 14.0]), ServoGains([100.0], [20.0]))
    np.testing.assert_array_equal(full, subset)


@pytest.mark.parametrize('name', ['polar_two_link', 'planar_two_link'])
def test_hybrid_on_articulated_arms_gives_task_acceleration_f_prime(name):
    """Closed loop with the model as plant and contact force f_e: J qdd + Jdot qd = F' (Xdd = F')."""
    model, axes = make_model(name), np.array([False, True])
    gT, gN = ServoGains.uniform(2, 36.0, 12.0), ServoGains.uniform(2, 400.0, 40.0)
    for _ in range(50):
        q = RNG.uniform([0.2, 0.4], [1.2, 1.2])
        qd, x_d, xd_d, xdd_d = RNG.uniform(-1.0, 1.0, (4, 2))
        f_d, fd_d, fdd_d, f, fdot = RNG.uniform(-20.0, 20.0, (5, 2))
        args = (x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, axes, 2000.0, gT, gN)
        tau = hybrid(model, q, qd, *args)
        J = model.J(q)
        F = hybrid_servo(model.fk(q), J @ qd, *args)
        qdd = model.forward_dynamics(q, qd, tau - J.T @ np.where(axes, f, 0.0))
        np.testing.assert_allclose(J @ qdd + model.Jdot_qd(q, qd), F, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(operational_space(model, q, qd, F, np.where(axes, f, 0.0)), tau, atol=1e-9)


def test_hybrid_error_picks_position_error_on_motion_axes_and_force_error_on_force_axes():
    E = hybrid_error([1.0, 2.0, 3.0], [1.5, 2.5, 3.5], [10.0, 20.0, 30.0], [11.0, 22.0, 33.0], [False, True, False])
    np.testing.assert_allclose(E, [0.5, 2.0, 0.5])


def test_hybrid_rejects_a_singular_jacobian():
    model = make_model('planar_two_link')
    g = ServoGains.uniform(2, 36.0, 12.0)
    with pytest.raises(ValueError, match='^q: task Jacobian singular'):
        hybrid(model, [0.3, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0] * 2, [0.0] * 2, [0.0] * 2, [0.0] * 2,
               [0.0] * 2, [0.0] * 2, [0.0] * 2, [False, False], 1.0, g, None)


# -- bad input: ValueError naming the argument; never a non-finite torque ---------------------
G2 = ServoGains.uniform(2, 36.0, 12.0)
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
OK2 = [0.3, 0.5]


@pytest.mark.parametrize('kwargs, name', [
    ({'q': [0.3]}, '^q:'), ({'q': [0.3, np.nan]}, '^q:'), ({'qd': [0.0, np.inf]}, '^qd:'),
    ({'q_d': [1.0, 2.0, 3.0]}, '^q_d:'), ({'qd_d': [[0.0, 0.0]]}, '^qd_d:'), ({'qdd_d': 'fast'}, '^qdd_d:'),
    ({'gains': ServoGains.uniform(3, 36.0, 12.0)}, '^gains.kp:'), ({'gains': (36.0, 12.0)}, '^gains:'),
    ({'gains': SimpleNamespace(kp=[36.0, -1.0], kv=[12.0, 12.0], ki=None)}, '^gains.kp:'),
    ({'int_E': [0.0, np.nan]}, '^int_E:'),
])
def test_computed_torque_bad_input_names_the_argument(kwargs, name):
    args = {'q': OK2, 'qd': OK2, 'q_d': OK2, 'qd_d': OK2, 'qdd_d': OK2, 'gains': G2, 'int_E': None}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        computed_torque(POLAR, **args)


def test_computed_torque_overflow_raises_instead_of_returning_inf():
    with pytest.raises(ValueError, match='^(v|tau):'):
        with np.errstate(all='ignore'):
            computed_torque(POLAR, OK2, OK2, [1e307, 0.5], OK2, OK2, G2)


@pytest.mark.parametrize('kwargs, name', [
    ({'q': [0.0, 1.0, 2.0]}, '^q:'), ({'qd': [np.nan, 0.0]}, '^qd:'), ({'int_E': [1.0]}, '^int_E:'),
    ({'gains': ServoGains.uniform(1, 1.0, 1.0)}, '^gains.kp:'),
])
def test_independent_joint_bad_input_names_the_argument(kwargs, name):
    args = {'q': OK2, 'qd': OK2, 'q_d': OK2, 'qd_d': OK2, 'gains': G2, 'int_E': None}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        independent_joint(**args)


G1 = ServoGains.uniform(1, 36.0, 12.0)


@pytest.mark.parametrize('kwargs, name', [
    ({'k_e': 0.0}, '^k_e:'), ({'k_e': -1000.0}, '^k_e:'), ({'k_e': np.inf}, '^k_e:'), ({'m': 0.0}, '^m:'),
    ({'f': np.nan}, '^f:'), ({'fdot': [1.0, 2.0]}, '^fdot:'), ({'f_d': np.inf}, '^f_d:'),
    ({'gains': G2}, '^gains.kp:'), ({'int_Ef': np.nan}, '^int_Ef:'),
])
def test_force_1dof_bad_input_names_the_argument(kwargs, name):
    args = {'m': 1.0, 'f': 1.0, 'fdot': 0.0, 'f_d': 10.0, 'fd_d': 0.0, 'fdd_d': 0.0, 'k_e': 1000.0,
            'gains': G1, 'int_Ef': None}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        force_1dof(**args)


@pytest.mark.parametrize('kwargs, name', [
    ({'k_e': 0.0}, '^k_e:'), ({'k_e': [1.0, -1.0]}, '^k_e:'), ({'x_e': [0.1, 0.2, 0.3]}, '^x_e:'),
    ({'sign': 2.0}, '^sign:'), ({'xd': [0.0]}, '^xd:'), ({'x': [np.nan, 0.0]}, '^x:'),
])
def test_spring_force_bad_input_names_the_argument(kwargs, name):
    args = {'x': [0.1, 0.2], 'xd': [0.0, 0.0], 'x_e': 0.1, 'k_e': 1000.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        spring_force(**args)


CXY = make_model('cartesian_xy')


@pytest.mark.parametrize('kwargs, name', [
    ({'force_axes': [True]}, '^force_axes:'), ({'force_axes': [1, 0]}, '^force_axes:'),
    ({'force_axes': [True, False, False]}, '^force_axes:'),
    ({'K_e': 0.0}, '^K_e:'), ({'K_e': [-5.0, 1000.0]}, '^K_e:'), ({'K_e': [1000.0, np.nan]}, '^K_e:'),
    ({'f': [np.nan, 0.0]}, '^f:'), ({'fdot': [0.0]}, '^fdot:'), ({'x_d': [0.0, np.inf]}, '^x_d:'),
    ({'f_d': [0.0, 0.0, 0.0]}, '^f_d:'), ({'q': [0.0]}, '^q:'), ({'qd': [np.nan, 0.0]}, '^qd:'),
    ({'gains_N': None}, '^gains_N:'), ({'gains_T': ServoGains.uniform(3, 1.0, 1.0)}, '^gains_T.kp:'),
    ({'q_posture': [0.0]}, '^q_posture:'), ({'k_posture': (1.0, -1.0)}, '^k_posture'),
    ({'int_E': [0.0, np.nan]}, '^int_E:'),
])
def test_hybrid_bad_input_names_the_argument(kwargs, name):
    args = {'q': [0.29, 0.0], 'qd': [0.0, 0.0], 'x_d': [0.3, 0.1], 'xd_d': [0.0, 0.0], 'xdd_d': [0.0, 0.0],
            'f_d': [10.0, 0.0], 'fd_d': [0.0, 0.0], 'fdd_d': [0.0, 0.0], 'f': [0.0, 0.0], 'fdot': [0.0, 0.0],
            'force_axes': [True, False], 'K_e': 1000.0, 'gains_T': G2, 'gains_N': G2, 'int_E': None}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        hybrid(CXY, **args)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=10, max_size=10))
def test_laws_return_a_finite_torque_or_raise_value_error(values):
    """Whatever the numbers, a law returns finite torques or raises ValueError: never NaN or inf."""
    q, qd, q_d, qd_d, qdd_d = (values[2 * i:2 * i + 2] for i in range(5))
    for call in (lambda: computed_torque(POLAR, q, qd, q_d, qd_d, qdd_d, G2, int_E=q_d),
                 lambda: independent_joint(q, qd, q_d, qd_d, G2, int_E=qdd_d),
                 lambda: hybrid(CXY, q, qd, q_d, qd_d, qdd_d, q_d, qd_d, qdd_d, q, qd, [True, False], 1e3, G2, G2),
                 lambda: force_1dof(1.0, q[0], qd[0], q_d[0], qd_d[0], qdd_d[0], 1e3, G1)):
        try:
            with np.errstate(all='ignore'):  # overflow warnings of absurd inputs; the outcome is checked
                tau = call()
        except ValueError:
            continue
        assert np.all(np.isfinite(tau))


# -- arrays and lists: the same checks, the same numbers --------------------------------------------
def _as_arrays(args):
    """Lists of numbers -> float64 arrays, lists of bools -> bool arrays."""
    out = {}
    for k, v in args.items():
        if isinstance(v, list):
            v = np.array(v, dtype=bool if isinstance(v[0], bool) else float)
        out[k] = v
    return out


HYBRID_OK = {'q': [0.29, 0.05], 'qd': [0.1, -0.2], 'x_d': [0.3, 0.1], 'xd_d': [0.01, 0.0], 'xdd_d': [0.0, 0.2],
             'f_d': [10.0, 0.0], 'fd_d': [1.0, 0.0], 'fdd_d': [0.5, 0.0], 'f': [8.0, 0.3], 'fdot': [20.0, 0.1],
             'force_axes': [True, False], 'K_e': 1000.0, 'gains_T': G2, 'gains_N': G2,
             'q_posture': [0.2, 0.1], 'int_E': [0.01, -0.02]}


def test_lists_and_arrays_give_identical_torques():
    """Whatever form the inputs come in, one check and one equation: the same numbers, bit for bit."""
    g = ServoGains([36.0, 49.0], [12.0, 14.0], [5.0, 3.0])
    ct = {'q': [0.3, 0.6], 'qd': [0.2, -0.4], 'q_d': [0.35, 0.5], 'qd_d': [0.1, 0.0], 'qdd_d': [1.0, -2.0],
          'gains': g, 'int_E': [0.01, -0.03]}
    for model in (POLAR, make_model('planar_two_link')):
        np.testing.assert_array_equal(computed_torque(model, **_as_arrays(ct)), computed_torque(model, **ct))
    ij = {k: v for k, v in ct.items() if k != 'qdd_d'}
    np.testing.assert_array_equal(independent_joint(**_as_arrays(ij)), independent_joint(**ij))
    fc = {'m': 1.5, 'f': [4.0], 'fdot': [30.0], 'f_d': [10.0], 'fd_d': [5.0], 'fdd_d': [-2.0], 'k_e': 1000.0,
          'gains': ServoGains([36.0], [12.0], [10.0]), 'int_Ef': [0.3]}
    np.testing.assert_array_equal(force_1dof(**_as_arrays(fc)), force_1dof(**fc))
    for model in (CXY, POLAR, make_model('planar_two_link')):
        np.testing.assert_array_equal(hybrid(model, **_as_arrays(HYBRID_OK)), hybrid(model, **HYBRID_OK))
    tau, limit = [5.0, -30.0], [10.0, 20.0]
    for got, want in zip(saturate(np.array(tau), np.array(limit)), saturate(tau, limit)):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize('bad', [np.nan, np.inf])
@pytest.mark.parametrize('index', [0, 1])
@pytest.mark.parametrize('name', ['q', 'qd', 'q_d', 'qd_d', 'qdd_d', 'int_E'])
def test_computed_torque_names_a_non_finite_array(name, index, bad):
    args = {k: np.array(OK2) for k in ('q', 'qd', 'q_d', 'qd_d', 'qdd_d', 'int_E')}
    args[name][index] = bad
    with pytest.raises(ValueError, match=f'^{name}:'):
        computed_torque(POLAR, gains=ServoGains.uniform(2, 36.0, 12.0, 0.0), **args)


@pytest.mark.parametrize('bad', [np.nan, -np.inf])
@pytest.mark.parametrize('index', [0, 1])   # the force axis and the motion axis
@pytest.mark.parametrize('name', ['q', 'qd', 'x_d', 'xd_d', 'xdd_d', 'f_d', 'fd_d', 'fdd_d', 'f', 'fdot',
                                  'q_posture', 'int_E'])
def test_hybrid_names_a_non_finite_array(name, index, bad):
    """Entries the law ignores (x_d on a force axis, f on a motion axis) must be finite too."""
    args = _as_arrays(HYBRID_OK)
    args[name][index] = bad
    with pytest.raises(ValueError, match=f'^{name}:'):
        hybrid(CXY, **args)


def test_integral_and_saturate_reject_non_finite_arrays():
    integ = Integral(2)
    integ.update(np.array([1.0, 2.0]), 0.5)
    with pytest.raises(ValueError, match='^E:'):
        integ.update(np.array([1.0, np.nan]), 0.5)
    np.testing.assert_array_equal(integ.value, [0.5, 1.0])
    with pytest.raises(ValueError, match='^tau:'):
        saturate(np.array([np.inf, 0.0]), np.array([1.0, 1.0]))


def test_saturate_writes_into_given_buffers():
    out = (np.zeros(3), np.zeros(3, dtype=bool))
    tau, mask = saturate(np.array([5.0, -30.0, 2.0]), np.array([10.0, 20.0, np.inf]), out=out)
    assert tau is out[0] and mask is out[1]
    np.testing.assert_array_equal(tau, [5.0, -20.0, 2.0])
    np.testing.assert_array_equal(mask, [False, True, False])
