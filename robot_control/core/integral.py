"""The error integral of the active law: clamp, anti-windup and bumpless re-initialisation.

Every law here is affine in its integral, tau = tau(0) + B int E with B = d tau / d int E, which the
two corrections below use (B is found by evaluating the law once per integrated entry):

- Anti-windup. Conditional integration: entries the law holds (Law.freeze: a saturated joint whose
  error pushes further into the limit) do not integrate on the next tick. Back-calculation (Astrom
  and Hagglund, Advanced PID Control, 3.5): after a saturated tick the integral moves toward the
  value whose law torque is the saturated torque, int += min(1, dt / Tt) d with B d = tau_sat - tau_law
  (least squares) and the tracking time constant Tt = sqrt(Ti Td) = sqrt(kv / ki) per entry. The hold
  alone stops the integral from growing while saturated, but not the integral of the large error
  left once the reference has run ahead of the saturated robot.
- Bumpless transfer: after a configuration change the integral is set, by least squares over the
  entries with ki > 0 and then clamped, so that the new law's torque equals the last torque sent.
"""
import numpy as np

from robot_control.laws.servo import Integral


class IntegralAction:
    """The integral of `dim` entries (0: none), clamped to +-limit (rad s, m s or N s per entry)."""

    def __init__(self, dim, limit):
        self.dim = dim
        self._integral = Integral(dim, limit) if dim else None
        self._step = None          # back-calculation step of the last saturated tick, applied next tick

    @property
    def value(self):
        """int E dt, (dim,) (read-only)."""
        return self._integral.value if self._integral is not None else np.zeros(0)

    def resized(self, dim, limit):
        """An IntegralAction for a new (dim, limit), keeping the value when dim is unchanged."""
        new = IntegralAction(dim, limit)
        if dim and dim == self.dim:
            new._integral.preset(self.value)
        return new

    def reset(self):
        self._step = None
        if self._integral is not None:
            self._integral.reset()

    def integrate(self, E, dt, hold):
        """One tick: first the pending back-calculation step, then value += E dt on entries not held."""
        step, self._step = self._step, None
        if step is not None:
            self._integral.preset(self.value + step)
        self._integral._update(E, dt, hold)

    def reinitialise(self, torque_of, tau_sent, ki):
        """Bumpless transfer: the integral whose torque_of(int E) is tau_sent (n,), on the entries with ki > 0."""
        self.reset()
        cols = np.flatnonzero(ki > 0.0)
        if cols.size == 0:
            return
        tau0, B = self._sensitivity(torque_of, np.zeros(self.dim), cols)
        if B is None:
            return
        sol = np.linalg.lstsq(B, tau_sent - tau0, rcond=None)[0]
        if np.all(np.isfinite(sol)):
            z = np.zeros(self.dim)
            z[cols] = sol
            self._integral.preset(z)

    def back_calculate(self, torque_of, tau_law, tau_sat, ki, kv, dt):
        """After a saturated tick (its law torque tau_law, sent tau_sat): the step applied next tick."""
        cols = np.flatnonzero(ki > 0.0)
        if cols.size == 0:
            return
        _, B = self._sensitivity(torque_of, np.array(self.value), cols, tau_law)
        if B is None:
            return
        d = np.linalg.lstsq(B, tau_sat - tau_law, rcond=None)[0]
        if np.all(np.isfinite(d)):
            tracking = np.sqrt(kv[cols] / ki[cols])
            step = np.zeros(self.dim)
            step[cols] = np.minimum(1.0, dt / np.maximum(tracking, dt)) * d
            self._step = step

    @staticmethod
    def _sensitivity(torque_of, z0, cols, tau0=None):
        """(tau(z0), B) with B[:, c] = tau(z0 + e_cols[c]) - tau(z0); (None, None) if the law fails there."""
        try:
            tau0 = np.array(torque_of(z0)) if tau0 is None else tau0
            B = np.empty((tau0.shape[0], cols.size))
            z = z0.copy()
            for c, j in enumerate(cols):
                z[j] = z0[j] + 1.0
                B[:, c] = np.asarray(torque_of(z), dtype=float) - tau0
                z[j] = z0[j]
        except (ValueError, np.linalg.LinAlgError):
            return None, None
        return tau0, B
