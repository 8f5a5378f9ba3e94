"""Trajectories as joint_trajectory_controller takes them: the first point at 0 s, empty and partial
goals, the joint limits, and the goal and path tolerances (its `constraints`)."""
import numpy as np
import pytest

from robot_control.core.config import ControllerConfig
from robot_control.laws.servo import gain_params
from robot_control.core.tick import ControllerCore
from robot_control.gains import design
from robot_control.models import for_scenario, make_model
from robot_control.trajectory import from_points

POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
DT = 0.001


def polar_core(**kw):
    return ControllerCore(ControllerConfig(POLAR, law_params=gain_params(design(1.0, 12.0).gains(2)), **kw))


def run(core, q, t0, t1, qd=None):
    for k in range(int(round(t0 / DT)), int(round(t1 / DT))):
        core.update(k * DT, q, np.zeros(2) if qd is None else qd)


def test_a_first_point_at_zero_is_the_planners_start_and_the_path_starts_from_the_reference():
    """MoveIt puts the current state first, at 0 s: the reference starts from itself, no jump."""
    core = polar_core()
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([0.0, 0.5, 1.0], [[0.2, 0.6], [0.4, 0.7], [0.5, 0.8]],
                        velocities=[[0.0, 0.0], [0.5, 0.2], [0.0, 0.0]])
    want = from_points(0.0, (q, None, None), [0.5, 1.0], [[0.4, 0.7], [0.5, 0.8]], [[0.5, 0.2], [0.0, 0.0]])
    for t in np.arange(1, 1200) * DT:
        core.update(t, q, np.zeros(2))
        for got, exp in zip(core.joint_reference, want.sample(t)):
            np.testing.assert_allclose(got, exp, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r'^points\[0\].time_from_start: a trajectory needs a point after 0 s'):
        core.set_trajectory([0.0], [[0.1, 0.5]])


def test_an_empty_trajectory_holds_the_measured_position_at_rest():
    core = polar_core()
    core.update(0.0, np.array([0.0, 0.5]), np.zeros(2))
    core.set_trajectory([1.0], [[1.0, 1.0]])
    run(core, np.array([0.0, 0.5]), DT, 0.5)
    where = np.array([0.31, 0.62])
    core.update(0.5, where, np.array([0.4, 0.2]))
    core.hold_position()
    assert core.goal.outcome == 'cancelled'
    core.update(0.501, where, np.zeros(2))
    np.testing.assert_array_equal(core.joint_reference[0], where)
    assert not core.joint_reference[1].any() and not core.joint_reference[2].any()


def test_a_partial_goal_holds_the_joints_it_leaves_out():
    core = polar_core()
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([0.5], [[np.nan, 0.9]])
    run(core, q, DT, 0.6)
    np.testing.assert_allclose(core.joint_reference[0], [0.2, 0.9], rtol=0, atol=1e-12)


def test_a_trajectory_beyond_the_urdf_limits_is_refused_naming_joint_point_and_limit():
    iiwa = for_scenario('iiwa')
    core = ControllerCore(ControllerConfig(iiwa, law_params=gain_params(design(1.0, 12.0).gains(7))))
    q0 = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0])
    core.update(0.0, q0, np.zeros(7))
    lower, upper = iiwa.position_limits
    far = q0.copy()
    far[3] = lower[3] - 0.1
    with pytest.raises(ValueError, match=r"^points\[1\]: lbr_iiwa_joint_4 position -2.1\d* beyond the limit -2.09"):
        core.set_trajectory([1.0, 2.0], [q0, far])
    fast = q0.copy()
    fast[0] += 2.0                                              # 2 rad in 0.3 s: peak 12.5 rad/s > 10 rad/s
    with pytest.raises(ValueError, match=r"^points\[0\]: lbr_iiwa_joint_1 velocity 1\d\.\d+ beyond the limit 10 "):
        core.set_trajectory([0.3], [fast])
    core.set_trajectory([1.0], [fast])                         # 3.75 rad/s at the peak: accepted


def test_a_path_tolerance_violation_holds_the_current_position():
    core = polar_core(trajectory_tolerance=[0.05, 0.05])
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([1.0], [[0.8, 0.6]])
    t, stuck = DT, q.copy()                                     # the robot does not move
    while core.goal.active:
        core.update(t, stuck, np.zeros(2))
        t += DT
    assert core.goal.outcome == 'path' and 'theta1: |q_d - q| = 0.05' in core.goal.reason
    core.update(t, stuck, np.zeros(2))
    np.testing.assert_array_equal(core.joint_reference[0], stuck)
    assert t < 0.5


def test_a_goal_is_reached_within_its_tolerance_and_at_rest_or_missed_after_goal_time():
    core = polar_core(goal_tolerance=0.01, goal_time=0.2)
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([0.1], [[0.25, 0.6]])
    run(core, np.array([0.245, 0.6]), DT, 0.101)
    assert core.goal.active                                     # not past the end yet
    core.update(0.101, np.array([0.245, 0.6]), np.zeros(2))
    assert core.goal.outcome == 'succeeded' and 'goal reached' in core.goal.reason
    core.set_trajectory([0.1], [[0.3, 0.6]])
    run(core, np.array([0.25, 0.6]), 0.102, 0.5)               # stays 0.05 short
    assert core.goal.outcome == 'missed' and 'goal tolerance exceeded' in core.goal.reason
    np.testing.assert_array_equal(core.joint_reference[0], [0.25, 0.6])   # holds where it is


def test_a_moving_robot_has_not_reached_its_goal():
    core = polar_core(goal_tolerance=0.1, goal_time=0.05, stopped_velocity_tolerance=0.01)
    q = np.array([0.2, 0.6])
    core.update(0.0, q, np.zeros(2))
    core.set_trajectory([0.1], [[0.25, 0.6]])
    run(core, np.array([0.25, 0.6]), DT, 0.2, qd=np.array([0.5, 0.0]))
    assert core.goal.outcome == 'missed' and "['theta1'] still moving" in core.goal.reason
