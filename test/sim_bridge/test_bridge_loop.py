"""The bridge without ROS: pacing pieces and command checks (sim_bridge.pacing), the loop's decisions over a
real World on each engine (sim_bridge.bridge_loop), parameter validation (sim_bridge.bridge_params)."""
import array
import dataclasses
import math
import re

import numpy as np
import pytest

from robot_control.models import make_model
from robot_control.laws.servo import gain_params
from robot_control.core.throttle import Throttle
from sim_bridge import bridge_params
from sim_bridge.bridge_loop import LockstepLoop, RealtimeLoop, make_loop
from sim_bridge.engines import ENGINES, make_world
from sim_bridge.pacing import (REJECT_REASONS, CommandMapper, CommandWatchdog, LockstepGate, RateMeter, RealtimePacer,
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


def test_guard_two_topics_conflict_holds_while_a_silent_source_stays_in_the_graph():
    """The controller on 'a' stalls for 200 ms (4 timeouts) while a rogue keeps sending on 'b': the rogue is
    refused throughout, since 'a' still shows a publisher; once 'b' has left the graph the conflict clears."""
    g = SourceGuard(50 * MS, ('a', 'b'))
    g.set_count(0, 1)
    g.set_count(1, 1)
    assert g.check(0, 0)
    assert not g.check(1, 5 * MS)                      # commands on both: the conflict starts
    assert not any(g.check(1, t * MS) for t in range(10, 210, 5))
    assert g.conflicts == 1 and g.reason == 'commands on both a and b'
    g.set_count(0, 0)                                  # the stalled controller left: the rogue is the only one
    assert not g.check(1, 210 * MS)                    # the evidence of 205 ms holds for the timeout
    assert g.check(1, 256 * MS)
    # the other way round: the rogue leaves, the controller's commands are applied after the timeout
    g.set_count(0, 1)
    g.reset()
    assert g.check(0, 0) is True and not g.check(1, 5 * MS)
    g.set_count(1, 0)
    assert not g.check(0, 50 * MS)                     # the rogue's last command came 45 ms before
    assert not g.check(0, 100 * MS) and g.check(0, 101 * MS)
    assert not g.in_conflict(101 * MS)


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


def test_every_parameter_has_a_description_and_only_pacing_disturbances_friction_and_pause_at_change_at_run_time():
    rows, _ = bridge_params.TABLE.resolve(lambda row: 'iiwa' if row.name == 'scenario' else row.default)
    for row in rows:
        assert row.description and row.type in ('bool', 'integer', 'double', 'string', 'double_array', 'string_array')
    assert {row.name for row in rows if not row.read_only} == {
        'real_time_factor', 'command_timeout', 'lockstep_timeout', 'disturbance.joint_torque',
        'disturbance.cartesian_force', 'diagnostics_period', 'pause_at', 'friction.coulomb', 'friction.viscous',
        'armature'}


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


@pytest.mark.parametrize('name, value', [('payload.mass', 1.0), ('disturbance.cartesian_force', [1.0, 0.0, 0.0])])
def test_what_acts_at_the_tip_is_refused_on_a_custom_robot_naming_the_parameter_that_gives_a_tip(name, value):
    """A custom URDF robot has no tip link: the refusal names this parameter and the one that gives a tip
    (scenario), not the World's keyword arguments."""
    custom = dict(urdf='kuka_iiwa/model.urdf', joints=['lbr_iiwa_joint_1', 'lbr_iiwa_joint_2'])
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}: needs a tip link .*\(parameter scenario\)") as err:
        bridge_params.validate(bridge_params.defaults('', **custom, **{name: value}))
    assert 'tip=' not in str(err.value)
    assert bridge_params.validate(bridge_params.defaults('iiwa', **{name: value}))


def test_deadline_meter_counts_answers_before_the_next_step():
    from sim_bridge.pacing import DeadlineMeter
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


# -- BridgeLoop: the node's decisions over a real World, a fake node and a fake wall clock -------------
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
JOINTS = ['theta1', 'r']
Q0 = np.array([0.0, 0.5])
HOLD = POLAR.g(Q0).tolist()                           # exactly g(q0): the robot stays where it is


class FakeNode:
    """What the node gives the loop: a wall clock the test sets (`now`, ns), publisher counts, and a
    record of the states, diagnostics and log lines it is asked for."""

    def __init__(self, world):
        self.world = world
        self.now = 1_000 * MS
        self.counts = [1, 0]
        self.counted = 0
        self.states = []                  # (t_ns, in_loop, with_clock, effort applied)
        self.diagnostics = 0
        self.logs = []                    # (level, text)
        self.timer_restarts = []          # wall ns of each restart_timer()

    def clock(self):
        return self.now

    def publish_state(self, in_loop, with_clock):
        self.states.append((self.world.t_ns, in_loop, with_clock, list(self.world.state_values()[2])))
        return self.now

    def count_publishers(self):
        self.counted += 1
        return list(self.counts)

    def publish_diagnostics(self):
        self.diagnostics += 1

    def log(self, level, text):
        self.logs.append((level, text))

    def restart_timer(self):
        self.timer_restarts.append(self.now)


@pytest.fixture(params=ENGINES)
def bridge(request):
    """bridge(**parameters) -> (loop, fake node): a started loop over a polar_two_link World, on each engine."""
    worlds = []

    def make(**params):
        cfg = bridge_params.validate(bridge_params.defaults('polar_two_link', engine=request.param, **params))
        worlds.append(make_world(cfg.engine, 'polar_two_link', dt=cfg.physics_step))
        node = FakeNode(worlds[-1])
        loop = make_loop(worlds[-1], cfg, publish_state=node.publish_state, count_publishers=node.count_publishers,
                         publish_diagnostics=node.publish_diagnostics, log=node.log, clock=node.clock,
                         restart_timer=node.restart_timer)
        loop.start()
        return loop, node
    yield make
    for w in worlds:
        w.close()


def statuses(loop):
    return {s.name: s for s in loop.diagnostics()}


def test_lockstep_answer_steps_once_and_publishes_the_next_state(bridge):
    loop, node = bridge(mode='lockstep')
    assert isinstance(loop, LockstepLoop)
    assert node.states == [(0, False, True, [0.0, 0.0])] and node.counted == 1     # first state, /clock
    push = (POLAR.g(Q0) + [0.0, 2.0]).tolist()
    loop.on_joint_command(0, ['r', 'theta1'], push[::-1])                          # by name, any order
    assert loop.world.t_ns == MS and loop.ticks == 1 and loop.mapper.accepted == 1
    assert node.states[-1] == (MS, True, False, push)                              # effort = torque applied
    for k in range(1, 12):
        loop.on_array_command(push)                                                # an array answers the latest
    assert [s[0] for s in node.states] == [k * MS for k in range(13)]
    assert [s[2] for s in node.states] == [k % 10 == 0 for k in range(13)]         # /clock every 10 ms


def test_lockstep_late_and_future_stamps_do_not_step(bridge):
    loop, node = bridge(mode='lockstep')
    loop.on_joint_command(0, JOINTS, HOLD)
    counted, published = node.counted, len(node.states)
    loop.on_joint_command(0, JOINTS, HOLD)                   # the state at 0 answered twice: late
    assert node.counted == counted + 1                       # the publishers are counted at once
    loop.on_joint_command(5 * MS, JOINTS, HOLD)              # answers nothing published yet
    assert (loop.gate.late, loop.gate.future) == (1, 1)
    assert loop.world.t_ns == MS and len(node.states) == published and loop.mapper.accepted == 1
    loop.on_joint_command(MS, JOINTS, HOLD)
    assert loop.world.t_ns == 2 * MS


def test_lockstep_bad_answer_still_steps_on_the_brakes_or_the_last_valid_command(bridge):
    loop, node = bridge(mode='lockstep')
    loop.on_joint_command(0, JOINTS, [math.nan, 0.0])
    assert loop.world.t_ns == MS and loop.world.braked and loop.brake_reason == 'no valid command yet'
    assert loop.mapper.rejected['non_finite'] == 1 and node.diagnostics == 1
    assert [lvl for lvl, text in node.logs if 'rejected command' in text] == ['warning']
    assert ('warning', 'brakes engaged at t = 0.000 s: no valid command yet') in node.logs
    loop.on_joint_command(MS, JOINTS, HOLD)
    assert not loop.brakes_engaged and not loop.world.braked and loop.brake_events == 2
    loop.on_joint_command(2 * MS, JOINTS, [0.0])                  # wrong length: HOLD stays in force
    assert loop.world.t_ns == 3 * MS and node.states[-1][3] == HOLD and loop.mapper.rejected['length'] == 1


def test_lockstep_republishes_when_no_answer_comes(bridge):
    loop, node = bridge(mode='lockstep', lockstep_timeout=0.02)
    node.now += 19 * MS
    loop.on_timer()
    assert len(node.states) == 1
    node.now += MS
    loop.on_timer()
    assert node.states[1][:2] == (0, False) and loop.republished == 1 and loop.world.t_ns == 0


def test_lockstep_pause_keeps_the_latest_answer_for_the_resume(bridge):
    loop, node = bridge(mode='lockstep')
    assert loop.pause(True) == 'paused at t = 0.000 s' and loop.paused
    push = (POLAR.g(Q0) + [0.0, 2.0]).tolist()
    loop.on_joint_command(0, JOINTS, HOLD)
    loop.on_joint_command(0, JOINTS, push)
    assert loop.world.t_ns == 0 and loop.mapper.accepted == 0
    node.now += 100 * MS                                     # a live robot standing still:
    loop.on_timer()                                          # the state every 0.1 s of wall time
    node.now += 50 * MS
    loop.on_timer()
    assert [s[:2] for s in node.states] == [(0, False), (0, False)]
    assert loop.pause(True) == 'already paused at t = 0.000 s'
    assert loop.pause(False) == 'resumed at t = 0.000 s'
    assert loop.world.t_ns == MS and node.states[-1] == (MS, True, False, push) and loop.mapper.accepted == 1
    loop.pause(True)
    loop.pause(False)                                        # nothing answered: the state again
    assert node.states[-1][:2] == (MS, False) and loop.world.t_ns == MS
    assert [lvl for lvl, _ in node.logs] == ['info'] * 4 and node.diagnostics == 4


def test_lockstep_pause_at_stops_at_that_tick_and_a_change_made_there_acts_from_it(bridge):
    """pause_at 3.5 ms: the first tick at or past it (4 ms) is published, then the loop pauses; its answer
    waits, a disturbance set there is in force for the step from 4 ms; a reset arms it again."""
    loop, node = bridge(mode='lockstep', pause_at=0.0035)
    assert statuses(loop)['pacing'].values['pause_at'] == 0.0035
    for k in range(4):
        loop.on_joint_command(k * MS, JOINTS, HOLD)
    assert loop.paused and loop.world.t_ns == 4 * MS and node.logs[-1] == ('info', 'paused at t = 0.004 s '
                                                                                   '(pause_at = 0.0035 s)')
    loop.on_joint_command(4 * MS, JOINTS, HOLD)                # answered while paused: held
    assert loop.world.t_ns == 4 * MS and statuses(loop)['pacing'].values['pause_at'] == 'n/a'   # disarmed
    qd_before = node.world.state()[1].copy()
    loop.configure(dataclasses.replace(loop.cfg, disturbance_joint_torque=np.array([0.0, 5.0])))
    loop.pause(False)
    assert loop.world.t_ns == 5 * MS and not loop.paused
    # the step from 4 ms ran with the 5 N push on r (the robot at rest in Q0): qd grew by M^-1 [0, 5] dt
    assert node.world.state()[1] - qd_before == pytest.approx(np.linalg.solve(POLAR.M(Q0), [0.0, 5.0]) * 1e-3,
                                                               rel=0.05, abs=1e-9)
    for k in range(5, 10):                                      # not again at the same value
        loop.on_joint_command(k * MS, JOINTS, HOLD)
    assert not loop.paused and loop.world.t_ns == 10 * MS
    loop.configure(dataclasses.replace(loop.cfg, pause_at=0.002))    # already past: the next tick
    loop.on_joint_command(10 * MS, JOINTS, HOLD)
    assert loop.paused and loop.world.t_ns == 11 * MS
    loop.pause(False)
    loop.reset()                                                # armed again at 2 ms
    loop.on_joint_command(0, JOINTS, HOLD)
    loop.on_joint_command(MS, JOINTS, HOLD)
    assert loop.paused and loop.world.t_ns == 2 * MS


def test_realtime_pause_at_stops_inside_a_burst_of_due_ticks(bridge):
    loop, node = bridge(mode='realtime', pause_at=0.0032)
    loop.on_joint_command(0, JOINTS, HOLD)
    node.now += 10 * MS                                         # ten ticks due: four run, 4 ms >= 3.2 ms
    loop.on_timer()
    assert loop.paused and loop.ticks == 4 and loop.world.t_ns == 4 * MS
    node.now += 10 * MS
    loop.on_timer()
    assert loop.ticks == 4
    loop.pause(False)
    node.now += 2 * MS
    loop.on_timer()
    assert loop.ticks == 6 and not loop.paused                 # re-anchored at the resume, no burst


def test_realtime_brakes_on_a_stale_command_and_releases_on_a_fresh_one(bridge):
    loop, node = bridge(mode='realtime', command_timeout=0.05)
    assert isinstance(loop, RealtimeLoop)
    assert loop.brake_reason == 'no command yet' and loop.world.braked and node.logs == []   # quiet at start
    loop.on_joint_command(0, JOINTS, HOLD)
    assert not loop.world.braked and loop.brake_events == 2
    node.now += 10 * MS
    loop.on_timer()
    assert loop.ticks == 10 and loop.world.t_ns == 10 * MS and not loop.brakes_engaged
    node.now += 60 * MS                                      # silent for more than command_timeout
    loop.on_timer()
    assert loop.world.t_ns == 70 * MS and loop.world.braked
    assert loop.brake_reason == 'stale command (none valid for more than command_timeout = 0.05 s)'
    # the release at t = 0 was logged 70 ms of wall time ago: one line per second, the engagement is not
    assert node.logs == [('info', 'brakes released at t = 0.000 s: fresh command')]
    brakes = statuses(loop)['brakes']
    assert (brakes.level, brakes.values) == ('WARN', {'engaged': True, 'reason': loop.brake_reason, 'events': 3})
    assert statuses(loop)['commands'].values['command_age'] == pytest.approx(0.07)
    node.now += 1_000 * MS
    loop.on_joint_command(70 * MS, JOINTS, HOLD)
    assert not loop.world.braked and node.logs[-1] == ('info', 'brakes released at t = 0.070 s: fresh command')
    assert statuses(loop)['brakes'].level == 'OK' and node.diagnostics == 4


def test_realtime_ignores_a_command_answering_a_state_older_than_command_timeout(bridge):
    """A command held up on the way (a network link that failed and came back) is counted and logged, never
    applied, and does not release the brakes; exactly command_timeout old is still in time."""
    loop, node = bridge(mode='realtime', command_timeout=0.05)
    loop.on_joint_command(0, JOINTS, HOLD)                  # the loop ran, then the link failed
    for _ in range(20):
        node.now += 10 * MS
        loop.on_timer()
    assert loop.world.t_ns == 200 * MS and loop.brake_reason.startswith('stale command')
    push = (POLAR.g(Q0) + [0.0, 50.0]).tolist()
    loop.on_joint_command(150 * MS - 1, JOINTS, push)
    assert loop.outdated_commands == 1 and loop.mapper.accepted == 1 and loop.world.braked
    assert statuses(loop)['commands'].values['outdated_commands'] == 1
    assert node.logs[-1] == ('warning', 'ignored a command answering the state of t = 0.150 s at t = 0.200 s '
                                        '(older than command_timeout = 0.05 s); 1 so far')
    loop.on_joint_command(150 * MS, JOINTS, HOLD)
    assert loop.outdated_commands == 1 and loop.mapper.accepted == 2 and not loop.world.braked


def test_an_outdated_first_command_is_information_not_a_warning(bridge):
    """While the loop closes (no valid command since the start or a reset) an outdated command is part of the
    start-up: the first state can reach a controller that joins late after a delay (DDS matching). It is
    ignored and counted like any other, and logged as information; the next fresh command closes the loop."""
    loop, node = bridge(mode='realtime', command_timeout=0.05)
    for _ in range(20):
        node.now += 10 * MS
        loop.on_timer()
    assert loop.brake_reason == 'no command yet'
    loop.on_joint_command(150 * MS - 1, JOINTS, HOLD)
    assert loop.outdated_commands == 1 and loop.mapper.accepted == 0 and loop.world.braked
    assert node.logs[-1] == ('info', 'ignored a command answering the state of t = 0.150 s at t = 0.200 s '
                                     '(older than command_timeout = 0.05 s); 1 so far; the brakes stay on until a '
                                     'fresh command')
    loop.on_joint_command(200 * MS, JOINTS, HOLD)
    assert not loop.world.braked and node.logs[-1] == ('info', 'brakes released at t = 0.200 s: fresh command')
    assert not [line for line in node.logs if line[0] != 'info']
    loop.reset()                                             # a reset starts the loop over: information again
    node.now += 1_000 * MS
    for _ in range(20):
        node.now += 10 * MS
        loop.on_timer()
    loop.on_joint_command(100 * MS, JOINTS, HOLD)
    assert loop.outdated_commands == 2 and node.logs[-1][0] == 'info' and loop.world.braked


def test_realtime_runs_the_ticks_due_on_the_wall_clock(bridge):
    loop, node = bridge(mode='realtime', real_time_factor=0.5)
    loop.on_joint_command(0, JOINTS, HOLD)
    loop.on_timer()
    assert loop.ticks == 0                                   # never ahead of the wall clock
    node.now += 10 * MS
    loop.on_timer()
    assert loop.ticks == 5 and all(s[1] for s in node.states[1:])
    pacing = statuses(loop)['pacing']
    assert pacing.level == 'OK' and pacing.values['achieved_real_time_factor'] == pytest.approx(0.5)
    assert (pacing.values['deadline_hits'], pacing.values['deadline_misses']) == (1, 4)   # one answer, to t = 0
    loop.configure(dataclasses.replace(loop.cfg, real_time_factor=2.0))                  # re-anchored now
    node.now += 10 * MS
    loop.on_timer()
    assert loop.ticks == 25
    node.now += 1_000 * MS                                   # a stall: one tick, no burst
    loop.on_timer()
    assert loop.ticks == 26
    pacing = statuses(loop)['pacing']
    assert pacing.level == 'WARN' and pacing.message == 'realtime x2.0: 1 overruns (stalls > 0.1 s)'


def prepared_ticks(loop):
    """A list that grows by the World's t_ns at each World.prepare the loop calls."""
    calls, prepare = [], loop.world.prepare

    def counting(tau=None):
        calls.append(loop.world.t_ns)
        prepare(tau)
    loop.world.prepare = counting
    return calls


def test_the_next_tick_is_prepared_in_lockstep_once_published_in_realtime_once_answered(bridge):
    """Lockstep forms the next tick's terms as soon as it publishes a state (the controller computes meanwhile);
    realtime leaves the CPU to the controller then and forms them once the answer to the latest state is in
    (an answer to an older state does not), else the tick forms them itself."""
    loop, node = bridge(mode='lockstep')
    calls = prepared_ticks(loop)
    loop.on_joint_command(0, JOINTS, HOLD)
    assert calls == [MS] and node.states[-1][0] == MS
    loop, node = bridge(mode='realtime')
    calls = prepared_ticks(loop)
    loop.on_joint_command(0, JOINTS, HOLD)
    assert calls == [0]                                      # the answer to the state of t = 0
    node.now += MS
    loop.on_timer()
    assert loop.ticks == 1 and node.states[-1][0] == MS and calls == [0]
    loop.on_joint_command(0, JOINTS, HOLD)                   # answers t = 0, not the latest state
    assert calls == [0]
    loop.on_joint_command(MS, JOINTS, HOLD)
    assert calls == [0, MS]


def test_realtime_restarts_the_timer_as_it_anchors_so_that_each_call_runs_one_tick(bridge):
    """The pacing timer is restarted at each anchoring of the pacing (start, resume, a new real_time_factor,
    reset), so its calls come whole periods after it: each finds exactly one tick due, even 0.9 period late.
    (A timer whose calls came just before the ticks fell due would find none, run each a period late, and
    run two back to back whenever a call came a little late.)"""
    loop, node = bridge(mode='realtime')
    loop.on_joint_command(0, JOINTS, HOLD)

    def one_tick_per_call(period_ns, calls=20):
        start, ticks = node.timer_restarts[-1], loop.ticks
        for n in range(1, calls + 1):
            node.now = start + n * period_ns + round(0.9 * period_ns)
            loop.on_timer()
            assert loop.ticks == ticks + n, (period_ns, n)

    assert node.timer_restarts == [1_000 * MS]              # at the start
    one_tick_per_call(MS)
    loop.pause(True)
    node.now += 123_456_789
    loop.pause(False)
    assert node.timer_restarts[-1] == node.now              # resumed
    one_tick_per_call(MS)
    node.now += 333_333
    loop.configure(dataclasses.replace(loop.cfg, real_time_factor=2.0))
    assert node.timer_restarts[-1] == node.now              # a new real-time factor: a tick every 0.5 ms
    one_tick_per_call(MS // 2)
    node.now += 777_777
    loop.reset()
    assert node.timer_restarts[-1] == node.now and loop.ticks == 0
    one_tick_per_call(MS // 2)
    assert len(node.timer_restarts) == 4


def test_realtime_pause_stands_still_and_resumes_without_a_burst(bridge):
    loop, node = bridge(mode='realtime')
    loop.on_joint_command(0, JOINTS, HOLD)
    loop.pause(True)
    node.now += 500 * MS
    loop.on_timer()
    assert loop.ticks == 0 and node.states[-1][:2] == (0, False)       # re-published, not stepped
    assert statuses(loop)['pacing'].message == 'realtime x1.0, paused'
    loop.pause(False)
    node.now += 3 * MS
    loop.on_timer()
    assert loop.ticks == 3 and statuses(loop)['pacing'].values['overruns'] == 0


def test_two_publishers_on_a_command_topic_engage_the_brakes_until_the_evidence_is_old(bridge):
    loop, node = bridge(mode='lockstep', command_timeout=0.02)
    node.counts = [2, 0]
    commands = statuses(loop)['commands']                    # counted for the diagnostics
    assert commands.level == 'WARN' and commands.message == 'duplicate publishers: 2 publishers on robot_joint_commands'
    loop.on_joint_command(0, JOINTS, HOLD)
    assert loop.world.t_ns == MS and loop.brake_reason == 'publisher conflict: 2 publishers on robot_joint_commands'
    commands = statuses(loop)['commands']
    assert commands.level == 'ERROR' and commands.values['publisher_conflicts'] == 1
    node.counts = [1, 0]                                     # the second one left
    loop.refresh_publisher_counts()
    released = None
    for k in range(1, 40):
        loop.on_joint_command(k * MS, JOINTS, HOLD)
        if released is None and not loop.brakes_engaged:
            released = k
    assert released == 21                  # the first answer more than command_timeout after the evidence at 0
    assert statuses(loop)['commands'].level == 'OK'


def test_commands_on_both_topics_engage_the_brakes_in_realtime(bridge):
    loop, node = bridge(mode='realtime')
    loop.on_joint_command(0, JOINTS, HOLD)
    assert not loop.brakes_engaged
    loop.on_array_command(HOLD)
    assert loop.world.braked
    assert loop.brake_reason == 'publisher conflict: commands on both robot_joint_commands and effort_controller/commands'
    assert statuses(loop)['commands'].level == 'ERROR'


def test_reset_rebuilds_the_world_and_forgets_the_command(bridge):
    loop, node = bridge(mode='lockstep')
    push = (POLAR.g(Q0) + [0.0, 2.0]).tolist()
    for k in range(20):
        loop.on_joint_command(k * MS, JOINTS, push)
    assert loop.world.state()[0][1] > 0.5 + 1e-5
    assert loop.reset() == 'world rebuilt, t = 0.000 s'
    assert loop.world.t_ns == 0 and loop.ticks == 0 and loop.mapper.values == [0.0, 0.0]
    assert node.states[-1] == (0, False, True, [0.0, 0.0]) and loop.world.state()[0].tolist() == Q0.tolist()
    loop.on_joint_command(0, JOINTS, HOLD)                   # the gate expects t = 0 again
    assert loop.world.t_ns == MS and loop.mapper.accepted == 21
    realtime, node = bridge(mode='realtime')
    realtime.on_joint_command(0, JOINTS, HOLD)
    node.now += 5 * MS
    realtime.on_timer()
    assert realtime.reset() and realtime.world.braked and realtime.brake_reason == 'no command yet'
    node.now += 5 * MS
    realtime.on_timer()
    realtime.on_array_command(HOLD)                          # the command history restarted with the time
    assert realtime.world.t_ns == 5 * MS and not realtime.brakes_engaged


def test_diagnostics_keys_and_levels(bridge):
    loop, node = bridge(mode='lockstep')
    s = statuses(loop)
    assert [(x.level, x.message) for x in s.values()] == [('OK', 'lockstep'), ('OK', '0 commands accepted'),
                                                         ('OK', 'released')]
    assert list(s['pacing'].values) == ['mode', 'sim_time', 'paused', 'pause_at', 'control_ticks', 'physics_step',
                                        'control_period', 'republished_states', 'late_commands', 'future_commands']
    assert list(s['commands'].values) == (
        ['accepted', 'rejected'] + [f'rejected_{r}' for r in REJECT_REASONS]
        + ['last_reject_reason', 'command_age', 'command_timeout', 'outdated_commands', 'publishers robot_joint_commands',
           'publishers effort_controller/commands', 'publisher_conflicts'])
    assert s['commands'].values['command_age'] == 'n/a'
    loop.on_joint_command(0, ['theta1', 'x'], HOLD)
    commands = statuses(loop)['commands']
    assert commands.level == 'WARN' and commands.message.startswith('1 commands rejected, last: name: unknown')
    realtime, _ = bridge(mode='realtime')
    s = statuses(realtime)
    assert list(s['pacing'].values)[7:] == ['real_time_factor', 'achieved_real_time_factor', 'overruns',
                                            'deadline_hits', 'deadline_misses', 'latency_p50_ms', 'latency_p99_ms']
    assert s['brakes'].level == 'WARN' and s['brakes'].message == 'engaged: no command yet'


def test_configure_applies_timeout_and_disturbance_and_refuses_fixed_fields(bridge):
    loop, node = bridge(mode='realtime')
    cfg = bridge_params.validate(bridge_params.defaults(
        'polar_two_link', mode='realtime', command_timeout=0.2, **{'disturbance.joint_torque': [0.0, -1.5]}))
    loop.configure(cfg)
    assert loop.world.disturbance[0].tolist() == [0.0, -1.5]
    loop.on_joint_command(0, JOINTS, HOLD)
    for _ in range(2):
        node.now += 90 * MS
        loop.on_timer()
    assert loop.ticks == 180 and not loop.brakes_engaged     # silent for 0.18 s: stale after 0.2 s only
    with pytest.raises(ValueError, match='^mode: cannot change'):
        loop.configure(dataclasses.replace(cfg, mode='lockstep'))


def test_lockstep_loop_runs_are_bit_identical(bridge):
    def run():
        loop, node = bridge(mode='lockstep')
        for k in range(200):
            q, qd, _ = loop.world.state()
            loop.on_joint_command(k * MS, JOINTS, (POLAR.g(q) + 36.0 * ([0.5, 0.8] - q) - 12.0 * qd).tolist())
        return np.array([loop.world.state()[0]] + [s[3] for s in node.states])
    first, second = run(), run()
    assert np.ptp(first, axis=0).max() > 1e-2 and first.tobytes() == second.tobytes()


class ControllerLike:
    """The controller node's decisions without ROS, on the rclpy-free core it runs: the time line of the stamps
    (a jump of more than state_timeout is refused while running), the watchdog (no accepted state for
    state_timeout of the larger of simulation and steady time stops the core, which then restarts from the state
    it sees) and the core's computed torque holding where it (re)started."""

    def __init__(self, state_timeout=0.5):
        from robot_control.core.config import ControllerConfig
        from robot_control.core.controller import ControllerCore
        from robot_control.core.timeline import Timeline
        from robot_control.core.watchdog import StateWatchdog
        from robot_control.gains import design
        self.core = ControllerCore(ControllerConfig(POLAR, law_params=gain_params(design(1.0, 12.0).gains(2)),
                                                    effort_limit=[200.0, 200.0]))
        self.timeline, self.watchdog = Timeline(state_timeout), StateWatchdog(state_timeout)

    def answer(self, stamp_ns, q, qd, steady_ns):
        """The command (tau, stamp) for the state stamped `stamp_ns`, or None when the state is refused."""
        if self.core.active and self.watchdog.check(stamp_ns, steady_ns):
            self.core.stop()
        try:
            t = self.timeline.accept(stamp_ns, running=self.core.active)
        except ValueError:
            return None
        tau = self.core.update(t, q, qd).tolist()
        self.watchdog.fresh(stamp_ns, steady_ns)
        return tau, stamp_ns


def test_realtime_reset_holds_the_initial_positions_after_pause_and_resume(bridge):
    """Pause, resume and ~/reset in realtime, 20 times, with a controller that answers each state one tick later:
    the answer to the last state before the reset is still on its way when the World is rebuilt. Stamped with a
    time of the old run, after the new run's time, it must be ignored: applied, it would release the brakes and
    push the rebuilt robot with the torque of another pose until the brakes came back (command_timeout later), and
    the controller, refusing the jump back in time until its watchdog trips, would restart and hold there. Each
    time, 3 s after the reset the arm is within 1e-3 rad (m) of initial_positions."""
    loop, node = bridge(mode='realtime')
    ctrl, world, in_flight = ControllerLike(), loop.world, None

    def run(seconds):
        nonlocal in_flight
        for _ in range(int(round(seconds * 1000))):
            if in_flight is not None:                  # the answer to the previous state arrives
                loop.on_joint_command(in_flight[1], JOINTS, in_flight[0])
            node.now += MS
            loop.on_timer()
            q, qd, _ = world.state()
            in_flight = ctrl.answer(world.t_ns, q, qd, node.now)

    errors = []
    for k in range(20):
        run(0.1)
        ctrl.core.set_goal([0.5 * (-1) ** k, 0.8], duration=0.3)     # away from initial_positions
        run(0.5)
        assert np.abs(world.state()[0] - Q0).max() > 0.1
        loop.pause(True)
        node.now += 300 * MS
        loop.on_timer()                                # the paused state is re-published, and answered
        loop.pause(False)
        run(0.05)
        loop.reset()
        run(3.0)
        errors.append(np.abs(world.state()[0] - Q0).max())
    assert max(errors) < 1e-3, errors
    assert loop.outdated_commands == 20                # each answer in flight at the reset, ignored


def test_realtime_after_a_reset_only_stamps_of_the_old_run_are_ignored(bridge):
    """Ahead of the current time, a stamp up to where the run before the reset got answers a state of that run
    (ignored, counted as outdated); one beyond it is another time base (applied, as before any reset)."""
    loop, node = bridge(mode='realtime')
    loop.on_joint_command(0, JOINTS, HOLD)
    for _ in range(30):
        node.now += 10 * MS
        loop.on_timer()
    loop.reset()
    node.now += 10 * MS
    loop.on_timer()
    loop.on_joint_command(300 * MS, JOINTS, HOLD)              # the old run's last state: ignored
    assert loop.outdated_commands == 1 and loop.world.braked
    assert node.logs[-1] == ('info', 'ignored a command answering the state of t = 0.300 s at t = 0.010 s (a state '
                                     'of the run before the reset); 1 so far; the brakes stay on until a fresh command')
    loop.on_joint_command(300 * MS + 1, JOINTS, HOLD)          # beyond it: not of the old run
    assert loop.outdated_commands == 1 and not loop.world.braked
