"""The model interface every controller uses: M(q) qdd + C(q, qd) qd + g(q) = tau.

Units: SI (rad, m, kg, N, N m, s). Shapes: q, qd, tau are (n,); M and C are (n, n).
Task space (Cartesian laws): x = fk(q) is (m,), J(q) is (m, n), Jdot_qd(q, qd) = Jdot qd is (m,).
A model is immutable: what the robot is. Scratch memory, where needed, is private to the model.

The laws' fast path (package-internal, underscore methods): the laws check their arguments once
and then call _inverse_dynamics, _task, _task_motion and _Minv with finite float64 (n,) arrays,
which do no argument checks of their own. Defaults below derive them from the public methods;
models override them where one evaluation can serve several terms (UrdfModel: one Pinocchio pass).
"""
from abc import ABC, abstractmethod

import numpy as np

from robot_control import validation


class RobotModel(ABC):
    """Joint-space rigid-body dynamics, with optional task-space kinematics."""

    #: names of the n joints, in the order of every joint-space vector
    joint_names: tuple = ()
    #: names of the m task-space axes (empty when the model has no task space)
    task_axes: tuple = ()

    @property
    def n(self):
        """Number of joints (degrees of freedom)."""
        return len(self.joint_names)

    @property
    def task_dim(self):
        """Dimension m of the task space (0 when fk is not available)."""
        return len(self.task_axes)

    @property
    def effort_limit(self):
        """Per-joint effort limit, N m or N, shape (n,); inf where the model sets none."""
        return np.full(self.n, np.inf)

    # -- joint space -------------------------------------------------------------------------
    @abstractmethod
    def M(self, q):
        """Mass matrix M(q), (n, n), symmetric positive definite."""

    @abstractmethod
    def C(self, q, qd):
        """Coriolis/centrifugal matrix C(q, qd), (n, n), with Mdot - 2C skew-symmetric."""

    def C_qd(self, q, qd):
        """Velocity-dependent torque C(q, qd) qd, (n,)."""
        return self.C(q, qd) @ qd

    @abstractmethod
    def g(self, q):
        """Gravity (and other position-dependent) torque g(q), (n,)."""

    def inverse_dynamics(self, q, qd, qdd):
        """tau = M(q) qdd + C(q, qd) qd + g(q)."""
        return self.M(q) @ qdd + self.C_qd(q, qd) + self.g(q)

    def forward_dynamics(self, q, qd, tau):
        """qdd = M(q)^-1 (tau - C(q, qd) qd - g(q))."""
        return np.linalg.solve(self.M(q), tau - self.C_qd(q, qd) - self.g(q))

    # -- task space --------------------------------------------------------------------------
    def fk(self, q):
        """Task-space position x(q), (m,)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    def J(self, q):
        """Task Jacobian dx/dq, (m, n)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    def Jdot_qd(self, q, qd):
        """Task acceleration bias Jdot(q, qd) qd, (m,)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    # -- the laws' fast path: arguments already checked (finite float64 (n,) arrays) -----------
    def _inverse_dynamics(self, q, qd, qdd):
        """tau = M qdd + C qd + g, (n,), a new array."""
        return self.inverse_dynamics(q, qd, qdd)

    def _task(self, q, qd):
        """(x, J, Jdot_qd) at (q, qd): (m,), (m, n), (m,). Read them only: they may be shared."""
        return self.fk(q), self.J(q), self.Jdot_qd(q, qd)

    def _task_motion(self, q, qd, qdd):
        """(x, xd, xdd) = (fk(q), J qd, J qdd + Jdot qd), each (m,). Read them only."""
        J = self.J(q)
        return self.fk(q), J @ qd, J @ qdd + self.Jdot_qd(q, qd)

    def _Minv(self, q):
        """M(q)^-1, (n, n). Read it only."""
        return np.linalg.inv(self.M(q))

    # -- checks ------------------------------------------------------------------------------
    def check_q(self, q, name='q'):
        """q as a finite (n,) array, or ValueError naming `name`."""
        return validation.vector(name, q, self.n)
