"""The joint_states watchdog: no state for `timeout` s stops commanding.

The age of the last state is taken on two clocks, the node's (simulated time when use_sim_time)
and the steady clock, and the larger counts: a stopped simulator also stops /clock, and then only
the steady clock shows that time passes. Times are integer ns.
"""
from robot_control import units


class StateWatchdog:
    """Trips when no state came for `timeout` s (> 0); the next state clears it (`recovered` tells)."""

    def __init__(self, timeout):
        self.timeout = timeout
        self.tripped = False
        self.trips = 0
        self._node_ns = self._steady_ns = None

    def fresh(self, node_ns, steady_ns):
        """A state was answered at these clock readings; True when that ends a trip (a recovery)."""
        self._node_ns, self._steady_ns = node_ns, steady_ns
        recovered, self.tripped = self.tripped, False
        return recovered

    def age(self, node_ns, steady_ns):
        """Seconds since the last state (the larger of the two clocks), None before the first."""
        if self._node_ns is None:
            return None
        return units.seconds(max(node_ns - self._node_ns, steady_ns - self._steady_ns))

    def check(self, node_ns, steady_ns):
        """True when this check trips the watchdog (the age passed timeout and it was not tripped yet)."""
        age = self.age(node_ns, steady_ns)
        if self.tripped or age is None or age <= self.timeout:
            return False
        self.tripped = True
        self.trips += 1
        return True
