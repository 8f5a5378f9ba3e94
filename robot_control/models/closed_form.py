"""The lecture's closed-form models (section 2.2.2 and 3), in its notation.

Each class holds its physical parameters (SI units) and implements RobotModel. Positions in
the task space are expressed in the lecture's frame: x horizontal, y vertical (up) for the
planar robots; the Cartesian robots' task space is their joint space (X = q, J = I).
"""
import math

import numpy as np

from robot_control import units, validation
from robot_control.models.base import RobotModel



def _param(name, value):
    return validation.scalar(name, value, positive=True)


def _read_only(a):
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


class _ClosedForm(RobotModel):
    """Closed forms evaluate tau = M qdd + C qd + g in Python floats (_inverse_dynamics)."""

    def inverse_dynamics(self, q, qd, qdd):
        """tau = M(q) qdd + C(q, qd) qd + g(q), (n,)."""
        return self._inverse_dynamics(*(np.asarray(a, dtype=float) for a in (q, qd, qdd)))


class MassSpringCubic(_ClosedForm):
    """m xdd + b xd + k x^3 = u (section 2.2): b xd is reported as C qd, k x^3 as g(q).

    The partitioned law alpha = m, beta = b xd + k x^3 is then computed torque on this model.
    """

    joint_names = ('x',)
    task_axes = ('x',)

    def __init__(self, m=1.0, b=1.0, k=100.0):
        self.m = _param('m', m)
        self.b = validation.scalar('b', b, nonnegative=True)
        self.k = validation.scalar('k', k, nonnegative=True)

    def M(self, q):
        return np.array([[self.m]])

    def C(self, q, qd):
        # Friction, not a Christoffel term: Mdot - 2C is not skew for this system.
        return np.array([[self.b]])

    def g(self, q):
        return np.array([self.k * q[0] ** 3])

    def _inverse_dynamics(self, q, qd, qdd):
        (x,), (xd,), (a,) = q.tolist(), qd.tolist(), qdd.tolist()
        return np.array([self.m * a + self.b * xd + self.k * (x * x * x)])  # floats: * overflows to inf, ** raises

    def fk(self, q):
        return np.array([q[0]])

    def J(self, q):
        return np.eye(1)

    def Jdot_qd(self, q, qd):
        return np.zeros(1)


class SingleLink(_ClosedForm):
    """m l^2 thdd + m g l cos(th) = tau: point mass m at the end of a link of length l.

    th is measured from the horizontal in a vertical plane.
    """

    joint_names = ('theta',)
    task_axes = ('x', 'y')

    def __init__(self, m=1.0, l=0.5, gravity=units.GRAVITY):
        self.m = _param('m', m)
        self.l = _param('l', l)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)

    def M(self, q):
        return np.array([[self.m * self.l ** 2]])

    def C(self, q, qd):
        return np.zeros((1, 1))

    def g(self, q):
        return np.array([self.m * self.gravity * self.l * math.cos(q[0])])

    def _inverse_dynamics(self, q, qd, qdd):
        (th,), (a,) = q.tolist(), qdd.tolist()
        return np.array([self.m * (self.l * self.l) * a + self.m * self.gravity * self.l * math.cos(th)])

    def fk(self, q):
        return self.l * np.array([math.cos(q[0]), math.sin(q[0])])

    def J(self, q):
        return self.l * np.array([[-math.sin(q[0])], [math.cos(q[0])]])

    def Jdot_qd(self, q, qd):
        return -self.l * qd[0] ** 2 * np.array([math.cos(q[0]), math.sin(q[0])])


class PolarTwoLink(_ClosedForm):
    """Two-link polar robot, q = [th1, r], point mass m at radius r (the lecture's example).

    M = diag(m r^2, m), C qd = [2 m r rd th1d, -m r th1d^2], g = [m g r cos th1, m g sin th1].
    """

    joint_names = ('theta1', 'r')
    task_axes = ('x', 'y')

    def __init__(self, m=2.0, gravity=units.GRAVITY):
        self.m = _param('m', m)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)

    def M(self, q):
        r = q[1]
        return np.array([[self.m * r * r, 0.0], [0.0, self.m]])

    def C(self, q, qd):
        m, r = self.m, q[1]
        return np.array([[m * r * qd[1], m * r * qd[0]], [-m * r * qd[0], 0.0]])

    def C_qd(self, q, qd):
        m, r = self.m, q[1]
        return np.array([2.0 * m * r * qd[1] * qd[0], -m * r * qd[0] ** 2])

    def g(self, q):
        mg = self.m * self.gravity
        return np.array([mg * q[1] * math.cos(q[0]), mg * math.sin(q[0])])

    def _inverse_dynamics(self, q, qd, qdd):
        (th, r), (thd, rd), (a0, a1) = q.tolist(), qd.tolist(), qdd.tolist()
        m = self.m
        mg = m * self.gravity
        return np.array([m * r * r * a0 + 2.0 * m * r * rd * thd + mg * r * math.cos(th),
                         m * a1 - m * r * (thd * thd) + mg * math.sin(th)])

    def fk(self, q):
        return q[1] * np.array([math.cos(q[0]), math.sin(q[0])])

    def J(self, q):
        c, s, r = math.cos(q[0]), math.sin(q[0]), q[1]
        return np.array([[-r * s, c], [r * c, s]])

    def Jdot_qd(self, q, qd):
        c, s, r = math.cos(q[0]), math.sin(q[0]), q[1]
        t, rd = qd
        return np.array([-2.0 * rd * t * s - r * t * t * c, 2.0 * rd * t * c - r * t * t * s])


class PlanarTwoLink(_ClosedForm):
    """Two-link planar arm in a vertical plane, point masses m1, m2 at the link ends.

    th1 from the horizontal, th2 relative to link 1. M and g are the lecture's. C qd is
    [-m2 l1 l2 s2 (2 th1d th2d + th2d^2), m2 l1 l2 s2 th1d^2]: the lecture prints the first
    row as +m2 l1 l2 (th1d^2 + 2 th1d th2d) s2, which is not what Lagrange's equation gives
    (Craig, eq. 6.60); the second row agrees. Pinocchio on the same arm confirms this form.
    """

    joint_names = ('theta1', 'theta2')
    task_axes = ('x', 'y')

    def __init__(self, m1=1.0, m2=1.0, l1=0.5, l2=0.5, gravity=units.GRAVITY):
        self.m1, self.m2 = _param('m1', m1), _param('m2', m2)
        self.l1, self.l2 = _param('l1', l1), _param('l2', l2)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)

    def M(self, q):
        m1, m2, l1, l2 = self.m1, self.m2, self.l1, self.l2
        c2 = math.cos(q[1])
        m12 = m2 * l2 * l2 + m2 * l1 * l2 * c2
        m11 = (m1 + m2) * l1 * l1 + m2 * l2 * l2 + 2.0 * m2 * l1 * l2 * c2
        return np.array([[m11, m12], [m12, m2 * l2 * l2]])

    def C(self, q, qd):
        h = self.m2 * self.l1 * self.l2 * math.sin(q[1])
        return np.array([[-h * qd[1], -h * (qd[0] + qd[1])], [h * qd[0], 0.0]])

    def C_qd(self, q, qd):
        h = self.m2 * self.l1 * self.l2 * math.sin(q[1])
        return np.array([-h * (2.0 * qd[0] * qd[1] + qd[1] ** 2), h * qd[0] ** 2])

    def g(self, q):
        c1, c12 = math.cos(q[0]), math.cos(q[0] + q[1])
        g2 = self.m2 * self.gravity * self.l2 * c12
        return np.array([(self.m1 + self.m2) * self.gravity * self.l1 * c1 + g2, g2])

    def _inverse_dynamics(self, q, qd, qdd):
        (t1, t2), (w1, w2), (a1, a2) = q.tolist(), qd.tolist(), qdd.tolist()
        m1, m2, l1, l2, g0 = self.m1, self.m2, self.l1, self.l2, self.gravity
        c2 = math.cos(t2)
        m12 = m2 * l2 * l2 + m2 * l1 * l2 * c2
        m11 = (m1 + m2) * l1 * l1 + m2 * l2 * l2 + 2.0 * m2 * l1 * l2 * c2
        h = m2 * l1 * l2 * math.sin(t2)
        g2 = m2 * g0 * l2 * math.cos(t1 + t2)
        return np.array([m11 * a1 + m12 * a2 - h * (2.0 * w1 * w2 + w2 * w2) + (m1 + m2) * g0 * l1 * math.cos(t1) + g2,
                         m12 * a1 + m2 * l2 * l2 * a2 + h * (w1 * w1) + g2])

    def fk(self, q):
        a, b = q[0], q[0] + q[1]
        return np.array([self.l1 * math.cos(a) + self.l2 * math.cos(b),
                         self.l1 * math.sin(a) + self.l2 * math.sin(b)])

    def J(self, q):
        a, b = q[0], q[0] + q[1]
        s1, c1, s12, c12 = math.sin(a), math.cos(a), math.sin(b), math.cos(b)
        return np.array([[-self.l1 * s1 - self.l2 * s12, -self.l2 * s12],
                         [self.l1 * c1 + self.l2 * c12, self.l2 * c12]])

    def Jdot_qd(self, q, qd):
        a, b = q[0], q[0] + q[1]
        w1, w12 = qd[0], qd[0] + qd[1]
        return np.array([-self.l1 * math.cos(a) * w1 ** 2 - self.l2 * math.cos(b) * w12 ** 2,
                         -self.l1 * math.sin(a) * w1 ** 2 - self.l2 * math.sin(b) * w12 ** 2])


class _Cartesian(_ClosedForm):
    """Prismatic gantry: diagonal constant M, gravity on one axis, X = q and J = I."""

    def __init__(self, axis_masses, gravity_axis, gravity):
        self._M = np.diag(axis_masses)
        self._g = np.zeros(len(axis_masses))
        self._g[gravity_axis] = axis_masses[gravity_axis] * gravity
        n = len(axis_masses)
        self._mass = _read_only(axis_masses)              # the diagonal of M
        self._Minv_ro = _read_only(np.diag(1.0 / self._mass))
        self._eye = _read_only(np.eye(n))
        self._zeros = _read_only(np.zeros(n))

    def M(self, q):
        return self._M.copy()

    def C(self, q, qd):
        return np.zeros_like(self._M)

    def C_qd(self, q, qd):
        return np.zeros(self.n)

    def g(self, q):
        return self._g.copy()

    def fk(self, q):
        return np.array(q, dtype=float)

    def J(self, q):
        return np.eye(self.n)

    def Jdot_qd(self, q, qd):
        return np.zeros(self.n)

    def _inverse_dynamics(self, q, qd, qdd):
        return self._mass * qdd + self._g   # M diagonal, C qd = 0

    def _task(self, q, qd):
        return q.copy(), self._eye, self._zeros

    def _Minv(self, q):
        return self._Minv_ro


class Force1Dof(_Cartesian):
    """m xdd + f = tau (section 3): a horizontal slider of mass m; f is the contact force."""

    joint_names = ('x',)
    task_axes = ('x',)

    def __init__(self, m=1.0):
        self.m = _param('m', m)
        super().__init__([self.m], 0, 0.0)


class CartesianXY(_Cartesian):
    """The lecture's hybrid example (3.1): m1 xdd + f = tau1, (m1 + m2)(ydd + g) = tau2.

    x is horizontal (normal to the wall), y vertical; the y stage carries the x stage.
    """

    joint_names = ('x', 'y')
    task_axes = ('x', 'y')

    def __init__(self, m1=1.0, m2=1.0, gravity=units.GRAVITY):
        self.m1, self.m2 = _param('m1', m1), _param('m2', m2)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)
        super().__init__([self.m1, self.m1 + self.m2], 1, self.gravity)


class CartesianXYZ(_Cartesian):
    """Three-axis gantry (3.1, general form): z vertical carries x, x carries y.

    M = diag(m1 + m2, m1, m1 + m2 + m3) for X = [x, y, z]; g = [0, 0, (m1 + m2 + m3) g].
    """

    joint_names = ('x', 'y', 'z')
    task_axes = ('x', 'y', 'z')

    def __init__(self, m1=1.0, m2=1.0, m3=1.0, gravity=units.GRAVITY):
        self.m1, self.m2, self.m3 = _param('m1', m1), _param('m2', m2), _param('m3', m3)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)
        super().__init__([self.m1 + self.m2, self.m1, self.m1 + self.m2 + self.m3], 2, self.gravity)


CLOSED_FORM = {
    'mass_spring_cubic': MassSpringCubic,
    'single_link': SingleLink,
    'polar_two_link': PolarTwoLink,
    'planar_two_link': PlanarTwoLink,
    'force_1dof': Force1Dof,
    'cartesian_xy': CartesianXY,
    'cartesian_xyz': CartesianXYZ,
}
