"""The lost-contact guard of force control (control core, no ROS).

Force control in free space runs away. On a force axis the lecture's servo commands
    F_N = K_e^-1 (fdd_d + kv (fd_d - fdot) + kp (f_d - f)),   fdot = k_e xd,
so with the surface gone (f = 0) the axis settles at the constant velocity
    xd = kp f_d / (kv k_e)          (hybrid_cartesian_xy: 36 * 5 / (12 * 1000) = 15 mm/s)
and travels without bound. ContactGuard bounds that motion, per force axis i:

- travel: with s = sign(f_d) the pressing direction, the position beyond the surface that the
  measured force does not explain,  beyond = s (x - x_e) - s f / k_e  (0 in contact, since there
  f = k_e (x - x_e); the distance travelled past the surface plane in free space), must stay
  <= max_travel (m);
- speed: |xd| <= max_speed (m/s) along the force axis (in contact xd is the slow change of the
  penetration; an approach from free space runs at kp f_d / (kv k_e)).

When either bound is exceeded the axis trips (latched until reset()): it becomes a position hold
at the position where it tripped, x_hold, with the force servo's own gains, by substituting the
force reference on that axis (substitute()):
    f_d' = f + k_e (x_hold - x),  fd_d' = 0,  fdd_d' = 0
which turns the force servo into  F_N = -kv xd - kp (x - x_hold)  (a critically damped position
servo when the force gains are) while the measured force f still enters the model part
(f_e) unchanged: the law itself is not modified. The reason names the axis, the bound and the
values, e.g. "x: lost contact: 0.0212 m beyond the surface (max_travel 0.02 m) at 0.0151 m/s,
|f| = 0.00 N; holding x = 0.3262 m".

Units SI; arrays (k,) over the force axes in the controller's force-axis order. Not thread-safe.
"""
import math

import numpy as np

from robot_control import validation
from robot_control.validation import ArgumentError


class ContactGuard:
    """Latching lost-contact guard over k force axes (see the module docstring).

    names: axis names (k,) for the reasons; k_e (k,) N/m > 0; x_e (k,) m; max_travel m > 0
    (math.inf disables the travel bound); max_speed m/s > 0 (math.inf disables the speed bound).
    """

    def __init__(self, names, k_e, x_e, max_travel=0.02, max_speed=0.25):
        self.names = validation.names('names', names)
        k = len(self.names)
        self.k_e = validation.vector('k_e', k_e, k)
        if np.any(self.k_e <= 0.0):
            raise ArgumentError('k_e', f'expected positive stiffness (N/m), got {self.k_e.tolist()}')
        self.x_e = validation.vector('x_e', x_e, k)
        self.max_travel = _bound('max_travel', max_travel)
        self.max_speed = _bound('max_speed', max_speed)
        self._tripped = np.zeros(k, dtype=bool)
        self._hold = np.full(k, math.nan)
        self.trips = 0
        self.reason = ''

    @property
    def k(self):
        return len(self.names)

    @property
    def tripped(self):
        """Bool (k,): axes held in position after a trip (copy)."""
        return self._tripped.copy()

    @property
    def active(self):
        """True while any axis is tripped."""
        return bool(self._tripped.any())

    @property
    def hold(self):
        """(k,) hold positions, m (NaN on axes that did not trip) (copy)."""
        return self._hold.copy()

    def reset(self):
        """Re-arm every axis (a restart, or a new force reference acknowledging the trip)."""
        self._tripped[:] = False
        self._hold[:] = math.nan
        self.reason = ''

    def beyond(self, x, f, f_d):
        """(k,) m travelled past the surface that the measured force does not explain (0 where f_d = 0)."""
        s = np.sign(f_d)
        return s * (x - self.x_e) - s * f / self.k_e

    def check(self, x, xd, f, f_d):
        """Update with the force-axis state: x (k,) m, xd (k,) m/s, f (k,) N measured, f_d (k,) N target,
        finite float64 arrays (the controller core's, checked where they entered).

        Returns the bool (k,) tripped mask (internal array: do not modify). Newly tripped axes
        latch x_hold = x and set `reason`; `trips` counts trip events.
        """
        beyond = self.beyond(x, f, f_d)
        over_travel = beyond > self.max_travel
        over_speed = np.abs(xd) > self.max_speed
        new = (over_travel | over_speed) & ~self._tripped
        if new.any():
            parts = []
            for i in np.flatnonzero(new):
                self._hold[i] = x[i]
                why = (f'{beyond[i]:.4f} m beyond the surface (max_travel {self.max_travel:g} m)' if over_travel[i]
                       else f'speed {abs(xd[i]):.4f} m/s along the force axis (max_speed {self.max_speed:g} m/s)')
                parts.append(f'{self.names[i]}: lost contact: {why} at {xd[i]:+.4f} m/s, |f| = {abs(f[i]):.2f} N; '
                             f'holding {self.names[i]} = {x[i]:.4f} m')
            self._tripped |= new
            self.trips += 1
            self.reason = '; '.join(parts)
        return self._tripped

    def substitute(self, x, f, f_d, fd_d, fdd_d):
        """On tripped axes, overwrite the force reference (in place) so the force servo holds x_hold:
        f_d = f + k_e (x_hold - x), fd_d = fdd_d = 0. x, f (k,) as in check(); f_d, fd_d, fdd_d (k,) arrays."""
        t = self._tripped
        if t.any():
            f_d[t] = f[t] + self.k_e[t] * (self._hold[t] - x[t])
            fd_d[t] = 0.0
            fdd_d[t] = 0.0


def _bound(name, value):
    """A positive float bound; +inf (no bound) allowed."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ArgumentError(name, f'expected a number, got {value!r}') from None
    if not x > 0.0:  # also rejects NaN
        raise ArgumentError(name, f'expected a positive bound (m or m/s; inf = none), got {value!r}')
    return x
