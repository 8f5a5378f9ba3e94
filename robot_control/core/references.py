"""The controller's references: the joint reference and the force reference, on the core's time line.

Times are seconds on the core's time base (any increasing base; the node uses its joint_states
stamps). Both references are robot_control.trajectory Trajectories, so a reference is always a
C2 curve: a new motion or force target starts from the current reference sampled at its start
time, and the reference never jumps.

Joint reference (q_d, qd_d, qdd_d), (n,): holds the measured position at a (re)start; set_goal()
makes a quintic move, set_trajectory() a path through points like joint_trajectory_controller
(a start in the future is pending until then). Force reference (f_d, fd_d, fdd_d), (k,) over the
force axes: ramps from the measured force to the target at a (re)start and on every new target
(quintic over force_ramp_time; a step when that is 0); a target may be stamped ahead (pending).
"""
import numpy as np

from robot_control import validation
from robot_control.trajectory import from_points, hold
from robot_control.validation import ArgumentError


class References:
    """Joint and force references of one controller (see the module docstring).

    n joints, k force axes; move_time and force_ramp_time in s (the active configuration's).
    """

    def __init__(self, n, k, move_time, force_ramp_time):
        self.n = n
        self.move_time = move_time
        self.force_ramp_time = force_ramp_time
        self.q_d, self.qd_d, self.qdd_d = np.zeros(n), np.zeros(n), np.zeros(n)
        self._traj = self._pending = self._goal = None
        self._held = None           # the trajectory whose end state (held after t_end) q_d ... hold
        self.set_force_axes(k)

    def set_force_axes(self, k):
        """k force axes: the force target back to zeros, the reference re-made at the next start."""
        self.k = k
        self.f_target = np.zeros(k)
        self.f_d, self.fd_d, self.fdd_d = np.zeros(k), np.zeros(k), np.zeros(k)
        self._force = hold(self.f_target) if k else None
        self._force_pending = None

    # -- start and sampling ------------------------------------------------------------------------
    def start(self, t, q, f):
        """(Re)start at time t: hold q (n,) (or make the move set_goal() asked for before the start) and
        ramp the force reference from f (k,) N (None: from the target) to the target."""
        self._traj, self._pending = hold(q, t), None
        if self._goal is not None:
            goal, duration = self._goal
            self._goal = None
            self._traj = from_points(t, (q, None, None), [duration], [goal])
        self._force_pending = None
        if self.k:
            self._force = self._ramp(t, (self.f_target if f is None else f, None, None), self.f_target)

    def sample(self, t, force):
        """Write the joint reference at t into q_d, qd_d, qdd_d (and the force reference into f_d, fd_d,
        fdd_d when `force`); a pending trajectory or force target whose start has come takes over."""
        if self._pending is not None and t >= self._pending.t0:
            self._traj, self._pending = self._pending, None
        traj = self._traj
        if not (t > traj.t_end and self._held is traj):   # else the arrays hold its end state already
            traj.sample_into(t, self.q_d, self.qd_d, self.qdd_d)
            self._held = traj if t > traj.t_end else None
        if force:
            pending = self._force_pending
            if pending is not None and t >= pending[0]:
                self._force_pending = None
                self._set_force(t, pending[1])
            self._force.sample_into(t, self.f_d, self.fd_d, self.fdd_d)

    def at(self, t):
        """(q_d, qd_d, qdd_d) the joint reference gives at time t (new arrays)."""
        traj = self._pending if self._pending is not None and t >= self._pending.t0 else self._traj
        return traj.sample(t)

    # -- new references -----------------------------------------------------------------------------
    def set_goal(self, t_now, q_goal, duration=None):
        """Quintic move to q_goal (n,) over `duration` s (default move_time) from the reference at t_now;
        before the first state (t_now None) it becomes the first move, from the measured start position."""
        q_goal = validation.vector('q_goal', q_goal, self.n)
        duration = self.move_time if duration is None else validation.scalar('duration', duration, positive=True)
        if t_now is None:
            self._goal = (q_goal.copy(), duration)
            return
        self._traj = from_points(t_now, self._traj.sample(t_now), [duration], [q_goal])
        self._pending = None

    def set_trajectory(self, t_now, times, positions, velocities=None, accelerations=None, t_start=None):
        """A path through points (joint_trajectory_controller): times (k,) s after t_start (None: t_now),
        positions (k, n), optional velocities/accelerations (k, n). Starts from the reference sampled
        at its start; a start in the future is pending; points already due are dropped (all due:
        ArgumentError naming times). Returns the start time used."""
        times = validation.vector('times', times)
        positions = validation.matrix('positions', positions, (times.shape[0], self.n))
        t_start = t_now if t_start is None else validation.scalar('t_start', t_start)
        if t_start < t_now:
            keep = t_start + times > t_now
            if not keep.any():
                raise ArgumentError('times', f'the trajectory ended {t_now - (t_start + times[-1]):.6g} s ago')
            times, positions = t_start + times[keep] - t_now, positions[keep]
            velocities = None if velocities is None else np.asarray(velocities, dtype=float)[keep]
            accelerations = None if accelerations is None else np.asarray(accelerations, dtype=float)[keep]
            t_start = t_now
        traj = from_points(t_start, self._traj.sample(t_start), times, positions, velocities, accelerations)
        if t_start > t_now:
            self._pending = traj
        else:
            self._traj, self._pending = traj, None
        return t_start

    def set_force_target(self, t_now, f_target, t_start=None):
        """Ramp the force reference to f_target (k,) N over force_ramp_time from t_start (None or not
        after t_now: now; later: pending until a tick reaches it). t_now None: before the first state."""
        f_target = validation.vector('f_d', f_target, self.k)
        if t_now is not None and t_start is not None and t_start > t_now:
            self._force_pending = (t_start, f_target.copy())
            return
        self._force_pending = None
        self._set_force(t_now, f_target)

    def _set_force(self, t, f_target):
        self.f_target = f_target.copy()
        if t is not None and self.k:
            self._force = self._ramp(t, self._force.sample(t), self.f_target)

    def _ramp(self, t, start, target):
        if self.force_ramp_time <= 0.0:
            return hold(target, t)
        return from_points(t, start, [self.force_ramp_time], [target])

    @property
    def force_pending(self):
        """(t_start s, f_target (k,)) of a force target stamped ahead, or None."""
        return self._force_pending
