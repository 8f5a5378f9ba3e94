"""Trajectories against their analytic forms: boundary conditions, continuity, limits, validation."""
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_control import trajectory as tr

RNG = np.random.default_rng(20261122)
Q0, Q1 = np.array([0.3, -1.0, 2.0]), np.array([1.3, 0.5, 2.0])   # the last joint does not move
EXACT = dict(rtol=0, atol=1e-12)


def _one_sided(traj, t, side, delta=1e-7):
    """Limit of (q, qd, qdd) at t from the left (side=-1) or right (+1): 2 f(t + s d) - f(t + 2 s d), error ~d^2."""
    a = np.array(traj.sample(t + side * delta))
    b = np.array(traj.sample(t + 2 * side * delta))
    return 2.0 * a - b


def _assert_continuous(traj, t, order, atol=1e-6):
    """Both one-sided limits of q, qd, ... (up to derivative `order`) equal the value at t."""
    at = np.array(traj.sample(t))
    scale = 1.0 + np.max(np.abs(at[: order + 1]))
    for side in (-1, 1):
        np.testing.assert_allclose(_one_sided(traj, t, side)[: order + 1], at[: order + 1], rtol=0,
                                   atol=atol * scale, err_msg=f'discontinuous at t = {t} from side {side}')


def _assert_derivatives_consistent(traj, ts, h=1e-5, tol=1e-6):
    """qd = d/dt q and qdd = d/dt qd by central differences at the times ts."""
    for t in ts:
        q_m, qd_m, _ = traj.sample(t - h)
        q_p, qd_p, _ = traj.sample(t + h)
        _, qd, qdd = traj.sample(t)
        np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, rtol=0, atol=tol * (1 + np.max(np.abs(qd))))
        np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, rtol=0, atol=tol * (1 + np.max(np.abs(qdd))))


def _interior_times(traj, count=25):
    """Times strictly inside every segment, away from the knots by more than the difference steps."""
    knots = traj.knots
    return [a + (b - a) * f for a, b in zip(knots[:-1], knots[1:]) for f in np.linspace(0.05, 0.95, count)]


# -- point to point: the analytic profiles --------------------------------------------------------

@pytest.mark.parametrize('profile, shape', [
    ('cubic', (lambda s: 3 * s ** 2 - 2 * s ** 3, lambda s: 6 * s - 6 * s ** 2, lambda s: 6 - 12 * s)),
    ('quintic', (lambda s: 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, lambda s: 30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4,
                 lambda s: 60 * s - 180 * s ** 2 + 120 * s ** 3)),
])
def test_polynomial_profiles_match_their_closed_forms(profile, shape):
    """q = q0 + D p(s), qd = D p'(s)/T, qdd = D p''(s)/T^2 with s = (t - t0)/T."""
    T, t0 = 1.7, 0.4
    traj = tr.point_to_point(Q0, Q1, T, profile=profile, t0=t0)
    D = Q1 - Q0
    for t in np.linspace(t0, t0 + T, 41):
        s = (t - t0) / T
        q, qd, qdd = traj.sample(t)
        np.testing.assert_allclose(q, Q0 + D * shape[0](s), rtol=0, atol=1e-12)
        np.testing.assert_allclose(qd, D * shape[1](s) / T, rtol=0, atol=1e-12)
        if 0.0 < s < 1.0:   # the cubic's qdd is not zero at the ends; sample holds rest after t_end
            np.testing.assert_allclose(qdd, D * shape[2](s) / T ** 2, rtol=0, atol=1e-11)


@pytest.mark.parametrize('profile', ['cubic', 'quintic', 'trapezoid'])
def test_point_to_point_boundary_conditions_are_exact(profile):
    traj = tr.point_to_point(Q0, Q1, 2.0, profile=profile, t0=1.0)
    q, qd, qdd = traj.sample(1.0)
    np.testing.assert_allclose(q, Q0, **EXACT)
    np.testing.assert_allclose(qd, 0.0, **EXACT)
    q, qd, qdd = traj.sample(3.0)
    np.testing.assert_allclose(q, Q1, **EXACT)
    np.testing.assert_allclose(qd, 0.0, **EXACT)
    assert (traj.t0, traj.t_end, traj.duration) == (1.0, 3.0, 2.0)


def test_quintic_starts_and_ends_with_zero_acceleration():
    traj = tr.point_to_point(Q0, Q1, 2.0, profile='quintic', t0=1.0)
    np.testing.assert_allclose(traj.sample(1.0)[2], 0.0, **EXACT)
    np.testing.assert_allclose(traj.sample(3.0)[2], 0.0, **EXACT)


@pytest.mark.parametrize('profile', ['cubic', 'quintic', 'trapezoid'])
def test_before_start_and_after_end(profile):
    traj = tr.point_to_point(Q0, Q1, 2.0, profile=profile, t0=1.0)
    for t in (-5.0, 0.999):
        q, qd, qdd = traj.sample(t)
        np.testing.assert_array_equal(q, Q0)
        np.testing.assert_array_equal(qd, 0.0)
        np.testing.assert_array_equal(qdd, 0.0)
    for t in (3.0 + 1e-9, 100.0):
        q, qd, qdd = traj.sample(t)
        np.testing.assert_array_equal(q, Q1)
        np.testing.assert_array_equal(qd, 0.0)
        np.testing.assert_array_equal(qdd, 0.0)


@pytest.mark.parametrize('profile', ['cubic', 'quintic', 'trapezoid'])
def test_derivatives_are_consistent(profile):
    traj = tr.point_to_point(Q0, Q1, 1.5, profile=profile, t0=0.2)
    _assert_derivatives_consistent(traj, _interior_times(traj))


def test_quintic_is_c2_at_both_ends_and_cubic_is_only_c1():
    quintic = tr.point_to_point(Q0, Q1, 1.5, profile='quintic')
    cubic = tr.point_to_point(Q0, Q1, 1.5, profile='cubic')
    for t in (0.0, 1.5):
        _assert_continuous(quintic, t, order=2)
        _assert_continuous(cubic, t, order=1)
    # the cubic's qdd steps from 0 (at rest) to 6 D / T^2 at t0 and from -6 D / T^2 to 0 at t_end
    D = Q1 - Q0
    np.testing.assert_allclose(cubic.sample(0.0)[2], 6 * D / 1.5 ** 2, **EXACT)
    np.testing.assert_allclose(cubic.sample(1.5)[2], -6 * D / 1.5 ** 2, atol=1e-12)
    np.testing.assert_allclose(_one_sided(cubic, 0.0, -1)[2], 0.0, atol=1e-12)
    for t in (0.0, 1.5):
        with pytest.raises(AssertionError, match='discontinuous'):
            _assert_continuous(cubic, t, order=2)


# -- trapezoid ------------------------------------------------------------------------------------

def _peaks(traj, count=4001):
    samples = [traj.sample(t) for t in np.linspace(traj.t0, traj.t_end, count)]
    return np.max([np.abs(s[1]) for s in samples], axis=0), np.max([np.abs(s[2]) for s in samples], axis=0)


def test_trapezoid_minimum_time_meets_v_max_and_a_max():
    """Limiting joint: T = D/v + v/a; joints move in sync on the straight line q0 + s (q1 - q0)."""
    v_max, a_max = np.array([0.8, 2.0, 1.0]), np.array([2.0, 3.0, 1.0])
    traj = tr.point_to_point(Q0, Q1, profile='trapezoid', v_max=v_max, a_max=a_max)
    # s-space limits: V = min(0.8/1, 2/1.5) = 0.8, A = min(2/1, 3/1.5) = 2 -> T = 1/0.8 + 0.8/2
    assert traj.duration == pytest.approx(1.0 / 0.8 + 0.8 / 2.0, rel=1e-14)
    vpk, apk = _peaks(traj)
    assert np.all(vpk <= v_max * (1 + 1e-12)) and np.all(apk <= a_max * (1 + 1e-12))
    assert vpk[0] == pytest.approx(0.8, rel=1e-12) and apk[0] == pytest.approx(2.0, rel=1e-12)
    for t in np.linspace(0.0, traj.t_end, 17):
        q = traj.sample(t)[0]
        s = (q[:2] - Q0[:2]) / (Q1 - Q0)[:2]
        assert s[0] == pytest.approx(s[1], abs=1e-12) and q[2] == Q0[2]


def test_trapezoid_blend_times_are_v_over_a():
    traj = tr.point_to_point([0.0], [2.0], profile='trapezoid', v_max=1.0, a_max=4.0)
    np.testing.assert_allclose(traj.knots, [0.0, 0.25, 2.0, 2.25], rtol=0, atol=1e-15)
    np.testing.assert_allclose(traj.sample(0.25)[0], [0.125], **EXACT)   # a tb^2 / 2
    np.testing.assert_allclose(traj.sample(1.0)[1], [1.0], **EXACT)     # cruise at v_max


def test_trapezoid_is_triangular_when_v_max_is_not_reached():
    """D = 1, a = 4: T = 2 sqrt(D/a) = 1, peak velocity sqrt(D a) = 2 < v_max."""
    traj = tr.point_to_point([0.0], [1.0], profile='trapezoid', v_max=10.0, a_max=4.0)
    assert traj.duration == pytest.approx(1.0, rel=1e-15) and len(traj.knots) == 3
    np.testing.assert_allclose(traj.sample(0.5)[:2], [[0.5], [2.0]], **EXACT)


def test_trapezoid_is_c1_with_acceleration_steps_at_the_blends():
    traj = tr.point_to_point([0.0], [2.0], profile='trapezoid', v_max=1.0, a_max=4.0)
    for t in traj.knots:
        _assert_continuous(traj, t, order=1)
    left, right = _one_sided(traj, 0.25, -1)[2], _one_sided(traj, 0.25, +1)[2]
    np.testing.assert_allclose([left[0], right[0]], [4.0, 0.0], atol=1e-6)


def test_trapezoid_with_duration_only_blends_over_a_third():
    """Blend T/3: peak qd = 1.5 D/T, |qdd| = 4.5 D/T^2."""
    traj = tr.point_to_point(Q0, Q1, 3.0, profile='trapezoid')
    D = Q1 - Q0
    np.testing.assert_allclose(traj.knots, [0.0, 1.0, 2.0, 3.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(traj.sample(1.5)[1], 1.5 * D / 3.0, **EXACT)
    np.testing.assert_allclose(traj.sample(0.5)[2], 4.5 * D / 9.0, **EXACT)


def test_trapezoid_with_duration_and_a_max_uses_the_shortest_blend():
    """tb = T/2 - sqrt(a^2 T^2 - 4 a D)/(2 a): D = 1, a = 2, T = 2 -> tb = 1 - sqrt(2)/2."""
    traj = tr.point_to_point([0.0], [1.0], 2.0, profile='trapezoid', a_max=2.0)
    tb = 1.0 - math.sqrt(2.0) / 2.0
    np.testing.assert_allclose(traj.knots, [0.0, tb, 2.0 - tb, 2.0], rtol=0, atol=1e-15)
    vpk, apk = _peaks(traj)
    assert apk[0] == pytest.approx(2.0, rel=1e-12) and vpk[0] == pytest.approx(2.0 * tb, rel=1e-9)
    np.testing.assert_allclose(traj.sample(2.0)[0], [1.0], **EXACT)


@pytest.mark.parametrize('profile', ['cubic', 'quintic'])
def test_polynomial_minimum_time_hits_the_limit(profile):
    """Peak |qd| = a D/T, |qdd| = b D/T^2 (PEAKS): with only v_max (only a_max) the peak equals the limit."""
    traj = tr.point_to_point([0.0], [2.0], profile=profile, v_max=0.5)
    assert traj.duration == pytest.approx(tr.PEAKS[profile][0] * 2.0 / 0.5, rel=1e-14)
    assert _peaks(traj, 20001)[0][0] == pytest.approx(0.5, rel=1e-6)
    traj = tr.point_to_point([0.0], [2.0], profile=profile, a_max=3.0)
    assert _peaks(traj, 20001)[1][0] == pytest.approx(3.0, rel=1e-6)
    assert _peaks(traj, 20001)[1][0] <= 3.0 * (1 + 1e-12)


@pytest.mark.parametrize('profile, limits', [('quintic', dict(v_max=0.1)), ('cubic', dict(a_max=0.1)),
                                             ('trapezoid', dict(a_max=0.1)), ('trapezoid', dict(v_max=0.1))])
def test_duration_too_short_for_the_limits_is_rejected(profile, limits):
    with pytest.raises(ValueError, match='^T'):
        tr.point_to_point([0.0], [2.0], 1.0, profile=profile, **limits)


def test_no_motion_without_duration_is_a_hold():
    for profile in ('quintic', 'trapezoid'):
        traj = tr.point_to_point(Q0, Q0, profile=profile, v_max=1.0, a_max=1.0, t0=2.0)
        assert traj.duration == 0.0
        np.testing.assert_array_equal(traj.sample(5.0)[0], Q0)


# -- hold and sample_into -------------------------------------------------------------------------

def test_hold_is_constant_with_zero_rates():
    traj = tr.hold([0.5, -0.25], t0=3.0)
    for t in (-1.0, 3.0, 1e6):
        q, qd, qdd = traj.sample(t)
        np.testing.assert_array_equal(q, [0.5, -0.25])
        np.testing.assert_array_equal(qd, 0.0)
        np.testing.assert_array_equal(qdd, 0.0)
    assert traj.t_end == traj.t0 == 3.0 and traj.n == 2


def test_sample_into_writes_the_given_arrays():
    traj = tr.from_points(0.0, (Q0, None, None), [1.0, 2.5], [Q1, Q0])
    buf = (np.zeros(3), np.zeros(3), np.zeros(3))
    for t in (-1.0, 0.0, 0.3, 1.0, 1.7, 2.5, 9.0):
        out = traj.sample_into(t, *buf)
        assert all(o is b for o, b in zip(out, buf))
        np.testing.assert_array_equal(np.array(buf), np.array(traj.sample(t)))


def test_sample_into_allocates_no_joint_sized_arrays():
    """With n = 100000 any (n,) temporary would cost 800 kB; the peak stays far below."""
    n = 100_000
    traj = tr.point_to_point(np.zeros(n), np.linspace(-1.0, 1.0, n), 2.0)
    q, qd, qdd = np.empty(n), np.empty(n), np.empty(n)
    traj.sample_into(0.5, q, qd, qdd)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        for t in np.linspace(-0.5, 2.5, 50):
            traj.sample_into(float(t), q, qd, qdd)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak - base < 100_000
    np.testing.assert_array_equal(q, np.linspace(-1.0, 1.0, n))


# -- paths through points (JointTrajectory) ------------------------------------------------------

def test_single_point_equals_the_quintic_point_to_point_move():
    traj = tr.from_points(1.0, (Q0, None, None), [2.0], [Q1])
    ref = tr.point_to_point(Q0, Q1, 2.0, profile='quintic', t0=1.0)
    for t in np.linspace(0.5, 3.5, 61):
        np.testing.assert_allclose(np.array(traj.sample(t)), np.array(ref.sample(t)), rtol=0, atol=1e-12)


def test_points_from_a_quintic_are_reproduced_exactly():
    """Given q, qd, qdd of a quintic p(t) at the points, each quintic Hermite segment is p itself."""
    coeffs = RNG.normal(size=(6, 2))
    p = np.polynomial.polynomial
    t0, times = 0.5, np.array([0.4, 1.1, 1.5, 2.3])
    ts = t0 + times

    def state(t):
        return (p.polyval(t, coeffs), p.polyval(t, p.polyder(coeffs)), p.polyval(t, p.polyder(coeffs, 2)))

    traj = tr.from_points(t0, state(t0), times, [state(t)[0] for t in ts], [state(t)[1] for t in ts],
                          [state(t)[2] for t in ts])
    for t in np.linspace(t0, ts[-1], 50):
        np.testing.assert_allclose(np.array(traj.sample(t)), np.array(state(t)), rtol=1e-9, atol=1e-9)


def test_spline_reproduces_a_cubic_with_matching_end_velocities():
    """A clamped C2 cubic spline through samples of a cubic p (end slopes p') is p: V = p', A = p''."""
    c = np.array([0.3, -1.0, 0.7, 0.25])
    p = np.polynomial.polynomial
    knots = np.array([0.0, 0.3, 1.0, 1.2, 2.0, 3.1])
    Q = p.polyval(knots, c)[:, None]
    v = p.polyval(knots, p.polyder(c))[:, None]
    V = tr.spline_velocities(knots, Q, v[0], v[-1])
    np.testing.assert_allclose(V, v, rtol=0, atol=1e-12)
    A = tr.knot_accelerations(knots, Q, V, [0.0], [0.0])
    np.testing.assert_allclose(A[1:-1], p.polyval(knots, p.polyder(c, 2))[1:-1, None], rtol=0, atol=1e-11)


def test_spline_velocities_solve_the_c2_equations():
    """Interior equations h_i v_i-1 + 2 (h_i-1 + h_i) v_i + h_i-1 v_i+1 = 3 (h_i s_i-1 + h_i-1 s_i), dense solve."""
    knots = np.cumsum(np.r_[0.0, RNG.uniform(0.1, 2.0, 8)])
    Q = RNG.normal(size=(9, 2))
    v0, vK = np.array([0.5, -0.2]), np.zeros(2)
    h, s = np.diff(knots), np.diff(Q, axis=0) / np.diff(knots)[:, None]
    M, rhs = np.zeros((9, 9)), np.zeros((9, 2))
    M[0, 0] = M[8, 8] = 1.0
    rhs[0], rhs[8] = v0, vK
    for i in range(1, 8):
        M[i, i - 1], M[i, i], M[i, i + 1] = h[i], 2 * (h[i - 1] + h[i]), h[i - 1]
        rhs[i] = 3 * (h[i] * s[i - 1] + h[i - 1] * s[i])
    np.testing.assert_allclose(tr.spline_velocities(knots, Q, v0, vK), np.linalg.solve(M, rhs), rtol=0, atol=1e-12)


def test_given_velocities_and_accelerations_are_honoured():
    start = (Q0, [0.1, 0.2, 0.3], [-1.0, 0.0, 1.0])
    vel = [[1.0, 0.0, -1.0], [0.0, 0.0, 0.0]]
    acc = [[0.5, 0.5, 0.5], [0.0, 0.0, 0.0]]
    traj = tr.from_points(2.0, start, [1.0, 2.0], [Q1, Q0], vel, acc)
    for got, want in zip(traj.sample(2.0), start):
        np.testing.assert_allclose(got, want, **EXACT)
    for got, want in zip(traj.sample(3.0), (Q1, vel[0], acc[0])):
        np.testing.assert_allclose(got, want, **EXACT)
    for got, want in zip(traj.sample(4.0), (Q0, vel[1], acc[1])):
        np.testing.assert_allclose(got, want, **EXACT)
    for t in traj.knots:
        _assert_continuous(traj, t, order=2)


def test_velocities_without_accelerations_stay_c2():
    traj = tr.from_points(0.0, (Q0, None, None), [1.0, 1.5, 3.0], [Q1, Q0, Q1],
                          velocities=[[1.0, 1.0, 0.0], [-0.5, 0.0, 0.5], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(traj.sample(1.5)[1], [-0.5, 0.0, 0.5], **EXACT)
    for t in traj.knots:
        _assert_continuous(traj, t, order=2)
    _assert_derivatives_consistent(traj, _interior_times(traj, 9))


def test_final_velocity_is_held_only_until_the_end():
    """Like joint_trajectory_controller: after the last point the position is held, at rest."""
    traj = tr.from_points(0.0, ([0.0], None, None), [1.0], [[1.0]], [[2.0]])
    np.testing.assert_allclose(traj.sample(1.0)[1], [2.0], **EXACT)
    np.testing.assert_array_equal(np.array(traj.sample(1.0 + 1e-9)), [[1.0], [0.0], [0.0]])


@st.composite
def _paths(draw):
    n = draw(st.integers(1, 3))
    k = draw(st.integers(1, 6))
    coord = st.floats(-2.0, 2.0, allow_nan=False)
    vec = st.lists(coord, min_size=n, max_size=n)
    gaps = draw(st.lists(st.floats(0.2, 2.0), min_size=k, max_size=k))
    t0 = draw(st.floats(-5.0, 5.0))
    start = (draw(vec), draw(st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n)),
             draw(st.lists(st.floats(-2.0, 2.0), min_size=n, max_size=n)))
    positions = draw(st.lists(vec, min_size=k, max_size=k))
    velocities = draw(st.one_of(st.none(), st.lists(vec, min_size=k, max_size=k)))
    return t0, start, np.cumsum(gaps), positions, velocities


@settings(max_examples=80, deadline=None, derandomize=True)
@given(_paths())
def test_from_points_passes_through_every_point_and_is_c2(path):
    t0, start, times, positions, velocities = path
    traj = tr.from_points(t0, start, times, positions, velocities)
    for got, want in zip(traj.sample(t0), start):
        np.testing.assert_allclose(got, want, **EXACT)
    for i, t in enumerate(t0 + times):
        q, qd, _ = traj.sample(t)
        np.testing.assert_allclose(q, positions[i], rtol=0, atol=1e-12)
        if velocities is not None:
            np.testing.assert_allclose(qd, velocities[i], rtol=0, atol=1e-12)
    for t in traj.knots[1:-1]:
        _assert_continuous(traj, t, order=2)
    if velocities is None:   # positions only: the path comes to rest, so the hold after it is C2 too
        _assert_continuous(traj, traj.t_end, order=2)
    _assert_derivatives_consistent(traj, _interior_times(traj, 3))
    np.testing.assert_array_equal(traj.sample(traj.t_end + 1.0)[0], positions[-1])


# -- force profiles -------------------------------------------------------------------------------

def test_force_step_through_point_to_point_is_smooth():
    """A 0 -> 10 N step as a quintic: f_d, fd_d, fdd_d continuous at start and end, 10 N held after."""
    profile = tr.point_to_point([0.0], [10.0], 0.5, t0=1.0)
    for t in (1.0, 1.5):
        _assert_continuous(profile, t, order=2)
    f_d, fd_d, fdd_d = profile.sample(1.25)
    assert f_d[0] == pytest.approx(5.0, abs=1e-12)
    assert fd_d[0] == pytest.approx(10.0 * 30 * 0.5 ** 2 * 0.25 / 0.5, abs=1e-9)   # D p'(1/2) / T
    np.testing.assert_array_equal(np.array(profile.sample(9.0)), [[10.0], [0.0], [0.0]])


def test_force_profile_through_points_on_a_contact_axis():
    """Ramp up to 5 N, hold, ramp to 8 N (the same from_points as for positions): passes the points, C2."""
    profile = tr.from_points(0.0, ([0.0], None, None), [0.5, 1.0, 1.5], [[5.0], [5.0], [8.0]])
    for t, f in zip((0.5, 1.0, 1.5), (5.0, 5.0, 8.0)):
        assert profile.sample(t)[0][0] == pytest.approx(f, abs=1e-12)
    for t in profile.knots:
        _assert_continuous(profile, t, order=2)


# -- rejected input -------------------------------------------------------------------------------

START = (np.zeros(2), None, None)


@pytest.mark.parametrize('kwargs, field', [
    (dict(times=[1.0, 1.0], positions=[[0, 0], [1, 1]]), 'times'),
    (dict(times=[2.0, 1.0], positions=[[0, 0], [1, 1]]), 'times'),
    (dict(times=[0.0, 1.0], positions=[[0, 0], [1, 1]]), 'times'),
    (dict(times=[-1.0], positions=[[0, 0]]), 'times'),
    (dict(times=[1.0, float('nan')], positions=[[0, 0], [1, 1]]), 'times'),
    (dict(times=[], positions=[]), 'times'),
    (dict(times=[1.0, 2.0], positions=[[0, 0]]), 'positions'),
    (dict(times=[1.0, 2.0, 3.0], positions=[[0, 0], [1, 1], [1, 2, 3]]), r'positions\[2\]'),
    (dict(times=[1.0, 2.0], positions=[[0, 0], [1, float('nan')]]), r'positions\[1\]'),
    (dict(times=[1.0, 2.0], positions=[[0, 0], [1, float('inf')]]), r'positions\[1\]'),
    (dict(times=[1.0], positions=[[0, 0]], velocities=[[float('inf'), 0]]), r'velocities\[0\]'),
    (dict(times=[1.0], positions=[[0, 0]], velocities=[[0, 0], [0, 0]]), 'velocities'),
    (dict(times=[1.0, 2.0], positions=[[0, 0], [1, 1]], velocities=[[0, 0], [0, 0]],
          accelerations=[[0, 0], [0]]), r'accelerations\[1\]'),
    (dict(times=[1.0], positions=[[0, 0]], accelerations=[[0, 0]]), 'accelerations'),
])
def test_from_points_rejects_bad_fields_naming_them(kwargs, field):
    with pytest.raises(ValueError, match=f'^{field}'):
        tr.from_points(0.0, START, **kwargs)


@pytest.mark.parametrize('start, field', [
    (([0.0, 0.0], [0.0], None), r'start\.qd'),
    (([0.0, float('nan')], None, None), r'start\.q'),
    (([0.0, 0.0], None, [0.0, 0.0, 0.0]), r'start\.qdd'),
    (([0.0, 0.0], None), 'start'),
    (5.0, 'start'),
])
def test_from_points_rejects_a_bad_start(start, field):
    with pytest.raises(ValueError, match=f'^{field}'):
        tr.from_points(0.0, start, [1.0], [[1.0, 1.0]])


@pytest.mark.parametrize('args, kwargs, field', [
    (([0.0, 0.0], [1.0]), dict(T=1.0), 'q1'),
    (([0.0, float('nan')], [1.0, 1.0]), dict(T=1.0), 'q0'),
    (([0.0], [1.0]), dict(T=0.0), 'T'),
    (([0.0], [1.0]), dict(T=-1.0), 'T'),
    (([0.0], [1.0]), dict(T=float('inf')), 'T'),
    (([0.0], [1.0]), dict(), 'T'),
    (([0.0], [1.0]), dict(T=1.0, profile='septic'), 'profile'),
    (([0.0], [1.0]), dict(profile='trapezoid', v_max=1.0), 'a_max'),
    (([0.0], [1.0]), dict(v_max=-1.0), 'v_max'),
    (([0.0, 0.0], [1.0, 1.0]), dict(a_max=[1.0, 1.0, 1.0]), 'a_max'),
    (([0.0], [1.0]), dict(T=1.0, t0=float('nan')), 't0'),
])
def test_point_to_point_rejects_bad_arguments_naming_them(args, kwargs, field):
    with pytest.raises(ValueError, match=f'^{field}'):
        tr.point_to_point(*args, **kwargs)


def test_sampling_at_a_non_finite_time_is_rejected():
    traj = tr.hold([0.0])
    with pytest.raises(ValueError, match='^t'):
        traj.sample(float('nan'))
