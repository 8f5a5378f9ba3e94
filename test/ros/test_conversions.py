"""Message <-> array conversions: round trips, joints by name, and every rejection reason."""
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message
from trajectory_msgs.msg import JointTrajectoryPoint

from robot_control.ros import conversions as cv
from robot_control.ros.cdr import JointStateDecoder

JOINTS = ('theta1', 'r')
RNG = np.random.default_rng(20261123)


# -- time ------------------------------------------------------------------------------------------
@given(st.integers(min_value=0, max_value=2 ** 62))
def test_stamp_round_trip_is_exact(ns):
    assert cv.stamp_to_ns(cv.ns_to_stamp(ns)) == ns


def test_ns_to_stamp_fills_in_place_and_rejects_negative():
    stamp = cv.ns_to_stamp(0)
    out = cv.ns_to_stamp(3_000_000_007, stamp)
    assert out is stamp and (stamp.sec, stamp.nanosec) == (3, 7)
    with pytest.raises(ValueError, match='^ns:'):
        cv.ns_to_stamp(-1)


@given(st.floats(min_value=0.0, max_value=1e6, allow_nan=False))
def test_duration_round_trip_to_the_nanosecond(seconds):
    d = cv.s_to_duration(seconds)
    assert 0 <= d.nanosec < cv.NS_PER_S
    assert abs(cv.duration_to_s(d) - seconds) <= 0.5e-9 + 1e-15 * seconds


# -- joint states ----------------------------------------------------------------------------------
def test_joint_state_round_trip_by_name_in_any_order_with_extra_joints():
    q, qd = np.array([0.3, 0.7]), np.array([-1.5, 2.5])
    names = ['gripper', 'r', 'other_arm_j1', 'theta1']
    position = [9.0, q[1], 8.0, q[0]]
    velocity = [7.0, qd[1], 6.0, qd[0]]
    msg = cv.joint_state(names, 123_456_789_012, position, velocity, [1.0, 2.0, 3.0, 4.0])
    reader = cv.JointStateReader(JOINTS)
    got_q, got_qd = reader.read(msg)
    np.testing.assert_array_equal(got_q, q)
    np.testing.assert_array_equal(got_qd, qd)
    names_back, stamp, pos, vel, eff = cv.joint_state_arrays(msg)
    assert names_back == tuple(names) and stamp == 123_456_789_012
    np.testing.assert_array_equal(pos, position)
    np.testing.assert_array_equal(vel, velocity)
    np.testing.assert_array_equal(eff, [1.0, 2.0, 3.0, 4.0])


@settings(max_examples=60, deadline=None)
@given(st.permutations(['a', 'b', 'c', 'x1', 'x2']), st.lists(st.floats(-1e3, 1e3), min_size=5, max_size=5))
def test_reader_maps_any_permutation_by_name(order, values):
    reader = cv.JointStateReader(('c', 'a', 'b'))
    by_name = dict(zip(['a', 'b', 'c', 'x1', 'x2'], values))
    msg = cv.joint_state(order, 0, [by_name[n] for n in order], [2 * by_name[n] for n in order])
    q, qd = reader.read(msg)
    np.testing.assert_array_equal(q, [by_name['c'], by_name['a'], by_name['b']])
    np.testing.assert_array_equal(qd, [2 * by_name['c'], 2 * by_name['a'], 2 * by_name['b']])


def test_reader_follows_a_change_of_name_order_between_messages():
    reader = cv.JointStateReader(JOINTS)
    q1, _ = reader.read(cv.joint_state(['theta1', 'r'], 0, [1.0, 2.0], [0.0, 0.0]))
    np.testing.assert_array_equal(q1, [1.0, 2.0])
    q2, _ = reader.read(cv.joint_state(['r', 'theta1'], 0, [1.0, 2.0], [0.0, 0.0]))
    np.testing.assert_array_equal(q2, [2.0, 1.0])


def test_reader_reuses_its_buffers():
    reader = cv.JointStateReader(JOINTS)
    a = reader.read(cv.joint_state(JOINTS, 0, [1.0, 2.0], [0.0, 0.0]))
    b = reader.read(cv.joint_state(JOINTS, 0, [3.0, 4.0], [0.0, 0.0]))
    assert a[0] is b[0] and a[1] is b[1]


@pytest.mark.parametrize('names, position, velocity, match', [
    (['theta1'], [0.0], [0.0], r"^name: missing controlled joints \['r'\]"),
    (['theta1', 'r', 'r'], [0.0, 0.1, 0.1], [0.0, 0.0, 0.0], "^name: duplicate joint 'r'"),
    (['theta1', 'r'], [0.0], [0.0, 0.0], r'^position: expected one entry per name \(2\), got 1'),
    (['theta1', 'r'], [0.0, 0.1], [0.0], r'^velocity: expected one entry per name \(2\) or none, got 1'),
    (['theta1', 'r'], [0.0, math.nan], [0.0, 0.0], "^position: not finite for 'r': nan"),
    (['theta1', 'r'], [0.0, 0.1], [math.inf, 0.0], "^velocity: not finite for 'theta1': inf"),
    (['a', 'b'], [0.0, 0.1], [0.0, 0.0], r"^name: missing controlled joints \['theta1', 'r'\]"),
])
@pytest.mark.parametrize('kind', ['message', 'cdr frame', 'cdr frame of floats'])
def test_reader_rejects_bad_states_naming_the_field(names, position, velocity, match, kind):
    msg = as_kind(cv.joint_state(names, 0, position, velocity), kind)
    with pytest.raises(ValueError, match=match):
        cv.JointStateReader(JOINTS).read(msg)


def as_kind(msg, kind):
    """The JointState itself, or what the nodes read: the robot_control.ros.cdr frame of its bytes."""
    if kind == 'message':
        return msg
    return JointStateDecoder(arrays=kind == 'cdr frame').decode(serialize_message(msg))


@pytest.mark.parametrize('arrays', [True, False])
@pytest.mark.parametrize('names', [JOINTS, JOINTS[::-1], ('gripper',) + JOINTS])
def test_reader_reads_cdr_frames_like_messages(names, arrays):
    reader, frames = cv.JointStateReader(JOINTS), JointStateDecoder(arrays)
    for k in range(3):
        q = [0.1 * k + i for i in range(len(names))]
        qd = [-0.2 * k - i for i in range(len(names))]
        msg = cv.joint_state(names, k, q, qd)
        want = [a.copy() for a in cv.JointStateReader(JOINTS).read(msg)]
        got = reader.read(frames.decode(serialize_message(msg)))
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)


@pytest.mark.parametrize('bad, match', [(1e7, r"^position: implausible magnitude .* for 'r'"),
                                        (math.inf, "^position: not finite for 'r': inf")])
def test_a_frame_of_floats_is_checked_like_the_message(bad, match):
    """The float path checks the state with one sum, max and min: a state failing them is named
    like any other; an overflow of that sum alone (two huge but valid values) is not an error."""
    reader, frames = cv.JointStateReader(JOINTS), JointStateDecoder(arrays=False)
    msg = cv.joint_state(JOINTS, 1, [0.1, bad], [0.0, 0.0])
    with pytest.raises(ValueError, match=match):
        reader.read(frames.decode(serialize_message(msg)))
    q, qd = reader.read(frames.decode(serialize_message(cv.joint_state(JOINTS, 2, [0.1, 0.2], [0.3, 0.4]))))
    assert q.tolist() == [0.1, 0.2] and qd.tolist() == [0.3, 0.4]


def test_non_finite_values_of_uncontrolled_joints_are_ignored():
    msg = cv.joint_state(['theta1', 'broken', 'r'], 0, [0.1, math.nan, 0.2], [0.0, math.inf, 0.0])
    q, qd = cv.JointStateReader(JOINTS).read(msg)
    np.testing.assert_array_equal(q, [0.1, 0.2])
    np.testing.assert_array_equal(qd, [0.0, 0.0])


def test_reader_needs_unique_joint_names():
    with pytest.raises(ValueError, match='^joints:'):
        cv.JointStateReader(('a', 'a'))
    with pytest.raises(ValueError, match='^joints:'):
        cv.JointStateReader(())


def test_effort_array_round_trip():
    tau = RNG.normal(size=7)
    np.testing.assert_array_equal(cv.effort_array_values(cv.effort_array(tau)), tau)


# -- trajectories ----------------------------------------------------------------------------------
def test_trajectory_round_trip_reorders_to_controller_joints():
    times = np.array([0.5, 1.25, 2.0])
    pos = RNG.normal(size=(3, 2))
    vel = RNG.normal(size=(3, 2))
    acc = RNG.normal(size=(3, 2))
    msg = cv.joint_trajectory(['r', 'theta1'], times, pos[:, ::-1], vel[:, ::-1], acc[:, ::-1], stamp_ns=42)
    goal = cv.trajectory_goal(msg, JOINTS)
    assert goal.stamp_ns == 42
    np.testing.assert_allclose(goal.times, times, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(goal.positions, pos)
    np.testing.assert_array_equal(goal.velocities, vel)
    np.testing.assert_array_equal(goal.accelerations, acc)


def test_trajectory_without_velocities_gives_none():
    goal = cv.trajectory_goal(cv.joint_trajectory(JOINTS, [1.0], [[0.1, 0.2]]), JOINTS)
    assert goal.velocities is None and goal.accelerations is None
    assert goal.positions.shape == (1, 2)


def _traj(names=JOINTS, times=(1.0, 2.0), positions=((0.0, 0.5), (0.1, 0.6))):
    return cv.joint_trajectory(names, times, positions)


@pytest.mark.parametrize('msg, match', [
    (_traj(names=('theta1', 'elbow')), r"^joint_names: unknown \['elbow'\], missing \['r'\]"),
    (_traj(names=('theta1',), positions=((0.0,), (0.1,))), r"^joint_names: unknown \[\], missing \['r'\]"),
    (_traj(names=('theta1', 'r', 'r'), positions=((0, 0, 0), (0, 0, 0))), '^joint_names: duplicate'),
    (_traj(times=(2.0, 1.0)), r'^points\[1\].time_from_start: not after points\[0\]'),
    (_traj(times=(1.0, 1.0)), r'^points\[1\].time_from_start: not after'),
    (_traj(times=(-1.0, 1.0)), r'^points\[0\].time_from_start: expected >= 0'),
    (_traj(positions=((0.0, math.nan), (0.1, 0.6))), r'^points\[0\].positions: not finite'),
    (_traj(positions=((0.0, 0.5), (0.1,))), r'^points\[1\].positions: expected one entry per joint'),
])
def test_bad_trajectories_are_rejected_naming_the_field(msg, match):
    with pytest.raises(ValueError, match=match):
        cv.trajectory_goal(msg, JOINTS)


def test_joint_trajectory_controller_semantics_first_point_at_zero_empty_and_partial_goals():
    """The first point may be at 0 s (a planner's current state); no points is an empty trajectory
    (cancel); a joint left out is refused unless allow_partial_joints_goal (then its column is NaN)."""
    goal = cv.trajectory_goal(_traj(times=(0.0, 1.0)), JOINTS)
    np.testing.assert_array_equal(goal.times, [0.0, 1.0])
    assert cv.trajectory_goal(cv.joint_trajectory(JOINTS, [], np.zeros((0, 2))), JOINTS).empty
    partial = _traj(names=('r',), positions=((0.5,), (0.6,)))
    with pytest.raises(ValueError, match=r"^joint_names: unknown \[\], missing \['theta1'\].*allow_partial_joints_goal"):
        cv.trajectory_goal(partial, JOINTS)
    goal = cv.trajectory_goal(partial, JOINTS, allow_partial=True)
    assert goal.given.tolist() == [False, True]
    assert np.isnan(goal.positions[:, 0]).all() and goal.positions[:, 1].tolist() == [0.5, 0.6]


def test_velocities_in_some_points_only_are_rejected():
    msg = _traj()
    msg.points[0].velocities = [0.0, 0.0]
    with pytest.raises(ValueError, match=r'^points\[1\].velocities: expected none, or one entry per joint'):
        cv.trajectory_goal(msg, JOINTS)


def test_non_finite_velocity_is_rejected():
    msg = _traj()
    for p in msg.points:
        p.velocities = [0.0, math.inf]
    with pytest.raises(ValueError, match=r'^points\[0\].velocities: not finite'):
        cv.trajectory_goal(msg, JOINTS)


def test_point_message_fields_are_the_ones_read():
    assert set(JointTrajectoryPoint.get_fields_and_field_types()) >= {
        'positions', 'velocities', 'accelerations', 'time_from_start'}


# -- wrenches ----------------------------------------------------------------------------------------
@given(st.lists(st.floats(-1e4, 1e4), min_size=3, max_size=3))
def test_wrench_round_trip_along_task_axes(values):
    for axes in (('x',), ('y',), ('z',), ('x', 'y'), ('x', 'y', 'z'), ('z', 'x')):
        msg = cv.wrench_along(axes, values[:len(axes)], stamp_ns=7, frame_id='world')
        np.testing.assert_array_equal(cv.wrench_force(msg, axes), values[:len(axes)])
        assert msg.header.frame_id == 'world' and cv.stamp_to_ns(msg.header.stamp) == 7


def test_wrench_force_picks_components_by_axis_name():
    msg = cv.wrench_stamped(force=(1.0, 2.0, 3.0), torque=(4.0, 5.0, 6.0))
    np.testing.assert_array_equal(cv.wrench_force(msg, ('z', 'x')), [3.0, 1.0])
    out = np.zeros(1)
    assert cv.wrench_force(msg, ('y',), out=out) is out and out[0] == 2.0


def test_wrench_rejects_non_finite_and_unknown_axes():
    msg = cv.wrench_stamped()
    msg.wrench.force.y = math.nan
    with pytest.raises(ValueError, match='^wrench.force: not finite'):
        cv.wrench_force(msg, ('y',))
    with pytest.raises(ValueError, match='^force: expected finite'):
        cv.wrench_stamped(force=(math.nan, 0.0, 0.0))
    with pytest.raises(ValueError, match='^axes:'):
        cv.wrench_force(cv.wrench_stamped(), ('theta',))


# -- diagnostics -------------------------------------------------------------------------------------
def test_diagnostic_round_trip():
    status = cv.diagnostic_status('controller: watchdog', 'ERROR', 'no joint_states',
                                  {'trips': 2, 'timeout_s': 0.5, 'limit': math.inf}, 'controller')
    level, message, values = cv.diagnostic_values(status)
    assert (level, message) == ('ERROR', 'no joint_states')
    assert values == {'trips': '2', 'timeout_s': '0.5', 'limit': 'inf'}
    array = cv.diagnostic_array([status], 1_500_000_000)
    assert cv.stamp_to_ns(array.header.stamp) == 1_500_000_000 and array.status[0] is status


def test_pose_target_normalises_a_near_unit_quaternion_and_refuses_the_rest():
    """A quaternion of norm 0.5..2 is normalised; norm 0, 3 or NaN and a frame other than the base are refused
    naming the field; '' counts as the base frame."""
    msg = cv.pose_stamped([0.5, 0.0, 0.4], [0.0, 0.0, 0.0, 1.5], frame_id='base')
    position, quat = cv.pose_target(msg, 'base')
    assert position.tolist() == [0.5, 0.0, 0.4] and quat.tolist() == [0.0, 0.0, 0.0, 1.0]
    assert cv.pose_target(cv.pose_stamped([0.5, 0.0, 0.4], [0.0, 0.0, 0.6, 0.0]), 'base')[1].tolist() == [0, 0, 1, 0]
    for bad in ([0.0] * 4, [0.0, 0.0, 0.0, 3.0], [math.nan, 0.0, 0.0, 1.0], [1e300, 1e300, 0.0, 1.0]):
        with warnings.catch_warnings():
            warnings.simplefilter('error')      # refused without an overflow on the way
            with pytest.raises(ValueError, match='^pose.orientation: not a rotation'):
                cv.pose_target(cv.pose_stamped([0.5, 0.0, 0.4], bad), 'base')
    with pytest.raises(ValueError, match='^pose.position'):
        cv.pose_target(cv.pose_stamped([math.inf, 0.0, 0.4]), 'base')
    for frame in ('world', 'base ', 'tool'):
        with pytest.raises(ValueError, match="^header.frame_id: expected the model's base frame 'base'"):
            cv.pose_target(cv.pose_stamped([0.5, 0.0, 0.4], frame_id=frame), 'base')
    wrench = cv.wrench_along(('z',), (5.0,))
    wrench.header.frame_id = 'world'
    cv.check_base_frame(wrench, 'world')
    with pytest.raises(ValueError, match='^header.frame_id'):
        cv.check_base_frame(wrench, 'base')
