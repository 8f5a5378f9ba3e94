"""The controller's time line: joint_states stamps (integer ns) -> the core's time, s.

The core's time is seconds since the stamp of the first state (a stamp of 0, the first instant
of a simulation, is a time like any other). A state whose stamp moves more than `max_jump` s away
from the previous one, while the controller runs, is refused: a clock that jumped (a simulator
reset) restarts the controller only once the watchdog has stopped it. References stamped in the
future (trajectories, force targets) are placed on the same time line. The robot's tick is the last
forward step between two accepted stamps within `max_jump` (step_ns); a state `follows` the last one
when it is at most two of those steps later (or the same stamp again): the robot's time stood still.
"""
from robot_control import units
from robot_control.validation import ArgumentError


class Timeline:
    """Stamps -> core time; `max_jump` s (> 0), the largest accepted step between two states."""

    def __init__(self, max_jump):
        self.max_jump = max_jump
        self.epoch_ns = None        # stamp of the first state
        self.last_ns = None         # stamp of the last accepted state
        self.step_ns = None         # the robot's tick: the last forward step within max_jump between two of them

    def accept(self, stamp_ns, running):
        """The core time (s) of a state stamped `stamp_ns`; ArgumentError naming header.stamp when it is
        negative or, while `running`, further than max_jump from the previous state."""
        if stamp_ns < 0:
            raise ArgumentError('header.stamp', f'negative time {units.seconds(stamp_ns):.9f} s')
        last = self.last_ns
        if running and last is not None and not self.continues(stamp_ns):
            raise ArgumentError('header.stamp', f'{units.seconds(stamp_ns - last):+.6g} s from the previous state, '
                                                f'more than state_timeout {self.max_jump:g} s (a clock reset '
                                                'restarts the controller once the watchdog trips)')
        if self.epoch_ns is None:
            self.epoch_ns = stamp_ns
        if last is not None and 0 < stamp_ns - last <= self.max_jump * units.NS_PER_S:
            self.step_ns = stamp_ns - last
        self.last_ns = stamp_ns
        return units.seconds(stamp_ns - self.epoch_ns)

    def continues(self, stamp_ns):
        """True when a state stamped `stamp_ns` lies within max_jump of the last accepted one (the time line goes
        on without a gap); False before the first."""
        return self.last_ns is not None and abs(stamp_ns - self.last_ns) <= self.max_jump * units.NS_PER_S

    def follows(self, stamp_ns):
        """True when a state stamped `stamp_ns` is the robot's next tick after the last accepted one: the same stamp
        or later by at most two steps step_ns (its time stood still meanwhile); False before a step is known. A
        simulator that restarted its clock lands there only by chance of a few ticks."""
        return self.step_ns is not None and 0 <= stamp_ns - self.last_ns <= 2 * self.step_ns

    def time_of(self, stamp_ns):
        """The core time of a reference's header.stamp; None for 0 (start now) or before the first state."""
        if stamp_ns == 0 or self.epoch_ns is None:
            return None
        return units.seconds(stamp_ns - self.epoch_ns)

    def ahead(self, stamp_ns):
        """True when a reference stamped `stamp_ns` lies after the last state (it is then pending)."""
        return bool(stamp_ns) and self.last_ns is not None and stamp_ns > self.last_ns
