"""The lecture's closed-form models (section 2.2.2 and 3), in its notation.

Each class holds its physical parameters (SI units) and writes the lecture's terms once: the
mass matrix _M(q), the velocity term _C_qd(q, qd) = C(q, qd) qd, the gravity term _g(q) and, where
the robot has one, its task space (_fk, _J, _Jdot_qd). RobotModel composes inverse and forward
dynamics from them and checks the arguments of the public methods. Positions in the task space are
expressed in the lecture's frame: x horizontal, y vertical (up) for the planar robots; the
Cartesian robots' task space is their joint space (X = q, J = I).
"""
import math

import numpy as np

from robot_control import units, validation
from robot_control.models.base import RobotModel


def _param(name, value):
    return validation.scalar(name, value, positive=True)


class MassSpringCubic(RobotModel):
    """m xdd + b xd + k x^3 = u (section 2.2): b xd is reported as C qd, k x^3 as g(q).

    The partitioned law alpha = m, beta = b xd + k x^3 is then computed torque on this model.
    """

    joint_names = ('x',)
    task_axes = ('x',)

    def __init__(self, m=1.0, b=1.0, k=100.0):
        self.m = _param('m', m)
        self.b = validation.scalar('b', b, nonnegative=True)
        self.k = validation.scalar('k', k, nonnegative=True)

    def _M(self, q):
        return np.array([[self.m]])

    def _C(self, q, qd):
        """[[b]]: friction, not a Christoffel term (Mdot - 2C is not skew for this system)."""
        return np.array([[self.b]])

    def _C_qd(self, q, qd):
        return self.b * qd

    def _g(self, q):
        (x,) = q.tolist()
        return np.array([self.k * (x * x * x)])   # float products: overflow gives inf, not an exception

    def _fk(self, q):
        return q.copy()

    def _J(self, q):
        return np.eye(1)

    def _Jdot_qd(self, q, qd):
        return np.zeros(1)


class SingleLink(RobotModel):
    """m l^2 thdd + m g l cos(th) = tau: point mass m at the end of a link of length l.

    th is measured from the horizontal in a vertical plane.
    """

    joint_names = ('theta',)
    task_axes = ('x', 'y')

    def __init__(self, m=1.0, l=0.5, gravity=units.GRAVITY):
        self.m = _param('m', m)
        self.l = _param('l', l)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)

    def _M(self, q):
        return np.array([[self.m * self.l ** 2]])

    def _C(self, q, qd):
        return np.zeros((1, 1))

    def _C_qd(self, q, qd):
        return np.zeros(1)

    def _g(self, q):
        (th,) = q.tolist()
        return np.array([self.m * self.gravity * self.l * math.cos(th)])

    def _fk(self, q):
        (th,) = q.tolist()
        return self.l * np.array([math.cos(th), math.sin(th)])

    def _J(self, q):
        (th,) = q.tolist()
        return self.l * np.array([[-math.sin(th)], [math.cos(th)]])

    def _Jdot_qd(self, q, qd):
        (th,), (thd,) = q.tolist(), qd.tolist()
        return -self.l * thd * thd * np.array([math.cos(th), math.sin(th)])


class PolarTwoLink(RobotModel):
    """Two-link polar robot, q = [th1, r], point mass m at radius r (the lecture's example).

    M = diag(m r^2, m), C qd = [2 m r rd th1d, -m r th1d^2], g = [m g r cos th1, m g sin th1].
    """

    joint_names = ('theta1', 'r')
    task_axes = ('x', 'y')

    def __init__(self, m=2.0, gravity=units.GRAVITY):
        self.m = _param('m', m)
        self.gravity = validation.scalar('gravity', gravity, nonnegative=True)

    def _M(self, q):
        m, (th1, r) = self.m, q.tolist()
        return np.array([[m * r * r, 0.0],
                         [0.0, m]])

    def _C(self, q, qd):
        """Christoffel form, C qd = C_qd and Mdot - 2C skew."""
        m, (th1, r), (th1d, rd) = self.m, q.tolist(), qd.tolist()
        return np.array([[m * r * rd, m * r * th1d],
                         [-m * r * th1d, 0.0]])

    def _C_qd(self, q, qd):
        m, (th1, r), (th1d, rd) = self.m, q.tolist(), qd.tolist()
        return np.array([2.0 * m * r * rd * th1d,
                         -m * r * th1d * th1d])

    def _g(self, q):
        mg, (th1, r) = self.m * self.gravity, q.tolist()
        return np.array([mg * r * math.cos(th1),
                         mg * math.sin(th1)])

    def _fk(self, q):
        th1, r = q.tolist()
        return r * np.array([math.cos(th1), math.sin(th1)])

    def _J(self, q):
        th1, r = q.tolist()
        c, s = math.cos(th1), math.sin(th1)
        return np.array([[-r * s, c],
                         [r * c, s]])

    def _Jdot_qd(self, q, qd):
        (th1, r), (t, rd) = q.tolist(), qd.tolist()
        c, s = math.cos(th1), math.sin(th1)
        return np.array([-2.0 * rd * t * s - r * t * t * c,
                         2.0 * rd * t * c - r * t * t * s])


class PlanarTwoLink(RobotModel):
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

    def _M(self, q):
        m1, m2, l1, l2 = self.m1, self.m2, self.l1, self.l2
        c2 = math.cos(q.tolist()[1])
        m12 = m2 * l2 * l2 + m2 * l1 * l2 * c2
        return np.array([[(m1 + m2) * l1 * l1 + m2 * l2 * l2 + 2.0 * m2 * l1 * l2 * c2, m12],
                         [m12, m2 * l2 * l2]])

    def _C(self, q, qd):
        """Christoffel form, C qd = C_qd and Mdot - 2C skew."""
        h = self.m2 * self.l1 * self.l2 * math.sin(q.tolist()[1])
        th1d, th2d = qd.tolist()
        return np.array([[-h * th2d, -h * (th1d + th2d)],
                         [h * th1d, 0.0]])

    def _C_qd(self, q, qd):
        h = self.m2 * self.l1 * self.l2 * math.sin(q.tolist()[1])
        th1d, th2d = qd.tolist()
        return np.array([-h * (2.0 * th1d * th2d + th2d * th2d),
                         h * th1d * th1d])

    def _g(self, q):
        th1, th2 = q.tolist()
        g2 = self.m2 * self.gravity * self.l2 * math.cos(th1 + th2)
        return np.array([(self.m1 + self.m2) * self.gravity * self.l1 * math.cos(th1) + g2,
                         g2])

    def _fk(self, q):
        th1, th2 = q.tolist()
        return np.array([self.l1 * math.cos(th1) + self.l2 * math.cos(th1 + th2),
                         self.l1 * math.sin(th1) + self.l2 * math.sin(th1 + th2)])

    def _J(self, q):
        th1, th2 = q.tolist()
        s1, c1, s12, c12 = math.sin(th1), math.cos(th1), math.sin(th1 + th2), math.cos(th1 + th2)
        return np.array([[-self.l1 * s1 - self.l2 * s12, -self.l2 * s12],
                         [self.l1 * c1 + self.l2 * c12, self.l2 * c12]])

    def _Jdot_qd(self, q, qd):
        (th1, th2), (w1, w2) = q.tolist(), qd.tolist()
        w12 = w1 + w2
        return np.array([-self.l1 * math.cos(th1) * w1 * w1 - self.l2 * math.cos(th1 + th2) * w12 * w12,
                         -self.l1 * math.sin(th1) * w1 * w1 - self.l2 * math.sin(th1 + th2) * w12 * w12])


class _Cartesian(RobotModel):
    """Prismatic gantry: constant diagonal M, gravity on one axis, X = q and J = I."""

    def __init__(self, axis_masses, gravity_axis, gravity):
        self.axis_masses = np.array(axis_masses, dtype=float)    # the diagonal of M
        self.axis_masses.flags.writeable = False
        self.gravity_axis = gravity_axis
        self.gravity_force = axis_masses[gravity_axis] * gravity  # N, along the gravity axis

    def _M(self, q):
        return np.diag(self.axis_masses)

    def _C(self, q, qd):
        return np.zeros((self.n, self.n))

    def _C_qd(self, q, qd):
        return np.zeros(self.n)

    def _g(self, q):
        g = np.zeros(self.n)
        g[self.gravity_axis] = self.gravity_force
        return g

    def _fk(self, q):
        return q.copy()

    def _J(self, q):
        return np.eye(self.n)

    def _Jdot_qd(self, q, qd):
        return np.zeros(self.n)


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

#: unit of each physical parameter of the closed-form models (their constructors' arguments, SI)
PARAMETER_UNITS = {'m': 'kg', 'm1': 'kg', 'm2': 'kg', 'm3': 'kg', 'l': 'm', 'l1': 'm', 'l2': 'm',
                   'b': 'N s/m (viscous friction)', 'k': 'N/m^3 (cubic spring)', 'gravity': 'm/s^2'}
#: the physical parameters that may be zero (no friction, no spring, no gravity); the others are positive
MAY_BE_ZERO = ('b', 'k', 'gravity')
