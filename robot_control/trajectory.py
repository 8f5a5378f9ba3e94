"""Reference trajectories q_d(t), qd_d(t), qdd_d(t) for point-to-point and path control (lecture, section 1).

Every trajectory is piecewise polynomial: on segment k, t in [t_k, t_k+1), tau = t - t_k,
q_d(t) = sum_j c_kj tau^j (degree <= 5, per joint). Builders:

- point_to_point(q0, q1, T, profile): 'cubic' (zero end velocities), 'quintic' (zero end velocities and
  accelerations) or 'trapezoid' (trapezoidal velocity, from a duration T or from v_max/a_max).
- from_points(t0, start, times, positions, velocities=None, accelerations=None): a path through points,
  like trajectory_msgs/JointTrajectory; continuous position, velocity and acceleration (C2).
- hold(q, t0): a constant reference.

Sampling: before t0 the start state (at rest for point_to_point; the given start for from_points), on
[t0, t_end] the polynomials, after t_end the last point held with zero velocity and acceleration.
Units: t in s; q in rad or m, qd per s, qdd per s^2. Shapes: every vector (n,).

Force profiles: nothing here is specific to positions. Pass forces (N) instead of positions and the same
builders return f_d, fd_d, fdd_d (N, N/s, N/s^2), e.g. point_to_point([0.0], [10.0], 0.5) is a smooth
10 N force step whose f_d, fd_d and fdd_d are continuous at its start and end.
"""
import bisect
import math

import numpy as np

from robot_control.validation import ArgumentError
from robot_control import validation

PROFILES = ('quintic', 'cubic', 'trapezoid')
#: peak |qd| = a |q1 - q0| / T and peak |qdd| = b |q1 - q0| / T^2 of the polynomial profiles: (a, b)
PEAKS = {'cubic': (1.5, 6.0), 'quintic': (15.0 / 8.0, 10.0 / math.sqrt(3.0))}
_RTOL = 1e-12  # slack on limit checks, relative


class Trajectory:
    """Piecewise polynomial reference; build it with point_to_point, from_points or hold.

    knots: (K+1,) strictly increasing times (s); coeffs: (K, 6, n), q = sum_j coeffs[k, j] tau^j.
    before: (q, qd, qdd) returned for t < t0 (the start); last: the exact end of the last segment,
    returned at t = t_end; after t_end: (q_last, 0, 0). Each state (3, n). On [t0, t_end) the
    segments are evaluated (at t0 exactly: coeffs[0, 0], coeffs[0, 1], 2 coeffs[0, 2]).
    """

    def __init__(self, knots, coeffs, before, last):
        self._knots = [float(t) for t in knots]
        self._c = np.ascontiguousarray(coeffs, dtype=float)
        self._dc = np.ascontiguousarray(self._c[:, 1:] * np.arange(1.0, 6.0)[None, :, None])
        self._ddc = np.ascontiguousarray(self._dc[:, 1:] * np.arange(1.0, 5.0)[None, :, None])
        self._before = np.array(before, dtype=float)
        self._last = np.array(last, dtype=float)
        self._rest = np.zeros_like(self._last)
        self._rest[0] = self._last[0]
        self._powers = np.ones(6)  # scratch for sample_into: 1, tau, ..., tau^5

    @property
    def n(self):
        """Number of joints (or force axes)."""
        return self._last.shape[1]

    @property
    def t0(self):
        """Start time, s."""
        return self._knots[0]

    @property
    def t_end(self):
        """End time, s (equal to t0 for a hold)."""
        return self._knots[-1]

    @property
    def duration(self):
        """t_end - t0, s."""
        return self._knots[-1] - self._knots[0]

    @property
    def knots(self):
        """Segment boundaries t_0 = t0 < t_1 < ... < t_K = t_end, s."""
        return tuple(self._knots)

    def sample(self, t):
        """(q_d, qd_d, qdd_d) at time t (s), three new (n,) arrays."""
        out = (np.empty(self.n), np.empty(self.n), np.empty(self.n))
        return self.sample_into(t, *out)

    def sample_into(self, t, q_out, qd_out, qdd_out):
        """Write q_d, qd_d, qdd_d at time t (s) into C-contiguous float64 (n,) arrays; no array allocation.

        Not thread-safe (one scratch buffer per trajectory). Returns (q_out, qd_out, qdd_out).
        """
        if not math.isfinite(t):
            raise ArgumentError('t', f'expected a finite time, got {t}')
        if t < self._knots[0] or t >= self._knots[-1]:
            state = self._before if t < self._knots[0] else self._last if t == self._knots[-1] else self._rest
            q_out[:], qd_out[:], qdd_out[:] = state[0], state[1], state[2]
            return q_out, qd_out, qdd_out
        k = bisect.bisect_right(self._knots, t) - 1
        p = self._powers
        tau = t - self._knots[k]
        for j in range(1, 6):
            p[j] = p[j - 1] * tau
        np.dot(p, self._c[k], out=q_out)
        np.dot(p[:5], self._dc[k], out=qd_out)
        np.dot(p[:4], self._ddc[k], out=qdd_out)
        return q_out, qd_out, qdd_out

    def __repr__(self):
        return f'Trajectory(n={self.n}, t0={self.t0:g}, t_end={self.t_end:g}, segments={len(self._knots) - 1})'


# -- polynomial segments --------------------------------------------------------------------------

def cubic_hermite(h, q0, q1, v0, v1):
    """Coefficients (..., 6, n) of the cubic with q(0)=q0, q(h)=q1, qd(0)=v0, qd(h)=v1; h (...,) or scalar."""
    h = np.asarray(h, dtype=float)[..., None]
    d = q1 - q0
    c2 = (3.0 * d - (2.0 * v0 + v1) * h) / h ** 2
    c3 = (-2.0 * d + (v0 + v1) * h) / h ** 3
    zero = np.zeros_like(c2)
    return np.stack([q0 + zero, v0 + zero, c2, c3, zero, zero], axis=-2)


def quintic_hermite(h, q0, q1, v0, v1, a0, a1):
    """Coefficients (..., 6, n) of the quintic with q, qd, qdd = (q0, v0, a0) at 0 and (q1, v1, a1) at h."""
    h = np.asarray(h, dtype=float)[..., None]
    d = q1 - q0
    c3 = (20.0 * d - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h ** 2) / (2.0 * h ** 3)
    c4 = (-30.0 * d + (14.0 * v1 + 16.0 * v0) * h + (3.0 * a0 - 2.0 * a1) * h ** 2) / (2.0 * h ** 4)
    c5 = (12.0 * d - 6.0 * (v1 + v0) * h + (a1 - a0) * h ** 2) / (2.0 * h ** 5)
    zero = np.zeros_like(c3)
    return np.stack([q0 + zero, v0 + zero, 0.5 * a0 + zero, c3, c4, c5], axis=-2)


# -- argument checks ------------------------------------------------------------------------------

def _limit(name, value, n):
    """None, or a positive finite (n,) bound (a scalar is broadcast), else ValueError naming `name`."""
    if value is None:
        return None
    a = validation.vector(name, value)
    if a.shape[0] == 1:
        a = np.full(n, a[0])
    if a.shape[0] != n or not np.all(a > 0.0):
        raise ArgumentError(name, f'expected a positive number or {n} positive numbers, got {a.tolist()}')
    return a


def _times(times):
    """time_from_start of each point: (K,), K >= 1, strictly increasing, > 0."""
    tf = validation.vector('times', times)
    if tf.shape[0] == 0:
        raise ArgumentError('times', 'expected at least one point')
    if not tf[0] > 0.0:
        raise ArgumentError('times', f'expected time_from_start > 0 (the start is the point at t0), got {tf.tolist()}')
    if not np.all(np.diff(tf) > 0.0):
        raise ArgumentError('times', f'expected strictly increasing values, got {tf.tolist()}')
    return tf


def _points(name, value, count, n):
    """`count` points of length n as a (count, n) array; ValueError naming `name` or `name[i]`."""
    try:
        rows = list(value)
    except TypeError as exc:
        raise ArgumentError(name, f'expected a sequence of points, got {value!r}') from exc
    if len(rows) != count:
        raise ArgumentError(name, f'expected {count} points (one per time), got {len(rows)}')
    return np.array([validation.vector(f'{name}[{i}]', p, n) for i, p in enumerate(rows)]).reshape(count, n)


def _start(start):
    """(q, qd, qdd) at t0 as three (n,) arrays; qd or qdd None means zeros."""
    try:
        parts = list(start)
    except TypeError as exc:
        raise ArgumentError('start', f'expected (q, qd, qdd), got {start!r}') from exc
    if len(parts) != 3:
        raise ArgumentError('start', f'expected (q, qd, qdd), got {len(parts)} items')
    q = validation.vector('start.q', parts[0])
    n = q.shape[0]
    qd, qdd = (np.zeros(n) if p is None else validation.vector(f'start.{k}', p, n)
               for k, p in (('qd', parts[1]), ('qdd', parts[2])))
    return q, qd, qdd


# -- point to point -------------------------------------------------------------------------------

def _polynomial_duration(profile, delta, T, v_max, a_max):
    """T, or the shortest T with peak |qd| <= v_max and |qdd| <= a_max (PEAKS); ValueError if T is shorter."""
    a, b = PEAKS[profile]
    dist = np.abs(delta)
    need = 0.0
    if v_max is not None:
        need = max(need, float(np.max(a * dist / v_max)))
    if a_max is not None:
        need = max(need, float(np.max(np.sqrt(b * dist / a_max))))
    if T is None:
        if v_max is None and a_max is None:
            raise ArgumentError('T', 'give a duration T or the limits v_max/a_max')
        return need
    if T < need * (1.0 - _RTOL):
        raise ArgumentError('T', f'{T:g} s is shorter than the {need:g} s that v_max/a_max allow for this {profile} move')
    return T


def _path_limits(delta, v_max, a_max):
    """Bounds (V, A) on sd, sdd of the path parameter s in q = q0 + s (q1 - q0): min over moving joints."""
    moving = delta != 0.0
    if not np.any(moving):
        return math.inf, math.inf
    dist = np.abs(delta[moving])
    V = math.inf if v_max is None else float(np.min(v_max[moving] / dist))
    A = math.inf if a_max is None else float(np.min(a_max[moving] / dist))
    return V, A


def _trapezoid_timing(T, V_lim, A_lim):
    """(T, tb, A) of the s-profile 0 -> 1: blend time tb at acceleration A, cruise sd = A tb, A tb (T - tb) = 1."""
    if T is None:
        if V_lim * V_lim >= A_lim:  # v_max not reached: triangular profile
            tb = math.sqrt(1.0 / A_lim)
            return 2.0 * tb, tb, A_lim
        return 1.0 / V_lim + V_lim / A_lim, V_lim / A_lim, A_lim
    if math.isinf(A_lim):  # no acceleration limit: blends of T/3
        tb, A = T / 3.0, 4.5 / T ** 2
    else:  # the shortest blend a_max allows
        if A_lim * T * T < 4.0 * (1.0 - _RTOL):
            raise ArgumentError('T', f'{T:g} s is too short for a_max (needs T >= {2.0 / math.sqrt(A_lim):g} s)')
        tb, A = 0.5 * T - 0.5 * math.sqrt(max(T * T - 4.0 / A_lim, 0.0)), A_lim
    if A * tb > V_lim * (1.0 + _RTOL):
        raise ArgumentError('T', f'{T:g} s needs a peak velocity above v_max')
    return T, tb, A


def _trapezoid(q0, delta, T, t0, v_max, a_max):
    """Trapezoidal velocity along q0 + s (q1 - q0): accelerate at A for tb, cruise, decelerate at A for tb."""
    if T is None and a_max is None:
        raise ArgumentError('a_max', 'the trapezoid needs a_max (and v_max), or a duration T')
    V_lim, A_lim = _path_limits(delta, v_max, a_max)
    if T is None and math.isinf(A_lim):
        return hold(q0, t0)
    T, tb, A = _trapezoid_timing(T, V_lim, A_lim)
    V = A * tb
    pieces = [(0.0, tb, (0.0, 0.0, 0.5 * A)),
              (tb, T - tb, (0.5 * A * tb * tb, V, 0.0)),
              (T - tb, T, (1.0 - 0.5 * A * tb * tb, V, -0.5 * A))]
    pieces = [p for p in pieces if t0 + p[1] > t0 + p[0]]
    knots = [t0 + p[0] for p in pieces] + [t0 + T]
    s = np.array([p[2] + (0.0, 0.0, 0.0) for p in pieces])  # (K, 6)
    coeffs = s[:, :, None] * delta
    coeffs[:, 0, :] += q0
    zero = np.zeros_like(q0)
    return Trajectory(knots, coeffs, (q0, zero, zero), (q0 + delta, zero, -A * delta))


def point_to_point(q0, q1, T=None, profile='quintic', t0=0.0, *, v_max=None, a_max=None):
    """Move from q0 to q1 (n,) in T s starting at t0, at rest at both ends; profile 'quintic'|'cubic'|'trapezoid'.

    cubic: q = q0 + (q1 - q0)(3 s^2 - 2 s^3); quintic: q = q0 + (q1 - q0)(10 s^3 - 15 s^4 + 6 s^5), s = (t - t0)/T.
    trapezoid: all joints along the line q0 + s (q1 - q0), s with a trapezoidal velocity (C1 only: qdd jumps).
    T None: the shortest move within v_max, a_max (scalar or (n,), per joint; the slowest joint sets T).
    T given with limits: the limits are checked (ValueError naming T); a trapezoid with a_max uses the
    shortest blend a_max allows, without a_max blends of T/3 (peak qd = 1.5 (q1 - q0)/T).
    """
    q0 = validation.vector('q0', q0)
    n = q0.shape[0]
    q1 = validation.vector('q1', q1, n)
    t0 = validation.scalar('t0', t0)
    T = None if T is None else validation.scalar('T', T, positive=True)
    if profile not in PROFILES:
        raise ArgumentError('profile', f'expected one of {PROFILES}, got {profile!r}')
    v_max, a_max = _limit('v_max', v_max, n), _limit('a_max', a_max, n)
    if profile == 'trapezoid':
        return _trapezoid(q0, q1 - q0, T, t0, v_max, a_max)
    T = _polynomial_duration(profile, q1 - q0, T, v_max, a_max)
    if T == 0.0:
        return hold(q1, t0)
    zero = np.zeros(n)
    if profile == 'cubic':  # C1 only: qdd = +-6 (q1 - q0)/T^2 at the ends, 0 before and after
        coeffs, qdd_end = cubic_hermite(T, q0, q1, zero, zero), -6.0 * (q1 - q0) / T ** 2
    else:
        coeffs, qdd_end = quintic_hermite(T, q0, q1, zero, zero, zero, zero), zero
    return Trajectory([t0, t0 + T], coeffs[None], (q0, zero, zero), (q1, zero, qdd_end))


# -- paths through points -------------------------------------------------------------------------

def _solve_tridiagonal(lower, diag, upper, rhs):
    """Thomas algorithm for a diagonally dominant tridiagonal system: bands (m,), rhs (m, n) -> (m, n)."""
    m = diag.shape[0]
    c, d = np.zeros(m), np.array(rhs, dtype=float)
    c[0], d[0] = upper[0] / diag[0], d[0] / diag[0]
    for i in range(1, m):
        w = diag[i] - lower[i] * c[i - 1]
        c[i] = upper[i] / w
        d[i] = (d[i] - lower[i] * d[i - 1]) / w
    for i in range(m - 2, -1, -1):
        d[i] -= c[i] * d[i + 1]
    return d


def spline_velocities(knots, Q, v_first, v_last):
    """Knot velocities (K+1, n) of the C2 cubic spline through Q (K+1, n) with end velocities clamped.

    At each interior knot i (h_i = t_i+1 - t_i, slope s_i = (q_i+1 - q_i)/h_i):
    h_i v_i-1 + 2 (h_i-1 + h_i) v_i + h_i-1 v_i+1 = 3 (h_i s_i-1 + h_i-1 s_i).
    """
    h = np.diff(knots)
    V = np.empty_like(Q)
    V[0], V[-1] = v_first, v_last
    if h.shape[0] < 2:
        return V
    s = np.diff(Q, axis=0) / h[:, None]
    a, b = h[:-1], h[1:]  # h_i-1, h_i for the interior knots
    rhs = 3.0 * (b[:, None] * s[:-1] + a[:, None] * s[1:])
    rhs[0] -= b[0] * V[0]
    rhs[-1] -= a[-1] * V[-1]
    V[1:-1] = _solve_tridiagonal(b, 2.0 * (a + b), a, rhs)
    return V


def knot_accelerations(knots, Q, V, a_first, a_last):
    """Knot accelerations (K+1, n): at interior knots the mean of the two adjacent cubic Hermite segments'.

    With V from spline_velocities both sides agree, so these are the C2 spline's own accelerations.
    """
    h = np.diff(knots)[:, None]
    d = np.diff(Q, axis=0)
    start = (6.0 * d - (4.0 * V[:-1] + 2.0 * V[1:]) * h) / h ** 2  # qdd at the start of each segment
    end = (-6.0 * d + (2.0 * V[:-1] + 4.0 * V[1:]) * h) / h ** 2   # qdd at the end of each segment
    A = np.empty_like(Q)
    A[0], A[-1] = a_first, a_last
    A[1:-1] = 0.5 * (end[:-1] + start[1:])
    return A


def from_points(t0, start, times, positions, velocities=None, accelerations=None):
    """C2 path through JointTrajectory-like points: quintic segments between knots t0, t0 + times[k].

    start: (q, qd, qdd) at t0, the implicit first point (qd/qdd None = zeros); times: time_from_start
    (K,), s, strictly increasing, > 0; positions: K points (n,); velocities, accelerations: K points or
    None. Given values are met at the points; missing velocities come from the C2 cubic spline
    (spline_velocities, final velocity 0), missing accelerations from knot_accelerations (final 0).
    Quintic Hermite segments then match q, qd, qdd at every knot: position, velocity and acceleration
    are continuous. Bad input: ValueError naming the field ('times', 'positions[2]', 'velocities[0]').
    """
    t0 = validation.scalar('t0', t0)
    q0, v0, a0 = _start(start)
    n = q0.shape[0]
    tf = _times(times)
    K = tf.shape[0]
    if accelerations is not None and velocities is None:
        raise ArgumentError('accelerations', 'given without velocities')
    knots = np.concatenate([[t0], t0 + tf])
    if not np.all(np.diff(knots) > 0.0):
        raise ArgumentError('times', f'points closer than the resolution of t0 = {t0!r}')
    Q = np.vstack([q0, _points('positions', positions, K, n)])
    zero = np.zeros(n)
    if velocities is None:
        V = spline_velocities(knots, Q, v0, zero)
    else:
        V = np.vstack([v0, _points('velocities', velocities, K, n)])
    if accelerations is None:
        A = knot_accelerations(knots, Q, V, a0, zero)
    else:
        A = np.vstack([a0, _points('accelerations', accelerations, K, n)])
    coeffs = quintic_hermite(np.diff(knots), Q[:-1], Q[1:], V[:-1], V[1:], A[:-1], A[1:])
    return Trajectory(knots, coeffs, (q0, v0, a0), (Q[-1], V[-1], A[-1]))


def hold(q, t0=0.0):
    """The constant reference q_d = q (n,), qd_d = qdd_d = 0, for all t; t_end = t0."""
    q = validation.vector('q', q)
    t0 = validation.scalar('t0', t0)
    zero = np.zeros_like(q)
    return Trajectory([t0], np.zeros((0, 6, q.shape[0])), (q, zero, zero), (q, zero, zero))
