"""The bridge's loop, free of rclpy: when physics runs, which torque is in force, and what the node
publishes, over a World (sim_bridge.world).

The node decodes messages and calls the loop (`make_loop`: a LockstepLoop or a RealtimeLoop,
both BridgeLoops); the loop calls back to publish a state, to count the publishers on the
command topics, to publish diagnostics and to log. Simulation time is the World's integer
nanoseconds; wall time is integer nanoseconds of the `clock` given at construction
(``time.monotonic_ns`` in the node, a fake clock in tests).

Pacing (`cfg.mode`):
- lockstep (LockstepLoop): the state of tick k is published at t_k; the command stamped t_k (an
  effort array, which has no stamp, answers the latest state) is applied, held for
  control_period (`cfg.substeps` physics steps) and the next state published, all inside the
  command call. Without an answer the state is re-published every lockstep_timeout of wall
  time; physics never runs without a command, so the same controller gives bit-identical runs.
  A rejected command still completes the handshake: the step runs with the last valid command
  (brakes if there is none), so a faulty controller cannot stall the simulation.
- realtime (RealtimeLoop): a timer runs the control ticks that are due at real_time_factor
  (sim_bridge.pacing.RealtimePacer; it re-anchors after a stall of more than 0.1 s rather than
  bursting). The latest valid command is held; no valid command for command_timeout of
  simulation time (or none yet) engages the World's brakes, a fresh command releases them. A
  JointState command stamped (the state it answers) more than command_timeout before the current
  simulation time arrived too late (held up by a network link that failed and came back): it is
  ignored and counted (outdated_commands), never applied, and does not count as fresh. So is a command
  answering a state of the run before a reset (stamped after the current simulation time, at most the
  time the reset ended): in flight when the World was rebuilt, its torque was computed for another
  state, and applying it would release the brakes and push the rebuilt robot away from its start.

Paused (by `pause`, or by itself after the first tick at or past cfg.pause_at: a breakpoint in
simulation time, so a run-time change made while paused acts from an exact tick), physics stands
still and the unchanged state is re-published every 0.1 s of wall time, so a controller sees a live
robot (its watchdog does not trip) and may be configured or given a trajectory before the resume;
in lockstep the latest answer received while paused is applied on resume. Reset rebuilds the World
at t = 0 and forgets the command.

The robot's driver (sim_bridge.sensors.Driver, parameters noise.*, encoder_resolution, wrench_bias,
delay.*, seed): the loop publishes `measured`, the World's readings as the driver delivers them (the
World itself when nothing is modelled); with a measurement delay of d ticks a state is stamped when it
was measured, d ticks before the World's time (lockstep expects the command stamped like the published
state; start and reset run d warm-up ticks with the brakes engaged first), and valid commands reach the
World actuation_ticks ticks after they arrive.

Bad commands (unknown, missing or duplicate joint names, wrong lengths, NaN or inf) never reach
the World: a throttled warning, a count per reason, and the last valid command (or the brakes)
stays in force. Mixing sources is refused (sim_bridge.pacing.SourceGuard): more than one publisher
on a command topic (counted by the node's graph on `refresh_publisher_counts`, and whenever a
lockstep state is answered twice) or commands on both command topics (evidence again with every
command while the graph still shows publishers on both) engage the brakes until command_timeout of
simulation time has passed without such evidence.

Diagnostics (`diagnostics()`): three `Status` entries, `pacing` (mode, sim_time, paused,
control_ticks, ...; lockstep: republished_states, late_commands, future_commands; realtime:
achieved_real_time_factor, overruns, deadline hits and misses, latency percentiles), `commands`
(accepted, rejected and rejected_<reason> counts, last_reject_reason, command_age, command_timeout,
outdated_commands, publishers per topic, publisher_conflicts) and `brakes` (engaged, reason,
events). The node publishes them every diagnostics_period and the loop asks for them at once when
the brakes change or on pause/resume.
"""
import abc
import dataclasses
import time

import numpy as np

from robot_control import units
from robot_control.core.throttle import Throttle
from robot_control.validation import ArgumentError
from sim_bridge.pacing import (CommandMapper, CommandWatchdog, DeadlineMeter, LockstepGate, RateMeter, RealtimePacer,
                             SourceGuard)
from sim_bridge.sensors import Driver

NS = units.NS_PER_S
#: the command topics, in the order of the publisher counts (`count_publishers`)
COMMAND_TOPICS = ('robot_joint_commands', 'effort_controller/commands')
JOINT_STATE, ARRAY = 0, 1             # indices of COMMAND_TOPICS
WARN_PERIOD_NS = NS                   # throttled warnings: at most one per second of wall time
PAUSED_STATE_PERIOD_NS = NS // 10     # wall time between re-published states while paused
#: the config fields a running loop cannot change (the node declares them read-only)
FIXED = ('mode', 'joints', 'physics_step_ns', 'control_period_ns', 'clock_period_ns')


def _armed(pause_at):
    """The simulation time, ns, a pause_at value (s) arms, or None when negative (never)."""
    return None if pause_at < 0.0 else units.to_ns(pause_at)


@dataclasses.dataclass(frozen=True)
class Status:
    """One diagnostics entry: `name` (pacing, commands or brakes), `level` ('OK', 'WARN' or
    'ERROR'), `message` (str) and `values` ({key: plain Python value})."""

    name: str
    level: str
    message: str
    values: dict


class BridgeLoop(abc.ABC):
    """The bridge's decisions over `world` (a sim_bridge.world.World) for `cfg` (a validated
    sim_bridge.bridge_params.BridgeConfig): the parts both modes share. Make one with `make_loop`.

    Callbacks into the node:
    - publish_state(in_loop, with_clock) -> wall_ns: publish the current state of `measured` (its t_ns,
      state_values() as joint_states, contact_wrench() as ft_sensor/wrench), then /clock (the World's
      time) when `with_clock`; return the wall time
      at which joint_states went out. `in_loop`: a tick of the running loop (False for a first,
      re-published or resumed state).
    - count_publishers() -> (n, n): publishers on COMMAND_TOPICS.
    - publish_diagnostics(): publish `diagnostics()` now.
    - log(level, text): level 'info' or 'warning'.
    - clock() -> wall time, ns (monotonic).
    - restart_timer(): start the period of the pacing timer over now. Realtime calls it right after
      anchoring its pacing (start, reset, resume, a new real_time_factor), so that the timer's calls
      come just after the ticks fall due: a call then runs one tick, and only a call more than a
      period late runs two back to back. Optional (default: nothing).

    The node calls on_joint_command, on_array_command, on_timer (a steady timer: lockstep every
    lockstep_timeout / 4, realtime every control period of wall time), pause, reset,
    refresh_publisher_counts (every 0.1 s) and diagnostics. Public counters: `ticks` (control
    ticks since the last reset), `brake_events`, `outdated_commands` (realtime: ignored as too
    old); `mapper` (CommandMapper: accepted and rejected counts).
    """

    def __init__(self, world, cfg, *, publish_state, count_publishers, publish_diagnostics, log,
                 clock=time.monotonic_ns, restart_timer=lambda: None):
        self.world = world
        self.cfg = cfg
        self._publish_state = publish_state
        self._count_publishers = count_publishers
        self._publish_diagnostics = publish_diagnostics
        self._log = log
        self._clock = clock
        self._restart_timer = restart_timer
        self._substeps = cfg.substeps
        self._control_ns = cfg.control_period_ns
        self._clock_period_ns = cfg.clock_period_ns
        self.mapper = CommandMapper(cfg.joints)
        self._watchdog = CommandWatchdog(cfg.command_timeout_ns)    # fed by valid realtime commands
        self._guard = SourceGuard(cfg.command_timeout_ns, COMMAND_TOPICS)
        self._deadline = DeadlineMeter()
        self._driver = Driver(world, cfg.sensors, cfg.control_period_ns)
        self.measured = self._driver.measured
        self._hold = self._driver.hold
        self._advance = self._driver.step
        self._reject_throttle = Throttle(WARN_PERIOD_NS)
        self._brake_throttle = Throttle(WARN_PERIOD_NS)
        self._have_cmd = False
        self._brake_reason = ''           # '' = brakes released
        self._paused = False
        self._pause_at_ns = _armed(cfg.pause_at)
        self._wall_last_pub = 0
        self.ticks = 0
        self.brake_events = 0
        self.outdated_commands = 0

    @property
    def brakes_engaged(self):
        return bool(self._brake_reason)

    @property
    def brake_reason(self):
        """Why the brakes are engaged; '' while released."""
        return self._brake_reason

    @property
    def paused(self):
        return self._paused

    def start(self):
        """Count the publishers, start pacing at the World's time and publish its first state."""
        self.refresh_publisher_counts()
        self._restart()

    # -- what each mode does --------------------------------------------------------------------
    @abc.abstractmethod
    def on_joint_command(self, stamp_ns, names, efforts):
        """A JointState command: header stamp (int ns), joint names (list of str), efforts (n floats)."""

    @abc.abstractmethod
    def on_array_command(self, values):
        """An effort array command: n floats in `cfg.joints` order."""

    @abc.abstractmethod
    def on_timer(self):
        """The node's pacing timer fired."""

    @abc.abstractmethod
    def _resume(self):
        """Continue after a pause."""

    @abc.abstractmethod
    def _pacing(self):
        """(level, message, {key: value}) of the mode's pacing, for diagnostics."""

    def configure(self, cfg):
        """Apply a new BridgeConfig: command_timeout, pause_at and the disturbance (realtime also the real-time
        factor). The FIXED fields must not change (ArgumentError naming the first that does)."""
        old = self.cfg
        changed = [name for name in FIXED if getattr(cfg, name) != getattr(old, name)]
        if changed:
            raise ArgumentError(changed[0], 'cannot change while the loop runs')
        self.cfg = cfg
        self._watchdog.timeout_ns = cfg.command_timeout_ns
        self._guard.timeout_ns = cfg.command_timeout_ns
        if cfg.pause_at != old.pause_at:
            self._pause_at_ns = _armed(cfg.pause_at)
        if (not np.array_equal(cfg.disturbance_joint_torque, old.disturbance_joint_torque)
                or not np.array_equal(cfg.disturbance_cartesian_force, old.disturbance_cartesian_force)):
            self.world.set_disturbance(joint_torque=cfg.disturbance_joint_torque,
                                       cartesian_force=cfg.disturbance_cartesian_force)

    def _reject(self, reason):
        if self._reject_throttle.ready(self._clock()):
            self._log('warning', f'rejected command: {reason}; {self.mapper.rejected_total} rejected so far; '
                                 f'{"the last valid command stays" if self._have_cmd else "the brakes stay"} in force')

    def _set_brakes(self, reason, log=True):
        """Engage the brakes for `reason`, or release them ('') and hold the last valid command."""
        was = bool(self._brake_reason)
        self._brake_reason = reason
        on = bool(reason)
        t = self.world.t_ns / NS
        if on == was:
            if on and log and self._brake_throttle.ready(self._clock()):
                self._log('warning', f'brakes stay engaged at t = {t:.3f} s: {reason}')
            return
        if on:
            self._driver.engage()
        else:
            self._driver.release(self.mapper.values)
        self.brake_events += 1
        if log and self._brake_throttle.ready(self._clock()):
            if on:
                self._log('warning', f'brakes engaged at t = {t:.3f} s: {reason}')
            else:
                self._log('info', f'brakes released at t = {t:.3f} s: fresh command')
        self._publish_diagnostics()

    # -- ticks and states -----------------------------------------------------------------------
    def _step(self):
        """One control tick: hold the torque in force for control_period, publish the new state; pause there
        when it reached pause_at."""
        self._advance(self._substeps)
        self.ticks += 1
        self._publish(in_loop=True)
        self._between_ticks()
        if self._pause_at_ns is not None and self.world.t_ns >= self._pause_at_ns:
            self._pause_at_ns = None
            self.pause(True, f' (pause_at = {self.cfg.pause_at:g} s)')

    def _between_ticks(self):
        """Once a state is published: form what the next tick needs of the state alone (Driver.prepare). Lockstep
        does it at once, while the controller computes its answer."""
        self._driver.prepare()

    def _publish(self, in_loop=False):
        """Publish the measured state; /clock on the tick that crosses a clock_period (every tick if 0)."""
        t = self.world.t_ns
        clock_ns = self._clock_period_ns
        wall = self._publish_state(in_loop, not clock_ns or t % clock_ns < self._control_ns)
        self._wall_last_pub = wall
        self._deadline.state(self.measured.t_ns, wall)

    def _heartbeat(self):
        """Paused: re-publish the unchanged state every PAUSED_STATE_PERIOD_NS of wall time."""
        if self._clock() - self._wall_last_pub >= PAUSED_STATE_PERIOD_NS:
            self._publish()

    def _restart(self):
        """Publish the measured state as the first of a run (start-up, reset), after the measurement delay's
        warm-up (sim_bridge.sensors: that many ticks with the brakes engaged, not counted in `ticks`)."""
        self._driver.restart()
        if self._driver.warm_up_ticks:
            if not self._brake_reason:
                self._set_brakes('no valid command yet', log=False)
            for _ in range(self._driver.warm_up_ticks):
                self._advance(self._substeps)
        self._publish()

    # -- pause, reset ---------------------------------------------------------------------------
    def pause(self, on, why=''):
        """Pause (True) or resume (False); returns the message for the caller (`why` appended)."""
        t = self.world.t_ns / NS
        if bool(on) == self._paused:
            return f'already {"paused" if self._paused else "running"} at t = {t:.3f} s'
        self._paused = bool(on)
        if self._paused:
            message = f'paused at t = {t:.3f} s{why}'
        else:
            message = f'resumed at t = {t:.3f} s'
            self._resume()
        self._log('info', message)
        self._publish_diagnostics()
        return message

    def reset(self):
        """Rebuild the World at t = 0 (the disturbance stays, pause_at is armed again), forget the command
        and the message history, restart pacing and publish the first state; returns the message for the caller."""
        w = self.world
        w.reset()
        self.ticks = 0
        self.mapper.clear()
        self._have_cmd = False
        self._watchdog.clear()
        self._guard.reset()
        self._pause_at_ns = _armed(self.cfg.pause_at)
        self._brake_reason = ''           # the rebuilt world has no brakes; _restart puts them back
        self._restart()
        message = f'world rebuilt, t = {w.t_ns / NS:.3f} s'
        self._log('info', message)
        return message

    # -- evidence and diagnostics ---------------------------------------------------------------
    def refresh_publisher_counts(self):
        """Ask the node for the publisher counts. After commands had come and stopped (stale, realtime):
        a publisher appearing now replaces a dead one (a killed controller stays in the graph for its
        DDS lease) and is not refused as a second one."""
        w = self._watchdog
        silent = w.last_ns is not None and w.stale(self.world.t_ns)
        for i, n in enumerate(self._count_publishers()):
            self._guard.set_count(i, n, silent=silent)

    def diagnostics(self):
        """[pacing, commands, brakes] Statuses now (realtime: the achieved real-time factor is read
        and a new window starts); counts the publishers first."""
        t = self.world.t_ns
        cfg = self.cfg
        level, message, mode_values = self._pacing()
        values = {'mode': cfg.mode, 'sim_time': t / NS, 'paused': self._paused,
                  'pause_at': 'n/a' if self._pause_at_ns is None else self._pause_at_ns / NS,
                  'control_ticks': self.ticks,
                  'physics_step': cfg.physics_step, 'control_period': cfg.control_period, **mode_values}
        if self._paused:
            message += ', paused'
        self.refresh_publisher_counts()
        return [Status('pacing', level, message, values), self._commands_status(t), self._brakes_status()]

    def _commands_status(self, t):
        m, guard = self.mapper, self._guard
        values = {'accepted': m.accepted, 'rejected': m.rejected_total}
        values.update({f'rejected_{k}': v for k, v in m.rejected.items()})
        values['last_reject_reason'] = m.last_reason
        age = self._watchdog.age_ns(t)
        values['command_age'] = 'n/a' if age is None else age / NS
        values['command_timeout'] = self.cfg.command_timeout
        values['outdated_commands'] = self.outdated_commands
        for topic, count in zip(COMMAND_TOPICS, guard.counts):
            values[f'publishers {topic}'] = count
        values['publisher_conflicts'] = guard.conflicts
        dup = [f'{c} publishers on {topic}' for topic, c in zip(COMMAND_TOPICS, guard.counts) if c > 1]
        if guard.in_conflict(t):
            level, message = 'ERROR', f'refusing to mix commands: {guard.reason}'
        elif dup:
            level, message = 'WARN', 'duplicate publishers: ' + '; '.join(dup)
        elif m.rejected_total:
            level, message = 'WARN', f'{m.rejected_total} commands rejected, last: {m.last_reason}'
        else:
            level, message = 'OK', f'{m.accepted} commands accepted'
        return Status('commands', level, message, values)

    def _brakes_status(self):
        reason = self._brake_reason
        values = {'engaged': bool(reason), 'reason': reason, 'events': self.brake_events}
        if reason:
            return Status('brakes', 'WARN', f'engaged: {reason}', values)
        return Status('brakes', 'OK', 'released', values)


class LockstepLoop(BridgeLoop):
    """Lockstep: the command stamped with the latest state's time steps the World once (see the
    module docstring). `gate` (LockstepGate) counts late and future stamps, `republished` the
    states re-published for want of an answer."""

    def __init__(self, world, cfg, **callbacks):
        super().__init__(world, cfg, **callbacks)
        self.gate = LockstepGate()
        self.republished = 0
        self._pending = None              # (names or None, efforts, ok): the answer received while paused

    def on_joint_command(self, stamp_ns, names, efforts):
        """Only the stamp of the latest state steps the World; a late stamp (a state answered twice) makes
        the loop count the publishers at once."""
        t = self.world.t_ns
        verdict = self.gate.classify(stamp_ns)
        if verdict != LockstepGate.MATCH:
            if verdict == LockstepGate.LATE:      # answered twice: a re-published state or a 2nd controller
                self.refresh_publisher_counts()
            self._guard.check(JOINT_STATE, t, stamp_ns)
            return
        ok = self._guard.check(JOINT_STATE, t, stamp_ns)
        if self._paused:
            self._pending = (names, efforts, ok)
            return
        self._answer(self.mapper.map_named(names, efforts), ok)

    def on_array_command(self, values):
        """An array has no stamp: it answers the latest state."""
        ok = self._guard.check(ARRAY, self.world.t_ns)
        if self._paused:
            self._pending = (None, values, ok)
        else:
            self._answer(self.mapper.map_array(values), ok)

    def _answer(self, reason, ok):
        """Apply the answer to the latest state (or keep the last valid command), step, publish."""
        if reason is not None:
            self._reject(reason)
        if not ok:
            self._set_brakes('publisher conflict: ' + self._guard.reason)
        elif reason is None:
            self._have_cmd = True
            if self._brake_reason:
                self._set_brakes('')
            else:
                self._hold(self.mapper.values)
        elif not self._have_cmd:
            self._set_brakes('no valid command yet')
        self._step()
        self.gate.expect(self.measured.t_ns)

    def on_timer(self):
        """Re-publish the state when no answer came for lockstep_timeout of wall time (paused: every 0.1 s)."""
        if self._paused:
            self._heartbeat()
        elif self._clock() - self._wall_last_pub >= self.cfg.lockstep_timeout * NS:
            self.republished += 1
            self._publish()

    def _resume(self):
        """Apply the answer received while paused, or re-publish the state."""
        pending, self._pending = self._pending, None
        if pending is None:
            self._publish()
            return
        names, values, ok = pending
        self._answer(self.mapper.map_array(values) if names is None else self.mapper.map_named(names, values), ok)

    def reset(self):
        self._pending = None
        return super().reset()

    def _restart(self):
        super()._restart()
        self.gate.expect(self.measured.t_ns)

    def _pacing(self):
        return 'OK', 'lockstep', {'republished_states': self.republished, 'late_commands': self.gate.late,
                                  'future_commands': self.gate.future}


class RealtimeLoop(BridgeLoop):
    """Realtime: the ticks due at real_time_factor run with the latest valid command; a stale or
    missing command, or mixed sources, engage the brakes (see the module docstring)."""

    def __init__(self, world, cfg, **callbacks):
        super().__init__(world, cfg, **callbacks)
        self._pacer = RealtimePacer(cfg.control_period_ns, cfg.real_time_factor)
        self._rate = RateMeter()
        self._achieved_rtf = None
        self._before_reset_ns = 0         # the latest simulation time of the runs before a reset

    def configure(self, cfg):
        old = self.cfg
        super().configure(cfg)
        if cfg.real_time_factor != old.real_time_factor:     # re-anchored now: no tick lost
            self._pacer.set_real_time_factor(cfg.real_time_factor, self._clock(), self.ticks)
            self._restart_timer()

    def on_joint_command(self, stamp_ns, names, efforts):
        """Held until the next valid one; the deadline meter times its answer to the latest state. One
        answering a state more than command_timeout old is ignored (outdated)."""
        t = self.world.t_ns
        ok = self._guard.check(JOINT_STATE, t, stamp_ns)
        if self._watchdog.outdated(t, stamp_ns):
            self._ignore_outdated(stamp_ns, t, f'older than command_timeout = {self.cfg.command_timeout} s')
            return
        if t < stamp_ns <= self._before_reset_ns:
            self._ignore_outdated(stamp_ns, t, 'a state of the run before the reset')
            return
        reason = self.mapper.map_named(names, efforts)
        if reason is None and ok:
            self._deadline.command(stamp_ns, self._clock())
        self._command(reason, ok)
        if stamp_ns == self.measured.t_ns:
            self._driver.prepare(answered=True)

    def _between_ticks(self):
        """Nothing at once: the next tick's terms are formed when the answer to this state is in (on_joint_command;
        else by the tick itself), so that the bridge leaves the CPU to the controller while it computes."""

    def on_array_command(self, values):
        """Held until the next valid one."""
        ok = self._guard.check(ARRAY, self.world.t_ns)
        self._command(self.mapper.map_array(values), ok)

    def _ignore_outdated(self, stamp_ns, t_ns, why):
        """Count and log an outdated command (`why` it is): a warning once the loop has run on a valid command,
        information before (the first state can reach a controller that has just joined late, held up while DDS
        matches the two nodes; the brakes are on until a fresh command anyway)."""
        self.outdated_commands += 1
        if self._reject_throttle.ready(self._clock()):
            self._log('warning' if self._have_cmd else 'info',
                      f'ignored a command answering the state of t = {stamp_ns / NS:.3f} s at t = {t_ns / NS:.3f} s '
                      f'({why}); {self.outdated_commands} so far'
                      + ('' if self._have_cmd else '; the brakes stay on until a fresh command'))

    def _command(self, reason, ok):
        """Hold a valid command; the next due tick applies it."""
        if reason is not None:
            self._reject(reason)
            return
        t = self.world.t_ns
        if not ok:
            self._update_brakes(t)
            return
        self._watchdog.fresh(t)
        self._have_cmd = True
        if self._brake_reason:
            self._update_brakes(t)
        if not self._brake_reason:
            self._hold(self.mapper.values)

    def _update_brakes(self, t_ns, log=True):
        """Brakes on while mixing is seen or the command is stale, else off."""
        if self._guard.in_conflict(t_ns):
            reason = 'publisher conflict: ' + self._guard.reason
        elif self._watchdog.stale(t_ns):
            reason = ('no command yet' if self._watchdog.last_ns is None
                      else f'stale command (none valid for more than command_timeout = {self.cfg.command_timeout} s)')
        else:
            reason = ''
        if reason != self._brake_reason:
            self._set_brakes(reason, log)

    def on_timer(self):
        """Run the ticks that are due at the wall clock's time, brakes checked before each (paused: re-publish
        the state every 0.1 s)."""
        if self._paused:
            self._heartbeat()
            return
        w = self.world
        for _ in range(self._pacer.due(self._clock(), self.ticks)):
            t = w.t_ns
            if self._brake_reason or self._watchdog.stale(t) or self._guard.in_conflict(t):
                self._update_brakes(t)
            self._deadline.step(self.measured.t_ns)
            self._step()
            if self._paused:                  # reached pause_at
                break

    def _resume(self):
        """Re-anchor pacing at the wall clock: no burst of ticks follows the pause."""
        now = self._clock()
        self._pacer.anchor(now, self.ticks)
        self._restart_timer()
        self._rate.reset(now, self.world.t_ns)

    def reset(self):
        self._before_reset_ns = max(self._before_reset_ns, self.world.t_ns)
        return super().reset()

    def _restart(self):
        t = self.world.t_ns
        self._update_brakes(t, log=False)
        now = self._clock()
        self._pacer.anchor(now, 0)
        self._restart_timer()
        super()._restart()
        self._rate.reset(now, self.world.t_ns)      # after the warm-up: it is not paced

    def _pacing(self):
        cfg, d, overruns = self.cfg, self._deadline, self._pacer.overruns
        if not self._paused:
            rtf = self._rate.read(self._clock(), self.world.t_ns)
            if rtf is not None:
                self._achieved_rtf = rtf
        values = {'real_time_factor': cfg.real_time_factor,
                  'achieved_real_time_factor': self._achieved_rtf if self._achieved_rtf else 'n/a',
                  'overruns': overruns, 'deadline_hits': d.hits, 'deadline_misses': d.misses,
                  'latency_p50_ms': d.latency_ms(50) or 'n/a', 'latency_p99_ms': d.latency_ms(99) or 'n/a'}
        if overruns:
            return 'WARN', f'realtime x{cfg.real_time_factor}: {overruns} overruns (stalls > 0.1 s)', values
        return 'OK', f'realtime x{cfg.real_time_factor}', values


def make_loop(world, cfg, **callbacks):
    """The LockstepLoop or RealtimeLoop for `cfg.mode`; `callbacks` as BridgeLoop takes them."""
    return (LockstepLoop if cfg.lockstep else RealtimeLoop)(world, cfg, **callbacks)
