"""The small pieces of the bridge's loop (sim_bridge.bridge_loop), free of rclpy: real-time pacing,
the command watchdog, the lockstep gate, command checks and mapping, the source guard, and the
rate and deadline meters.

Time: simulation time is integer nanoseconds (as the World keeps it); wall time is integer
nanoseconds of a monotonic clock (``time.monotonic_ns``).
"""
import array
import math

import numpy as np

from robot_control.validation import ArgumentError
from robot_control import units

_F64 = np.dtype(np.float64)


#: reasons a command is rejected, the keys of :attr:`CommandMapper.rejected`
REJECT_REASONS = ('unknown_joint', 'missing_joint', 'duplicate_joint', 'length', 'non_finite')


class RealtimePacer:
    """How many control ticks are due at a wall time, for a real-time factor.

    Anchored at (wall w0, tick k0): tick k may run once the wall clock has reached
    ``w0 + (k + 1 - k0) * tick_ns / rtf`` (simulation never runs ahead of scaled wall time).
    When the simulation falls more than ``max_lag_ns`` of wall time behind (a stall, a
    debugger), the pacer re-anchors instead of bursting to catch up and counts an overrun.
    """

    def __init__(self, tick_ns, real_time_factor=1.0, max_lag_ns=100_000_000):
        if int(tick_ns) <= 0:
            raise ArgumentError('tick_ns', f'expected a positive integer, got {tick_ns}')
        self.tick_ns = int(tick_ns)
        self.max_lag_ns = int(max_lag_ns)
        self.overruns = 0
        self._rtf = 1.0
        self._w0 = 0
        self._k0 = 0
        self.set_real_time_factor(real_time_factor)

    @property
    def real_time_factor(self):
        return self._rtf

    def set_real_time_factor(self, rtf, wall_ns=None, ticks_done=None):
        """Change the factor; re-anchors at (wall_ns, ticks_done) when given so no tick is lost."""
        rtf = float(rtf)
        if not (math.isfinite(rtf) and rtf > 0.0):
            raise ArgumentError('real_time_factor', f'expected a positive number, got {rtf}')
        self._rtf = rtf
        self._wall_per_tick = self.tick_ns / rtf
        if wall_ns is not None:
            self.anchor(wall_ns, ticks_done)

    def anchor(self, wall_ns, ticks_done):
        """Start (or restart after a pause or reset) pacing from tick `ticks_done` at `wall_ns`."""
        self._w0 = int(wall_ns)
        self._k0 = int(ticks_done)

    def due(self, wall_ns, ticks_done):
        """Number of ticks to run now so that ticks_done catches up with scaled wall time."""
        target = self._k0 + int((wall_ns - self._w0) // self._wall_per_tick)
        n = target - ticks_done
        if n * self._wall_per_tick > self.max_lag_ns:
            self.overruns += 1
            self.anchor(wall_ns, ticks_done + 1)
            return 1
        return n if n > 0 else 0

    def next_due_wall_ns(self, ticks_done):
        """Wall time at which tick `ticks_done` becomes due."""
        return self._w0 + int(math.ceil((ticks_done + 1 - self._k0) * self._wall_per_tick))


class CommandWatchdog:
    """A command is stale when none was accepted within `timeout_ns` of simulation time."""

    def __init__(self, timeout_ns):
        self.timeout_ns = int(timeout_ns)
        self.last_ns = None

    def clear(self):
        """Forget the last command (start-up, reset): stale until the next one."""
        self.last_ns = None

    def fresh(self, t_ns):
        """A valid command was accepted at simulation time `t_ns`."""
        self.last_ns = t_ns

    def stale(self, t_ns):
        return self.last_ns is None or t_ns - self.last_ns > self.timeout_ns

    def age_ns(self, t_ns):
        """Simulation time since the last accepted command; None when there was none."""
        return None if self.last_ns is None else t_ns - self.last_ns

    def outdated(self, t_ns, stamp_ns):
        """True for a command stamped `stamp_ns` (the state it answers) more than timeout_ns before the
        simulation time `t_ns`: held up on the way (a network link that failed and came back) and no
        longer fit to apply. Stamp 0 means unstamped and is never outdated."""
        return 0 < stamp_ns < t_ns - self.timeout_ns


stamp_ns = units.stamp_ns


class LockstepGate:
    """Lockstep handshake: the state of tick k is published at t_k; only the command stamped
    t_k advances the simulation. Earlier stamps are late answers (a re-published state answered
    twice, a second controller); later stamps cannot answer anything yet."""

    MATCH, LATE, FUTURE = 0, 1, 2

    def __init__(self):
        self.expected_ns = 0
        self.late = 0
        self.future = 0

    def expect(self, t_ns):
        self.expected_ns = t_ns

    def classify(self, t):
        """MATCH, LATE or FUTURE for a command stamped `t` (integer ns, see stamp_ns)."""
        if t == self.expected_ns:
            return self.MATCH
        if t < self.expected_ns:
            self.late += 1
            return self.LATE
        self.future += 1
        return self.FUTURE


class CommandMapper:
    """Checks effort commands and maps them into the simulator's joint order.

    ``map_named(names, efforts)`` for sensor_msgs/JointState (by name, any order), ``map_array(values)``
    for std_msgs/Float64MultiArray (in `joints` order). Both fill the scratch vector ``tau`` and
    return None, or leave the last accepted command untouched and return a reason starting with the
    field name. Counts per reason are in ``rejected``. The name -> index permutation is cached for
    the last name list seen. ``values`` is the accepted command as a list of floats (what the
    simulator is sent, zeros before the first), ``tau`` a copy of it as an array.
    """

    def __init__(self, joint_names):
        self.joint_names = tuple(joint_names)
        self.n = len(self.joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.values = [0.0] * self.n
        self._cached_names = None
        self._cached_perm = None       # None for the identity permutation, else msg index of each joint
        self.rejected = dict.fromkeys(REJECT_REASONS, 0)
        self.accepted = 0
        self.last_reason = ''

    @property
    def tau(self):
        """The last accepted command, (n,) array (a copy)."""
        return np.array(self.values)

    def clear(self):
        """Forget the last accepted command: zeros."""
        self.values = [0.0] * self.n

    @property
    def rejected_total(self):
        return sum(self.rejected.values())

    def _reject(self, kind, reason):
        self.rejected[kind] += 1
        self.last_reason = reason
        return reason

    def _permutation(self, names):
        n = self.n
        if len(set(names)) != len(names):
            dup = sorted({s for s in names if names.count(s) > 1})
            return None, self._reject('duplicate_joint', f'name: duplicate joints {dup}')
        unknown = [s for s in names if s not in self._index]
        if unknown:
            return None, self._reject('unknown_joint',
                                      f'name: unknown joints {unknown} (expected {list(self.joint_names)})')
        if len(names) != n:
            missing = [s for s in self.joint_names if s not in names]
            return None, self._reject('missing_joint', f'name: missing joints {missing}')
        where = {s: i for i, s in enumerate(names)}
        perm = [where[s] for s in self.joint_names]
        self._cached_names = list(names)
        self._cached_perm = None if perm == list(range(n)) else perm
        return True, None

    def map_named(self, names, efforts):
        """JointState command: `names` (list of str) with `efforts` (sequence of float)."""
        if names != self._cached_names:
            ok, reason = self._permutation(names)
            if not ok:
                return reason
        if len(efforts) != self.n:
            return self._reject('length', f'effort: expected {self.n} values (one per name), got {len(efforts)}')
        return self._commit(efforts, self._cached_perm)

    def map_array(self, values):
        """Float64MultiArray command: `values` in `joints` order."""
        if len(values) != self.n:
            return self._reject('length', f'data: expected {self.n} values in joints order '
                                          f'{list(self.joint_names)}, got {len(values)}')
        return self._commit(values, None)

    def _commit(self, values, perm):
        kind = type(values)
        if kind is array.array and values.typecode == 'd' or kind is np.ndarray and values.dtype is _F64:
            v = values.tolist()      # a message's float64[] / an array
        else:
            v = list(map(float, values))   # a cdr frame's tuple (JointStateDecoder(arrays=False)), any numbers
        total = sum(v)
        if perm is not None:
            v = [v[i] for i in perm]
        if not math.isfinite(total):   # one C pass; entry by entry only for a NaN, an inf or an overflow
            bad = [name for name, x in zip(self.joint_names, v) if not math.isfinite(x)]
            if bad:
                return self._reject('non_finite', f'effort: non-finite values for joints {bad}')
        self.values = v
        self.accepted += 1
        return None


class SourceGuard:
    """Refuses to mix commands from more than one publisher: one controller drives the robot.

    Evidence of mixing, checked per message in O(1):
    - a command on a topic that the ROS graph shows with more than one publisher (the counts are
      refreshed by the loop: periodically and whenever a lockstep answer comes twice);
    - commands on both command topics (JointState and Float64MultiArray) within `timeout_ns`;
    - stamped commands (JointState, `stamp_ns` given) whose stamp is not after the previous one's
      while the graph shows more than one publisher (two sources answering the same states);
    - once commands came on both topics: a command on either while the graph still shows a publisher
      on the other (a source that falls silent for a while, a stalled process, is still there).
    While there is evidence the loop holds the brakes; the conflict clears after `timeout_ns` of
    simulation time without new evidence.

    A controller killed without a goodbye (SIGKILL, a crash) stays in the ROS graph for its DDS
    participant lease (20 s with Fast DDS defaults). A publisher that appears while the commands
    are silent (set_count(..., silent=True): no valid command for command_timeout after there had
    been one) is a replacement, not a second source: up to that many publishers are tolerated
    (`allowed`) until the count drops again, so a restarted controller resumes at once.
    """

    def __init__(self, timeout_ns, topics):
        self.timeout_ns = int(timeout_ns)
        self.topics = tuple(topics)
        self._others = [tuple(j for j in range(len(self.topics)) if j != i) for i in range(len(self.topics))]
        self.counts = [0] * len(self.topics)
        self.allowed = [1] * len(self.topics)     # publishers tolerated (1 + presumed-dead replaced ones)
        self.replacements = 0
        self.conflicts = 0
        self.reason = ''
        self._evidence_ns = None
        self._across = False        # the conflict in force is commands on both topics
        self.reset()

    def reset(self):
        """Forget message history (simulation time restarts); publisher counts are kept."""
        self._last_t = [None] * len(self.topics)
        self._last_stamp = [None] * len(self.topics)
        self._evidence_ns = None
        self._across = False

    def set_count(self, topic, n, silent=False):
        """Number of publishers the graph shows on topic index `topic`; `silent`: no command is coming in
        (the previous source stopped), so a newly appeared publisher replaces it."""
        n = int(n)
        if silent and n > max(self.counts[topic], self.allowed[topic]):
            self.allowed[topic] = n
            self.replacements += 1
        elif n < self.allowed[topic]:
            self.allowed[topic] = max(1, n)
        self.counts[topic] = n

    def in_conflict(self, t_ns):
        if self._evidence_ns is None:
            return False
        if t_ns - self._evidence_ns > self.timeout_ns or t_ns < self._evidence_ns:
            self._evidence_ns = None
            self._across = False
            return False
        return True

    def _evidence(self, t_ns, reason, across=False):
        if self._evidence_ns is None:
            self.conflicts += 1
        self._evidence_ns = t_ns
        self.reason = reason
        self._across = across

    def check(self, topic, t_ns, stamp_ns=None):
        """Record a command on topic index `topic` at simulation time `t_ns` (header stamp `stamp_ns`,
        None for unstamped messages); True when it may be applied, False while mixing is seen."""
        n = self.counts[topic]
        last = self._last_stamp[topic]
        if stamp_ns is not None:
            self._last_stamp[topic] = stamp_ns
        if n > self.allowed[topic]:
            self._evidence(t_ns, f'{n} publishers on {self.topics[topic]}')
        elif n > 1 and stamp_ns is not None and last is not None and stamp_ns <= last:
            self._evidence(t_ns, f'{n} publishers on {self.topics[topic]} sending interleaved commands')
        last_t = self._last_t
        for other in self._others[topic]:
            t_other = last_t[other]
            recent = t_other is not None and 0 <= t_ns - t_other <= self.timeout_ns
            if recent or (self._across and self.counts[other] > 0 and self.in_conflict(t_ns)):
                self._evidence(t_ns, f'commands on both {self.topics[other]} and {self.topics[topic]}', across=True)
        last_t[topic] = t_ns
        return self._evidence_ns is None or not self.in_conflict(t_ns)


class RateMeter:
    """Achieved real-time factor (simulation time / wall time) between two readings."""

    def __init__(self):
        self._wall = None
        self._sim = None

    def reset(self, wall_ns, sim_ns):
        self._wall, self._sim = wall_ns, sim_ns

    def read(self, wall_ns, sim_ns):
        """Factor since the last read (or reset), None if no wall time passed; restarts the window."""
        if self._wall is None or wall_ns <= self._wall or sim_ns < self._sim:
            self.reset(wall_ns, sim_ns)
            return None
        rtf = (sim_ns - self._sim) / (wall_ns - self._wall)
        self.reset(wall_ns, sim_ns)
        return rtf


class DeadlineMeter:
    """Realtime: did the command answering the state of tick k arrive before tick k+1's physics step?

    state(t_ns, wall_ns): the state stamped t_ns was published at wall_ns. command(stamp_ns, wall_ns):
    a valid command stamped stamp_ns arrived; when it answers the latest state its latency
    (wall_ns - publication) is kept (the last `window` of them). step(t_ns): the physics step that
    leaves the state t_ns is about to run: a hit when that state was answered, else a miss.
    """

    def __init__(self, window=1000):
        self.hits = 0
        self.misses = 0
        self._state_ns = None
        self._state_wall = 0
        self._answered_ns = None
        self._latency = np.zeros(int(window))
        self._count = 0

    def state(self, t_ns, wall_ns):
        self._state_ns, self._state_wall = t_ns, wall_ns

    def command(self, stamp_ns, wall_ns):
        if stamp_ns == self._state_ns and self._answered_ns != stamp_ns:
            self._answered_ns = stamp_ns
            self._latency[self._count % self._latency.shape[0]] = wall_ns - self._state_wall
            self._count += 1

    def step(self, t_ns):
        if self._answered_ns == t_ns:
            self.hits += 1
        else:
            self.misses += 1

    def latency_ms(self, q):
        """Percentile q (0..100) of the kept latencies, ms; None before the first answer."""
        k = min(self._count, self._latency.shape[0])
        return float(np.percentile(self._latency[:k], q)) / 1e6 if k else None
