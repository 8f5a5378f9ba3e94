"""Payload identification: the mass and centre of mass a tip carries, from the joint torques at rest (no ROS).

At rest (qd = qdd = 0) the link-side joint torque a torque sensor reads is the gravity torque alone,
whatever the motor and its friction do (stiction holds the rest of the motor's torque):

    tau = g_robot(q) + Y(q) theta,   theta = [m, m c_x, m c_y, m c_z]   (kg, kg m)

Y(q) (n, 4) is the tip's payload regressor (UrdfModel.payload_regressor: -J_v^T g m + J_w^T [g]x R (m c)),
g_robot(q) = g_model(q) - Y(q) theta_model the model's gravity torque without the payload it carries.
Over poses k = 1..P, each the mean of the states over `sample_time` s at rest, theta solves the stacked
least squares

    min_theta  sum_k || Y(q_k) theta - (tau_k - g_robot(q_k)) ||^2,   c = (m c) / m.

The pose schedule: the start pose q_0 plus each offset (P, n) rad, visited in turn by a quintic move of
`move_time` s (ControllerCore.set_goal) under the active law, then back to q_0. At a pose, sampling starts
once the move is over, `settle_time` s have passed and every |qd| < settle_velocity (rad/s), restarts if a
joint moves faster again, and ends after `sample_time` s of states at rest (their mean is the pose's). A
sample needs the measured joint torques (effort, N m) of that tick.
"""
import dataclasses

import numpy as np

from robot_control.validation import ArgumentError

#: default offsets of the last (at most three) joints, rad: each of them +- this, one at a time
DEFAULT_OFFSET = 0.6
#: smallest singular value of the stacked regressor, relative to its largest, that counts as excited
MIN_EXCITATION = 1e-3


def default_offsets(n, amplitude=DEFAULT_OFFSET):
    """(P, n) offsets: the start pose, then +-amplitude rad on each of the last min(3, n) joints (the wrist)."""
    rows = [np.zeros(n)]
    for j in range(max(0, n - 3), n):
        for sign in (1.0, -1.0):
            row = np.zeros(n)
            row[j] = sign * amplitude
            rows.append(row)
    return np.array(rows)


def offsets_of(flat, n):
    """The offsets (P, n) of a flat list of P * n joint offsets, rad; empty -> default_offsets(n)."""
    if not len(flat):
        return default_offsets(n)
    if len(flat) % n:
        raise ArgumentError('payload_identification.poses', f'expected a multiple of {n} values (n joint offsets '
                                                            f'per pose), got {len(flat)}')
    return np.array(flat, dtype=float).reshape(-1, n)


@dataclasses.dataclass(frozen=True)
class Estimate:
    """An identified payload: mass kg, com (3,) m in the tip frame, residual N m (RMS of the fit's
    torque error over every pose and joint), poses used."""

    mass: float
    com: np.ndarray
    residual: float
    poses: int

    def message(self):
        com = ', '.join(f'{c:.4f}' for c in self.com)
        return f'mass {self.mass:.4f} kg, com [{com}] m, residual {self.residual:.4f} N m over {self.poses} poses'


def solve(regressors, torques):
    """Estimate from Y_k (n, 4) and the payload's measured torques tau_k - g_robot(q_k) (n,) of each pose:
    the least squares of the module docstring. ArgumentError when the poses do not excite theta (a singular
    value of the stacked Y below MIN_EXCITATION times the largest: the noise would decide that direction)
    or the mass comes out <= 0."""
    Y, r = np.vstack(regressors), np.concatenate(torques)
    theta, _, _, sv = np.linalg.lstsq(Y, r, rcond=None)
    rank = int(np.sum(sv > MIN_EXCITATION * sv[0]))
    if rank < 4:
        raise ArgumentError('payload_identification.poses', f'the poses determine {rank} of the 4 payload '
                                                            'parameters: vary the tip orientation more')
    if theta[0] <= 0.0:
        raise ArgumentError('payload_identification', f'no payload found (mass {theta[0]:.4g} kg)')
    residual = float(np.sqrt(np.mean((Y @ theta - r) ** 2)))
    return Estimate(float(theta[0]), theta[1:] / theta[0], residual, len(regressors))


def payload_torque(model, q, tau):
    """(Y (n, 4), tau - g_robot(q) (n,)) at pose q for the measured torque tau, N m (module docstring)."""
    Y = model.payload_regressor(q)
    mass, com = model.payload
    return Y, tau - model._g(q) + Y @ np.concatenate(([mass], mass * com))


class PayloadIdentification:
    """The schedule and the samples of one identification on a ControllerCore (module docstring).

    start(core, q) once the core runs; then tick(core, q, qd, tau) after each answered state (q, qd,
    tau: (n,) in joint order). `done` when back at the start pose with every pose measured; then
    `estimate` holds the Estimate, or `error` the ArgumentError of the solve."""

    def __init__(self, offsets, move_time, settle_time, settle_velocity, sample_time):
        self.offsets = np.asarray(offsets, dtype=float)
        self.move_time, self.settle_time = move_time, settle_time
        self.settle_velocity, self.sample_time = settle_velocity, sample_time
        self.estimate = self.error = None
        self.done = False
        self.pose = 0                # index into offsets; == len(offsets): returning to the start
        self._regressors, self._torques = [], []

    def start(self, core, q):
        """Begin at the measured pose q (n,): the first move."""
        self._q0 = np.array(q, dtype=float)
        self._goto(core, 0)

    def _goto(self, core, k):
        self.pose = k
        goal = self._q0 + self.offsets[k] if k < len(self.offsets) else self._q0
        core.set_goal(goal, self.move_time)
        self._ready_at = core.t + self.move_time + self.settle_time
        self._sum_q, self._sum_tau, self._count = 0.0, 0.0, 0

    def tick(self, core, q, qd, tau):
        """One answered state (q, qd rad, rad/s; tau the measured joint torques, N m)."""
        if self.done or core.t < self._ready_at:
            return
        if np.max(np.abs(qd)) >= self.settle_velocity:
            self._sum_q, self._sum_tau, self._count = 0.0, 0.0, 0
            return
        if self.pose == len(self.offsets):
            self._finish()
            return
        if not self._count:
            self._first = core.t
        self._sum_q, self._sum_tau, self._count = self._sum_q + q, self._sum_tau + tau, self._count + 1
        if core.t - self._first >= self.sample_time:
            Y, r = payload_torque(core.config.model, self._sum_q / self._count, self._sum_tau / self._count)
            self._regressors.append(Y)
            self._torques.append(r)
            self._goto(core, self.pose + 1)

    def _finish(self):
        self.done = True
        try:
            self.estimate = solve(self._regressors, self._torques)
        except ArgumentError as exc:
            self.error = exc
