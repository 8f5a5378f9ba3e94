"""The joint_states watchdog: no state for `timeout` s stops commanding.

The age of the last state is taken on two clocks, the node's (simulated time when use_sim_time)
and the steady clock, and the larger counts: a stopped simulator also stops /clock, and then only
the steady clock shows that time passes. Times are integer ns.

A node clock that read 0 when the state was answered had not started (use_sim_time before the first
/clock message: ROS time is 0 until then), so that state's age is taken on the steady clock alone. The
first /clock then jumps the node clock from 0 to the simulator's time, and that jump is not an age:
/clock and joint_states are two topics, and under load DDS may match /clock's reader a second or more
after joint_states'.

The watchdog is checked every `period` s of the steady clock (timeout / CHECKS_PER_TIMEOUT). A check
that comes more than two periods after the one before it finds its own process held up (by the
machine's load, not by the robot): states that came in the meantime wait in the queue behind the
check, unread, so that check does not trip; the next one, a period on, decides. A silent robot is
then stopped after at most timeout + 2 periods instead of timeout + 1.
"""
from robot_control import units

#: checks per timeout: the check period is timeout / CHECKS_PER_TIMEOUT
CHECKS_PER_TIMEOUT = 5
#: smallest check period, s
MIN_PERIOD = 0.001


class StateWatchdog:
    """Trips when no state came for `timeout` s (> 0); the next state clears it (`recovered` tells)."""

    def __init__(self, timeout):
        self.timeout = timeout
        self.tripped = False
        self.trips = 0
        self.late_checks = 0        # checks that found their process held up (and so did not trip)
        self._node_ns = self._steady_ns = None
        self.checked_ns = None      # steady clock reading of the last check, ns (None before the first)

    @property
    def period(self):
        """The check period, s: timeout / CHECKS_PER_TIMEOUT, at least MIN_PERIOD."""
        return max(self.timeout / CHECKS_PER_TIMEOUT, MIN_PERIOD)

    def fresh(self, node_ns, steady_ns):
        """A state was answered at these clock readings; True when that ends a trip (a recovery)."""
        self._node_ns, self._steady_ns = node_ns, steady_ns
        recovered, self.tripped = self.tripped, False
        return recovered

    def age(self, node_ns, steady_ns):
        """Seconds since the last state (the larger of the two clocks; the steady clock alone when the node
        clock had not started then), None before the first."""
        if self._node_ns is None:
            return None
        steady = steady_ns - self._steady_ns
        return units.seconds(max(node_ns - self._node_ns, steady) if self._node_ns else steady)

    def check(self, node_ns, steady_ns):
        """True when this check trips the watchdog: the age passed timeout, it was not tripped yet, and
        this check came within two periods of the one before it (see the module docstring)."""
        last, self.checked_ns = self.checked_ns, steady_ns
        age = self.age(node_ns, steady_ns)
        if self.tripped or age is None or age <= self.timeout:
            return False
        if last is not None and steady_ns - last > 2 * units.to_ns(self.period):
            self.late_checks += 1
            return False
        self.tripped = True
        self.trips += 1
        return True
