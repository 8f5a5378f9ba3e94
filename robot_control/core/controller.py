"""Controller: the whole controller without ROS, from a joint state to the command that answers it.

One object owns everything a state goes through: reading q, qd by joint name
(robot_control.core.joint_states; qd estimated from q by robot_control.core.velocity when
velocity_cutoff_hz is set or the state carries no velocities), the time line of the stamps (core.timeline), the pairing of a
state with the wrench of its own tick (core.pairing), the law's tick on the core's time (references,
integral, saturation: core.tick.ControllerCore), the joint_states watchdog (core.watchdog) and the
counts /diagnostics reports (core.status). A node, a test or an offline tool drives it the same way:

    controller = Controller(config, state_timeout=0.5)
    result = controller.step(stamp_ns, names, positions, velocities, wrench)
    if isinstance(result, Command): send(result.stamp_ns, result.values)     # else a Rejection

step() answers one state with the wrench of its own tick (or the last one measured). A node whose
wrench and state come through two readers uses the three pairing calls instead, each returning the
results to publish, in order, as an iterator that answers each state when it is reached (publish a
Command before taking the next: its tau is the controller's buffer): state_arrived() (a state of a paired stream may wait there for its
wrench), wrench_arrived() and wait_over() (the node's one-shot timer: the wait is over). After
publishing a Command the node calls sent() (watchdog, counts); its watchdog timer calls
check_watchdog(); law_warning() says when the law keeps saturating or falling back (for the node's log).
Stamps and clock readings are integer ns. Not thread-safe.
"""
import numpy as np

from robot_control import units, validation
from robot_control.core.joint_states import JointStateReader
from robot_control.core.pairing import WrenchPairing
from robot_control.core.status import LAW_WARN_PERIOD, Counters, LawWatch, controller_statuses, needs_wrench
from robot_control.core.tick import ControllerCore
from robot_control.core.timeline import Timeline
from robot_control.core.velocity import DEFAULT_CUTOFF_HZ, METHOD, VelocityEstimator
from robot_control.core.watchdog import StateWatchdog

#: what the law does when states come back after a watchdog trip (check_watchdog), as the node logs it
RESTARTED = 'restarting from the current state'
RESUMED = "resuming where the law was: the state is the robot's next tick after the last answered one"
#: rejected-input sources, in the order /diagnostics lists them
INPUTS = ('joint_states', 'joint_trajectory', 'wrench_reference', 'ft_sensor_wrench', 'target_pose', 'target_wrench')


class Command:
    """The answer to a state: stamp_ns (the state's), tau (n,) N m or N saturated and finite, and the
    same torque as a list of floats (values, what a serializer takes). tau is the controller's buffer,
    overwritten by the next step."""

    __slots__ = ('stamp_ns', 'tau', 'values')

    def __init__(self, stamp_ns, tau, values):
        self.stamp_ns, self.tau, self.values = stamp_ns, tau, values


class Rejection:
    """A state refused: source ('joint_states'), reason (the ArgumentError's text, naming the field)."""

    __slots__ = ('stamp_ns', 'source', 'reason')

    def __init__(self, stamp_ns, source, reason):
        self.stamp_ns, self.source, self.reason = stamp_ns, source, reason


class Controller:
    """The controller of ControllerConfig `config`; `state_timeout` s (> 0): the watchdog's timeout and
    the largest step between two states' stamps (see the module docstring)."""

    def __init__(self, config, state_timeout):
        self.core = ControllerCore(config)
        self.timeline = Timeline(state_timeout)
        self.watchdog = StateWatchdog(state_timeout)
        self.counters = Counters(INPUTS)
        self.law_watch = LawWatch(units.to_ns(LAW_WARN_PERIOD))
        self._reader = JointStateReader(config.joints)
        self._velocity = VelocityEstimator(config.n)
        self._cutoff = 0.0                  # f_c of the last state's velocity estimate, Hz (0: measured)
        self._restarting = True             # the last answered state (re)started the law
        self._pairing = WrenchPairing()
        self._pairs = needs_wrench(config)
        self._f_meas = np.zeros(config.model.task_dim)

    # -- configuration ---------------------------------------------------------------------------------
    @property
    def config(self):
        """The active ControllerConfig."""
        return self.core.config

    def configure(self, config):
        """A new ControllerConfig, effective on the next state. Returns the results to publish (a state
        that waited for its wrench is answered when the new law reads no measured force)."""
        self.core.configure(config)
        pairs, self._pairs = self._pairs, needs_wrench(config)
        if pairs == self._pairs:
            return []
        if self._pairs:              # the measured force starts again from 0 N, not yet seen
            self._f_meas[:] = 0.0
            self.counters.wrench_seen = False
            self._pairing = WrenchPairing()
            return []
        return self.wait_over()

    def set_state_timeout(self, timeout):
        """The watchdog's timeout and the time line's largest step, s (> 0)."""
        self.watchdog.timeout = self.timeline.max_jump = timeout

    @property
    def running(self):
        """True while the law runs: a state answered, and no watchdog trip since (references are taken then)."""
        return self.core.active and not self.watchdog.tripped

    @property
    def needs_wrench(self):
        """True while the law reads the measured force (ft_sensor/wrench): states pair with wrenches."""
        return self._pairs

    # -- states -> commands ----------------------------------------------------------------------------
    def step(self, stamp_ns, names, positions, velocities, wrench=None):
        """The Command answering the state (stamp ns; joint names (k,), positions and velocities (k,),
        the controlled joints matched by name), or its Rejection. wrench: the measured force (m,) on the
        model's task axes at this stamp (N, N m; None: the last one measured, 0 before any)."""
        if wrench is not None:
            self._measured(validation.vector('wrench', wrench, self._f_meas.shape[0]))
        return self._answer(stamp_ns, names, positions, velocities)

    def state_arrived(self, stamp_ns, names, positions, velocities, wrench_publisher=None):
        """A state from the node: the results to publish now, in order. With paired streams it waits for
        the wrench of its own stamp (then it is not in the list; `waiting` tells). wrench_publisher: a
        callable, True when a wrench publisher exists (asked for the first state only)."""
        if not self._pairs:
            return [self._answer(stamp_ns, names, positions, velocities)]
        publisher = (self._pairing.last_state_ns is None and wrench_publisher is not None
                     and wrench_publisher())
        return self._answers(self._pairing.state(stamp_ns, (stamp_ns, names, positions, velocities), publisher))

    def wrench_arrived(self, stamp_ns, force):
        """A measured force (m,) on the task axes, N (checked by the reader of the message), stamped
        stamp_ns: the results to publish now (the state that waited for it)."""
        self._measured(force)
        return self._answers(self._pairing.wrench(stamp_ns))

    def wait_over(self):
        """The wait for a wrench is over: the results to publish (the state that waited, if any)."""
        return self._answers(self._pairing.release())

    @property
    def waiting(self):
        """True while a state waits for its wrench."""
        return self._pairing.held is not None

    def _answers(self, states):
        """The answers to the released `states`, each computed when the iterator reaches it."""
        return (self._answer(*state) for state in states)

    def _measured(self, force):
        self._f_meas[:] = force
        self.counters.wrench_seen = True

    def _answer(self, stamp_ns, names, positions, velocities):
        """State -> Command (or Rejection): read, time line, the law's tick."""
        core = self.core
        try:
            q, qd = self._reader.read_fields(names, positions, velocities)
            if self.watchdog.tripped and core.active and not self.timeline.follows(stamp_ns):
                core.stop()                         # the robot's time went on unanswered: restart (check_watchdog)
            t = self.timeline.accept(stamp_ns, running=core.active)
            self._restarting = not core.active
        except ValueError as exc:
            self.counters.reject('joint_states', exc)
            return Rejection(stamp_ns, 'joint_states', str(exc))
        cutoff = core.config.velocity_cutoff_hz or (DEFAULT_CUTOFF_HZ if qd is None else 0.0)
        if cutoff:
            if not (core.active and self._cutoff):   # a (re)start, or the estimate taking over: from qd (or rest)
                self._velocity.reset()
            qd = self._velocity.update(t, q, qd, cutoff)
        if cutoff != self._cutoff:
            self._cutoff = cutoff
            self.counters.velocity_source = f'estimated: {METHOD}, f_c = {cutoff:g} Hz' if cutoff else 'measured'
        tau = core.update_checked(t, q, qd, self._f_meas)
        return Command(stamp_ns, tau, core.tau_values)

    def in_joint_order(self, names, values):
        """A state's values per name (k,), e.g. its efforts, in joint order: a new (n,) array. ArgumentError
        ('effort') unless there is one finite value per name."""
        if len(values) != len(names):
            raise validation.ArgumentError('effort', f'expected one entry per name ({len(names)}), got {len(values)}')
        out = np.asarray(values, dtype=float)[self._reader.index(names)]
        if not np.isfinite(out).all():
            raise validation.ArgumentError('effort', f'not finite: {out.tolist()}')
        return out

    def sent(self, node_ns, steady_ns, tick_ns):
        """A Command was published at these clock readings, tick_ns of wall time after its state came: when that
        ends a watchdog trip (the states are back), what the law did (text for the log), else None."""
        self.counters.commands_sent += 1
        self.counters.tick(tick_ns)
        if not self.watchdog.fresh(node_ns, steady_ns):
            return None
        return RESTARTED if self._restarting else RESUMED

    def law_warning(self, steady_ns):
        """At most once per LAW_WARN_PERIOD s of the monotonic clock (steady_ns): a warning when the law kept
        saturating or fell back since the last look (core.status.LawWatch), else None."""
        return self.law_watch.report(self.core, steady_ns)

    # -- running -----------------------------------------------------------------------------------------
    def restart(self):
        """The next state restarts the law from that state (no jump)."""
        self.core.stop()

    def deactivate(self):
        """Stop: the next state restarts; a state waiting for its wrench is dropped."""
        self.core.stop()
        self._pairing = WrenchPairing()

    def check_watchdog(self, node_ns, steady_ns):
        """The watchdog's check at these clock readings: True when it trips now. Nothing is commanded while no
        state comes (a command only answers a state); the next state decides. The robot's next tick after the
        last answered state (Timeline.follows: at most two of its steps later), its time stood still (the machine
        or a process was held up, e.g. a lockstep simulator waiting for its answer): the law resumes where it
        was. Any other stamp (the robot ran unanswered, or a simulator restarted its clock), it restarts from
        that state."""
        return self.core.active and self.watchdog.check(node_ns, steady_ns)

    def state_age(self, node_ns, steady_ns):
        """Seconds since the last answered state (None before the first)."""
        return self.watchdog.age(node_ns, steady_ns)

    def reject(self, source, reason):
        """Count a rejected input of `source` (one of INPUTS)."""
        self.counters.reject(source, reason)

    def statuses(self, name, node_ns, steady_ns):
        """/diagnostics content of controller `name` (robot_control.core.status)."""
        return controller_statuses(name, self.core, self.watchdog, self.state_age(node_ns, steady_ns),
                                   self.counters)
