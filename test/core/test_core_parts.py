"""The control core's parts on their own: the law registry, the time line, the watchdog, the
pairing of states with their wrenches, and the diagnostics content."""
import math

import numpy as np
import pytest

from robot_control import laws
from robot_control.core.config import ControllerConfig
from robot_control.core.tick import ControllerCore
from robot_control.core.pairing import WrenchPairing
from robot_control.core.status import Counters, controller_statuses
from robot_control.core.timeline import Timeline
from robot_control.core.watchdog import StateWatchdog
from robot_control.gains import ServoGains, design
from robot_control.laws import LAWS, Law, gravity_compensation
from robot_control.laws.force_task import gain_params
from robot_control.laws.servo import MotionServo, MotionServoParams
from robot_control.laws.servo import gain_params as servo_params
from robot_control.models import make_model
from robot_control.validation import ArgumentError

POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
MS = 1_000_000


# -- the registry ----------------------------------------------------------------------------------
def test_the_registry_names_every_law_and_each_says_what_it_needs():
    assert list(LAWS) == ['computed_torque', 'independent_joint', 'force', 'hybrid', 'gravity_compensation',
                          'impedance', 'joint_impedance', 'adaptive_computed_torque']
    for name, law in LAWS.items():
        assert law.name == name and issubclass(law, Law)
        assert law.tracks in ('joint', 'task', None)
    assert LAWS['hybrid'].needs_task_space and LAWS['hybrid'].uses_force
    assert not LAWS['computed_torque'].needs_task_space and LAWS['independent_joint'].torque_gains
    with pytest.raises(ArgumentError, match="^law: unknown 'pid'") as info:
        laws.law_class('pid')
    assert info.value.name == 'law'


def test_gravity_compensation_is_g_of_q_every_tick_and_the_arm_floats():
    """tau = g(q) whatever the reference; with the model as the plant the arm stays where it is put."""
    core = ControllerCore(ControllerConfig(POLAR, law='gravity_compensation'))
    q, qd = np.array([0.4, 0.8]), np.zeros(2)
    for k in range(200):                                  # 1 ms ticks, semi-implicit Euler on the model
        tau = core.update(k * 1e-3, q, qd)
        np.testing.assert_array_equal(tau, POLAR.g(q))
        qd = qd + 1e-3 * POLAR.forward_dynamics(q, qd, tau)
        q = q + 1e-3 * qd
    np.testing.assert_allclose(q, [0.4, 0.8], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(gravity_compensation(POLAR, [0.4, 0.8]), POLAR.g([0.4, 0.8]))
    assert core.integral_value.shape == (0,)


def test_switching_to_gravity_compensation_and_back_restarts_the_reference_from_where_the_arm_is():
    d = design(1.0, 12.0)
    core = ControllerCore(ControllerConfig(POLAR, law_params=servo_params(d.gains(2))))
    core.update(0.0, np.array([0.2, 0.6]), np.zeros(2))
    core.configure(core.config.replace(law='gravity_compensation', law_params=None))
    core.update(0.001, np.array([0.3, 0.7]), np.zeros(2))        # the arm was moved by hand
    core.configure(core.config.replace(law='computed_torque', law_params=servo_params(d.gains(2))))
    core.update(0.002, np.array([0.5, 0.9]), np.zeros(2))
    np.testing.assert_array_equal(core.joint_reference[0], [0.5, 0.9])   # holds where it is, no pull back


class _Damping(Law):
    """A law the core has never heard of: tau = g(q) - Kd qd (kv as Kd, N m s/rad)."""

    name = 'damping'
    tracks = None
    parts = (MotionServo,)
    Params = MotionServoParams

    @property
    def integral_dim(self):
        return 0

    def torque(self, state, ref, err, int_E):
        return self.model._g(state.q) - self.motion_gains.kv * state.qd


def test_a_law_is_one_class_and_one_registry_entry(monkeypatch):
    monkeypatch.setitem(LAWS, 'damping', _Damping)
    core = ControllerCore(ControllerConfig(POLAR, law='damping',
                                           law_params=servo_params(ServoGains.uniform(2, 0.0, 3.0))))
    q, qd = np.array([0.1, 0.5]), np.array([1.0, -2.0])
    np.testing.assert_allclose(core.update(0.0, q, qd), POLAR.g(q) - 3.0 * qd, rtol=0, atol=1e-12)


# -- the time line ------------------------------------------------------------------------------------
def test_the_time_line_starts_at_the_first_stamp_even_zero():
    line = Timeline(0.5)
    assert line.accept(0, running=False) == 0.0             # a simulation's first instant
    assert line.accept(MS, running=True) == pytest.approx(0.001)
    assert line.time_of(0) is None and line.time_of(3 * MS) == pytest.approx(0.003)
    assert line.ahead(5 * MS) and not line.ahead(MS) and not line.ahead(0)


def test_the_time_line_refuses_jumps_while_running_and_negative_stamps():
    line = Timeline(0.5)
    line.accept(10 * 1000 * MS, running=False)
    with pytest.raises(ArgumentError, match=r'^header.stamp: -10 s from the previous state') as info:
        line.accept(0, running=True)
    assert info.value.name == 'header.stamp'
    assert line.accept(0, running=False) == pytest.approx(-10.0)   # after the watchdog: accepted, time went back
    with pytest.raises(ArgumentError, match='negative time'):
        line.accept(-1, running=False)


def test_a_state_follows_the_last_one_when_it_is_the_robots_next_tick():
    """The robot's tick is the last forward step within max_jump; the same stamp or up to two ticks later
    follows, anything else does not (a restarted clock near the last stamp, a jump, time going back)."""
    line = Timeline(0.5)
    assert not line.follows(0)                                   # nothing accepted yet
    line.accept(1000 * MS, running=False)
    assert not line.follows(1001 * MS)                           # one state: no tick known yet
    line.accept(1001 * MS, running=True)
    assert line.follows(1001 * MS) and line.follows(1002 * MS) and line.follows(1003 * MS)
    assert not line.follows(1004 * MS) and not line.follows(1300 * MS) and not line.follows(700 * MS)
    line.accept(0, running=False)                                # a clock reset does not set the tick
    assert line.step_ns == MS and line.follows(MS) and not line.follows(3 * MS)


# -- the watchdog ---------------------------------------------------------------------------------------
def test_the_watchdog_trips_on_the_larger_age_of_the_two_clocks_and_recovers():
    dog = StateWatchdog(0.5)
    assert not dog.check(0, 0) and dog.age(0, 0) is None
    assert not dog.fresh(1000 * MS, 1000 * MS)
    assert not dog.check(1000 * MS, 1400 * MS)               # 0.4 s on the steady clock
    assert dog.check(1000 * MS, 1600 * MS)                   # sim time stood still; the steady clock counts
    assert dog.tripped and dog.trips == 1 and not dog.check(1000 * MS, 2000 * MS)   # trips once
    assert dog.age(1000 * MS, 2000 * MS) == pytest.approx(1.0)
    assert dog.fresh(1001 * MS, 2001 * MS) and not dog.tripped   # recovery reported once


def test_a_state_answered_before_the_node_clock_started_ages_on_the_steady_clock_alone():
    dog = StateWatchdog(0.5)
    dog.fresh(0, 1000 * MS)                  # use_sim_time, no /clock yet: ROS time reads 0
    # the first /clock arrives with the simulator at 1.39 s, before the next state: not an age of 1.39 s
    assert not dog.check(1390 * MS, 1001 * MS) and dog.age(1390 * MS, 1001 * MS) == pytest.approx(0.001)
    assert not dog.check(1390 * MS, 1401 * MS)
    assert dog.check(1390 * MS, 1501 * MS)   # the steady clock still counts
    dog.fresh(1391 * MS, 1502 * MS)          # answered once the clock runs: both clocks count again
    assert dog.check(1892 * MS, 1503 * MS) and dog.age(1892 * MS, 1503 * MS) == pytest.approx(0.501)


def test_a_check_that_comes_late_finds_its_process_held_up_and_leaves_the_trip_to_the_next():
    held, silent = StateWatchdog(0.5), StateWatchdog(0.5)
    assert held.period == pytest.approx(0.1)
    for dog in (held, silent):
        dog.fresh(0, 0)
        assert not dog.check(0, 100 * MS)
        # the process was held up for 0.6 s: a state may wait unread behind this check
        assert not dog.check(0, 700 * MS) and not dog.tripped and dog.late_checks == 1
    assert not held.fresh(0, 701 * MS)                          # one did: read right after, no trip
    assert not held.check(0, 800 * MS) and held.trips == 0
    assert silent.check(0, 800 * MS) and silent.trips == 1      # none did: the next check, on time, trips
    assert silent.late_checks == 1


def test_the_check_period_is_a_fifth_of_the_timeout_and_at_least_a_millisecond():
    assert StateWatchdog(2.0).period == pytest.approx(0.4)
    assert StateWatchdog(0.001).period == pytest.approx(0.001)


# -- pairing states with their wrenches -------------------------------------------------------------------
def test_a_paired_state_waits_for_its_wrench_and_goes_when_it_comes():
    p = WrenchPairing()
    assert p.state(0, 's0', publisher=True) == [] and p.held == (0, 's0')   # the first: a publisher is there
    assert p.wrench(0) == ['s0']
    assert p.state(MS, 's1') == []                                         # paired: wrench 0 = state 0
    assert p.wrench(MS) == ['s1']
    assert p.wrench(2 * MS) == [] and p.state(2 * MS, 's2') == ['s2']      # its wrench came first: at once


def test_an_unpaired_or_late_wrench_stream_is_not_waited_for_again():
    p = WrenchPairing()
    assert p.state(0, 's0') == ['s0']                      # no publisher known: no wait
    assert p.state(MS, 's1') == ['s1']                     # no wrench at all: unpaired
    p.wrench(0)                                            # a wrench of an old tick
    assert p.state(2 * MS, 's2') == ['s2']                 # 0 != 1 ms: unpaired
    p.wrench(2 * MS)
    assert p.state(3 * MS, 's3') == [] and p.release() == ['s3']   # paired again; the wait ran out
    assert p.state(4 * MS, 's4') == ['s4']                 # its wrench never came: not waited for again


def test_a_held_state_coming_again_keeps_waiting_for_its_wrench():
    """A lockstep simulator re-publishes the state it has no answer for: the state still waits for its wrench."""
    p = WrenchPairing()
    p.state(0, 's0', publisher=True)
    assert p.state(0, 's0 again') == [] and p.held == (0, 's0')
    assert p.wrench(0) == ['s0'] and p.held is None


def test_a_new_state_releases_a_held_one_first():
    p = WrenchPairing()
    p.state(0, 's0', publisher=True)
    assert p.state(MS, 's1') == ['s0', 's1'] and p.held is None


# -- diagnostics content --------------------------------------------------------------------------------------
def test_the_statuses_report_watchdog_saturation_rejections_and_the_law():
    core = ControllerCore(ControllerConfig(POLAR, law_params=servo_params(design(1.0, 12.0).gains(2)),
                                           effort_limit=[5.0, 50.0]))
    core.update(0.0, np.array([0.0, 0.5]), np.zeros(2))          # gravity 9.8 N m > 5: saturates
    dog, counters = StateWatchdog(0.5), Counters(('joint_states',))
    counters.reject('joint_states', 'position: not finite')
    statuses = controller_statuses('controller', core, dog, None, counters)
    names = [s[0] for s in statuses]
    assert names == ['controller: joint_states watchdog', 'controller: effort saturation',
                     'controller: rejected inputs', 'controller: control law', 'controller: trajectory']
    levels = {s[0].split(': ')[1]: s[1] for s in statuses}
    assert levels == {'joint_states watchdog': 'WARN', 'effort saturation': 'WARN', 'rejected inputs': 'WARN',
                      'control law': 'OK', 'trajectory': 'OK'}
    assert "saturated: ['theta1']" in statuses[1][2] and 'position: not finite' in statuses[2][2]
    dog.fresh(0, 0)
    dog.check(0, 10 ** 9)
    assert controller_statuses('controller', core, dog, 1.0, counters)[0][1] == 'ERROR'
    assert math.isclose(dict(statuses[1][3])['effort_limit.theta1'], 5.0)
    core.goal.start(1.0)
    core.goal.check(0.5, np.zeros(2), np.zeros(2), np.ones(2), core.config.replace(trajectory_tolerance=0.1).tolerances)
    trajectory = controller_statuses('controller', core, dog, 1.0, counters)[4]
    assert trajectory[1] == 'ERROR' and 'trajectory 1 path: trajectory tolerance exceeded' in trajectory[2]


def test_the_law_status_names_the_force_axes():
    """A bag reader tells the force axes from the motion axes of ~/reference by this key."""
    d = design(1.0, 12.0)
    hybrid = ControllerCore(ControllerConfig(make_model('cartesian_xy', m1=1.0, m2=1.0, gravity=9.81), law='hybrid',
                                             law_params={**servo_params(d.gains(2)), 'force_axes': ('x',), 'k_e': [1000.0],
                                                         'x_e': [0.3],
                                                         'force_feedback': 'model', **gain_params(d.gains(1))}))
    joint = ControllerCore(ControllerConfig(POLAR, law_params=servo_params(d.gains(2))))
    for core, axes in ((hybrid, 'x'), (joint, '')):
        law = controller_statuses('controller', core, StateWatchdog(0.5), None, Counters(('joint_states',)))[3]
        assert dict(law[3])['force_axes'] == axes
