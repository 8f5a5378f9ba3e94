"""Bridge pacing, command checks and parameter validation without ROS (sim_bridge.loop, bridge_params)."""
import array
import math

import numpy as np
import pytest

from sim_bridge import parameters as bridge_params
from robot_control.ros.throttle import Throttle
from sim_bridge.loop import (CommandMapper, CommandWatchdog, LockstepGate, RateMeter, RealtimePacer,
                               SourceGuard, stamp_ns)

MS = 1_000_000


# -- RealtimePacer ---------------------------------------------------------------------------
def test_pacer_runs_ticks_as_wall_time_passes():
    p = RealtimePacer(MS, 1.0)
    p.anchor(wall_ns=5_000 * MS, ticks_done=0)
    assert p.due(5_000 * MS, 0) == 0
    assert p.due(5_000 * MS + MS - 1, 0) == 0        # never ahead of the wall clock
    assert p.due(5_000 * MS + MS, 0) == 1
    assert p.due(5_000 * MS + 10 * MS + 5, 3) == 7   # catches up what is due


def test_pacer_real_time_factor_scales_wall_time():
    p = RealtimePacer(MS, 2.0)
    p.anchor(0, 0)
    assert p.due(10 * MS, 0) == 20
    p.set_real_time_factor(0.5, wall_ns=10 * MS, ticks_done=20)
    assert p.due(12 * MS, 20) == 1
    assert p.next_due_wall_ns(21) == 14 * MS


def test_pacer_long_run_factor_is_exact():
    p = RealtimePacer(MS, 1.0)
    p.anchor(0, 0)
    ticks = 0
    wall = 0
    rng = np.random.default_rng(0)
    while wall < 10_000 * MS:                         # 10 s of jittery timer wake-ups
        wall += int(rng.uniform(0.2, 3.0) * MS)
        ticks += p.due(wall, ticks)
    assert abs(ticks * MS / wall - 1.0) < 1e-3
    assert p.overruns == 0


def test_pacer_reanchors_after_a_stall_instead_of_bursting():
    p = RealtimePacer(MS, 1.0, max_lag_ns=100 * MS)
    p.anchor(0, 0)
    assert p.due(500 * MS, 0) == 1
    assert p.overruns == 1
    assert p.due(500 * MS + MS, 1) == 1


@pytest.mark.parametrize('rtf', [0.0, -1.0, math.nan, math.inf])
def test_pacer_rejects_bad_factor(rtf):
    with pytest.raises(ValueError, match='^real_time_factor'):
        RealtimePacer(MS, rtf)


# -- watchdog, gate, guard, throttle, rate ------------------------------------------------------
def test_watchdog_stale_in_simulation_time():
    w = CommandWatchdog(50 * MS)
    assert w.stale(0) and w.age_ns(0) is None
    w.fresh(10 * MS)
    assert not w.stale(60 * MS)
    assert w.stale(60 * MS + 1)
    assert w.age_ns(30 * MS) == 20 * MS
    w.clear()
    assert w.stale(10 * MS)


def test_watchdog_calls_a_command_answering_an_old_state_outdated():
    w = CommandWatchdog(50 * MS)
    assert not w.outdated(100 * MS, 50 * MS)            # exactly command_timeout old: still in time
    assert w.outdated(100 * MS, 50 * MS - 1)
    assert not w.outdated(100 * MS, 0)                  # unstamped
    assert not w.outdated(100 * MS, 200 * MS)           # ahead (another time base): not this check's business
    assert not w.outdated(10 * MS, 1)                   # younger than command_timeout since the start


def test_lockstep_gate_matches_only_the_expected_stamp():
    g = LockstepGate()
    g.expect(stamp_ns(1, 500))
    assert g.classify(stamp_ns(1, 500)) == LockstepGate.MATCH
    assert g.classify(stamp_ns(1, 499)) == LockstepGate.LATE
    assert g.classify(stamp_ns(2, 0)) == LockstepGate.FUTURE
    assert (g.late, g.future) == (1, 1)


def test_guard_single_publisher_never_conflicts():
    g = SourceGuard(50 * MS, ('a', 'b'))
    g.set_count(0, 1)
    assert all(g.check(0, i * MS) for i in range(200))
    assert g.conflicts == 0 and not g.in_conflict(200 * MS)


def test_guard_two_publishers_conflict_until_one_is_left():
    g = SourceGuard(50 * MS, ('a', 'b'))
    g.set_count(0, 1)
    assert g.check(0, 0)
    g.set_count(0, 2)
    assert not g.check(0, MS) and not g.check(0, 10 * MS)
    assert g.conflicts == 1 and g.reason == '2 publishers on a'
    g.set_count(0, 1)                                  # the second one left the graph
    assert not g.check(0, 60 * MS)                     # evidence at 10 ms still holds for the timeout
    assert g.check(0, 10 * MS + 50 * MS + 1)
    assert g.conflicts == 1


def test_guard_two_topics_conflict():
    g = SourceGuard(50 * MS, ('a', 'b'))
    g.set_count(0, 1)
    g.set_count(1, 1)
    assert g.check(0, 0)
    assert not g.check(1, 10 * MS)
    assert g.reason == 'commands on both a and b'
    assert g.in_conflict(60 * MS) and not g.in_conflict(60 * MS + 1)
    g.reset()                                          # simulation time restarts
    assert g.check(1, 0)


def test_throttle_and_rate_meter():
    t = Throttle(1000)
    assert t.ready(0) and not t.ready(999) and t.ready(1000)
    assert t.suppressed == 1
    r = RateMeter()
    r.reset(0, 0)
    assert r.read(2 * MS, MS) == pytest.approx(0.5)
    assert r.read(2 * MS, 5 * MS) is None              # no wall time passed


# -- CommandMapper -----------------------------------------------------------------------------
def test_mapper_maps_by_name_in_any_order():
    m = CommandMapper(('a', 'b', 'c'))
    assert m.map_named(['c', 'a', 'b'], [3.0, 1.0, 2.0]) is None
    assert m.tau.tolist() == [1.0, 2.0, 3.0]
    assert m.map_named(['a', 'b', 'c'], [4.0, 5.0, 6.0]) is None
    assert m.tau.tolist() == [4.0, 5.0, 6.0]
    assert m.map_array(np.array([7.0, 8.0, 9.0])) is None
    assert m.tau.tolist() == [7.0, 8.0, 9.0] and m.accepted == 3
    # what the bridge decodes (a cdr frame's tuple) and what a message holds (array('d')); ints are numbers
    for efforts in ((3.0, 1.0, 2.0), array.array('d', [3.0, 1.0, 2.0]), (3, 1, True), np.array([3, 1, 2])):
        assert m.map_named(['c', 'a', 'b'], efforts) is None
        assert m.values == [1.0, float(efforts[2]), 3.0] and all(type(v) is float for v in m.values)
    assert m.map_named(['c', 'a', 'b'], (math.nan, 1.0, 2.0)).startswith('effort')


@pytest.mark.parametrize('names, efforts, kind, field', [
    (['a', 'x', 'c'], [1.0, 2.0, 3.0], 'unknown_joint', 'name'),
    (['a', 'b'], [1.0, 2.0], 'missing_joint', 'name'),
    (['a', 'a', 'b'], [1.0, 2.0, 3.0], 'duplicate_joint', 'name'),
    (['a', 'b', 'c'], [1.0, 2.0], 'length', 'effort'),
    (['a', 'b', 'c'], [], 'length', 'effort'),
    (['a', 'b', 'c'], [1.0, math.nan, 3.0], 'non_finite', 'effort'),
    (['c', 'b', 'a'], [1.0, 2.0, -math.inf], 'non_finite', 'effort'),
])
def test_mapper_rejects_bad_commands_and_keeps_the_last_valid(names, efforts, kind, field):
    m = CommandMapper(('a', 'b', 'c'))
    assert m.map_named(['a', 'b', 'c'], [1.0, 1.0, 1.0]) is None
    reason = m.map_named(names, efforts)
    assert reason.startswith(field)
    assert m.rejected[kind] == 1 and m.rejected_total == 1 and m.last_reason == reason
    assert m.tau.tolist() == [1.0, 1.0, 1.0]


def test_mapper_rejects_bad_arrays():
    m = CommandMapper(('a', 'b'))
    assert m.map_array([1.0]).startswith('data')
    assert m.map_array([1.0, math.inf]).startswith('effort')
    assert m.rejected == {'unknown_joint': 0, 'missing_joint': 0, 'duplicate_joint': 0,
                          'length': 1, 'non_finite': 1}
    assert m.tau.tolist() == [0.0, 0.0]


# -- parameters ---------------------------------------------------------------------------------
def test_defaults_validate_for_every_scenario():
    from robot_control import scenarios
    for name, sc in scenarios.SCENARIOS.items():
        cfg = bridge_params.validate(bridge_params.defaults(name))
        assert cfg.joints == sc.joints
        assert cfg.initial_positions.tolist() == list(sc.q0)
        assert cfg.surface_enable == (sc.surface is not None)
        assert cfg.substeps == 1 and cfg.physics_step_ns == MS and cfg.command_timeout_ns == 50 * MS
        assert set(cfg.sim_params) >= set(sc.params)


def test_every_parameter_has_a_description():
    for spec in bridge_params.robot_specs() + [bridge_params.joints_spec('iiwa')] + bridge_params.specs('iiwa', 7):
        assert spec.description and spec.kind in ('bool', 'double', 'string', 'double_array', 'string_array')
        assert spec.read_only == (spec.name not in bridge_params.DYNAMIC)


def test_control_period_multiple_of_physics_step():
    cfg = bridge_params.validate(bridge_params.defaults(physics_step=0.0005, control_period=0.002))
    assert cfg.substeps == 4 and cfg.control_period_ns == 2 * MS
    with pytest.raises(ValueError, match='^control_period: expected an integer multiple'):
        bridge_params.validate(bridge_params.defaults(physics_step=0.001, control_period=0.0015))


@pytest.mark.parametrize('changes, name', [
    ({'scenario': 'nope'}, 'scenario'),
    ({'urdf': '/no/such/robot.urdf'}, 'urdf'),
    ({'joints': ['theta1', 'z']}, 'joints'),
    ({'initial_positions': [0.0]}, 'initial_positions'),
    ({'initial_positions': [0.0, math.nan]}, 'initial_positions'),
    ({'mode': 'fast'}, 'mode'),
    ({'physics_step': 0.0}, 'physics_step'),
    ({'physics_step': 1e-10}, 'physics_step'),
    ({'control_period': -0.001}, 'control_period'),
    ({'real_time_factor': 0.0}, 'real_time_factor'),
    ({'command_timeout': 0.001}, 'command_timeout'),
    ({'lockstep_timeout': math.inf}, 'lockstep_timeout'),
    ({'surface.enable': True}, 'surface.enable'),
    ({'disturbance.joint_torque': [1.0]}, 'disturbance.joint_torque'),
    ({'disturbance.cartesian_force': [0.0, math.nan, 0.0]}, 'disturbance.cartesian_force'),
    ({'sim_params.m': -2.0}, 'sim_params.m'),
    ({'wrench_frame_id': ''}, 'wrench_frame_id'),
    ({'diagnostics_period': 0.0}, 'diagnostics_period'),
])
def test_bad_parameters_are_named(changes, name):
    with pytest.raises(ValueError) as err:
        bridge_params.validate(bridge_params.defaults('polar_two_link', **changes))
    assert str(err.value).startswith(name + ':')


def test_custom_urdf_needs_urdf_and_joints():
    with pytest.raises(ValueError, match='^urdf: required'):
        bridge_params.validate(bridge_params.defaults(''))
    with pytest.raises(ValueError, match='^joints: required'):
        bridge_params.validate(bridge_params.defaults('', urdf='kuka_iiwa/model.urdf'))
    cfg = bridge_params.validate(bridge_params.defaults(
        '', urdf='kuka_iiwa/model.urdf', joints=['lbr_iiwa_joint_1', 'lbr_iiwa_joint_2']))
    assert cfg.n == 2 and cfg.initial_positions.tolist() == [0.0, 0.0] and not cfg.surface_enable
    assert cfg.urdf.endswith('kuka_iiwa/model.urdf')


def test_deadline_meter_counts_answers_before_the_next_step():
    from sim_bridge.loop import DeadlineMeter
    meter = DeadlineMeter(window=8)
    assert meter.latency_ms(50) is None
    meter.state(0, 1_000_000)
    meter.command(0, 1_400_000)          # answers state 0 after 0.4 ms
    meter.step(0)                        # hit
    meter.state(1_000_000, 2_000_000)
    meter.step(1_000_000)                # no answer yet: miss
    meter.command(1_000_000, 3_100_000)  # too late for that step, still a latency sample
    meter.state(2_000_000, 3_000_000)
    meter.command(1_000_000, 3_200_000)  # answers an old state: ignored
    assert (meter.hits, meter.misses) == (1, 1)
    assert meter.latency_ms(50) == pytest.approx((0.4 + 1.1) / 2)
