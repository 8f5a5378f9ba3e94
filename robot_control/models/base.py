"""The model interface every controller uses: M(q) qdd + C(q, qd) qd + g(q) = tau.

Units: SI (rad, m, kg, N, N m, s). Shapes: q, qd, qdd, tau are (n,); M and C are (n, n).
Task space (Cartesian laws): x = fk(q) is (m,), J(q) is (m, n), Jdot_qd(q, qd) = Jdot qd is (m,).
A model is immutable: what the robot is. Scratch memory, where needed, is private to the model.

Two layers, so that every input is checked once, where it enters:
- the public methods (M, C_qd, g, inverse_dynamics, fk, J, ...) check their arguments (an
  ArgumentError naming q, qd, qdd or tau) and then call
- the equations, the underscore methods (_M, _C_qd, _g, _fk, _J, _Jdot_qd), which take finite
  float64 (n,) arrays and check nothing. The laws and the control core call these on arrays they
  checked at their own edge.
A closed form writes _M, _C_qd and _g once; inverse and forward dynamics are composed from them
here. A model with a faster evaluation of the same terms (UrdfModel: one RNEA call) overrides the
composition, never the terms.
"""
from abc import ABC, abstractmethod

import numpy as np

from robot_control import validation

#: task spaces of a URDF model: their axes (the tip frame's position, then its orientation)
TASK_SPACES = {'position': ('x', 'y', 'z'), 'pose': ('x', 'y', 'z', 'rx', 'ry', 'rz')}
#: joints an arm needs to hold a pose: one per task axis of 'pose'
POSE_JOINTS = len(TASK_SPACES['pose'])


def task_space_for(task_space, n):
    """The task space (a key of TASK_SPACES) `task_space` means on an arm whose tip n joints move: 'auto' is
    'pose' where the arm can hold one (n >= POSE_JOINTS), else 'position'; 'position' and 'pose' are themselves."""
    if task_space == 'auto':
        return 'pose' if n >= POSE_JOINTS else 'position'
    return task_space


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

    @property
    def velocity_limit(self):
        """Per-joint velocity limit, rad/s or m/s, (n,); inf where the model sets none."""
        return np.full(self.n, np.inf)

    @property
    def position_limits(self):
        """(lower, upper) per-joint position limits, rad or m, each (n,); -inf, inf where none."""
        return np.full(self.n, -np.inf), np.full(self.n, np.inf)

    # -- checks at the edge --------------------------------------------------------------------
    def check_q(self, q, name='q'):
        """q as a finite float64 (n,) array, or ArgumentError naming `name`."""
        return validation.vector(name, q, self.n)

    def _check_task(self):
        if not self.task_axes:
            raise NotImplementedError(f'{type(self).__name__} has no task space')

    # -- joint space (checked) ---------------------------------------------------------------------
    def M(self, q):
        """Mass matrix M(q), (n, n), symmetric positive definite."""
        return self._M(self.check_q(q))

    def C(self, q, qd):
        """Coriolis/centrifugal matrix C(q, qd), (n, n), with C(q, qd) qd = C_qd(q, qd)."""
        return self._C(self.check_q(q), self.check_q(qd, 'qd'))

    def C_qd(self, q, qd):
        """Velocity-dependent torque C(q, qd) qd, (n,)."""
        return self._C_qd(self.check_q(q), self.check_q(qd, 'qd'))

    def g(self, q):
        """Gravity (and other position-dependent) torque g(q), (n,)."""
        return self._g(self.check_q(q))

    def inverse_dynamics(self, q, qd, qdd):
        """tau = M(q) qdd + C(q, qd) qd + g(q), (n,)."""
        return self._inverse_dynamics(self.check_q(q), self.check_q(qd, 'qd'), self.check_q(qdd, 'qdd'))

    def forward_dynamics(self, q, qd, tau):
        """qdd = M(q)^-1 (tau - C(q, qd) qd - g(q)), (n,)."""
        return self._forward_dynamics(self.check_q(q), self.check_q(qd, 'qd'), self.check_q(tau, 'tau'))

    # -- task space (checked) ----------------------------------------------------------------------
    def fk(self, q):
        """Task-space position x(q), (m,)."""
        self._check_task()
        return self._fk(self.check_q(q))

    def J(self, q):
        """Task Jacobian dx/dq, (m, n)."""
        self._check_task()
        return self._J(self.check_q(q))

    def Jdot_qd(self, q, qd):
        """Task acceleration bias Jdot(q, qd) qd, (m,)."""
        self._check_task()
        return self._Jdot_qd(self.check_q(q), self.check_q(qd, 'qd'))

    # -- the equations: finite float64 (n,) arrays in, no checks -------------------------------------
    @abstractmethod
    def _M(self, q):
        """M(q), (n, n)."""

    def _C(self, q, qd):
        """C(q, qd), (n, n); models that give only C qd leave it out."""
        raise NotImplementedError(f'{type(self).__name__} gives C(q, qd) qd only (C_qd)')

    def _C_qd(self, q, qd):
        """C(q, qd) qd, (n,)."""
        return self._C(q, qd) @ qd

    @abstractmethod
    def _g(self, q):
        """g(q), (n,)."""

    def _inverse_dynamics(self, q, qd, qdd):
        """tau = M(q) qdd + C(q, qd) qd + g(q), (n,), a new array."""
        return self._M(q) @ qdd + self._C_qd(q, qd) + self._g(q)

    def _forward_dynamics(self, q, qd, tau):
        """qdd = M(q)^-1 (tau - C(q, qd) qd - g(q)), (n,)."""
        return np.linalg.solve(self._M(q), tau - self._C_qd(q, qd) - self._g(q))

    def _Minv(self, q):
        """M(q)^-1, (n, n)."""
        return np.linalg.inv(self._M(q))

    def _fk(self, q):
        """x(q), (m,)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    def _J(self, q):
        """J(q), (m, n)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    def _Jdot_qd(self, q, qd):
        """Jdot(q, qd) qd, (m,)."""
        raise NotImplementedError(f'{type(self).__name__} has no task space')

    def _task(self, q, qd):
        """(x, J, Jdot qd) at (q, qd): (m,), (m, n), (m,)."""
        return self._fk(q), self._J(q), self._Jdot_qd(q, qd)

    def _task_difference(self, x_d, x):
        """The task error x_d - x, (m,) (a model with orientation axes measures them on SO(3))."""
        return x_d - x

    def task_difference(self, x_d, x):
        """x_d "minus" x in the task space, (m,): the error the task-space laws servo."""
        self._check_task()
        return self._task_difference(validation.vector('x_d', x_d, self.task_dim),
                                     validation.vector('x', x, self.task_dim))

    #: the frame task positions are expressed in (a pose target's header.frame_id names it)
    base_frame = 'world'

    def task_position(self, position, quaternion):
        """The task position (m,) of a pose: position (3,) m, unit quaternion (4,) (x, y, z, w). Closed
        forms take the position components their axes name (x, y, z: the lecture's frame)."""
        self._check_task()
        return np.array([position['xyz'.index(a)] for a in self.task_axes])

    def task_pose(self, x):
        """(position (3,), quaternion (4,)) of a task position x (m,): the inverse of task_position."""
        self._check_task()
        position = np.zeros(3)
        for a, v in zip(self.task_axes, validation.vector('x', x, self.task_dim)):
            position['xyz'.index(a)] = v
        return position, np.array([0.0, 0.0, 0.0, 1.0])

    def _task_motion(self, q, qd, qdd):
        """(x, xd, xdd) = (fk(q), J qd, J qdd + Jdot qd), each (m,): a joint motion seen in the task space."""
        J = self._J(q)
        return self._fk(q), J @ qd, J @ qdd + self._Jdot_qd(q, qd)
