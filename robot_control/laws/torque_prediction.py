"""The torque prediction of composite adaptation: what the tip body's parameters must explain, tick by tick.

Over the step from tick k-1 (time t0, state q0, qd0) to tick k (t, qd) the arm's mean acceleration is
a = (qd - qd0) / (t - t0), and the torque the law sent at k-1, tau0, drove the model and the body:

    r = tau0 - (M0(q0) a + C0(q0, qd0) qd0 + g0(q0)) = W theta,   W = Y(q0, qd0, qd0, a)   (n,), (n, 10)

(M0, C0, g0 the model as configured; Y the tip body's regressor with the reference motion the measured
one: the body's share of the inverse dynamics, robot_control.models.urdf_model.tip_body_regressor). It is
exact when the robot integrates its dynamics over the tick from the tick's start state (semi-implicit
Euler, as PyBullet does) and the torque is applied as sent (no saturation; friction compensated); else it
holds to O(dt). No acceleration is measured: a comes from two velocities, and W and r are both low-pass
filtered (first order, cutoff f, x_f += alpha (x - x_f), alpha = 1 - exp(-2 pi f dt), both from 0), which
leaves W_f theta = r_f because the filter is linear and theta constant. The prediction error of an
estimate theta_hat is then

    e = W_f theta_hat - r_f = W_f (theta_hat - theta)   (n,), N m.
"""
import math

import numpy as np

from robot_control.models.urdf_model import slotine_li_arguments, slotine_li_body_regressors


class TorquePrediction:
    """W_f (n, 10) and r_f (n,), filtered at cutoff_hz (> 0, Hz), from the ticks recorded; a step of at most
    max_step s is sampled, a longer one (or a time going back) is not. filtered (11, n) = [W_f^T; r_f^T], of
    which WT = W_f^T, W and r are views."""

    def __init__(self, n, cutoff_hz, max_step):
        self.cutoff_hz, self.max_step = cutoff_hz, max_step
        self.filtered, self._sample = np.zeros((11, n)), np.empty((11, n))    # [W^T; r^T], filtered and sampled
        self.WT, self.r = self.filtered[:10], self.filtered[10]
        self.W = self.WT.T
        self._sample_W, self._sample_r = self._sample[:10], self._sample[10]
        self._z = np.empty((1, 42))
        self._last = self._step = None
        self._rate = -2.0 * math.pi * cutoff_hz          # alpha = 1 - exp(rate dt), 1/s

    def record(self, t, qd, tau, M, h, tip_motion):
        """The tick at t (s): velocity qd (n,), the law's torque tau (n,), the model's M (n, n) and
        h = C qd + g (n,), the tip's (J, Jdot, a_g) (UrdfModel._tip_motion): record_terms of them."""
        J, Jdot, a_g = tip_motion
        self.record_terms(t, qd, tau, np.vstack((J, M)), h, J @ qd, Jdot @ qd - a_g)

    def record_terms(self, t, qd, tau, JM, h, v, b):
        """The tick at t (s) as record's terms: qd, tau, h (n,); JM = [J; M] (6 + n, n); the tip's velocity
        v = J qd and b = Jdot qd - a_g (6,) each."""
        self._last = (t, qd, tau - h, JM, v, b)

    def sample(self, t, qd):
        """Filter in the step from the last recorded tick to (t, qd): True when a step was sampled (arguments,
        then filter with the regressor of its arguments)."""
        if not self.arguments(t, qd, self._z):
            return False
        self.filter(slotine_li_body_regressors(self._z)[0])
        return True

    def arguments(self, t, qd, z):
        """Begin the sample of the step from the last recorded tick to (t, qd): True when it can be sampled,
        with z (1, 42) then holding the arguments (slotine_li_arguments) of its regressor Y_b(v0, v0, J0 a + b0)
        for filter, and r = (tau0 - h0) - M0 a, with a = (qd - qd0) / (t - t0) and J0 a, M0 a from one product."""
        if self._last is None:
            return False
        t0, qd0, c0, JM0, v0, b0 = self._last
        dt = t - t0
        if not 0.0 < dt <= self.max_step:
            return False
        JMa = np.dot(JM0, (qd - qd0) / dt)
        np.add(JMa[:6], b0, out=z[0, :6])
        slotine_li_arguments(z, v0, v0)
        np.subtract(c0, JMa[6:], out=self._sample_r)
        self._step = (dt, JM0[:6])
        return True

    def filter(self, Yb):
        """End the sample arguments began, Y_b (6, 10) the regressor of its arguments: the sample
        [W^T; r^T] (11, n), W = J0^T Y_b, filtered in."""
        dt, J0 = self._step
        sample, filtered = self._sample, self.filtered
        np.dot(Yb.T, J0, out=self._sample_W)
        sample -= filtered                  # x_f += alpha (x - x_f), W and r at once
        sample *= 1.0 - math.exp(self._rate * dt)     # alpha = 1 - exp(-2 pi f dt)
        filtered += sample

    def error(self, theta):
        """e = W_f theta - r_f (n,), N m."""
        return np.dot(theta, self.WT) - self.r

    def continue_from(self, old):
        """Take over another prediction's filter and last tick (same model)."""
        self.filtered[...] = old.filtered
        self._last = old._last
