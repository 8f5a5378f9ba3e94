"""Joint velocities estimated from the measured positions: a filtered differentiator (no ROS).

A driver's velocities may be noisy (an encoder's count differences over one cycle: steps of r / T, with
r the resolution, 0.18 rad/s for r = 1.8e-4 rad at 1 kHz) or absent (many drivers send none). The
damping term of every law multiplies them (D (qd_d - qd)): their noise becomes torque chatter. The
estimate is the derivative seen through a first-order low-pass of cutoff f_c (Hz), w_c = 2 pi f_c:

    qd_hat(s) = w_c s / (s + w_c) q(s)

discretised with Tustin's rule s = (2 / T) (z - 1) / (z + 1), T the step between the two states' stamps
(s), per joint:

    qd_hat_k = a qd_hat_{k-1} + b (q_k - q_{k-1}),    a = (2 - w_c T) / (2 + w_c T),  b = 2 w_c / (2 + w_c T)

Unit DC gain on a ramp (a constant velocity is estimated exactly once the transient of time constant
1 / w_c has died out), a lag of about 1 / w_c on a changing velocity, white noise above f_c attenuated
by f_c / f. Keep w_c T < 2 (f_c < 1 / (pi T): 318 Hz at 1 kHz), else a < 0 and the estimate rings.

A (re)start (the first state, the controller restarted, time not moving forward) starts the filter from
the state's measured velocities, or from rest when it carries none.
"""
import math

import numpy as np

#: the cutoff used for a state without velocities while velocity_filter.cutoff_hz is 0, Hz
DEFAULT_CUTOFF_HZ = 50.0
#: what /diagnostics names the estimator
METHOD = 'first-order low-pass differentiator, Tustin'


def tustin_coefficients(cutoff_hz, T):
    """(a, b) of qd_hat_k = a qd_hat_{k-1} + b (q_k - q_{k-1}) for cutoff f_c (Hz, > 0) and step T (s, > 0)."""
    wT = 2.0 * math.pi * cutoff_hz * T
    return (2.0 - wT) / (2.0 + wT), 2.0 * wT / ((2.0 + wT) * T)


class VelocityEstimator:
    """qd_hat for n joints (see the module docstring): update(t, q, qd_measured, cutoff_hz) -> qd_hat (n,),
    an internal buffer overwritten by the next update."""

    def __init__(self, n):
        self._qd = np.zeros(n)
        self._q_prev = np.zeros(n)
        self._t = None

    def reset(self):
        """The next update starts the filter again."""
        self._t = None

    def update(self, t, q, qd_measured, cutoff_hz):
        """The estimate at time t (s) from the positions q (n,), rad or m; qd_measured (n,) or None: the
        start value after a (re)start (None: 0); cutoff_hz > 0."""
        if self._t is None or t <= self._t:
            if qd_measured is None:
                self._qd[:] = 0.0
            else:
                self._qd[:] = qd_measured
        else:
            a, b = tustin_coefficients(cutoff_hz, t - self._t)
            self._qd *= a
            self._qd += b * (q - self._q_prev)
        self._q_prev[:] = q
        self._t = t
        return self._qd
