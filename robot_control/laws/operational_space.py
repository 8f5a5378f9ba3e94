"""Operational-space control (Khatib 1987): joint torques that give a task acceleration.

For an articulated, possibly redundant arm with task X = fk(q) (m,), J (m, n), m <= n:

    tau = J^T (Lambda F + mu + p + f_e) + N^T tau_0,   Lambda = (J M^-1 J^T)^-1,
    mu = Lambda (J M^-1 C qd - Jdot qd),  p = Lambda J M^-1 g,  Jbar = M^-1 J^T Lambda,
    N^T = I - J^T Jbar^T,  tau_0 = M qdd_0 + C qd + g,

gives Xdd = F in closed loop with the contact force f_e (the robot's dynamics being
M qdd + C qd + g + J^T f_e = tau), and the posture acceleration qdd_0 acts in the null space only.
For a Cartesian robot (J = I) it is the lecture's tau = M_x F + C_x + g_x + f_e (3.1). The same
torque in joint-space form, which is how it is evaluated (one RNEA call, M^-1 by Cholesky, the
eigendecomposition of the m x m J M^-1 J^T, which also tells a singular J):

    tau = M qdd* + C qd + g + J^T f_e,  qdd* = qdd_0 + Jbar (F - Jdot qd - J qdd_0)
        = rnea(q, qd, qdd_0) + J^T (Lambda (F - Jdot qd - J qdd_0) + f_e).
"""
import dataclasses

import numpy as np

from robot_control import validation
from robot_control.param_table import Row, gt_eq
from robot_control.validation import ArgumentError

#: largest accepted condition number of J M^-1 J^T (the inverse task inertia), from its eigenvalues
#: (_task_inertia): their rounding is about 1e-16 of the largest, so a singular J shows a smallest
#: one below 1e-14 of it (a bound of 1e9 on cond(J), squared, would drown in rounding); the mass weighting
#: alone spreads the iiwa's (a light last link) over 1e3 to 1e4
MAX_INERTIA_COND = 1e14


def check_task_dimension(J):
    """ArgumentError naming J when the task has more axes than joints."""
    m, n = J.shape
    if m > n:
        raise ArgumentError('J', f'task dimension {m} exceeds the {n} joints; operational-space control '
                                 'needs m <= n')


def check_law_fits(law, model):
    """ArgumentError naming law when `model` has more task axes than joints: an operational-space law
    (hybrid, impedance) needs m <= n."""
    if model.task_dim > model.n:
        raise ArgumentError('law', f'{law} needs task dimension <= joints; the model has {model.task_dim} task axes '
                                   f'{list(model.task_axes)} and {model.n} joints')


def _inverse_task_inertia(model, q, J):
    """(w (m,), V (m, m)): the eigendecomposition J M^-1 J^T = V diag(w) V^T of the inverse operational-space
    inertia Lambda^-1 (1/kg, 1/(kg m^2)). ArgumentError naming q when J(q) is (nearly) singular: the spread
    of w beyond MAX_INERTIA_COND (J (m, n), m <= n)."""
    w, V = np.linalg.eigh(J @ model._Minv(q) @ J.T)
    if not w[0] * MAX_INERTIA_COND > w[-1]:
        raise ArgumentError('q', f'task Jacobian singular or nearly (eigenvalues of J M^-1 J^T {w.tolist()})')
    return w, V


def _inertia_roots(w, V, root=False):
    """Lambda = R R^T, R = V diag(w^-1/2), (m, m) symmetric positive definite, from the eigendecomposition
    (w, V) of Lambda^-1 (_inverse_task_inertia); with `root`, (Lambda, Lambda^1/2 = R V^T)."""
    R = V / np.sqrt(w)
    Lambda = R @ R.T
    return (Lambda, R @ V.T) if root else Lambda


def _task_inertia(model, q, J, root=False):
    """The operational-space inertia Lambda = (J M^-1 J^T)^-1 (kg, kg m^2), (m, m), from one
    eigendecomposition of J M^-1 J^T (_inverse_task_inertia); with `root`, (Lambda, Lambda^1/2)."""
    return _inertia_roots(*_inverse_task_inertia(model, q, J), root=root)


def _operational_space(model, q, qd, J, Jdot_qd, F, f_e, qdd_0, Lambda):
    """tau (n,) = rnea(q, qd, qdd_0) + J^T (Lambda (F - Jdot qd - J qdd_0) + f_e), Lambda = (J M^-1 J^T)^-1.

    Checked arrays: q, qd, qdd_0 (n,); J (m, n); Jdot_qd, F (m/s^2), f_e (N) (m,); Lambda (m, m) the task
    inertia (_task_inertia, which refuses a singular J)."""
    return model._inverse_dynamics(q, qd, qdd_0) + J.T @ (Lambda @ (F - Jdot_qd - J @ qdd_0) + f_e)


def _posture_acceleration(q, qd, q_posture, kp0, kv0):
    """qdd_0 = Kp0 (q_posture - q) - Kv0 qd, (n,): the null-space posture servo."""
    return kp0 * (q_posture - q) - kv0 * qd


def posture_gains(k_posture, n):
    """(kp0, kv0), each (n,) >= 0, from a (kp, kv) pair of scalars or (n,) arrays, or an object with kp, kv."""
    if hasattr(k_posture, 'kp'):
        k_posture = (k_posture.kp, k_posture.kv)
    try:
        kp0, kv0 = k_posture
    except (TypeError, ValueError):
        raise ArgumentError('k_posture', f'expected a (kp, kv) pair, got {k_posture!r}') from None
    kp0, kv0 = validation.per_entry('k_posture.kp', kp0, n), validation.per_entry('k_posture.kv', kv0, n)
    if min(kp0.tolist()) < 0.0 or min(kv0.tolist()) < 0.0:
        raise ArgumentError('k_posture', f'expected non-negative gains, got {k_posture!r}')
    return kp0, kv0


#: the null-space posture's parameters, in the order of the controller's parameter table
POSTURE_ROWS = (
    Row('posture_kp', 'double', 25.0, 'null-space posture stiffness (hybrid, impedance; redundant arms), 1/s^2',
        [gt_eq(0)]),
    Row('posture_kv', 'double', 10.0, 'null-space posture damping (hybrid, impedance; redundant arms), 1/s',
        [gt_eq(0)]),
)


@dataclasses.dataclass(frozen=True)
class Posture:
    """The null-space posture's gains (POSTURE_ROWS), shared by the operational-space laws that declare it
    (Law.parts): posture_kp Kp0 (1/s^2) and posture_kv Kv0 (1/s), each >= 0 (ArgumentError naming it)."""

    posture_kp: float = POSTURE_ROWS[0].default
    posture_kv: float = POSTURE_ROWS[1].default

    param_rows = POSTURE_ROWS
    field = 'posture'          # the name a law's Params holds it under

    def __post_init__(self):
        for name in ('posture_kp', 'posture_kv'):
            object.__setattr__(self, name, validation.scalar(name, getattr(self, name), nonnegative=True))

    def fitted(self, model):
        """The same gains: they do not depend on the model."""
        return self

    def gains(self, n):
        """(kp0, kv0), each (n,): the posture gains on every joint."""
        return np.full(n, self.posture_kp), np.full(n, self.posture_kv)


def posture_acceleration(q, qd, q_posture, k_posture):
    """qdd_0 = Kp0 (q_posture - q) - Kv0 qd (n,), gains in 1/s^2 and 1/s; q_posture None: damping only."""
    q = validation.vector('q', q)
    n = q.shape[0]
    qd = validation.vector('qd', qd, n)
    q_posture = q if q_posture is None else validation.vector('q_posture', q_posture, n)
    kp0, kv0 = posture_gains(k_posture, n)
    return validation.result('qdd_0', _posture_acceleration(q, qd, q_posture, kp0, kv0))


def operational_space(model, q, qd, F, f_e, qdd_0=None):
    """tau (n,) giving Xdd = F (m,) m/s^2 with contact force f_e (m,) N and null-space acceleration qdd_0 (n,)."""
    q, qd = validation.vectors(model.n, q=q, qd=qd)
    F, f_e = validation.vectors(model.task_dim, F=F, f_e=f_e)
    qdd_0 = np.zeros(model.n) if qdd_0 is None else validation.vector('qdd_0', qdd_0, model.n)
    x, J, Jdot_qd = model._task(q, qd)
    check_task_dimension(J)
    Lambda = _task_inertia(model, q, J)
    return validation.result('tau', _operational_space(model, q, qd, J, Jdot_qd, F, f_e, qdd_0, Lambda))
