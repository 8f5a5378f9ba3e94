"""Closed loops in tests: fixed-step RK4, joint-space computed torque, the designed error equation.

Critically damped PD (zeta = 1): e(t) = (e0 + (ed0 + w_n e0) t) exp(-w_n t).
"""
import numpy as np

from robot_control.laws import computed_torque


def rk4_step(rhs, t, y, dt):
    """One classical Runge-Kutta step of y' = rhs(t, y)."""
    k1 = rhs(t, y)
    k2 = rhs(t + dt / 2, y + dt / 2 * k1)
    k3 = rhs(t + dt / 2, y + dt / 2 * k2)
    k4 = rhs(t + dt, y + dt * k3)
    return y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def integrate(rhs, y0, t_end, dt=1e-3):
    """Times (k,) and states (k, len(y0)) of y' = rhs(t, y) on a fixed grid from t = 0."""
    steps = int(round(t_end / dt))
    ts, ys = np.arange(steps + 1) * dt, np.empty((steps + 1, len(y0)))
    ys[0] = y0
    for i in range(steps):
        ys[i + 1] = rk4_step(rhs, ts[i], ys[i], dt)
    return ts, ys


def critically_damped(e0, ed0, w_n, t):
    """e(t) = (e0 + (ed0 + w_n e0) t) exp(-w_n t), t (k,) -> (k, len(e0))."""
    t = np.asarray(t)[:, None]
    return (e0 + (ed0 + w_n * e0) * t) * np.exp(-w_n * t)


def joint_space_loop(model, reference, gains, plant=None):
    """y = [q, qd]; qdd = plant(q, qd, computed_torque(model, ...)) with the reference (q_d, qd_d, qdd_d)(t).

    plant(q, qd, tau) -> qdd, default the model's own forward dynamics (a perfect model)."""
    n = model.n
    plant = model.forward_dynamics if plant is None else plant

    def rhs(t, y):
        q, qd = y[:n], y[n:]
        tau = computed_torque(model, q, qd, *reference(t), gains)
        return np.concatenate([qd, plant(q, qd, tau)])
    return rhs
