"""Throttle: at most one event per period of wall time (warnings of both nodes).

rclpy's own `throttle_duration_sec` looks up the caller's source line (inspect, file system calls)
on every call, also on the suppressed ones: about 0.4 ms per rejected message here, so a flood of
bad input would cost the node its loop. The nodes ask a Throttle first and call the logger only
when it is ready.
"""


class Throttle:
    """At most one event per `period_ns` of wall time (for warnings); counts the suppressed ones."""

    def __init__(self, period_ns):
        self.period_ns = int(period_ns)
        self._next = None
        self.suppressed = 0

    def ready(self, wall_ns):
        if self._next is None or wall_ns >= self._next:
            self._next = wall_ns + self.period_ns
            return True
        self.suppressed += 1
        return False
