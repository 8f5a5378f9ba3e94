"""The surfaces of sim_bridge.surfaces in a MuJoCo world: the lecture's spring applied at the tip.

    f = max(k_e d + b_e dd, 0) for d = sign (n . p - x_e) > 0 with the tip inside the box's lateral extent,
    F_tip = -sign f n on the tip (at its frame origin, the probe sphere's centre), F_surface = -F_tip

n the surface normal (world, unit), p the tip frame origin (m), k_e N/m, b_e N s/m (surface_damping), dd the
rate of d. MuJoCo's own soft contact is not used: its constraint force per penetration scales with the
contact's effective mass (solref/solimp set an acceleration, not N/m), so it cannot be the scenario's
k_e at every configuration; the force is applied explicitly at the step's state (the step's other
loads are too), where PyBullet solves its contact within the step. Steady state: f = k_e d on both.
"""
import mujoco
import numpy as np

from sim_bridge import surfaces


class MujocoSurface:
    """The spring surface of a built MuJoCo world. surface: scenarios.Surface; normal (3,) unit, world;
    radius: the tip's probe sphere, m; tip_start (3,) m; damping b_e N s/m; half_width m; body: the tip's
    MuJoCo body id."""

    def __init__(self, surface, normal, radius, tip_start, damping, half_width, body):
        self.surface, self.normal, self.radius, self.damping, self.body = surface, np.asarray(normal), radius, \
            damping, body
        self.centre, self.half = surfaces.box(surface, self.normal, radius, tip_start, half_width)
        self._axis = int(np.argmax(np.abs(self.normal)))     # the normal is a world axis (surfaces.surface_normal)
        self._lateral = [(a, float(self.centre[a]), float(self.half[a])) for a in range(3) if a != self._axis]
        self._jac = None
        self._none = (np.zeros(3), np.zeros(3))
        self.wrench = self._none      # of the last step: on the surface, torque about the origin

    def apply(self, model, data, qfrc):
        """Add the tip's load J^T F_tip to qfrc (nv,) at data's state (after mj_step1) and keep the wrench on
        the surface (force N, torque N m about the world origin) for contact_wrench."""
        s, n = self.surface, self.normal
        p = data.xpos[self.body]
        depth = s.sign * (float(p[self._axis]) * n[self._axis] - s.x_e)
        if depth <= 0.0 or depth > 2.0 * surfaces.HALF_THICKNESS or \
                any(abs(float(p[a]) - c) > h for a, c, h in self._lateral):
            self.wrench = self._none
            return
        rate = 0.0
        if self.damping > 0.0:
            if self._jac is None:
                self._jac = np.zeros((3, model.nv))
            mujoco.mj_jac(model, data, self._jac, None, p, self.body)
            rate = s.sign * (n @ (self._jac @ data.qvel))
        f = surfaces.spring_force(s.k_e, self.damping, depth, rate)
        on_surface = s.sign * f * n
        mujoco.mj_applyFT(model, data, -on_surface, np.zeros(3), p, self.body, qfrc)
        contact = p + (s.x_e + s.sign * self.radius - n @ p) * n      # on the box face, below the probe
        self.wrench = (on_surface, np.cross(contact, on_surface))
