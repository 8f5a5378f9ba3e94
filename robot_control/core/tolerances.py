"""Goal and path tolerances of a trajectory, as joint_trajectory_controller's `constraints`.

Per joint (rad or m, 0 = not checked): `trajectory`, the largest |q_d - q| while the trajectory
runs; `goal`, the largest |q_d - q| at its end. `goal_time` (s, 0 = no limit): how long after the
trajectory's end time the goal may take to be reached; `stopped_velocity_tolerance` (rad/s or m/s):
the largest |qd| of a reached goal.

Outcomes of a trajectory: 'succeeded' (at or after its end every joint within its goal tolerance and
below the stopped velocity), 'path' (a joint left its trajectory tolerance: the controller holds the
current position), 'missed' (not reached within goal_time: the controller holds the current
position), 'cancelled' (an empty trajectory, or a new one before the end).
"""
import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Tolerances:
    """trajectory, goal: (n,) >= 0 (0 = not checked); goal_time s >= 0 (0 = no limit); stopped_velocity >= 0."""

    trajectory: np.ndarray
    goal: np.ndarray
    goal_time: float = 0.0
    stopped_velocity: float = 0.01


class GoalMonitor:
    """Follows one trajectory at a time and reports its outcome (see the module docstring)."""

    def __init__(self, joints):
        self.joints = tuple(joints)
        self.t_end = None           # end time of the trajectory being followed, s (None: none)
        self.outcome = ''           # '', 'succeeded', 'path', 'missed', 'cancelled'
        self.reason = ''
        self.goals = 0

    @property
    def active(self):
        """True while a trajectory is followed and its outcome is open."""
        return self.t_end is not None

    def start(self, t_end):
        """A new trajectory ending at t_end (s); one still open is cancelled."""
        if self.active:
            self._close('cancelled', 'replaced by a new trajectory')
        self.t_end = t_end
        self.goals += 1
        self.outcome = self.reason = ''

    def cancel(self, why):
        if self.active:
            self._close('cancelled', why)

    def check(self, t, q, qd, q_d, tol):
        """The outcome decided at time t (s) with the state q, qd and the reference q_d (n,), or ''."""
        if not self.active:
            return ''
        error = np.abs(q_d - q)
        if t <= self.t_end:
            over = (tol.trajectory > 0.0) & (error > tol.trajectory)
            if over.any():
                return self._close('path', self._describe('trajectory', error, tol.trajectory, over, t))
            return ''
        within = (tol.goal <= 0.0) | (error <= tol.goal)
        stopped = np.abs(qd) <= tol.stopped_velocity
        if within.all() and stopped.all():
            return self._close('succeeded', f'goal reached at t = {t:.3f} s, {t - self.t_end:.3f} s after its end '
                                            f'(largest error {error.max():.3g})')
        if tol.goal_time > 0.0 and t > self.t_end + tol.goal_time:
            if not within.all():
                return self._close('missed', self._describe('goal', error, tol.goal, ~within, t))
            slow = np.abs(qd) > tol.stopped_velocity
            return self._close('missed', f'{self._names(slow)} still moving at t = {t:.3f} s (|qd| '
                                         f'{np.abs(qd)[slow].tolist()} > stopped_velocity_tolerance '
                                         f'{tol.stopped_velocity:g})')
        return ''

    def _close(self, outcome, reason):
        self.t_end = None
        self.outcome, self.reason = outcome, reason
        return outcome

    def _names(self, mask):
        return [j for j, m in zip(self.joints, mask) if m]

    def _describe(self, kind, error, bound, mask, t):
        parts = [f'{j}: |q_d - q| = {e:.4g} > {b:g}' for j, e, b, m in zip(self.joints, error, bound, mask) if m]
        return f'{kind} tolerance exceeded at t = {t:.3f} s: {", ".join(parts)}'
