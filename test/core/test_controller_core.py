"""ControllerCore (no ROS): per-tick torque = the library law, references, integral, switching, limits."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_control.core.tick import ControllerConfig, ControllerCore, measure_task
from robot_control.gains import ServoGains, design
from robot_control.laws import (LAWS, Reference, State, computed_torque, force_1dof, hybrid, independent_joint,
                                saturate, spring_force)
from robot_control.laws.force_task import gain_params
from robot_control.laws.servo import gain_params as servo_params
from robot_control.models import make_model
from robot_control.trajectory import from_points, hold, point_to_point

RNG = np.random.default_rng(20261124)
DT = 0.001
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
LIMIT = np.array([200.0, 200.0])


def polar_config(integral=False, law='computed_torque', gains=None, law_params=None, **kw):
    """The polar arm's configuration; `gains` (default: designed) go to a law with the motion servo."""
    g = gains if gains is not None else design(1.0, 12.0, integral=integral).gains(2)
    kw.setdefault('effort_limit', LIMIT)
    params = {**(servo_params(g) if law not in LAWS or LAWS[law].motion_servo else {}), **(law_params or {})}
    return ControllerConfig(POLAR, law=law, law_params=params, integral=integral, **kw)


#: the hybrid law's parameters in the cartesian_xy cases: x against a spring at 0.3 m, the force from the model
XY_FORCE = {'force_axes': ('x',), 'k_e': [1000.0], 'x_e': [0.3], 'force_feedback': 'model',
            **gain_params(design(1.0, 12.0).gains(1)), **servo_params(design(1.0, 12.0).gains(2))}


def xy_config(integral=False, feedback='model', **kw):
    d = design(1.0, 12.0, integral=integral)
    model = make_model('cartesian_xy', m1=1.0, m2=1.0, gravity=9.81)
    kw.setdefault('effort_limit', [200.0, 200.0])
    force = {'force_axes': ('x',), 'k_e': [1000.0], 'x_e': [0.3], 'force_feedback': feedback,
             **gain_params(d.gains(1)), **kw.pop('force', {})}
    return ControllerConfig(model, law='hybrid', integral=integral,
                            law_params={**servo_params(d.gains(2)), **force}, **kw)


def force_config(integral=False, feedback='model', **kw):
    d = design(1.0, 12.0, integral=integral)
    kw.setdefault('effort_limit', [200.0])
    force = {'force_axes': ('x',), 'k_e': [1000.0], 'x_e': [0.1], 'force_feedback': feedback,
             **gain_params(d.gains(1)), **kw.pop('force', {})}
    return ControllerConfig(make_model('force_1dof', m=1.5), law='force', integral=integral, law_params=force,
                            **kw)


def random_state(n, scale=0.2, base=None):
    base = np.zeros(n) if base is None else base
    return base + RNG.uniform(-scale, scale, n), RNG.uniform(-1.0, 1.0, n)


# -- the lecture's example -----------------------------------------------------------------------------
def test_lecture_polar_example_torque_at_a_hold():
    """m = 2, w_res = 12: kp = 36, kv = 12; tau = [2r^2 v1 + 4 r rd th1d + 19.6 r c1, 2 v2 - 2 r th1d^2 + 19.6 s1]."""
    cfg = polar_config()
    np.testing.assert_array_equal(cfg.control_law.motion_gains.kp, [36.0, 36.0])
    np.testing.assert_array_equal(cfg.control_law.motion_gains.kv, [12.0, 12.0])
    core = ControllerCore(cfg)
    q, qd = np.array([0.4, 0.8]), np.array([0.3, -0.2])
    core.update(0.0, q, np.zeros(2))           # starts: reference holds q
    tau = core.update(DT, q, qd)
    th1, r = q
    v = 12.0 * (0.0 - qd)                       # E = 0, Ed = -qd, qdd_d = 0
    expected = [2 * r * r * v[0] + 4 * r * qd[1] * qd[0] + 19.6 * r * math.cos(th1),
                2 * v[1] - 2 * r * qd[0] ** 2 + 19.6 * math.sin(th1)]
    np.testing.assert_allclose(tau, expected, rtol=0, atol=1e-12)


# -- every tick is the library law ----------------------------------------------------------------------
def _library_tau(core, q, qd, f_meas=None):
    """The library law for the core's own reference and integral (what the node publishes)."""
    cfg = core.config
    pos, vel, acc = core.reference
    int_E = core.integral_value.copy() if cfg.integral else None
    if cfg.law == 'computed_torque':
        tau = computed_torque(cfg.model, q, qd, pos, vel, acc, cfg.control_law.motion_gains, int_E)
    elif cfg.law == 'independent_joint':
        tau = independent_joint(q, qd, pos, vel, cfg.control_law.motion_gains, int_E)
    else:
        model = cfg.model
        x, xd = model.fk(q), model.J(q) @ qd
        task = cfg.law_params.force_task
        mask = task.mask
        if task.force_feedback == 'model':
            f, fdot = spring_force(x[mask], xd[mask], task.x_e, task.k_e)
        else:
            f, fdot = np.asarray(f_meas)[mask], task.k_e * xd[mask]
        if cfg.law == 'force':
            tau = force_1dof(model.M(q)[0, 0], f, fdot, pos, vel, acc, task.k_e[0], task.gains, int_E)
        else:
            fm, fdm = np.zeros(model.task_dim), np.zeros(model.task_dim)
            fm[mask], fdm[mask] = f, fdot
            tau = hybrid(model, q, qd, pos, vel, acc, pos, vel, acc, fm, fdm, mask, np.where(mask, 1000.0, 1.0),
                         cfg.control_law.motion_gains, task.gains, q_posture=core.joint_reference[0],
                         k_posture=cfg.law_params.posture.gains(model.n), int_E=int_E)
    return saturate(tau, cfg.effort_limit)[0]


CASES = {
    'computed_torque': (lambda i: polar_config(integral=i), np.array([0.2, 0.6]), None),
    'independent_joint': (lambda i: polar_config(integral=i, law='independent_joint',
                                                 gains=ServoGains([50.0, 80.0], [10.0, 20.0], [5.0, 8.0])),
                          np.array([0.2, 0.6]), None),
    'force': (lambda i: force_config(integral=i), np.array([0.1005]), None),
    'hybrid': (lambda i: xy_config(integral=i), np.array([0.3002, 0.1]), None),
    'hybrid_sensor': (lambda i: xy_config(integral=i, feedback='sensor'), np.array([0.3002, 0.1]), np.array([2.0, 0.0])),
}


@pytest.mark.parametrize('entry', ['update', 'update_checked'])
@pytest.mark.parametrize('integral', [False, True])
@pytest.mark.parametrize('case', sorted(CASES))
def test_every_tick_equals_the_library_law(case, integral, entry):
    """Also through update_checked, the node's entry for states JointStateReader has checked; the
    move ends at tick 50 (move_time 0.1 s): the last ticks hold the goal."""
    make, q0, f_meas = CASES[case]
    core = ControllerCore(make(integral))
    update = getattr(core, entry)
    n = q0.shape[0]
    if core.config.control_law.force_task.force_axes:
        core.set_force_reference([4.0])
    core.set_goal(q0 + 0.05)
    for k in range(60):
        q, qd = random_state(n, 0.002, q0)
        tau = update(k * DT, q, qd, f_meas)
        assert core.tau_values == tau.tolist()
        if case == 'computed_torque':   # the core's own evaluation does the law's float operations in order
            np.testing.assert_array_equal(tau, _library_tau(core, q, qd, f_meas))
        else:
            np.testing.assert_allclose(tau, _library_tau(core, q, qd, f_meas), rtol=0, atol=1e-12)
        assert np.all(np.abs(tau) <= core.config.effort_limit)
    if integral:
        assert np.any(core.integral_value != 0.0)


def test_after_a_move_the_reference_holds_its_goal_until_the_next_move():
    """After t_end the reference is the goal at rest, tick after tick (the core then skips
    re-sampling); a new goal starts from there and ends at the new goal."""
    core = ControllerCore(polar_config(move_time=0.05))
    q0 = np.array([0.2, 0.6])
    first, second = q0 + 0.1, q0 - 0.2
    core.set_goal(first)
    for k in range(101):
        core.update_checked(k * DT, q0, np.zeros(2))
        if k > 50:
            q_d, qd_d, qdd_d = core.joint_reference
            np.testing.assert_allclose(q_d, first, rtol=0, atol=1e-12)
            assert not qd_d.any() and not qdd_d.any()
    core.set_goal(second)
    core.update_checked(0.101, q0, np.zeros(2))
    q_d, qd_d, _ = core.joint_reference
    assert 0.0 < np.abs(q_d - first).max() < 1e-3 and np.all(np.sign(qd_d) == np.sign(second - first))
    for k in range(102, 200):
        core.update_checked(k * DT, q0, np.zeros(2))
    np.testing.assert_allclose(core.joint_reference[0], second, rtol=0, atol=1e-12)
    assert not core.joint_reference[1].any()


def test_reference_follows_the_goal_move_from_the_start_position():
    core = ControllerCore(polar_config(move_time=0.5))
    goal = np.array([0.5, 0.9])
    core.set_goal(goal)                          # before the first state: the first move
    q0 = np.array([0.1, 0.5])
    expected = from_points(0.2, (q0, None, None), [0.5], [goal])
    for t in np.arange(0.2, 0.9, 0.01):
        core.update(t, q0, np.zeros(2))
        for got, want in zip(core.joint_reference, expected.sample(t)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(core.joint_reference[0], goal, rtol=0, atol=1e-12)


# -- start, stop, time -----------------------------------------------------------------------------------
def test_start_holds_the_measured_position():
    core = ControllerCore(polar_config(integral=True))
    q = np.array([0.3, 0.7])
    core.update(5.0, q, np.array([0.1, 0.2]))
    np.testing.assert_array_equal(core.joint_reference[0], q)
    np.testing.assert_array_equal(core.joint_reference[1], [0.0, 0.0])
    np.testing.assert_array_equal(core.error[0], [0.0, 0.0])
    np.testing.assert_array_equal(core.integral_value, [0.0, 0.0])


def _integrate_some(core, q_ref, steps=50):
    for k in range(steps):
        core.update(k * DT, q_ref - 0.01, np.zeros(q_ref.shape[0]))


def test_stop_then_update_restarts_with_reset_integral_and_hold_of_the_new_state():
    core = ControllerCore(polar_config(integral=True))
    core.update(0.0, np.array([0.2, 0.6]), np.zeros(2))
    for k in range(1, 50):
        core.update(k * DT, np.array([0.19, 0.59]), np.zeros(2))
    assert np.all(core.integral_value > 0.0)
    core.stop()
    assert not core.active
    q_new, qd_new = np.array([0.4, 0.7]), np.array([0.2, 0.0])
    tau = core.update(2.0, q_new, qd_new)
    assert core.active and core.restarts == 1
    np.testing.assert_array_equal(core.joint_reference[0], q_new)
    np.testing.assert_array_equal(core.integral_value, [0.0, 0.0])
    expected = computed_torque(POLAR, q_new, qd_new, q_new, np.zeros(2), np.zeros(2),
                               core.config.control_law.motion_gains, np.zeros(2))
    np.testing.assert_allclose(tau, expected, rtol=0, atol=1e-12)


def test_time_going_backwards_restarts():
    core = ControllerCore(polar_config(integral=True))
    core.update(10.0, np.array([0.2, 0.6]), np.zeros(2))
    core.update(10.001, np.array([0.1, 0.6]), np.zeros(2))
    assert np.any(core.integral_value != 0.0)
    core.update(0.0, np.array([0.3, 0.5]), np.zeros(2))
    assert core.restarts == 1
    np.testing.assert_array_equal(core.integral_value, [0.0, 0.0])
    np.testing.assert_array_equal(core.joint_reference[0], [0.3, 0.5])


def test_a_repeated_state_gets_the_same_torque_and_does_not_integrate():
    core = ControllerCore(polar_config(integral=True))
    core.update(0.0, np.array([0.2, 0.6]), np.zeros(2))
    q, qd = np.array([0.1, 0.55]), np.array([0.1, 0.1])
    tau1 = core.update(0.001, q, qd).copy()
    int1 = core.integral_value.copy()
    tau2 = core.update(0.001, q, qd)
    np.testing.assert_array_equal(tau1, tau2)
    np.testing.assert_array_equal(int1, core.integral_value)


def test_update_writes_into_preallocated_buffers():
    core = ControllerCore(polar_config())
    a = core.update(0.0, np.array([0.2, 0.6]), np.zeros(2))
    ref = core.reference[0]
    b = core.update(0.001, np.array([0.1, 0.6]), np.zeros(2))
    assert a is b and core.reference[0] is ref


# -- trajectories -----------------------------------------------------------------------------------------
def _run(core, times, q):
    for t in times:
        core.update(t, q, np.zeros(q.shape[0]))


def test_replacing_a_trajectory_mid_motion_keeps_the_reference_continuous():
    core = ControllerCore(polar_config())
    q = np.array([0.0, 0.5])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([1.0, 2.0], [[1.0, 0.8], [0.5, 0.6]])
    first = from_points(0.0, (q, None, None), [1.0, 2.0], [[1.0, 0.8], [0.5, 0.6]])
    _run(core, np.arange(1, 701) * DT, q)
    t_r = 700 * DT
    before = [a.copy() for a in core.joint_reference]
    for got, want in zip(before, first.sample(t_r)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert abs(before[1][0]) > 0.5            # mid-motion: moving fast
    assert core.set_trajectory([0.5], [[0.0, 0.5]]) == t_r
    second = from_points(t_r, first.sample(t_r), [0.5], [[0.0, 0.5]])
    prev = before
    for k in range(701, 1300):
        t = k * DT
        core.update(t, q, np.zeros(2))
        now = core.joint_reference
        for got, want in zip(now, second.sample(t)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        # no jump: one tick changes position by ~|qd| dt and velocity by ~|qdd| dt
        assert np.all(np.abs(now[0] - prev[0]) <= (np.abs(prev[1]) + 1.0) * DT + 1e-9)
        assert np.all(np.abs(now[1] - prev[1]) <= (np.abs(prev[2]) + 50.0) * DT + 1e-9)
        prev = [a.copy() for a in now]
    np.testing.assert_allclose(core.joint_reference[0], [0.0, 0.5], rtol=0, atol=1e-12)


def test_single_point_from_rest_is_the_quintic_point_to_point_move():
    core = ControllerCore(polar_config())
    q = np.array([0.1, 0.4])
    core.update(1.0, q, np.zeros(2))
    core.set_trajectory([2.0], [[0.7, 0.9]])
    quintic = point_to_point(q, [0.7, 0.9], 2.0, 'quintic', t0=1.0)
    for t in np.linspace(1.0, 3.5, 37):
        core.update(t, q, np.zeros(2))
        for got, want in zip(core.joint_reference, quintic.sample(t)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_future_start_keeps_the_current_reference_until_then():
    core = ControllerCore(polar_config())
    q = np.array([0.1, 0.4])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([1.0], [[0.5, 0.5]], t_start=0.5)
    core.update(0.499, q, np.zeros(2))
    np.testing.assert_array_equal(core.joint_reference[0], q)
    expected = from_points(0.5, (q, None, None), [1.0], [[0.5, 0.5]])
    core.update(0.9, q, np.zeros(2))
    np.testing.assert_allclose(core.joint_reference[0], expected.sample(0.9)[0], rtol=0, atol=1e-12)


def test_start_in_the_past_drops_due_points_and_rejects_a_finished_trajectory():
    core = ControllerCore(polar_config())
    q = np.array([0.1, 0.4])
    core.update(10.0, q, np.zeros(2))
    assert core.set_trajectory([1.0, 3.0], [[9.0, 9.0], [0.3, 0.5]], t_start=8.5) == 10.0
    expected = from_points(10.0, (q, None, None), [1.5], [[0.3, 0.5]])
    core.update(10.5, q, np.zeros(2))
    np.testing.assert_allclose(core.joint_reference[0], expected.sample(10.5)[0], rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match='^times: the trajectory ended'):
        core.set_trajectory([1.0, 2.0], [[0.0, 0.5], [0.3, 0.5]], t_start=5.0)


def test_trajectory_needs_a_running_controller_and_valid_points():
    core = ControllerCore(polar_config())
    with pytest.raises(ValueError, match='^trajectory: no state received yet'):
        core.set_trajectory([1.0], [[0.0, 0.5]])
    core.update(0.0, np.array([0.0, 0.5]), np.zeros(2))
    with pytest.raises(ValueError, match='^times:'):
        core.set_trajectory([2.0, 1.0], [[0.0, 0.5], [0.1, 0.5]])
    with pytest.raises(ValueError, match='^positions:'):
        core.set_trajectory([1.0], [[0.0, 0.5, 0.1]])


def test_force_reference_ramps_smoothly_to_a_new_target():
    core = ControllerCore(force_config(force={'force_ramp_time': 0.4}))
    q = np.array([0.1])
    core.update(0.0, q, np.zeros(1))             # starts from the measured (model) force 0 N
    np.testing.assert_array_equal(core.reference[0], [0.0])
    core.set_force_reference([10.0])
    ramp = from_points(0.0, ([0.0], None, None), [0.4], [[10.0]])
    for t in np.linspace(0.0, 0.6, 25):
        core.update(t, q, np.zeros(1))
        for got, want in zip(core.reference, ramp.sample(t)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(core.force_target, [10.0])


# -- saturation, integral ------------------------------------------------------------------------------------
def test_torque_is_clipped_to_the_effort_limits_and_counted():
    core = ControllerCore(polar_config(effort_limit=[5.0, 3.0]))
    tau0 = core.update(0.0, np.array([0.0, 0.5]), np.zeros(2))   # gravity 9.8 N m on theta1 > 5
    np.testing.assert_array_equal(tau0, [5.0, 0.0])
    core.set_goal([1.5, 1.0], duration=0.01)
    tau = core.update(0.5, np.array([0.0, 0.5]), np.zeros(2))
    np.testing.assert_array_equal(np.abs(tau), [5.0, 3.0])
    assert core.tau_values == tau.tolist()             # the clipped torque, also as floats
    assert core.saturated.tolist() == [True, True]
    assert core.saturated_ticks == 2 and core.saturation_counts.tolist() == [2, 1]


def test_anti_windup_freezes_the_integral_of_a_saturated_joint_only():
    gains = ServoGains([10.0, 10.0], [1.0, 1.0], [5.0, 5.0])
    core = ControllerCore(polar_config(integral=True, law='independent_joint', gains=gains,
                                       effort_limit=[1.0, 100.0]))
    q = np.array([0.0, 0.5])
    core.update(0.0, q, np.zeros(2))
    core.set_goal([1.0, 0.6], duration=0.001)
    for k in range(1, 200):
        core.update(k * DT, q, np.zeros(2))
    # joint 0: E = 1, kp E = 10 > 1 saturates from tick 1 on; the integral never grows past tick 1's
    # 1 * DT (frozen) and is back-calculated toward the value whose torque is the limit:
    # kp E + ki int = 1 -> int = -1.8 (tracking time sqrt(kv / ki) = 0.45 s). Joint 1 (E = 0.1, not
    # saturated) integrates every tick.
    assert core.saturated[0] and not core.saturated[1]
    assert -1.8 < core.integral_value[0] < 0.0
    assert core.integral_value[1] == pytest.approx(0.1 * 199 * DT, rel=1e-9)


def test_integral_limit_clamps_each_entry():
    core = ControllerCore(polar_config(integral=True, integral_limit=0.002))
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    for k in range(1, 500):
        core.update(k * DT, q - 0.1, np.zeros(2))
    np.testing.assert_allclose(core.integral_value, [0.002, 0.002], rtol=0, atol=1e-15)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=4, max_size=4), st.floats(0.5, 40.0), st.floats(0.1, 50.0))
def test_torque_is_always_finite_and_within_limits(state, omega_n, limit):
    g = design(1.0, omega_n=omega_n, integral=True).gains(2)
    core = ControllerCore(polar_config(integral=True, gains=g, effort_limit=[limit, 2 * limit]))
    core.update(0.0, np.array([0.0, 0.5]), np.zeros(2))
    core.set_goal([1.0, 1.0], duration=0.05)
    q, qd = np.array(state[:2]), np.array(state[2:])
    for k in range(1, 20):
        tau = core.update(k * 0.01, q, qd)
        assert np.all(np.isfinite(tau))
        assert np.all(np.abs(tau) <= [limit, 2 * limit])


# -- bumpless switching -------------------------------------------------------------------------------------
def _tracking_core(cfg, steps=300):
    core = ControllerCore(cfg)
    q0 = np.array([0.2, 0.6])
    core.update(0.0, q0, np.zeros(2))
    for k in range(1, steps):
        core.update(k * DT, q0 - [0.01, 0.02], np.zeros(2))
    return core, q0 - [0.01, 0.02], steps * DT


def test_gain_change_with_integral_is_bumpless():
    core, q, t = _tracking_core(polar_config(integral=True))
    tau_before = core.tau.copy()
    g = design(1.0, omega_n=4.0, integral=True).gains(2)
    core.configure(core.config.replace(law_params=servo_params(g)))
    tau_after = core.update(t, q, np.zeros(2))
    np.testing.assert_allclose(tau_after, tau_before, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tau_after, _library_tau(core, q, np.zeros(2)), rtol=0, atol=1e-12)
    tau_next = core.update(t + DT, q, np.zeros(2))
    assert np.all(np.abs(tau_next - tau_after) < 1e-3)     # and the loop carries on smoothly


def test_switch_computed_torque_to_independent_joint_with_integral_is_bumpless():
    core, q, t = _tracking_core(polar_config(integral=True))
    tau_before = core.tau.copy()
    ref_before = [a.copy() for a in core.joint_reference]
    gains = ServoGains([50.0, 80.0], [10.0, 20.0], [30.0, 40.0])
    core.configure(core.config.replace(law='independent_joint', law_params=servo_params(gains)))
    tau_after = core.update(t, q, np.zeros(2))
    np.testing.assert_allclose(tau_after, tau_before, rtol=0, atol=1e-9)
    for got, want in zip(core.joint_reference, ref_before):    # reference kept
        np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(tau_after, _library_tau(core, q, np.zeros(2)), rtol=0, atol=1e-12)


def test_switch_to_a_law_without_integral_gives_exactly_the_new_law():
    core, q, t = _tracking_core(polar_config(integral=True))
    gains = ServoGains([50.0, 80.0], [10.0, 20.0], [0.0, 0.0])
    core.configure(core.config.replace(law='independent_joint', law_params=servo_params(gains), integral=False))
    tau = core.update(t, q, np.zeros(2))
    pos, vel, _ = core.joint_reference
    np.testing.assert_allclose(tau, independent_joint(q, np.zeros(2), pos, vel, gains), rtol=0, atol=1e-12)


def test_switch_to_hybrid_restarts_the_reference_from_the_current_state():
    model = make_model('cartesian_xy', m1=1.0, m2=1.0, gravity=9.81)
    d = design(1.0, 12.0)
    core = ControllerCore(ControllerConfig(model, law_params=servo_params(d.gains(2)), effort_limit=[200.0, 200.0]))
    core.update(0.0, np.array([0.25, 0.0]), np.zeros(2))
    core.set_goal([0.25, 0.3], duration=0.5)
    for k in range(1, 200):
        core.update(k * DT, np.array([0.25, 0.01]), np.zeros(2))
    q, qd = np.array([0.301, 0.05]), np.array([0.0, 0.1])
    core.configure(core.config.replace(law='hybrid', law_params=XY_FORCE))
    core.set_force_reference([5.0])
    tau = core.update(0.2, q, qd)
    np.testing.assert_array_equal(core.joint_reference[0], q)        # restarted: hold q
    np.testing.assert_array_equal(core.joint_reference[1], [0.0, 0.0])
    assert core.reference[0][0] == pytest.approx(1000.0 * 0.001)     # force reference from the measured 1 N
    np.testing.assert_allclose(tau, _library_tau(core, q, qd), rtol=0, atol=1e-12)


def test_configure_cannot_change_joints():
    core = ControllerCore(polar_config())
    with pytest.raises(ValueError, match='^joints: cannot change'):
        core.configure(polar_config(joints=('a', 'b')))


# -- fallback ----------------------------------------------------------------------------------------
def test_singular_jacobian_falls_back_to_gravity_hold():
    model = make_model('planar_two_link')
    d = design(1.0, 12.0)
    core = ControllerCore(ControllerConfig(model, law='hybrid', law_params=servo_params(d.gains(2)),
                                           effort_limit=[5.0, 5.0]))
    q = np.array([0.3, 0.0])                     # arm stretched: J singular
    tau = core.update(0.0, q, np.zeros(2))
    np.testing.assert_allclose(tau, saturate(model.g(q), 5.0)[0], rtol=0, atol=1e-12)
    assert core.fallbacks == 1 and 'singular' in core.last_fallback


def test_sensor_feedback_uses_the_measured_force_and_model_rate():
    core = ControllerCore(force_config(feedback='sensor'))
    core.set_force_reference([3.0])
    core.update(0.0, np.array([0.1]), np.zeros(1), f_meas=[3.0])
    core.update(1.0, np.array([0.1]), np.array([0.01]), f_meas=[2.5])
    np.testing.assert_allclose(core.error[0], [0.5], rtol=0, atol=1e-12)
    np.testing.assert_allclose(core.error[1], [-1000.0 * 0.01], rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match='^f_meas: required'):
        core.update(1.1, np.array([0.1]), np.zeros(1))



@pytest.mark.parametrize('feedback', ['sensor', 'model'])
def test_force_lead_time_uses_the_force_one_period_ahead(feedback):
    """force_lead_time T: the force law sees f + fdot T (f measured or k_e (x - x_e), fdot = k_e xd)."""
    T, q, qd, f_meas = 0.001, np.array([0.103]), np.array([0.02]), 2.9
    core = ControllerCore(force_config(feedback=feedback, force={'force_lead_time': T, 'force_ramp_time': 0.0}))
    core.set_force_reference([3.0])
    tau = core.update(0.0, q, qd, f_meas=[f_meas])
    f = f_meas if feedback == 'sensor' else 1000.0 * (q[0] - 0.1)
    fdot, gains = 1000.0 * qd[0], core.config.control_law.force_task.gains
    want = force_1dof(1.5, np.array([f + fdot * T]), np.array([fdot]), np.array([3.0]), np.zeros(1), np.zeros(1),
                      1000.0, gains)
    np.testing.assert_allclose(tau, want, rtol=0, atol=1e-12)
    assert abs(want[0] - force_1dof(1.5, np.array([f]), np.array([fdot]), np.array([3.0]), np.zeros(1),
                                    np.zeros(1), 1000.0, gains)[0]) > 0.01   # T matters here

# -- configuration ---------------------------------------------------------------------------------------
def test_the_configuration_holds_only_what_every_law_shares():
    """What one law (or a group of laws: the force setup, the posture) reads is in its Params (law_params), not in
    ControllerConfig: no field of the configuration is a parameter of a law."""
    fields = {f.name for f in dataclasses.fields(ControllerConfig)}
    assert fields == {'model', 'law', 'integral', 'integral_limit', 'integral_rest_velocity',
                      'effort_limit', 'joints', 'move_time', 'trajectory_tolerance', 'goal_tolerance',
                      'goal_time', 'stopped_velocity_tolerance', 'law_params', 'friction_compensation',
                      'velocity_cutoff_hz'}
    law_rows = {row.name for law in LAWS.values() for row in law.all_param_rows()}
    assert {'kp', 'kv', 'ki', 'force_axes', 'k_e', 'x_e', 'force_kp', 'posture_kp', 'contact_max_travel',
            'control_period'} <= law_rows
    assert not fields & law_rows
    assert [name for name, law in LAWS.items() if law.uses_force] == ['force', 'hybrid']
    assert [name for name, law in LAWS.items() if law.motion_servo] == ['computed_torque', 'independent_joint',
                                                                         'hybrid']


@pytest.mark.parametrize('changes, match', [
    ({'law': 'pid'}, '^law: unknown'),
    ({'law_params': {'kp': [1.0, -1.0], 'kv': [1.0, 1.0]}}, '^kp: expected non-negative'),
    ({'law_params': {'kp': [1.0, 1.0], 'kv': [1.0]}}, '^kv:'),
    ({'gains': ServoGains.uniform(3, 1.0, 1.0)}, '^kp: expected 2 gains'),
    ({'effort_limit': [1.0, -1.0]}, '^effort_limits:'),
    ({'effort_limit': [1.0]}, '^effort_limits:'),
    ({'integral_limit': 0.0}, '^integral_limit:'),
    ({'law': 'hybrid', 'law_params': {'force_axes': ('q',), 'k_e': [1.0], 'x_e': [0.0]}}, '^force_axes:'),
    ({'law': 'hybrid', 'law_params': {'force_axes': ('x',), 'k_e': [-1.0], 'x_e': [0.0]}}, '^k_e:'),
    ({'law': 'hybrid', 'law_params': {'force_axes': ('x',), 'k_e': [1.0]}}, '^x_e:'),
    ({'law': 'hybrid', 'law_params': {'force_feedback': 'guess'}}, '^force_feedback:'),
    ({'law': 'hybrid', 'law_params': {'contact_max_travel': 0.0}}, '^contact_max_travel:'),
    ({'law': 'force'}, '^law: force is the 1-DOF'),
    ({'law': 'hybrid', 'law_params': {'force_axes': ('x',), 'k_e': [1.0], 'x_e': [0.0]}}, '^force_kp:'),
    ({'joints': ('a',)}, '^joints:'),
    ({'move_time': 0.0}, '^move_time:'),
    ({'law': 'hybrid', 'law_params': {'posture_kp': -1.0}}, '^posture_kp:'),
    ({'law': 'impedance', 'gains': None, 'law_params': {'posture_kv': -1.0}}, '^posture_kv:'),
    ({'law': 'impedance', 'gains': None, 'law_params': {'control_period': 0.0}}, '^control_period:'),
    ({'law': 'hybrid', 'law_params': {'force_lead_time': -0.001}}, '^force_lead_time:'),
    ({'law_params': {'force_axes': ('x',)}}, r"^law_params: \['force_axes'\] are not parameters of law computed"),
])
def test_invalid_configurations_are_rejected_naming_the_parameter(changes, match):
    with pytest.raises(ValueError, match=match):
        polar_config(**changes)


def test_operational_space_laws_need_task_dimension_at_most_the_joints():
    """single_link: 1 joint, 2 task axes (x, y); hybrid and impedance refuse it naming law and the sizes."""
    with pytest.raises(ValueError, match=r'^law: hybrid needs task dimension <= joints; the model has 2 task axes '
                                         r"\['x', 'y'\] and 1 joints"):
        ControllerConfig(make_model('single_link'), law='hybrid',
                         law_params=servo_params(ServoGains.uniform(2, 1.0, 1.0)))
    with pytest.raises(ValueError, match='^law: impedance needs task dimension <= joints; the model has 2 task axes'):
        ControllerConfig(make_model('single_link'), law='impedance', law_params={'cartesian_stiffness': [100.0] * 6})


def test_effort_limit_defaults_to_the_model():
    assert np.all(np.isinf(ControllerConfig(POLAR, law_params=servo_params(design(1.0, 12.0).gains(2))).effort_limit))


def test_hold_is_the_trajectory_module_hold():
    """The core's start reference is trajectory.hold: sampled anywhere it returns the start."""
    core = ControllerCore(polar_config())
    core.update(3.0, np.array([0.2, 0.6]), np.zeros(2))
    np.testing.assert_array_equal(core.reference_at(100.0)[0], hold([0.2, 0.6]).sample(0.0)[0])


# -- one evaluation of the law per tick --------------------------------------------------------------
def _count_torque_calls(core):
    law, calls = core.config.control_law, []
    torque = law.torque

    def counted(*args):
        calls.append(args)
        return torque(*args)
    law.torque = counted
    return calls


@pytest.mark.parametrize('case', sorted(CASES))
def test_the_law_is_evaluated_once_per_tick_saturated_or_not_and_after_a_switch(case):
    make, q0, f_meas = CASES[case]
    cfg = make(True)
    core = ControllerCore(cfg.replace(effort_limit=np.full(cfg.n, 1.0)))
    calls = _count_torque_calls(core)
    if core.config.control_law.force_task.force_axes:
        core.set_force_reference([40.0])
    core.set_goal(q0 + 0.3, duration=0.02)
    for k in range(40):
        core.update(k * DT, *random_state(q0.shape[0], 0.002, q0), f_meas)
    assert core.saturated_ticks > 30 and len(calls) == 40
    core.configure(core.config.replace(integral_limit=10.0))        # re-initialised: bumpless, still once
    calls = _count_torque_calls(core)
    core.update(40 * DT, *random_state(q0.shape[0], 0.002, q0), f_meas)
    assert len(calls) == 1


@pytest.mark.parametrize('law', ['computed_torque', 'independent_joint'])
def test_a_saturated_tick_back_calculates_the_integral_by_the_equation(law):
    """int += min(1, dt / Tt) d with B d = tau_sat - tau_law, B = d tau / d int E (the closed form agrees
    with the law's finite differences), Tt = sqrt(kv / ki); the step comes with the next tick's E dt."""
    gains = design(1.0, 12.0, integral=True).gains(2) if law == 'computed_torque' else \
        ServoGains([50.0, 80.0], [10.0, 20.0], [30.0, 40.0])
    core = ControllerCore(polar_config(integral=True, law=law, gains=gains, effort_limit=[0.5, 0.3]))
    q, qd = np.array([0.2, 0.6]), np.array([0.1, -0.1])
    core.update(0.0, q, qd)
    core.set_goal([0.5, 0.9], duration=0.5)
    for k in range(1, 20):
        core.update(k * DT, q, qd)
    int_prev, tau_sat = core.integral_value.copy(), core.tau.copy()
    pos, vel, acc = [a.copy() for a in core.reference]
    assert core.saturated.all()

    def law_tau(z):
        if law == 'computed_torque':
            return computed_torque(POLAR, q, qd, pos, vel, acc, gains, z)
        return independent_joint(q, qd, pos, vel, gains, z)
    tau_law = law_tau(int_prev)
    B = np.column_stack([law_tau(int_prev + e) - tau_law for e in np.eye(2)])
    closed = POLAR.M(q) * gains.ki if law == 'computed_torque' else np.diag(gains.ki)
    np.testing.assert_allclose(closed, B, rtol=1e-9, atol=1e-9)
    d = np.linalg.solve(closed, tau_sat - tau_law)
    step = np.minimum(1.0, DT / np.sqrt(gains.kv / gains.ki)) * d
    core.update(20 * DT, q, qd)
    E = core.error[0]
    hold = core.config.control_law.freeze(E, np.array([True, True]), tau_sat)
    np.testing.assert_allclose(core.integral_value, int_prev + step + np.where(hold, 0.0, E * DT),
                               rtol=0, atol=1e-12)
    assert np.abs(step).max() > 1e-6


@pytest.mark.parametrize('case', sorted(CASES))
def test_the_integral_map_of_every_law_is_its_torque_s_derivative_in_the_integral(case):
    """B = d tau / d int E in closed form equals the law's finite differences: tau is affine in int E."""
    make, q0, f_meas = CASES[case]
    cfg = make(True)
    law, k = cfg.control_law, len(cfg.control_law.force_task.force_axes)
    q, qd = random_state(q0.shape[0], 0.002, q0)
    state = State(0.1, q, qd, *measure_task(cfg, q, qd, f_meas)) if law.needs_task_space else State(0.1, q, qd)
    force = (np.full(k, 3.0), np.full(k, 0.5), np.full(k, 0.1)) if k else (None, None, None)
    ref = Reference(q0 + 0.01, np.full(q0.shape[0], 0.1), np.full(q0.shape[0], 0.2), *force)
    err = law.errors(state, ref)
    z = RNG.uniform(-0.1, 0.1, law.integral_dim)
    tau = law.torque(state, ref, err, z)
    fd = np.column_stack([law.torque(state, ref, err, z + e) - tau for e in np.eye(law.integral_dim)])
    np.testing.assert_allclose(law.integral_map(state, ref, err), fd, rtol=1e-9, atol=1e-9)


def test_a_law_s_own_parameters_are_checked_naming_them():
    xyz = make_model('cartesian_xyz')
    cfg = ControllerConfig(xyz, law='impedance', law_params={'cartesian_damping_ratio': 0.7})
    assert cfg.law_params.cartesian_damping_ratio == 0.7 and cfg.law_params.max_pose_error == (0.1, 0.5)
    for law_params, match in (({'max_pose_error': (0.0, 1.0)}, '^max_pose_error: expected two positive'),
                              ({'cartesian_stiffness': [1.0] * 5}, '^cartesian_stiffness:'),
                              ({'stiffness': 1.0}, r"^law_params: \['stiffness'\] are not parameters of law impedance")):
        with pytest.raises(ValueError, match=match):
            ControllerConfig(xyz, law='impedance', law_params=law_params)
    with pytest.raises(ValueError, match='^law_params: .* not parameters of law computed_torque'):
        polar_config(law_params={'max_pose_error': (0.1, 0.5)})


@pytest.mark.parametrize('case', sorted(CASES))
def test_a_law_reads_its_inputs_and_writes_none_of_them(case):
    """State and Reference are immutable tuples made for the tick; errors() and torque() leave every array
    in them as it was."""
    make, q0, f_meas = CASES[case]
    core = ControllerCore(make(True))
    law, seen = core.config.control_law, []
    torque = law.torque

    def watched(state, ref, err, int_E):
        before = [None if a is None else np.array(a, copy=True) for a in (*state[1:], *ref[:6])]
        tau = torque(state, ref, err, int_E)
        after = [None if a is None else np.asarray(a) for a in (*state[1:], *ref[:6])]
        seen.append(all((b is None and a is None) or np.array_equal(a, b) for a, b in zip(after, before)))
        with pytest.raises(AttributeError):
            state.q = None
        return tau
    law.torque = watched
    if core.config.control_law.force_task.force_axes:
        core.set_force_reference([4.0])
    core.set_goal(q0 + 0.05)
    for k in range(20):
        core.update(k * DT, *random_state(q0.shape[0], 0.002, q0), f_meas)
    assert len(seen) == 20 and all(seen)


def test_a_reference_given_between_a_law_switch_and_the_next_tick_is_kept():
    """A switch from a law without a reference restarts the references; a trajectory (or a task target) that
    comes before the next tick, as one sent right after `ros2 param set law ...` while the simulator is
    paused, is followed: the restart happens before it is taken, from the last tick's state."""
    q0 = np.array([0.2, 0.6])
    core = ControllerCore(polar_config(law='gravity_compensation', gains=None))
    core.update(0.0, q0, np.zeros(2))
    core.configure(polar_config())
    core.set_trajectory([1.0], [[0.5, 0.9]])
    core.update(0.001, q0, np.zeros(2))
    np.testing.assert_allclose(core.reference_at(1.0)[0], [0.5, 0.9])
    np.testing.assert_array_less(q0, core.reference_at(0.5)[0])
    xy = xy_config()
    core = ControllerCore(xy.replace(law='gravity_compensation', law_params=None))
    core.update(0.0, np.array([0.3, 0.1]), np.zeros(2))
    core.configure(ControllerConfig(xy.model, law='impedance', effort_limit=[200.0, 200.0]))
    core.set_target_pose([0.32, 0.12])
    core.update(0.001, np.array([0.3, 0.1]), np.zeros(2))
    np.testing.assert_array_equal(core.reference[0], [0.32, 0.12])
    # a law that uses force: its force reference still ramps from the force measured at the restart
    d = design(1.0, 12.0)
    ct = ControllerConfig(xy.model, law_params=servo_params(d.gains(2)), effort_limit=[200.0, 200.0])
    core = ControllerCore(ct)
    q = np.array([0.301, 0.05])
    core.update(0.0, q, np.zeros(2))
    core.configure(ct.replace(law='hybrid', law_params=XY_FORCE))
    core.set_force_reference([5.0])
    core.set_target_pose([0.0, 0.08])
    core.update(0.001, q, np.zeros(2))
    assert core.reference[0][0] == pytest.approx(1000.0 * 0.001)     # f_d from the measured 1 N
    assert core.reference[0][1] == 0.08                              # y: the target given before the tick
