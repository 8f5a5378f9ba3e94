"""Adaptive computed torque: Slotine and Li's adaptive control, estimating what the tip carries on line.

With E = q_d - q, Ed = qd_d - qd, the reference velocity and the sliding variable

    qr_d = qd_d + Lambda E,   qr_dd = qdd_d + Lambda Ed,   s = qd - qr_d = -(Ed + Lambda E),

the torque and the adaptation are

    tau = M0(q) qr_dd + C0(q, qd) qr_d + g0(q) + Y(q, qd, qr_d, qr_dd) theta_hat - K_D s,
    theta_hat_dot = -Gamma (Y^T s + W_f^T R e),   R = rho / (1 + tr(W_f Gamma W_f^T))
                    (then projected on Omega, below).

The second term makes it Slotine and Li's composite adaptation: e = W_f theta_hat - r_f (N m) is the error
of the estimate's prediction of the torque the law sent, from the motion it made (W_f, r_f filtered at
adaptive_prediction_cutoff_hz; robot_control.laws.torque_prediction), and R (1/(N m s)) weighs it, its
rate rho (adaptive_prediction_rate, 1/s; 0: the tracking error s alone) normalised by the size of W_f (with
the 1 in N m): the prediction moves theta_hat at most at rho in any direction (and the Euler step stays
stable for rho dt < 2). The tracking error alone (rho = 0) answers everything s holds, the command hold's
own error too, and drifts in the parameters that the move excites little; the prediction holds the
estimate to what the measured motion says.

M0, C0, g0 are the robot's model as configured (with C0 the Coriolis matrix for which Mdot - 2C is skew:
Pinocchio's); Y theta is the share of a body carried by the tip in M qr_dd + C qr_d + g, linear in its
ten inertial parameters theta (mass m kg; first moment m c, kg m, c the centre of mass in the tip frame;
the rotational inertia about the tip frame's origin, kg m^2: robot_control.models.urdf_model.UrdfModel
.tip_regressor). theta_hat is that body's estimate, beyond what the model already holds: 0 = the model
as configured. Lambda = lambda I (1/s); K_D = diag(kd) (N m s/rad), or designed each tick as
K_D = lambda M_hat(q), M_hat = M0 + M_theta_hat the model's inertia with the estimate's: then
tau = M_hat v + C_hat qr_d + g_hat with v = qdd_d + 2 lambda Ed + lambda^2 E, computed torque's servo
(kp = lambda^2, kv = 2 lambda) on the estimated model, C qr_d in place of C qd: with a right estimate the
error equation is computed torque's, critically damped at lambda rad/s (up to C s).

Stability (J.-J. E. Slotine and W. Li, "On the adaptive control of robot manipulators", The International
Journal of Robotics Research 6(3), 1987): with the error theta~ = theta_hat - theta,

    V = 1/2 s^T M s + 1/2 theta~^T Gamma^-1 theta~,
    V_dot = s^T (M s_dot + 1/2 Mdot s) + theta~^T Gamma^-1 theta_hat_dot
          = s^T (Y theta~ - K_D s) + 1/2 s^T (Mdot - 2C) s - theta~^T (Y^T s + W_f^T R W_f theta~)
          = -s^T K_D s - e^T R e <= 0,

since M s_dot + C s = tau - (M qr_dd + C qr_d + g) = Y theta~ - K_D s, Mdot - 2C is skew and e = W_f theta~
(J.-J. E. Slotine and W. Li, "Composite adaptive control of robot manipulators", Automatica 25(4), 1989;
R(t) >= 0 may vary in time). So s and theta~ stay bounded, s -> 0 (Barbalat) and with it E, Ed -> 0, and
e -> 0; theta_hat need not reach theta unless the motion excites every parameter. The projection: theta_hat is kept in the convex set

    Omega = {0 <= m <= mass_max, |m c| <= com_max m, each rotational inertia entry in
             [0, mass_max com_max^2] (diagonal) or [-mass_max com_max^2 / 2, ...] (off-diagonal)},

which holds every body of mass <= mass_max within com_max of the tip frame's origin: the mass stays >= 0,
the centre of mass within com_max and every parameter bounded. theta_hat is projected in the metric of
Gamma^-1 (Gamma = diag(gamma_m, gamma_h I3, gamma_I I6)), where for the true theta in Omega the projection
is no farther from theta than the unprojected step: V does not grow by it, and V_dot <= -s^T K_D s still holds.
The argument needs K_D positive definite: always with kd > 0; with the designed K_D = lambda M_hat when the
estimate's spatial inertia is positive semi-definite (any physical body), which Omega does not enforce
(an estimate with a negative inertia about its centre of mass could make M_hat indefinite).

theta_hat is integrated by explicit Euler between the law's ticks, from its time: the law holds the
estimate, and a new configuration of this law on the same model takes it over (continue_from; another
model or law starts again from 0); a tick more than MAX_ADAPTATION_STEP after the last one (a restart
after the watchdog) or before it does not integrate.
"""
import dataclasses
import functools
import math

import numpy as np

from robot_control import validation
from robot_control.laws.base import Law
from robot_control.laws.joint_impedance import per_joint
from robot_control.laws.torque_prediction import TorquePrediction
from robot_control.models.urdf_model import slotine_li_arguments, slotine_li_body_regressors
from robot_control.param_table import Row, custom, gt, gt_eq
from robot_control.validation import ArgumentError

#: the longest step, s, over which the estimate is integrated (a longer gap between ticks is not)
MAX_ADAPTATION_STEP = 0.1
#: entries of theta: the mass, the first moment m c (3), the rotational inertia (6, Pinocchio's order
#: Ixx, Ixy, Iyy, Ixz, Iyz, Izz)
MASS, FIRST_MOMENT, INERTIA = slice(0, 1), slice(1, 4), slice(4, 10)
#: the rotational inertia's bounds over mass_max com_max^2: [0, 1] on Ixx, Iyy, Izz, [-1/2, 1/2] off the diagonal
_INERTIA_LOWER, _INERTIA_UPPER = np.array([0.0, -0.5, 0.0, -0.5, -0.5, 0.0]), np.array([1.0, 0.5, 1.0, 0.5, 0.5, 1.0])


def _reference_matrix(lam, designed):
    """L (12, 5): the rows [qd, 0, qr_d, 0, s, 0, qr_dd, qr_d, x, qr_d, 0, qd] (n,) each = L @ [E, Ed, qd_d,
    qdd_d, qd], with qr_d = qd_d + Lambda E, qr_dd = qdd_d + Lambda Ed, s = qd - qr_d (Lambda = lam I, 1/s) and
    x = qr_dd - lam s when K_D is designed (lam M_hat), else qr_dd. Read as (6, 2n) the rows are the pairs
    [qd | 0], [qr_d | 0], [s | 0], [qr_dd | qr_d], [x | qr_d], [0 | qd]: what [J | Jdot] and [M | C] act on."""
    qd, zero = np.array((0.0, 0.0, 0.0, 0.0, 1.0)), np.zeros(5)
    qr_d, qr_dd = np.array((lam, 0.0, 1.0, 0.0, 0.0)), np.array((0.0, lam, 0.0, 1.0, 0.0))
    s = qd - qr_d
    x = qr_dd - lam * s if designed else qr_dd
    return np.array((qd, zero, qr_d, zero, s, zero, qr_dd, qr_d, x, qr_d, zero, qd))


def _reference_scratch(n):
    """V (6, 2n + 1): the pairs of _reference_matrix's rows as (6, 2n) (filled each tick), then the column
    (0, 0, 0, 1, 1, 1) that adds the last column of K (UrdfModel._tick_terms) where a_r and g enter."""
    V = np.empty((6, 2 * n + 1))
    V[:, 2 * n] = (0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
    return V


def _adaptive_computed_torque(model, L, S, q, theta, kd=None):
    """(tau, grad, terms): tau = M(q) qr_dd + C(q, qd) qr_d + g(q) + Y theta - K_D s, grad = Y^T s (10,), with
    Y = J^T Y_b (n, 10) the tip body's regressor (Y_b = slotine_li_body_regressors at v = J qd, v_r = J qr_d,
    a_r = J qr_dd + Jdot qr_d - a_g; J, Jdot, a_g from model._tick_terms); K_D = diag(kd), or when kd is None
    designed as K_D = lam M_hat(q), M_hat = M(q) + M_theta(q) the model's inertia with the estimate's:
    K_D s = lam (M s + J^T A(J s) theta) folds into M x + J^T Y_b(v, v_r, a_r - lam J s) theta, x = qr_dd - lam s.
    L (12, 5) of _reference_matrix(lam, kd is None), S = [E, Ed, qd_d, qdd_d, qd] (5, n); terms = ([J; M]
    (6 + n, n), C qd + g, J qd, Jdot qd - a_g) for TorquePrediction.record_terms. Checked arrays, theta (10,).
    _tick_arguments, then _tick_torque (the law's tick evaluates the prediction's regressor between them)."""
    z, V = np.empty((2, 42)), _reference_scratch(model.n)
    K, P = _tick_arguments(model, L, S, q, z, V)
    return _tick_torque(V, K, P, slotine_li_body_regressors(z), theta, kd)


def _tick_arguments(model, L, S, q, z, V):
    """(K, P) of _adaptive_computed_torque, V (_reference_scratch) filled with L S and z (2, 42) with
    the arguments of the tip body's regressors (slotine_li_arguments): K = model._tick_terms(q, qd),
    P = V K^T (6, 6 + n), each row [J | M] applied to a pair of V plus the last column where it enters."""
    n = model.n
    V[:, :2 * n] = np.dot(L, S).reshape(6, 2 * n)  # [qd|0], [qr_d|0], [s|0], [qr_dd|qr_d], [x|qr_d], [0|qd]
    K = model._tick_terms(q, S[4])         # [[J, Jdot, -a_g], [M, C, g]]
    P = np.dot(V, K.T)                     # rows J qd; J qr_d; J s; J qr_dd + Jdot qr_d - a_g | M qr_dd + C qr_d + g;
                                           # J x + Jdot qr_d - a_g | M x + C qr_d + g; Jdot qd - a_g | C qd + g
    slotine_li_arguments(z, P[0, :6], P[1, :6], P[3:5, :6])
    return K, P


def _tick_torque(V, K, P, Yb, theta, kd):
    """(tau, grad, terms) of _adaptive_computed_torque from _tick_arguments' V, K, P and Y_b (k >= 2, 6, 10), the
    regressors of its arguments: the regressor's (a_r) and the torque's (a_r - lam J s)."""
    n = K.shape[1] // 2
    tau = P[4, 6:] + np.dot(K[:6, :n].T, np.dot(Yb[1], theta))
    if kd is not None:
        tau -= kd * V[2, :n]
    return tau, np.dot(P[2, :6], Yb[0]), (K[:, :n], P[5, 6:], P[0, :6], P[5, :6])


def _adaptation_step(theta, grad, dt_gamma, prediction=None):
    """theta + dt theta_dot (10,), theta_dot = -Gamma (Y^T s + W^T R e), R = rho / (1 + tr(W Gamma W^T));
    grad = Y^T s (10,), dt_gamma (10,) the step dt (s) times Gamma's diagonal; prediction (W^T (10, n), e (n,),
    rho, Gamma's diagonal on each of W^T's columns (10, n)), or None: the first term alone."""
    if prediction is not None:
        WT, e, rho, gamma_W = prediction
        step = np.dot(WT, e)
        step *= rho / (1.0 + np.vdot(WT * WT, gamma_W))
        step += grad
        grad = step
    return theta - dt_gamma * grad


def _project(theta, gamma, mass_max, com_max):
    """The point of Omega (the module docstring) nearest theta (10,) in the metric of Gamma^-1, gamma (10,)
    its diagonal with one value on the three first moments: mass and first moment on the cone
    |m c| <= com_max m cut at m = mass_max, each rotational inertia entry clipped to its bounds; theta itself
    when it is in Omega."""
    bounds = _inertia_bounds(mass_max, com_max)
    m, hx, hy, hz, *inertia = theta.tolist()
    if 0.0 <= m <= mass_max and hx * hx + hy * hy + hz * hz <= (com_max * m) ** 2 and _within(inertia, bounds):
        return theta
    cone = _project_on_cone(m, (hx, hy, hz), float(gamma[0]), float(gamma[1]), mass_max, com_max)
    return np.array([*cone, *[lower if value < lower else upper if value > upper else value
                              for value, (lower, upper) in zip(inertia, bounds)]])


@functools.lru_cache(maxsize=8)
def _inertia_bounds(mass_max, com_max):
    """The (lower, upper) bounds (floats, kg m^2) of each of the rotational inertia's entries in Omega."""
    bound = mass_max * com_max ** 2
    return tuple(zip((bound * _INERTIA_LOWER).tolist(), (bound * _INERTIA_UPPER).tolist()))


def _within(values, bounds):
    """True when each value (floats) lies in its (lower, upper) of bounds."""
    for value, (lower, upper) in zip(values, bounds):
        if not lower <= value <= upper:
            return False
    return True


def _project_on_cone(m, h, gamma_m, gamma_h, mass_max, com_max):
    """(m, h_x, h_y, h_z) of {|h| <= com_max m, m <= mass_max} nearest (m, h) (h three floats) in the metric
    (dm^2 / gamma_m + |dh|^2 / gamma_h).

    In the scaled x = m / sqrt(gamma_m), y = h / sqrt(gamma_h) the set is the cone |y| <= b x,
    b = com_max sqrt(gamma_m / gamma_h), cut at x_max: the point itself inside; the apex when it lies in
    the polar cone (b |y| <= -x); else the ray (t, b t y / |y|), t = (x + b |y|) / (1 + b^2). A point beyond
    x_max goes to the disk |y| <= b x_max at x_max."""
    rm, rh = math.sqrt(gamma_m), math.sqrt(gamma_h)
    x, b, x_max = m / rm, com_max * rm / rh, mass_max / rm
    y0, y1, y2 = h[0] / rh, h[1] / rh, h[2] / rh
    r = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    scale = 1.0                               # y's, from here on
    if r > b * x:
        if b * r <= -x:
            x = r = y0 = y1 = y2 = 0.0
        else:
            x = (x + b * r) / (1.0 + b * b)
            scale, r = b * x / r, b * x
    if x > x_max and r > 0.0:
        y0, y1, y2, scale = y0 * scale, y1 * scale, y2 * scale, min(1.0, b * x_max / r)
    return min(x, x_max) * rm, y0 * scale * rh, y1 * scale * rh, y2 * scale * rh


def adaptive_computed_torque(model, q, qd, q_d, qd_d, qdd_d, theta, lam, kd=None):
    """tau (n,) = M qr_dd + C qr_d + g + Y(q, qd, qr_d, qr_dd) theta - K_D s, qr_d = qd_d + lam (q_d - q),
    qr_dd = qdd_d + lam (qd_d - qd), s = qd - qr_d.

    model: a URDF model with a tip (UrdfModel); vectors (n,) SI; theta (10,) the inertial parameters of a
    body carried by the tip (m kg, m c kg m, inertia kg m^2 about the tip frame's origin); lam > 0, 1/s;
    kd: N m s/rad per joint (one value or (n,)), None = lam M_hat(q) (M(q) with theta's inertia). ArgumentError naming the bad argument."""
    _check_model(model)
    q, qd, q_d, qd_d, qdd_d = validation.vectors(model.n, q=q, qd=qd, q_d=q_d, qd_d=qd_d, qdd_d=qdd_d)
    theta = validation.vector('theta', theta, 10)
    lam = validation.scalar('lam', lam, positive=True)
    kd = None if kd is None else per_joint('kd', kd, model.n)
    S = np.array((q_d - q, qd_d - qd, qd_d, qdd_d, qd))
    return validation.result('tau', _adaptive_computed_torque(model, _reference_matrix(lam, kd is None), S, q, theta,
                                                              kd)[0])


def project_payload(theta, gamma, mass_max, com_max):
    """theta (10,) projected on Omega (_project): gamma one value or three (mass, first moment, inertia) > 0;
    mass_max kg, com_max m > 0. ArgumentError naming the bad argument."""
    theta = validation.vector('theta', theta, 10)
    return _project(theta, _gamma_diagonal('gamma', gamma), validation.scalar('mass_max', mass_max, positive=True),
                    validation.scalar('com_max', com_max, positive=True))


def _gamma_diagonal(name, gamma):
    """The diagonal (10,) of Gamma from one value or three (mass, first moment, rotational inertia), each > 0."""
    g = validation.vector(name, [gamma] if np.isscalar(gamma) else gamma)
    if g.shape[0] not in (1, 3) or min(g.tolist()) <= 0.0:
        raise ArgumentError(name, f'expected one value or three (mass, first moment, inertia), each > 0, got {g.tolist()}')
    g = np.repeat(g, 3) if g.shape[0] == 1 else g
    return np.repeat(g, (1, 3, 6))


def _check_model(model):
    if not callable(getattr(model, '_tick_terms', None)) or not model.task_dim:
        raise ArgumentError('model', 'adaptive_computed_torque estimates the body carried by the tip: it needs a URDF '
                                     'model with a tip')


def _check_gain(value, values):
    _gamma_diagonal('adaptation_gain', value)


_PER_JOINT = 'empty, one value (every joint) or one per joint'

#: the adaptive law's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row('adaptation_gain', 'double_array', (5.0, 5.0, 1.0), 'adaptive_computed_torque: adaptation gain Gamma of '
        "the tip's payload estimate, for its mass, first moment m c and rotational inertia: one value for all or "
        'three, kg^2/J, (kg m)^2/J, (kg m^2)^2/J', [custom('one or three values, each > 0', _check_gain)]),
    Row('adaptive_lambda', 'double', 6.0, 'adaptive_computed_torque: Lambda, 1/s: the sliding variable '
        's = -(Ed + Lambda E); with the designed kd the error equation is critically damped at lambda rad/s',
        [gt(0)]),
    Row('adaptive_kd', 'double_array', (), 'adaptive_computed_torque: K_D per joint, N m s/rad (N s/m); empty = '
        "designed each tick as lambda M_hat(q), the model's inertia matrix with the estimate's", [custom(_PER_JOINT), gt_eq(0)]),
    Row('adaptive_mass_max', 'double', 10.0, 'adaptive_computed_torque: the largest payload mass the estimate may '
        'reach, kg (it stays >= 0)', [gt(0)]),
    Row('adaptive_com_max', 'double', 0.3, "adaptive_computed_torque: the payload's centre of mass lies within this "
        "distance of the tip frame's origin, m; its rotational inertia entries within adaptive_mass_max times its "
        'square', [gt(0)]),
    Row('adaptive_prediction_rate', 'double', 100.0, "adaptive_computed_torque: rho, 1/s: the weight of the "
        "estimate's torque prediction error in its adaptation (composite adaptation), normalised so that it moves "
        'the estimate at most at rho; 0 = the tracking error alone (Slotine and Li 1987)', [gt_eq(0)]),
    Row('adaptive_prediction_cutoff_hz', 'double', 20.0, 'adaptive_computed_torque: cutoff, Hz, of the first-order '
        'low-pass on the torque prediction (its regressor and the torque it explains)', [gt(0)]),
)
_DEFAULTS = {row.name: row.default for row in PARAM_ROWS}


@dataclasses.dataclass(frozen=True)
class AdaptiveParams:
    """The adaptive law's parameters (PARAM_ROWS), checked: adaptation_gain one or three values > 0 (kg^2/J,
    (kg m)^2/J, (kg m^2)^2/J); adaptive_lambda > 0, 1/s; adaptive_kd empty or values >= 0, N m s/rad (one per
    joint is checked with the model); adaptive_mass_max > 0, kg; adaptive_com_max > 0, m;
    adaptive_prediction_rate >= 0, 1/s; adaptive_prediction_cutoff_hz > 0, Hz."""

    adaptation_gain: tuple = _DEFAULTS['adaptation_gain']
    adaptive_lambda: float = _DEFAULTS['adaptive_lambda']
    adaptive_kd: tuple = _DEFAULTS['adaptive_kd']
    adaptive_mass_max: float = _DEFAULTS['adaptive_mass_max']
    adaptive_com_max: float = _DEFAULTS['adaptive_com_max']
    adaptive_prediction_rate: float = _DEFAULTS['adaptive_prediction_rate']
    adaptive_prediction_cutoff_hz: float = _DEFAULTS['adaptive_prediction_cutoff_hz']

    def __post_init__(self):
        set_ = functools.partial(object.__setattr__, self)
        gain = [self.adaptation_gain] if np.isscalar(self.adaptation_gain) else self.adaptation_gain
        _gamma_diagonal('adaptation_gain', gain)
        set_('adaptation_gain', tuple(validation.vector('adaptation_gain', gain).tolist()))
        kd = () if self.adaptive_kd is None else tuple(np.atleast_1d(np.asarray(self.adaptive_kd, dtype=float)).tolist())
        if kd and (not validation.finite(np.array(kd)) or min(kd) < 0.0):
            raise ArgumentError('adaptive_kd', f'expected {_PER_JOINT}, each >= 0, got {list(kd)}')
        set_('adaptive_kd', kd)
        for name in ('adaptive_lambda', 'adaptive_mass_max', 'adaptive_com_max', 'adaptive_prediction_cutoff_hz'):
            set_(name, validation.scalar(name, getattr(self, name), positive=True))
        set_('adaptive_prediction_rate', validation.scalar('adaptive_prediction_rate', self.adaptive_prediction_rate,
                                                           nonnegative=True))


class AdaptiveComputedTorque(Law):
    """The registry's 'adaptive_computed_torque': the joint reference; the law's own lambda, K_D, Gamma and
    bounds; no kp/kv/ki servo gains and no error integral (the estimate is the law's)."""

    name = 'adaptive_computed_torque'
    param_rows = PARAM_ROWS
    Params = AdaptiveParams

    def __init__(self, config):
        super().__init__(config)
        _check_model(self.model)
        params = config.law_params
        self.lam = params.adaptive_lambda
        self.kd = per_joint('adaptive_kd', params.adaptive_kd, self.model.n) if params.adaptive_kd else None
        self.gamma = _gamma_diagonal('adaptation_gain', params.adaptation_gain)
        self._gamma_W = np.repeat(self.gamma[:, None], self.model.n, axis=1)     # Gamma on each column of W^T
        self.mass_max, self.com_max = params.adaptive_mass_max, params.adaptive_com_max
        self.rho = params.adaptive_prediction_rate
        self.prediction = (TorquePrediction(self.model.n, params.adaptive_prediction_cutoff_hz, MAX_ADAPTATION_STEP)
                           if self.rho > 0.0 else None)
        self._L = _reference_matrix(self.lam, self.kd is None)
        self._z = np.empty((3, 42))      # the regressors' arguments: the law's two and the prediction's
        self._z_law, self._z_prediction = self._z[:2], self._z[2:]
        self._V = _reference_scratch(self.model.n)
        self.theta = np.zeros(10)        # the estimate theta_hat
        self._t = self._grad = None      # time and Y^T s of the last tick

    @property
    def payload(self):
        """(mass kg, centre of mass (3,) m in the tip frame) of the estimate; the centre is 0 without mass."""
        m = float(self.theta[0])
        return m, (self.theta[FIRST_MOMENT] / m if m > 0.0 else np.zeros(3))

    def continue_from(self, old):
        """The estimate of the same law on the same model goes on (projected on this law's bounds)."""
        if isinstance(old, AdaptiveComputedTorque) and old.model is self.model:
            self.theta = _project(old.theta, self.gamma, self.mass_max, self.com_max)
            self._t, self._grad = old._t, old._grad
            if self.prediction is not None and old.prediction is not None:
                self.prediction.continue_from(old.prediction)

    def torque(self, state, ref, err, int_E):
        """_adaptive_computed_torque at the estimate adapted to this tick: one product evaluates the tip body's
        regressors for the law and, over the step from the last tick, for the prediction."""
        t, qd, prediction = state.t, state.qd, self.prediction
        S = np.array((err.E, err.Ed, ref.qd_d, ref.qdd_d, qd))
        K, P = _tick_arguments(self.model, self._L, S, state.q, self._z_law, self._V)
        sampled = prediction is not None and prediction.arguments(t, qd, self._z_prediction)
        Yb = slotine_li_body_regressors(self._z if sampled else self._z_law)
        if sampled:
            prediction.filter(Yb[2])
        self._adapt(t, sampled)
        tau, self._grad, terms = _tick_torque(self._V, K, P, Yb, self.theta, self.kd)
        if prediction is not None:
            prediction.record_terms(t, qd, tau, *terms)
        return tau

    def _adapt(self, t, sampled):
        """theta_hat at t: one Euler step of theta_hat_dot from the last tick's Y^T s and (sampled: True) the
        prediction sampled over the step to t, projected."""
        last, self._t = self._t, t
        if last is None or not 0.0 < t - last <= MAX_ADAPTATION_STEP:
            return
        prediction = self.prediction
        prediction = (prediction.WT, prediction.error(self.theta), self.rho, self._gamma_W) if sampled else None
        step = _adaptation_step(self.theta, self._grad, (t - last) * self.gamma, prediction)
        self.theta = _project(step, self.gamma, self.mass_max, self.com_max)
