"""The integral of the error: Euler steps, a clamp, anti-windup and bumpless re-initialisation.

One object for the integral term of every law, like control_toolbox's Pid i-term (ros-controls): the
integral is clamped per entry to +-limit, and two anti-windup corrections act on it. Every law is
affine in its integral, tau = tau0 + B int E with B = d tau / d int E (n, dim) given by the law
(Law.integral_map), so neither correction evaluates the law again:

- conditional integration: entries held (the saturate() mask, or Law.freeze) do not integrate;
- back-calculation (Astrom and Hagglund, Advanced PID Control, 3.5): after a saturated tick (its law
  torque tau_law, the torque sent tau_sat) the integral moves toward the value whose law torque is the
  saturated one, int += min(1, dt / Tt) d with B d = tau_sat - tau_law (least squares over the entries
  with ki > 0) and the tracking time constant Tt = sqrt(Ti Td) = sqrt(kv / ki) per entry; the step is
  applied with the next update. The hold alone stops the integral from growing while saturated, but not
  the integral of the large error left once the reference has run ahead of the saturated robot;
- bumpless transfer: after a configuration change the integral z solves B z = tau_sent - tau0 (least
  squares over the entries with ki > 0, then clamped), so that the new law's torque equals the last
  torque sent.

Integration at rest (`moving`, the controller's integral_rest_velocity v_r): entry i integrates only
while |Ed_i| <= v_r, i.e. while its error is at rest (holding a position: while the joint stands still).
Why the integral hunts without it, on a joint with Coulomb friction F_c and stiction: at rest the joint
is held by the friction while |tau - tau_needed| <= F_c, so a small error stays and the integral winds
up while the joint sticks; it breaks away once the stored torque exceeds the friction, and while it
slides the integral keeps winding on the error that remains; where the friction drops once the joint
slides (stiction above the Coulomb level, as in real gears) or the loop is poorly damped, the stored
torque carries the joint past the target, where it sticks again with the error reversed, and the cycle
repeats the other way (a stick-slip limit cycle). With a rotor inertia I_a the law's model does not know (the armature), the
integral is worse still: computed torque scales its servo by the model's M_ii, so the true loop is
(M_ii + I_a) s^3 + M_ii kv s^2 + M_ii kp s + M_ii ki, unstable once (M_ii + I_a) ki > M_ii kp kv
(Routh); on the iiwa's wrist (M_77 = 0.001 kg m^2, I_a = 0.1 kg m^2, kp, kv, ki = 108, 18, 216) the
integral's oscillation grows until the friction and the joint's travel bound it (+-0.6 rad on joint 7
with the typical friction, measured). Integrating only at rest keeps the one thing the integral is
needed for at a hold, the torque that breaks a stuck joint free (it winds while the joint sticks, as
before), and takes away both mechanisms: once the joint moves the integral holds its value, so no
torque is stored during the slide to overshoot with, and the integral takes no part in a motion, which
is what its unstable oscillation needs. The cost: no integral action while the error moves (a
disturbance during a move is integrated only when the error comes to rest), so it is off (v_r = inf)
unless set; v_r above the velocity noise (or with the estimated velocity,
robot_control.core.velocity).
"""
import numpy as np

from robot_control import validation
from robot_control.validation import ArgumentError


def moving(Ed, rest_velocity):
    """|Ed_i| > v_r, bool (len(Ed),): the entries whose error is moving, not integrated this tick (see the
    module docstring); Ed in rad/s, m/s or N/s, v_r > 0 in the same units. None when v_r is inf (off)."""
    return np.abs(Ed) > rest_velocity if rest_velocity < np.inf else None


class Integral:
    """int E dt by explicit Euler, value (n,): value_i += E_i dt unless held, then |value_i| <= limit_i.

    `limit` (scalar or (n,), > 0, inf allowed) clamps the integral; the `hold` mask of update()
    freezes entries (conditional-integration anti-windup: pass the saturation mask of saturate()).
    """

    def __init__(self, n, limit=np.inf):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ArgumentError('n', f'expected a positive integer, got {n!r}')
        self._setup(int(n), validation.limit_vector('limit', limit, int(n)).copy())

    @classmethod
    def _of_checked(cls, n, limit):
        """An Integral of n >= 0 entries (0: none, value empty) with a checked scalar limit."""
        integral = cls.__new__(cls)
        integral._setup(n, np.full(n, float(limit)))
        return integral

    def _setup(self, n, limit):
        self._limit = limit
        self._value = np.zeros(n)
        self._view = self._value.view()     # what `value` hands out: read-only
        self._view.flags.writeable = False
        self._step = None                   # back-calculation step of the last saturated tick

    @property
    def n(self):
        """Number of integrated entries."""
        return self._value.shape[0]

    @property
    def limit(self):
        """Clamp |value_i| <= limit_i, (n,) (read-only copy)."""
        return self._limit.copy()

    @property
    def value(self):
        """Current int E dt, (n,), units of E times s (read-only view)."""
        return self._view

    def resized(self, n, limit):
        """An Integral of n >= 0 entries clamped to the scalar `limit`, keeping the value when n is unchanged."""
        new = Integral._of_checked(n, limit)
        if n and n == self.n:
            new._preset(self._value)
        return new

    def reset(self):
        """Set the integral to zero (and drop a pending back-calculation step)."""
        self._value[:] = 0.0
        self._step = None

    def preset(self, value):
        """Set the integral to `value` (clamped), e.g. for bumpless switching between laws."""
        self._preset(validation.vector('value', value, self.n))

    def _preset(self, value):
        np.minimum(np.maximum(value, -self._limit), self._limit, out=self._value)

    def update(self, E, dt, hold=None):
        """value += E dt on entries not held, clamp to +-limit; E (n,), dt in s (>= 0). Returns value.

        Checked: ArgumentError naming E, dt or hold; the value is unchanged then."""
        E = validation.vector('E', E, self.n)
        dt = validation.scalar('dt', dt, nonnegative=True)
        if hold is not None:
            hold = validation.bool_mask('hold', hold, self.n)
        with np.errstate(over='ignore', invalid='ignore'):   # an overflow is named below
            new = self._integrated(E, dt, hold)
        self._value[:] = validation.result('E', new)
        return self.value

    def _update(self, E, dt, hold=None):
        """update() on checked arguments (E finite (n,), 0 <= dt, hold None or bool (n,)), after the
        pending back-calculation step."""
        step, self._step = self._step, None
        if step is not None:
            self._preset(self._value + step)
        self._value[:] = self._integrated(E, dt, hold)
        return self.value

    def _integrated(self, E, dt, hold):
        """clip(value + E dt, -limit, limit), with E dt = 0 on held entries."""
        step = E * dt
        if hold is not None:
            step[hold] = 0.0
        return np.minimum(np.maximum(self._value + step, -self._limit), self._limit)

    def reinitialise(self, B, tau0, tau_sent, ki):
        """Bumpless transfer: the integral z (clamped) with tau0 + B z = tau_sent (n,), on the entries with
        ki > 0 (least squares; the others 0). B (n, dim) the law's integral map, tau0 its torque at z = 0."""
        self.reset()
        cols = np.flatnonzero(ki > 0.0)
        if cols.size == 0:
            return
        sol = np.linalg.lstsq(B[:, cols], tau_sent - tau0, rcond=None)[0]
        if np.all(np.isfinite(sol)):
            z = np.zeros(self.n)
            z[cols] = sol
            self._preset(z)

    def back_calculate(self, B, tau_law, tau_sat, ki, kv, dt):
        """After a saturated tick of dt s (> 0): the step min(1, dt / Tt) d, B d = tau_sat - tau_law, applied
        with the next update (entries with ki > 0; Tt = sqrt(kv / ki)). B (n, dim) the law's integral map."""
        cols = np.flatnonzero(ki > 0.0)
        if cols.size == 0:
            return
        d = np.linalg.lstsq(B[:, cols], tau_sat - tau_law, rcond=None)[0]
        if np.all(np.isfinite(d)):
            tracking = np.sqrt(kv[cols] / ki[cols])
            step = np.zeros(self.n)
            step[cols] = np.minimum(1.0, dt / np.maximum(tracking, dt)) * d
            self._step = step
