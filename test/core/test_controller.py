"""Controller (no ROS): a joint state in, a command or a rejection out; the wrench of each state's own
tick; the watchdog; the counts."""
import numpy as np
import pytest

from robot_control.core.config import ControllerConfig
from robot_control.core.controller import RESTARTED, RESUMED, Command, Controller, Rejection
from robot_control.core.tick import ControllerCore
from robot_control.gains import design
from robot_control.laws.force_task import gain_params
from robot_control.laws.servo import gain_params as servo_params
from robot_control.models import make_model

MS = 1_000_000
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
XY = make_model('cartesian_xy', m1=1.0, m2=1.0, gravity=9.81)


def polar():
    return ControllerConfig(POLAR, law_params=servo_params(design(1.0, 12.0).gains(2)), effort_limit=[200.0, 200.0])


#: the hybrid law's parameters: x against a spring at 0.3 m, the force from the sensor
FORCE = {'force_axes': ('x',), 'k_e': [1000.0], 'x_e': [0.3], 'force_feedback': 'sensor',
         **gain_params(design(1.0, 12.0).gains(1)), **servo_params(design(1.0, 12.0).gains(2))}


def hybrid_sensor():
    return ControllerConfig(XY, law='hybrid', law_params=FORCE, effort_limit=[200.0, 200.0])


def test_a_state_by_name_gets_the_core_torque_on_the_stamp_time_line():
    """Joints matched by name (extra joints ignored); the time is s since the first stamp."""
    ctrl, core = Controller(polar(), 0.5), ControllerCore(polar())
    q, qd = np.array([0.3, 0.7]), np.array([0.1, -0.2])
    for k in range(5):
        cmd = ctrl.step(7_000 * MS + k * MS, ['gripper', 'r', 'theta1'], [0.0, q[1], q[0]], [0.0, qd[1], qd[0]])
        assert type(cmd) is Command and cmd.stamp_ns == 7_000 * MS + k * MS
        np.testing.assert_array_equal(cmd.tau, core.update(k * 1e-3, q, qd))
        assert cmd.values == cmd.tau.tolist()
    assert ctrl.core.t == pytest.approx(0.004)


@pytest.mark.parametrize('names, pos, stamp, field', [
    (['theta1'], [0.1], 1 * MS, 'name'),
    (['theta1', 'r'], [0.1, np.nan], 1 * MS, 'position'),
    (['theta1', 'r'], [0.1, 0.5], 900 * MS, 'header.stamp'),          # 0.9 s after the last: > state_timeout
])
def test_a_bad_state_is_rejected_naming_the_field_and_counted(names, pos, stamp, field):
    ctrl = Controller(polar(), 0.5)
    ctrl.step(0, ['theta1', 'r'], [0.1, 0.5], [0.0, 0.0])
    out = ctrl.step(stamp, names, pos, [0.0] * len(names))
    assert type(out) is Rejection and out.source == 'joint_states' and out.reason.startswith(f'{field}:')
    assert ctrl.counters.rejected['joint_states'] == 1 and ctrl.counters.last_rejection.startswith('joint_states:')


def test_a_paired_state_waits_for_the_wrench_of_its_own_stamp():
    """The hybrid law on a sensor: each state is answered with the force stamped like it, whichever
    reader delivered first; the answer equals step() given that wrench."""
    ctrl, ref = Controller(hybrid_sensor(), 0.5), Controller(hybrid_sensor(), 0.5)
    names, q, qd = ['x', 'y'], [0.3002, 0.1], [0.0, 0.01]
    waited = list(ctrl.state_arrived(0, names, q, qd, wrench_publisher=lambda: True))
    assert waited == [] and ctrl.waiting
    [cmd] = ctrl.wrench_arrived(0, np.array([2.0, 0.0]))
    np.testing.assert_array_equal(cmd.tau, ref.step(0, names, q, qd, wrench=[2.0, 0.0]).tau)
    assert list(ctrl.wrench_arrived(MS, np.array([2.5, 0.0]))) == []          # the wrench came first
    [cmd] = ctrl.state_arrived(MS, names, q, qd)
    np.testing.assert_array_equal(cmd.tau, ref.step(MS, names, q, qd, wrench=[2.5, 0.0]).tau)
    assert list(ctrl.state_arrived(2 * MS, names, q, qd)) == [] and ctrl.waiting
    [cmd] = ctrl.wait_over()                                                  # its wrench never came
    np.testing.assert_array_equal(cmd.tau, ref.step(2 * MS, names, q, qd).tau)   # the last force measured
    assert not ctrl.waiting


def test_a_law_without_the_measured_force_answers_at_once_and_a_switch_releases_a_waiting_state():
    ctrl = Controller(hybrid_sensor(), 0.5)
    names, q = ['x', 'y'], [0.3002, 0.1]
    assert list(ctrl.state_arrived(0, names, q, [0.0, 0.0], wrench_publisher=lambda: True)) == []
    released = list(ctrl.configure(ctrl.config.replace(law_params=dict(FORCE, force_feedback='model'))))
    assert len(released) == 1 and released[0].stamp_ns == 0 and not ctrl.needs_wrench
    assert len(list(ctrl.state_arrived(MS, names, q, [0.0, 0.0]))) == 1


def test_the_watchdog_trips_once_and_a_state_after_a_clock_jump_restarts_the_law_from_there():
    """A trip commands nothing until a state comes; one stamped beyond state_timeout of the last answered one
    restarts the law from its position (the reference holds it)."""
    ctrl = Controller(polar(), 0.5)
    assert type(ctrl.step(0, ['theta1', 'r'], [0.1, 0.5], [0.0, 0.0])) is Command
    assert not ctrl.sent(0, 0, 1000)
    assert not ctrl.check_watchdog(400 * MS, 400 * MS)
    assert ctrl.check_watchdog(400 * MS, 600 * MS) and ctrl.watchdog.tripped
    assert not ctrl.check_watchdog(400 * MS, 700 * MS)                          # trips once
    assert type(ctrl.step(5_000 * MS, ['theta1', 'r'], [0.2, 0.5], [0.0, 0.0])) is Command   # clock jumped: accepted
    assert ctrl.sent(5_000 * MS, 5_000 * MS, 1000) == RESTARTED and ctrl.core.restarts == 1
    np.testing.assert_array_equal(ctrl.core.joint_reference[0], [0.2, 0.5])
    assert ctrl.counters.commands_sent == 2 and ctrl.counters.tick_count == 2
    levels = [s[1] for s in ctrl.statuses('c', 5_000 * MS, 5_000 * MS)]
    assert levels[0] == 'OK'


def test_states_back_at_the_robots_next_tick_resume_the_law_where_it_was():
    """A trip while the robot's own time stood still (a lockstep simulator held up with the machine): the next
    state, stamped one period after the last answered one, resumes the law. Its reference (a move under way) and
    its integral go on: the same torque, bit for bit, as from a controller that saw no trip; a later trip whose
    next state comes more than state_timeout on restarts from that state."""
    names = ['theta1', 'r']
    ctrls = [Controller(polar().replace(integral=True), 0.5) for _ in range(2)]
    q = lambda k: [0.1 + 1e-4 * k, 0.5 + 5e-5 * k]                              # noqa: E731
    for k in range(50):
        taus = [ctrl.step(k * MS, names, q(k), [0.1, 0.05]).tau.copy() for ctrl in ctrls]
        for ctrl in ctrls:
            ctrl.sent(k * MS, k * MS, 1000)
            if k == 0:
                ctrl.core.set_trajectory([1.0], [[0.4, 0.6]])
        np.testing.assert_array_equal(*taus)
    tripped = ctrls[0]
    assert tripped.check_watchdog(49 * MS, 49 * MS + 600 * MS) and tripped.watchdog.tripped
    assert np.all(tripped.core.integral_value != 0.0)
    for k in range(50, 60):
        taus = [ctrl.step(k * MS, names, q(k), [0.1, 0.05]).tau.copy() for ctrl in ctrls]
        assert tripped.sent(k * MS, k * MS, 1000) == (RESUMED if k == 50 else None)
        np.testing.assert_array_equal(*taus)
    assert tripped.core.restarts == 0 and tripped.watchdog.trips == 1
    assert tripped.check_watchdog(59 * MS, 59 * MS + 600 * MS)
    assert type(tripped.step(700 * MS, names, q(60), [0.1, 0.05])) is Command
    assert tripped.sent(700 * MS, 700 * MS, 1000) == RESTARTED and tripped.core.restarts == 1
    np.testing.assert_array_equal(tripped.core.joint_reference[0], q(60))     # holds where the robot is


@pytest.mark.parametrize('back_ms', [300, 760, 1000, 1400])
def test_a_restarted_clock_within_state_timeout_of_the_last_state_restarts_the_law(back_ms):
    """A simulator killed at t = 1.05 s and started again: its clock starts at 0, and under load the controller
    may first see a state stamped near the last answered one (before it, or after it, within state_timeout).
    Not the robot's next tick: the law restarts from that state (the reference holds it, the integral is 0)."""
    names = ['theta1', 'r']
    ctrl = Controller(polar().replace(integral=True), 0.5)
    for k in range(1000, 1051):
        ctrl.step(k * MS, names, [0.1 + 1e-4 * (k - 1000), 0.5], [0.1, 0.0])
        ctrl.sent(k * MS, k * MS, 1000)
    ctrl.core.set_trajectory([1.0], [[0.4, 0.6]])
    ctrl.step(1051 * MS, names, [0.106, 0.5], [0.1, 0.0])
    ctrl.sent(1051 * MS, 1051 * MS, 1000)
    assert ctrl.check_watchdog(1051 * MS, 1051 * MS + 600 * MS)
    assert type(ctrl.step(back_ms * MS, names, [0.1, 0.5], [0.0, 0.0])) is Command
    assert ctrl.sent(back_ms * MS, back_ms * MS, 1000) == RESTARTED and ctrl.core.restarts == 1
    np.testing.assert_array_equal(ctrl.core.joint_reference[0], [0.1, 0.5])
    assert np.all(ctrl.core.integral_value == 0.0) and np.all(ctrl.core.error[0] == 0.0)


# -- the law's warnings for the node's log ------------------------------------------------------------------
def test_a_law_that_keeps_falling_back_is_a_warning_once_per_period_with_the_count_and_the_reason():
    """Impedance on the planar arm stretched out (a singular Jacobian): every tick falls back to g(q). The
    first look opens the window; a look before its end says nothing; the look after it counts its ticks."""
    planar = make_model('planar_two_link')
    ctrl = Controller(ControllerConfig(planar, law='impedance'), 0.5)
    period = ctrl.law_watch.period_ns
    stretched = [0.3, 0.0]
    ctrl.step(0, planar.joint_names, stretched, [0.0, 0.0])
    assert ctrl.law_warning(0) is None                          # the window opens
    for k in range(1, 40):
        ctrl.step(k * MS, planar.joint_names, stretched, [0.0, 0.0])
    assert ctrl.law_warning(period - 1) is None                 # not over yet
    warning = ctrl.law_warning(period)
    assert warning.startswith('law impedance failed and fell back to the gravity hold g(q) in 39 of the last 39 '
                              'ticks (last: q: task Jacobian singular'), warning
    assert ctrl.law_warning(period + 1) is None                 # throttled: the next window has begun
    ctrl.step(40 * MS, planar.joint_names, [0.3, 0.8], [0.0, 0.0])
    assert ctrl.law_warning(2 * period) is None                 # a window without a fallback says nothing


def test_a_law_that_keeps_saturating_is_named_with_its_joints_a_few_saturated_ticks_are_not():
    """Effort limits of 0.5 N m / N hold nothing: every tick saturates both joints. One saturated tick in
    200 (below SATURATION_WARN_FRACTION) is no warning."""
    from robot_control.core.status import SATURATION_WARN_FRACTION
    weak = Controller(polar().replace(effort_limit=[0.5, 0.5]), 0.5)
    weak.law_warning(0)
    for k in range(30):
        weak.step(k * MS, ['theta1', 'r'], [0.3, 0.7], [0.0, 0.0])
    assert weak.law_warning(weak.law_watch.period_ns) == ('law computed_torque saturated the effort limits in 30 of '
                                                          'the last 30 ticks (theta1 in 30, r in 30)')
    ctrl = Controller(polar(), 0.5)
    ctrl.law_warning(0)
    ctrl.step(0, ['theta1', 'r'], [0.3, 0.7], [0.0, 50.0])        # 50 m/s: the damping asks for more than 200 N
    for k in range(1, 200):
        ctrl.step(k * MS, ['theta1', 'r'], [0.3, 0.7], [0.0, 0.0])
    assert ctrl.core.saturated_ticks == 1 and 1 < SATURATION_WARN_FRACTION * 200
    assert ctrl.law_warning(ctrl.law_watch.period_ns) is None
