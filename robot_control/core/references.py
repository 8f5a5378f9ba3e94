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
Task target (x_d, 0, 0), (m,) in the model's task space, and a feed-forward wrench (m,): set by
~/target_pose and ~/target_wrench, none after a (re)start; a target may be stamped ahead too.
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
        self.task_target = self.wrench = self._target_pending = None
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
        self.task_target = self.wrench = self._target_pending = None
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

    def sample_target(self, t):
        """The task target at t (a pending one whose start has come takes over): (x_d, 0, 0) or None."""
        pending = self._target_pending
        if pending is not None and t >= pending[0]:
            self._target_pending = None
            self.task_target = (pending[1], np.zeros_like(pending[1]), np.zeros_like(pending[1]))
        return self.task_target

    def set_task_target(self, t_now, x_d, t_start=None):
        """A task target x_d (m,), at rest, from t_start (None or not after t_now: now; later: pending)."""
        x_d = np.array(x_d, dtype=float)
        if t_now is not None and t_start is not None and t_start > t_now:
            self._target_pending = (t_start, x_d)
            return
        self._target_pending = None
        self.task_target = (x_d, np.zeros_like(x_d), np.zeros_like(x_d))

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

    def set_trajectory(self, t_now, times, positions, velocities=None, accelerations=None, t_start=None,
                       limits=None):
        """A path through points (joint_trajectory_controller): times (k,) s after t_start (None: t_now),
        the first may be 0 (the planner's start state: the current reference is the start instead);
        positions (k, n), NaN in the columns of joints to hold; optional velocities/accelerations (k, n).
        Starts from the reference sampled at its start; a start in the future is pending; points already
        due are dropped (all due: ArgumentError naming times). limits: (lower, upper, velocity, joints),
        (n,) each, checked along the path (ArgumentError naming the joint, the point and the limit).
        Returns the new trajectory."""
        times = validation.vector('times', times)
        positions = _rows_or_held('positions', positions, (times.shape[0], self.n))
        t_start = t_now if t_start is None else validation.scalar('t_start', t_start)
        first = 0
        if times.shape[0] and times[0] == 0.0:
            first = 1
        if t_start < t_now:
            due = t_start + times <= t_now
            first = max(first, int(np.count_nonzero(due)))
            if first >= times.shape[0]:
                raise ArgumentError('times', f'the trajectory ended {t_now - (t_start + times[-1]):.6g} s ago')
        if first >= times.shape[0]:
            raise ArgumentError('points[0].time_from_start', 'a trajectory needs a point after 0 s')
        keep = slice(first, None)
        start = max(t_start, t_now)
        times = t_start + times[keep] - start
        rows = [None if a is None else np.asarray(a, dtype=float)[keep] for a in (velocities, accelerations)]
        begin = self._traj.sample(start)
        positions = _held_columns(positions[keep], begin[0])
        rows = [None if a is None else _held_columns(a, 0.0) for a in rows]
        traj = from_points(start, begin, times, positions, *rows)
        if limits is not None:
            check_limits(traj, *limits, first)
        if start > t_now:
            self._pending = traj
        else:
            self._traj, self._pending = traj, None
        return traj

    def hold(self, t, q):
        """Hold q (n,) from time t on, at rest (a cancelled or aborted trajectory)."""
        self._traj, self._pending = hold(q, t), None

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


def _rows_or_held(name, value, shape):
    """`value` as a float64 array of `shape`: finite, or NaN for a joint to hold; ArgumentError naming `name`."""
    rows = validation.shaped(name, value, shape)
    if np.isinf(rows).any():
        raise ArgumentError(name, 'expected finite values (NaN: a joint to hold)')
    return rows


def _held_columns(rows, value):
    """rows (k, n) with the NaN columns (joints a partial goal leaves out) set to `value` (scalar or (n,))."""
    missing = np.isnan(rows)
    if missing.any():
        rows = np.where(missing, np.broadcast_to(value, rows.shape), rows)
    return rows


#: samples per segment when a path is checked against the joint limits
LIMIT_SAMPLES = 16


def check_limits(traj, lower, upper, velocity, joints, first=0):
    """ArgumentError naming the first point and joint where the path leaves [lower, upper] (rad or m) or
    exceeds |qd| <= velocity (rad/s or m/s), each (n,) (inf = none); points counted from `first`."""
    knots = traj.knots
    for k in range(len(knots) - 1):
        for t in np.linspace(knots[k], knots[k + 1], LIMIT_SAMPLES + 1)[1:]:
            q, qd, _ = traj.sample(t)
            for what, bad, bound in (('position', q < lower, lower), ('position', q > upper, upper),
                                     ('velocity', np.abs(qd) > velocity, velocity)):
                if bad.any():
                    j = int(np.flatnonzero(bad)[0])
                    value = (q if what == 'position' else qd)[j]
                    raise ArgumentError(f'points[{first + k}]', f'{joints[j]} {what} {value:.6g} beyond the '
                                                                f'limit {bound[j]:g} on the way to this point')
