"""Hybrid position/force control (lecture 3.1) in operational space (Khatib 1987).

Task space X = fk(q), (m,), split by the bool mask `force_axes` into motion axes x_T and force
axes x_N. Servo: F' = [F_T; F_N] with
    F_T = xdd_Td + K_Tv Ed_T + K_Tp E_T,   F_N = K_e^-1 (fdd_d + K_Nv Ed_N + K_Np E_N),
E_T = x_Td - x_T, E_N = f_d - f. Model portion, for an articulated, possibly redundant arm:
    tau = J^T (Lambda F' + mu + p + f_e) + N^T tau_0,   Lambda = (J M^-1 J^T)^-1,
    mu = Lambda (J M^-1 C qd - Jdot qd),  p = Lambda J M^-1 g,  Jbar = M^-1 J^T Lambda,
    N^T = I - J^T Jbar^T,  tau_0 = M qdd_0 + C qd + g  (qdd_0: the posture acceleration).
It is computed in the equivalent joint-space form
    tau = M qdd* + C qd + g + J^T f_e,   qdd* = Jbar (F' - Jdot qd) + (I - Jbar J) qdd_0,
and gives Xdd = F' in closed loop; qdd_0 acts in the null space only. With m = n, qdd* =
J^-1 (F' - Jdot qd) and, for a Cartesian robot (J = I), tau = M_x F' + C_x + g_x + f_e exactly.
Per tick (m < n): one kinematics pass for x, J, Jdot qd, M^-1 by Cholesky, an m x m solve and one
RNEA, since M qdd* + C qd + g = rnea(q, qd, qdd_0) + J^T Lambda (F' - Jdot qd - J qdd_0).

Force sign: f is the force the robot exerts on the environment, signed along each task axis, and
f_e = f on the force axes, 0 on the motion axes (the robot's dynamics: M qdd + C qd + g + J^T f_e
= tau). With f = K_e (x_N - x_e) and K_e > 0 this holds whichever side the robot presses from:
pressing down on a table (-z) gives f_z < 0, so pushing with 10 N is f_d = -10 N on z.
"""
import functools
import math

import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.laws.servo import bool_mask, check_finite, gain_arrays, per_entry, vectors
from robot_control.validation import ArgumentError, F64, finite, is_vector

#: largest accepted condition number of the task Jacobian J(q)
MAX_JACOBIAN_COND = 1e9
#: det(G) / trace(G)^m > this, G = J J^T (m x m), proves cond(J) < 1e6 without an SVD
_GRAM_ACCEPT = 1e-12


def _axis_gains(gains, axes, name):
    """(kp, kv, ki) over all m axes, zero off `axes`; gains given per selected axis or per all m."""
    m, k = axes.shape[0], int(np.count_nonzero(axes))
    if gains is None:
        if k:
            raise ArgumentError(name, f'gains required for {k} axes')
        return np.zeros(m), np.zeros(m), np.zeros(m)
    if np.size(getattr(gains, 'kp', ())) == k and k != m:
        full = (np.zeros(m), np.zeros(m), np.zeros(m))
        for dst, src in zip(full, gain_arrays(gains, k, name)):
            dst[axes] = src
        return full
    return tuple(np.where(axes, a, 0.0) for a in gain_arrays(gains, m, name))


def _axes_and_stiffness(force_axes, K_e, m):
    """The force-axes mask (m,) and the diagonal of K_e (m,): > 0 on the force axes, 1 elsewhere."""
    axes = bool_mask('force_axes', force_axes, m)
    K_e = per_entry('K_e', K_e, m)
    if not (K_e[axes] > 0.0).all():
        raise ArgumentError('K_e', f'expected positive stiffness on the force axes, got {K_e.tolist()}')
    return axes, np.where(axes, K_e, 1.0)


def _task_vectors(m, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot):
    return vectors(m, x_d=x_d, xd_d=xd_d, xdd_d=xdd_d, f_d=f_d, fd_d=fd_d, fdd_d=fdd_d, f=f, fdot=fdot)


@functools.lru_cache(maxsize=32)
def _task_setup(gains_T, gains_N, axes_key, K_e_key):
    """_axis_lists() of immutable arguments (ServoGains or None, the mask's bytes, K_e as a number
    or its float64 bytes), checked and computed once per combination (lru_cache)."""
    axes = np.frombuffer(axes_key, dtype=bool).copy()
    K_e = np.frombuffer(K_e_key, dtype=float) if isinstance(K_e_key, bytes) else K_e_key
    axes, K_e = _axes_and_stiffness(axes, K_e, axes.shape[0])
    gt, gn = _axis_gains(gains_T, ~axes, 'gains_T'), _axis_gains(gains_N, axes, 'gains_N')
    return _axis_lists(axes, K_e, gt[0] + gn[0], gt[1] + gn[1], gt[2] + gn[2])


def _axis_lists(axes, K_e, kp, kv, ki):
    """(axes, K_e, kp, kv, ki), each a tuple of m Python values (the servo below runs in floats)."""
    return tuple(tuple(a.tolist()) for a in (axes, K_e, kp, kv, ki))


def _servo_floats(setup, x, xd, task, int_E):
    """(F', f_e, total) over the m task axes as lists, in Python floats (m <= 6: cheaper than numpy
    here); total adds every entry of the task vectors: not finite when one of them is NaN or inf.

    Motion axes: F_i = xdd_d + kv Ed + kp E (+ ki int E), E = x_d - x, Ed = xd_d - xd; force axes:
    F_i = (fdd_d + kv Ed + kp E (+ ki int E)) / K_e, E = f_d - f, Ed = fd_d - fdot; f_e = f on the
    force axes, 0 elsewhere. The same operations, in the same order, as hybrid_servo's arrays.
    """
    axes, K_e, kp, kv, ki = setup
    lists = [a.tolist() for a in task]
    x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot = lists
    x, xd = x.tolist(), xd.tolist()
    ie = None if int_E is None else int_E.tolist()
    F, f_e = [], []
    for i, force in enumerate(axes):
        if force:
            u = fdd_d[i] + kv[i] * (fd_d[i] - fdot[i]) + kp[i] * (f_d[i] - f[i])
            f_e.append(f[i])
        else:
            u = xdd_d[i] + kv[i] * (xd_d[i] - xd[i]) + kp[i] * (x_d[i] - x[i])
            f_e.append(0.0)
        if ie is not None:
            u = u + ki[i] * ie[i]
        F.append(u / K_e[i])
    return F, f_e, sum(map(sum, lists))


@functools.lru_cache(maxsize=32)
def _posture_setup(k_posture, n):
    """(kp0, -kv0), each (n,) read-only, of an immutable k_posture (a tuple of numbers or ServoGains)."""
    kp0, kv0 = _posture_gains(k_posture, n)
    kp0, neg_kv0 = np.array(kp0, dtype=float), -kv0   # own copies, shared by every cache hit
    kp0.flags.writeable = neg_kv0.flags.writeable = False
    return kp0, neg_kv0


def _immutable_gains(gains):
    return gains is None or type(gains) is ServoGains


def _fast_setup(n, m, q, qd, task, force_axes, K_e, gains_T, gains_N, q_posture, k_posture, int_E):
    """The cached setup (_axis_lists(), (kp0, -kv0)) when every vector is already a float64 array of
    the right shape, q, qd and q_posture are finite (numpy arithmetic and the model use them; the
    task vectors and int_E are checked in Python floats, see _hybrid_torque) and the gains are
    immutable; None: the checked path."""
    if not (is_vector(q, n) and is_vector(qd, n)
            and type(force_axes) is np.ndarray and force_axes.dtype == np.bool_ and force_axes.shape == (m,)
            and (q_posture is None or is_vector(q_posture, n)) and (int_E is None or is_vector(int_E, m))
            and _immutable_gains(gains_T) and _immutable_gains(gains_N)
            and (type(k_posture) is tuple or type(k_posture) is ServoGains)):
        return None
    for a in task:
        if not is_vector(a, m):
            return None
    if not (finite(q) and finite(qd) and (q_posture is None or finite(q_posture))):
        return None
    K_e_key = K_e.tobytes() if type(K_e) is np.ndarray and K_e.dtype is F64 else K_e
    try:
        return _task_setup(gains_T, gains_N, force_axes.tobytes(), K_e_key), _posture_setup(k_posture, n)
    except (TypeError, ValueError):   # unhashable or invalid: the checked path words the error
        return None


def _servo_F(x, xd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, axes, K_e, gains_T, gains_N, int_E):
    """F' on checked arrays: [xdd_d + Kv Ed + Kp E (+ Ki int E)] on motion axes, K_e^-1 [fdd_d + ...] on force axes."""
    gt, gn = _axis_gains(gains_T, ~axes, 'gains_T'), _axis_gains(gains_N, axes, 'gains_N')
    kp, kv, ki = gt[0] + gn[0], gt[1] + gn[1], gt[2] + gn[2]
    E = np.where(axes, f_d - f, x_d - x)
    Ed = np.where(axes, fd_d - fdot, xd_d - xd)
    u = np.where(axes, fdd_d, xdd_d) + kv * Ed + kp * E
    if int_E is not None:
        u = u + ki * validation.vector('int_E', int_E, x.shape[0])
    return check_finite('F', u / K_e)


def hybrid_error(x, x_d, f, f_d, force_axes):
    """E (m,): E_T = x_d - x on the motion axes, E_N = f_d - f on the force axes (m and N)."""
    x = validation.vector('x', x)
    x_d, f, f_d = vectors(x.shape[0], x_d=x_d, f=f, f_d=f_d)
    return np.where(bool_mask('force_axes', force_axes, x.shape[0]), f_d - f, x_d - x)


def hybrid_servo(x, xd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, force_axes, K_e,
                 gains_T, gains_N, int_E=None):
    """F' (m,) in m/s^2: F_T = xdd_d + K_Tv Ed_T + K_Tp E_T (+ K_Ti int E_T), F_N = K_e^-1 (fdd_d + ...).

    All task vectors (m,) (entries of the other subspace ignored but must be finite); K_e in N/m,
    scalar or (m,); gains_T / gains_N: kp, kv, ki per selected axis or per all m axes (ignored
    off their subspace; None when that subspace is empty); int_E (m,) the integral of hybrid_error().
    """
    x = validation.vector('x', x)
    m = x.shape[0]
    (xd,) = vectors(m, xd=xd)
    task = _task_vectors(m, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot)
    axes, K_e = _axes_and_stiffness(force_axes, K_e, m)
    return _servo_F(x, xd, *task, axes, K_e, gains_T, gains_N, int_E)


def _task_shape(J):
    """(m, n) of the task Jacobian J, checked: m <= n and J far from singular (_check_jacobian)."""
    m, n = J.shape
    if m > n:
        raise ArgumentError('J', f'task dimension {m} exceeds the {n} joints; operational-space control needs m <= n')
    _check_jacobian(J)
    return m, n


def _check_jacobian(J):
    """ValueError naming q when cond(J) > MAX_JACOBIAN_COND; the SVD runs only near a singularity."""
    m = J.shape[0]
    if 0 < m <= 3:
        G = (J @ J.T).tolist()
        if m == 1:
            det = tr = G[0][0]
        elif m == 2:
            (a, b), (c, d) = G
            det, tr = a * d - b * c, a + d
        else:
            (a, b, c), (d, e, f), (g, h, i) = G
            det, tr = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g), a + e + i
        bound = tr
        for _ in range(m - 1):
            bound *= tr          # tr^m (multiplication overflows to inf, ** would raise)
        if tr > 0.0 and det > _GRAM_ACCEPT * bound:   # lambda_min / lambda_max of G >= det / tr^m
            return
    sv = np.linalg.svd(J, compute_uv=False)
    if not sv[-1] * MAX_JACOBIAN_COND > sv[0]:
        raise ArgumentError('q', f'task Jacobian singular or nearly (singular values {sv.tolist()})')


def _solve(A, b):
    """A^-1 b for a small non-singular A (k, k), b (k,). k <= 3: Cramer's rule in Python floats
    (cheaper than a LAPACK call at this size, and exact when A = I); larger k: np.linalg.solve."""
    k = b.shape[0]
    if k > 3:
        return np.linalg.solve(A, b)
    if k == 1:
        return b / A[0]
    if k == 2:
        (a, c), (d, e) = A.tolist()
        b0, b1 = b.tolist()
        det = a * e - c * d
        if det == 0.0:
            raise np.linalg.LinAlgError('Singular matrix')
        return np.array([(b0 * e - c * b1) / det, (a * b1 - d * b0) / det])
    (a, c, d), (e, f, g), (h, i, j) = A.tolist()
    b0, b1, b2 = b.tolist()
    c0, c1, c2 = f * j - g * i, g * h - e * j, e * i - f * h      # cofactors of the first row
    det = a * c0 + c * c1 + d * c2
    if det == 0.0:
        raise np.linalg.LinAlgError('Singular matrix')
    return np.array([(c0 * b0 + (d * i - c * j) * b1 + (c * g - d * f) * b2) / det,
                     (c1 * b0 + (a * j - d * h) * b1 + (d * e - a * g) * b2) / det,
                     (c2 * b0 + (c * h - a * i) * b1 + (a * f - c * e) * b2) / det])


def task_space_torque(M, h, J, Jdot_qd, F, f_e, qdd_0=None):
    """tau = M qdd* + h + J^T f_e, qdd* = Jbar (F - Jdot qd) + (I - Jbar J) qdd_0, Jbar = M^-1 J^T Lambda.

    M (n, n), h = C qd + g (n,), J (m, n) with m <= n, Jdot_qd (m,), F = F' (m,) m/s^2,
    f_e (m,) N, qdd_0 (n,) the posture acceleration (used only when m < n). Returns tau (n,).
    """
    m, n = _task_shape(J)
    a = F - Jdot_qd
    if m == n:
        qdd = np.linalg.solve(J, a)
    else:
        Minv_JT = np.linalg.solve(M, J.T)
        Jbar = Minv_JT @ np.linalg.inv(J @ Minv_JT)  # M^-1 J^T Lambda
        qdd = Jbar @ a
        if qdd_0 is not None:
            qdd = qdd + qdd_0 - Jbar @ (J @ qdd_0)
    return M @ qdd + h + J.T @ f_e


def _model_task_torque(model, q, qd, J, Jdot_qd, F, f_e, qdd_0):
    """task_space_torque on the model, checked arrays: M qdd* + C qd + g by RNEA, no M or h formed.

    m = n: tau = rnea(q, qd, J^-1 (F - Jdot qd)) + J^T f_e. m < n: with Jbar = M^-1 J^T Lambda,
    qdd* = qdd_0 + Jbar (F - Jdot qd - J qdd_0), so tau = rnea(q, qd, qdd_0) + J^T (y + f_e) with
    y = Lambda (F - Jdot qd - J qdd_0), Lambda^-1 = J M^-1 J^T (m x m).
    """
    m, n = _task_shape(J)
    a = F - Jdot_qd
    if m == n:
        return model._inverse_dynamics(q, qd, _solve(J, a)) + J.T @ f_e
    Minv_JT = model._Minv(q) @ J.T
    y = _solve(J @ Minv_JT, a - J @ qdd_0)
    return model._inverse_dynamics(q, qd, qdd_0) + J.T @ (y + f_e)


def operational_space(model, q, qd, F, f_e, qdd_0=None):
    """tau (n,) giving Xdd = F (m,) m/s^2 with contact force f_e (m,) N and null-space acceleration qdd_0 (n,)."""
    q, qd = vectors(model.n, q=q, qd=qd)
    F, f_e = vectors(model.task_dim, F=F, f_e=f_e)
    qdd_0 = np.zeros(model.n) if qdd_0 is None else validation.vector('qdd_0', qdd_0, model.n)
    x, J, Jdot_qd = model._task(q, qd)
    return check_finite('tau', _model_task_torque(model, q, qd, J, Jdot_qd, F, f_e, qdd_0))


def _posture_gains(k_posture, n):
    """(kp0, kv0), each (n,) >= 0, from a (kp, kv) pair of scalars/arrays or an object with kp, kv."""
    if hasattr(k_posture, 'kp'):
        return gain_arrays(k_posture, n, 'k_posture')[:2]
    try:
        kp0, kv0 = k_posture
    except (TypeError, ValueError):
        raise ArgumentError('k_posture', f'expected a (kp, kv) pair, got {k_posture!r}') from None
    kp0, kv0 = per_entry('k_posture.kp', kp0, n), per_entry('k_posture.kv', kv0, n)
    if (kp0 < 0.0).any() or (kv0 < 0.0).any():
        raise ArgumentError('k_posture', f'expected non-negative gains, got {k_posture!r}')
    return kp0, kv0


def posture_acceleration(q, qd, q_posture, k_posture):
    """qdd_0 = Kp0 (q_posture - q) - Kv0 qd (n,), gains in 1/s^2 and 1/s; q_posture None: damping only."""
    kp0, kv0 = _posture_gains(k_posture, q.shape[0])
    qdd_0 = -kv0 * qd
    if q_posture is not None:
        qdd_0 = qdd_0 + kp0 * (validation.vector('q_posture', q_posture, q.shape[0]) - q)
    return check_finite('qdd_0', qdd_0)


def hybrid(model, q, qd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, force_axes, K_e, gains_T, gains_N,
           q_posture=None, k_posture=(25.0, 10.0), int_E=None):
    """tau (n,) = J^T (Lambda F' + mu + p + f_e) + N^T tau_0: hybrid position/force control.

    x = fk(q), xd = J qd; F' as hybrid_servo(); f_e = f on the force axes, 0 elsewhere; the
    posture qdd_0 = Kp0 (q_posture - q) - Kv0 qd (k_posture = (Kp0, Kv0)) acts in the null space of
    redundant arms (m < n); checked but unused when m = n. Units: m, N, s; f signed (module doc).
    """
    n, m = model.n, model.task_dim
    task = (x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot)
    setup = _fast_setup(n, m, q, qd, task, force_axes, K_e, gains_T, gains_N, q_posture, k_posture, int_E)
    if setup is not None:
        tau = _hybrid_torque(model, q, qd, task, setup, q_posture, int_E, checked=False)
        if tau is not None:
            return tau
    # the checked path, in the order the arguments are documented
    q, qd = vectors(n, q=q, qd=qd)
    task = _task_vectors(m, *task)
    axes, K_e = _axes_and_stiffness(force_axes, K_e, m)
    kp0, kv0 = _posture_gains(k_posture, n)
    if q_posture is not None:
        q_posture = validation.vector('q_posture', q_posture, n)
    gt, gn = _axis_gains(gains_T, ~axes, 'gains_T'), _axis_gains(gains_N, axes, 'gains_N')
    if int_E is not None:
        int_E = validation.vector('int_E', int_E, m)
    setup = _axis_lists(axes, K_e, gt[0] + gn[0], gt[1] + gn[1], gt[2] + gn[2]), (kp0, -kv0)
    return _hybrid_torque(model, q, qd, task, setup, q_posture, int_E, checked=True)


def _hybrid_torque(model, q, qd, task, setup, q_posture, int_E, checked):
    """hybrid() on shaped arrays with finite q, qd, q_posture. A NaN or inf in a task vector or int_E
    makes F' (or the sum of the task entries) non-finite: unchecked, that returns None and the caller
    checks every argument; checked (all finite), a non-finite result is an overflow: ValueError."""
    axis_setup, (kp0, neg_kv0) = setup
    x, J, Jdot_qd = model._task(q, qd)
    F, f_e, total = _servo_floats(axis_setup, x, J @ qd, task, int_E)
    F = np.array(F)
    if not (math.isfinite(total) and finite(F)):
        if not checked:
            return None
        check_finite('F', F)
    qdd_0 = neg_kv0 * qd                       # posture_acceleration on checked arrays
    if q_posture is not None:
        qdd_0 = qdd_0 + kp0 * (q_posture - q)
    if not finite(qdd_0):
        if not checked:
            return None
        check_finite('qdd_0', qdd_0)
    tau = _model_task_torque(model, q, qd, J, Jdot_qd, F, np.array(f_e), qdd_0)
    if finite(tau):
        return tau
    return None if not checked else check_finite('tau', tau)
