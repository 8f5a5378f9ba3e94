"""Operational-space hybrid position/force control of the 7-DOF KUKA iiwa pressing on a table.

Controller model: robot_control.models.urdf_model.UrdfModel of pybullet_data's kuka_iiwa/model.urdf
(tip frame lbr_iiwa_link_7, task X = world position of the tip, m = 3 < n = 7: redundant).
Plant: a separate Pinocchio model of the same URDF, pin.aba forward dynamics, plus a frictionless
table at height z_e: the tip presses it with the force f_z = k_e (z - z_e) < 0 when z < z_e
(0 otherwise), applied to the robot as -J^T f_e. Sign convention (robot_control.laws.hybrid): f is
the force the robot exerts on the environment, signed along the world axes, so pressing down with
10 N is f_d = (0, 0, -10) N and f = K_e (x_N - x_e) holds with K_e > 0.
"""
import os

import numpy as np
import pinocchio as pin
import pybullet_data
import pytest

from robot_control.gains import ServoGains
from robot_control.laws import hybrid, hybrid_servo, spring_force
from robot_control.models.urdf_model import UrdfModel
from robot_control.scenarios import get

URDF = os.path.join(pybullet_data.getDataPath(), 'kuka_iiwa/model.urdf')
SCENARIO = get('iiwa')
Q0 = np.array(SCENARIO.q0)
AXES = np.array([False, False, True])     # z force controlled, x and y motion controlled
K_E = SCENARIO.surface.k_e                # N/m
G_T = ServoGains.uniform(3, 100.0, 20.0)  # motion: w_n = 10 rad/s, zeta = 1
G_N = ServoGains.uniform(3, 400.0, 40.0)  # force: w_n = 20 rad/s, zeta = 1
RNG = np.random.default_rng(20261124)


@pytest.fixture(scope='module')
def ctrl():
    """The controller's model (perfect: same URDF as the plant)."""
    return UrdfModel(URDF, joints=SCENARIO.joints, tip=SCENARIO.tip)


class Plant:
    """The 'real' iiwa: Pinocchio ABA with a unilateral table spring at the tip along world z."""

    def __init__(self, z_e):
        self.model = pin.buildModelFromUrdf(URDF)
        self.data = self.model.createData()
        self.fid = self.model.getFrameId(SCENARIO.tip)
        self.z_e = z_e

    def jacobian(self, q):
        """Tip linear Jacobian, world axes, (3, 7); also updates the tip placement."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return pin.computeFrameJacobian(self.model, self.data, q, self.fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]

    def contact(self, q, qd):
        """(f, fdot, J): force (3,) the tip exerts on the table (z < 0 when pressing), its rate, Jacobian."""
        J = self.jacobian(q)
        z, zd = self.data.oMf[self.fid].translation[2], (J @ qd)[2]
        f, fdot = (K_E * (z - self.z_e), K_E * zd) if z < self.z_e else (0.0, 0.0)
        return np.array([0.0, 0.0, f]), np.array([0.0, 0.0, fdot]), J

    def qdd(self, q, qd, tau):
        """M qdd + C qd + g + J^T f_e = tau."""
        f, _, J = self.contact(q, qd)
        return pin.aba(self.model, self.data, q, qd, tau - J.T @ f)

    def step(self, q, qd, tau, dt):
        """One RK4 step with tau held (zero-order hold)."""
        def rhs(y):
            return np.concatenate([y[7:], self.qdd(y[:7], y[7:], tau)])
        y = np.concatenate([q, qd])
        k1 = rhs(y)
        k2 = rhs(y + dt / 2 * k1)
        k3 = rhs(y + dt / 2 * k2)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + rhs(y + dt * k3))
        return y[:7], y[7:]


def _quintic(t, t0, T):
    """s, sd, sdd of the rest-to-rest quintic 0 -> 1 over [t0, t0 + T]."""
    s = min(max((t - t0) / T, 0.0), 1.0)
    moving = 0.0 < t - t0 < T
    return (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, moving * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / T,
            moving * (60 * s - 180 * s ** 2 + 120 * s ** 3) / T ** 2)


def _random_state():
    q = Q0 + RNG.uniform(-0.3, 0.3, 7)
    return q, RNG.uniform(-0.5, 0.5, 7)


def _random_task_args(x):
    x_d = x + RNG.uniform(-0.02, 0.02, 3)
    xd_d, xdd_d, fd_d, fdd_d = RNG.uniform(-0.2, 0.2, (4, 3))
    f_d, f, fdot = np.array([0, 0, -10.0]), np.array([0, 0, -8.0]), np.array([0, 0, 30.0])
    return (x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, AXES, K_E, G_T, G_N)


def test_urdf_model_agrees_with_pinocchio_plant(ctrl):
    plant = Plant(0.0)
    q, qd = _random_state()
    tau = RNG.uniform(-5, 5, 7)
    np.testing.assert_allclose(ctrl.forward_dynamics(q, qd, tau), pin.aba(plant.model, plant.data, q, qd, tau),
                               atol=1e-9)
    np.testing.assert_allclose(ctrl.J(q), plant.jacobian(q), atol=1e-12)


def test_hybrid_is_khatib_operational_space_law(ctrl):
    """tau = J^T (Lambda F' + mu + p + f_e) + N^T tau_0, written out term by term (Khatib 1987)."""
    for _ in range(20):
        q, qd = _random_state()
        args = _random_task_args(ctrl.fk(q))
        q_post = Q0 + RNG.uniform(-0.2, 0.2, 7)
        tau = hybrid(ctrl, q, qd, *args, q_posture=q_post, k_posture=(25.0, 10.0))
        M, C, g, J, Jdqd = ctrl.M(q), ctrl.C(q, qd), ctrl.g(q), ctrl.J(q), ctrl.Jdot_qd(q, qd)
        Minv = np.linalg.inv(M)
        Lam = np.linalg.inv(J @ Minv @ J.T)
        mu = Lam @ (J @ Minv @ C @ qd - Jdqd)
        p = Lam @ J @ Minv @ g
        Jbar = Minv @ J.T @ Lam
        N = np.eye(7) - Jbar @ J
        tau_0 = M @ (25.0 * (q_post - q) - 10.0 * qd) + C @ qd + g
        F = hybrid_servo(ctrl.fk(q), J @ qd, *args)
        f_e = np.where(AXES, args[6], 0.0)
        khatib = J.T @ (Lam @ F + mu + p + f_e) + N.T @ tau_0
        np.testing.assert_allclose(tau, khatib, rtol=1e-8, atol=1e-8 * np.max(np.abs(khatib)))


def test_task_acceleration_is_f_prime_and_posture_acts_in_the_null_space_only(ctrl):
    """With the plant's contact force: Xdd = J qdd + Jdot qd = F', whatever the posture target."""
    plant = Plant(10.0)  # table above the arm: the tip is 'in contact' everywhere, f from the spring
    for _ in range(20):
        q, qd = _random_state()
        f, fdot, J = plant.contact(q, qd)
        args = list(_random_task_args(ctrl.fk(q)))
        args[6], args[7] = f, fdot
        F = hybrid_servo(ctrl.fk(q), J @ qd, *args)
        xdd = []
        for q_post in (Q0, Q0 + RNG.uniform(-0.5, 0.5, 7)):
            tau = hybrid(ctrl, q, qd, *args, q_posture=q_post)
            xdd.append(J @ plant.qdd(q, qd, tau) + ctrl.Jdot_qd(q, qd))
            np.testing.assert_allclose(xdd[-1], F, rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose(xdd[0], xdd[1], atol=1e-7)


def test_iiwa_presses_10_newton_down_while_tracking_a_10_cm_line(ctrl):
    """Tip starts 2 mm above the table; f_d ramps to -10 N in 1 s; x follows a 10 cm quintic line from
    t = 0.5 s to 2.5 s, y holds. Control at 1 kHz (zero-order hold), plant RK4 at 1 ms, 3.5 s."""
    x0 = ctrl.fk(Q0)
    plant = Plant(x0[2] - 0.002)
    dt, steps = 1e-3, 3500
    q, qd = Q0.copy(), np.zeros(7)
    f_log, xy_err, dq, tau_max = [], [], [], 0.0
    for k in range(steps):
        t = k * dt
        f, fdot, _ = plant.contact(q, qd)
        x_model = ctrl.fk(q)
        np.testing.assert_allclose(spring_force([x_model[2]], [0.0], plant.z_e, K_E, sign=-1.0)[0], f[2:], atol=1e-6)
        s, sd, sdd = _quintic(t, 0.5, 2.0)
        u, ud, udd = _quintic(t, 0.0, 1.0)
        line = np.array([0.1, 0.0, 0.0])
        x_d, xd_d, xdd_d = x0 + line * s, line * sd, line * sdd
        f_d, fd_d, fdd_d = (np.array([0.0, 0.0, -10.0]) * a for a in (u, ud, udd))
        tau = hybrid(ctrl, q, qd, x_d, xd_d, xdd_d, f_d, fd_d, fdd_d, f, fdot, AXES, K_E, G_T, G_N, q_posture=Q0)
        tau_max = max(tau_max, np.max(np.abs(tau)))
        xy_err.append(np.max(np.abs(x_model[:2] - x_d[:2])))
        f_log.append(f[2])
        dq.append(np.max(np.abs(q - Q0)))
        q, qd = plant.step(q, qd, tau, dt)
    f_final = plant.contact(q, qd)[0][2]
    x_final = ctrl.fk(q)
    assert abs(f_final + 10.0) < 0.1, f'final force {f_final} N, expected -10 N within 1 %'
    assert np.max(np.abs(np.array(f_log[-500:]) + 10.0)) < 0.1  # settled for the last 0.5 s
    assert np.max(xy_err) < 1e-3, f'max path error {np.max(xy_err)} m'
    np.testing.assert_allclose(x_final[:2], x0[:2] + [0.1, 0.0], atol=1e-4)
    assert max(dq) < 1.0 and np.max(np.abs(qd)) < 1e-2  # posture bounded, self-motion damped
    lower, upper = ctrl.position_limits
    assert np.all((q > lower) & (q < upper))
    assert tau_max < np.min(ctrl.effort_limit)  # no saturation needed
