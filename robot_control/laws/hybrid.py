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

Force sign: f is the force the robot exerts on the environment, signed along each task axis, and
f_e = f on the force axes, 0 on the motion axes (the robot's dynamics: M qdd + C qd + g + J^T f_e
= tau). With f = K_e (x_N - x_e) and K_e > 0 this holds whichever side the robot presses from:
pressing down on a table (-z) gives f_z < 0, so pushing with 10 N is f_d = -10 N on z.
"""
import numpy as np

from robot_control import validation
from robot_control.laws.servo import bool_mask, check_finite, gain_arrays, per_entry, vectors

#: largest accepted condition number of the task Jacobian J(q)
MAX_JACOBIAN_COND = 1e9


def _axis_gains(gains, axes, name):
    """(kp, kv, ki) over all m axes, zero off `axes`; gains given per selected axis or per all m."""
    m, k = axes.shape[0], int(np.count_nonzero(axes))
    if gains is None:
        if k:
            raise ValueError(f'{name}: gains required for {k} axes')
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
        raise ValueError(f'K_e: expected positive stiffness on the force axes, got {K_e.tolist()}')
    return axes, np.where(axes, K_e, 1.0)


def _task_vectors(m, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot):
    return vectors(m, x_d=x_d, xd_d=xd_d, xdd_d=xdd_d, f_d=f_d, fd_d=fd_d, fdd_d=fdd_d, f=f, fdot=fdot)


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


def task_space_torque(M, h, J, Jdot_qd, F, f_e, qdd_0=None):
    """tau = M qdd* + h + J^T f_e, qdd* = Jbar (F - Jdot qd) + (I - Jbar J) qdd_0, Jbar = M^-1 J^T Lambda.

    M (n, n), h = C qd + g (n,), J (m, n) with m <= n, Jdot_qd (m,), F = F' (m,) m/s^2,
    f_e (m,) N, qdd_0 (n,) the posture acceleration (used only when m < n). Returns tau (n,).
    """
    m, n = J.shape
    if m > n:
        raise ValueError(f'J: task dimension {m} exceeds the {n} joints; operational-space control needs m <= n')
    sv = np.linalg.svd(J, compute_uv=False)
    if not sv[-1] * MAX_JACOBIAN_COND > sv[0]:
        raise ValueError(f'q: task Jacobian singular or nearly (singular values {sv.tolist()})')
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


def operational_space(model, q, qd, F, f_e, qdd_0=None):
    """tau (n,) giving Xdd = F (m,) m/s^2 with contact force f_e (m,) N and null-space acceleration qdd_0 (n,)."""
    q, qd = vectors(model.n, q=q, qd=qd)
    F, f_e = vectors(model.task_dim, F=F, f_e=f_e)
    if qdd_0 is not None:
        qdd_0 = validation.vector('qdd_0', qdd_0, model.n)
    h = model.C_qd(q, qd) + model.g(q)
    tau = task_space_torque(model.M(q), h, model.J(q), model.Jdot_qd(q, qd), F, f_e, qdd_0)
    return check_finite('tau', tau)


def _posture_gains(k_posture, n):
    """(kp0, kv0), each (n,) >= 0, from a (kp, kv) pair of scalars/arrays or an object with kp, kv."""
    if hasattr(k_posture, 'kp'):
        return gain_arrays(k_posture, n, 'k_posture')[:2]
    try:
        kp0, kv0 = k_posture
    except (TypeError, ValueError):
        raise ValueError(f'k_posture: expected a (kp, kv) pair, got {k_posture!r}') from None
    kp0, kv0 = per_entry('k_posture.kp', kp0, n), per_entry('k_posture.kv', kv0, n)
    if (kp0 < 0.0).any() or (kv0 < 0.0).any():
        raise ValueError(f'k_posture: expected non-negative gains, got {k_posture!r}')
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
    q, qd = vectors(n, q=q, qd=qd)
    task = _task_vectors(m, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot)
    axes, K_e = _axes_and_stiffness(force_axes, K_e, m)
    qdd_0 = posture_acceleration(q, qd, q_posture, k_posture)
    J = model.J(q)
    F = _servo_F(model.fk(q), J @ qd, *task, axes, K_e, gains_T, gains_N, int_E)
    f_e = np.where(axes, task[6], 0.0)  # task[6] = f, the measured contact force
    h = model.C_qd(q, qd) + model.g(q)
    tau = task_space_torque(model.M(q), h, J, model.Jdot_qd(q, qd), F, f_e, qdd_0)
    return check_finite('tau', tau)
