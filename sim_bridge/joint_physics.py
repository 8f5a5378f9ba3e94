"""The joint friction and armature of sim_bridge.joint_friction applied to a PyBullet body, step by step
(the equations and how PyBullet is made to follow them: that module's docstring). No rclpy."""
import numpy as np
import pybullet as p

from sim_bridge import physics_check
from sim_bridge import joint_friction


class JointPhysics:
    """The joint physics of one built PyBullet body: `joints` the controlled joints' PyBullet indices,
    `tip` the tip link index or None, dt the step, s. `set(friction)` puts a JointFriction in force; `torque` is the
    World's per-step call; `prepare`, between steps, forms ahead what the next one needs of the state alone."""

    def __init__(self, client, body, joints, tip, dt, friction):
        self._client, self._body, self._joints, self._tip, self.dt = client, body, list(joints), tip, dt
        self._movable = list(physics_check.movable_joints(client, body).values())
        dof = np.array([self._movable.index(j) for j in joints])
        #: the controlled joints' block of the full mass matrix and vectors (None: every movable joint, in order)
        self._dof = None if dof.tolist() == list(range(len(self._movable))) else dof
        self._block = None if self._dof is None else (dof[:, None], dof)
        self._zeros = [0.0] * len(self._movable)
        self.set(friction)

    def set(self, friction):
        """Put `friction` (a JointFriction for these joints) in force from the next step."""
        self.friction = friction
        self.exact = friction.exact
        self._last = None       # (M, predicted qd+, constraint torque assumed) of the last step; None: none
        self._sets = None       # the Coulomb solver's active sets of the last step (coulomb_sets); None: none
        self._ahead = None      # _step_ahead() formed by prepare() for the next step; None: none
        self._solved = None     # (loads, _solve()) formed by prepare() for the next step; None: none
        self.loss = None        # tau_loss (n,) of the last exact step (loss()); None: braked or not yet stepped
        for j, b in zip(self._joints, friction.viscous.tolist()):
            p.changeDynamics(self._body, j, jointDamping=b, physicsClientId=self._client)

    def torque(self, forces, cartesian_force=None, braked=False):
        """The joint torques (list of n floats) to send PyBullet for the step about to run, given `forces`
        (the actuator, disturbance and spring torque, list of n floats) and the Cartesian disturbance
        (3,) N or None (PyBullet applies it): see sim_bridge.joint_friction. While `braked`: `forces`.
        A step prepare() solved for these same loads is taken as solved."""
        if braked:
            self._last = self.loss = self._sets = self._ahead = self._solved = None
            return forces
        ahead = self._step_ahead() if self._ahead is None else self._ahead
        solved, loads = self._solved, (forces, cartesian_force)
        self._ahead = self._solved = None
        step = solved[1] if solved is not None and _same_loads(solved[0], loads) else self._solve(ahead, *loads)
        out, self._last, self.loss, self._sets = step
        return out

    def prepare(self, loads=None):
        """Form now the next step's _step_ahead() (the state does not change until that step): what the step
        after the next command then need not do (once until that step: a second call does nothing). `loads`:
        (forces, cartesian_force) as torque() will get them, when already known (a command that is due, or
        answered): the step is then solved for them too, and torque() takes that solution if its loads are the
        same. A step, set() or the brakes discard both."""
        if self._ahead is None:
            self._ahead = self._step_ahead()
        if loads is not None and self._solved is None:
            self._solved = (loads, self._solve(self._ahead, *loads))

    def _solve(self, ahead, forces, cartesian_force):
        """(torques to send (list of n floats), the step's (M, predicted qd+, tau_c assumed), tau_loss, the Coulomb
        sets) of the step `ahead` (_step_ahead) under these loads."""
        q_all, qd_all, mass, constraint, plan = ahead
        tau = np.array(forces)
        x = tau if cartesian_force is None else tau + self._jacobian(q_all, qd_all).T @ cartesian_force
        f, qdd, loss, sets = plan.solve(x)
        last = (mass, plan.qd + self.dt * qdd, constraint)
        return (tau + f - self.friction.armature * qdd).tolist(), last, loss, sets

    def _step_ahead(self):
        """What a step needs of the state alone: (q, qd of every movable joint (tuples), M (n, n), the constraint
        torque assumed tau_c (n,) or 0, the joint_friction.StepPlan with r0 = tau_c - b qd - h, h = C qd + g)
        of the controlled joints; the torque x = tau + tau_env (+ J^T F) comes with the command."""
        c, body = self._client, self._body
        q_all, qd_all, _, _ = zip(*p.getJointStates(body, self._movable, physicsClientId=c))
        mass = np.array(p.calculateMassMatrix(body, q_all, physicsClientId=c))
        h = np.array(p.calculateInverseDynamics(body, q_all, qd_all, self._zeros, physicsClientId=c))
        qd = np.array(qd_all)
        if self._dof is not None:
            mass, h, qd = mass[self._block], h[self._dof], qd[self._dof]
        constraint = 0.0 if self._last is None else self._constraint(qd)
        fr = self.friction
        plan = joint_friction.StepPlan(fr, joint_friction.inertia(fr, mass), qd, constraint - fr.viscous * qd - h,
                                       self.dt, self._sets)
        return q_all, qd_all, mass, constraint, plan

    def _constraint(self, qd):
        """tau_c (n,) N m or N: the joint torque of the constraints PyBullet solved in the last step (surface
        contact, joint limits, held joints). PyBullet's M (qd - qd+_predicted) / dt is what they added to
        the tau_c assumed then: M qdd_b = tau_sent - h + tau_c and M qdd = tau_sent - h + tau_c,assumed."""
        mass, predicted, assumed = self._last
        return assumed + mass @ (qd - predicted) / self.dt

    def _jacobian(self, q_all, qd_all):
        """The tip frame origin's linear Jacobian (3, n), m/rad or 1, world axes: where the World applies
        the Cartesian disturbance (calculateJacobian's point is in the link frame, measured)."""
        linear, _ = p.calculateJacobian(self._body, self._tip, [0.0, 0.0, 0.0], q_all, qd_all, self._zeros,
                                        physicsClientId=self._client)
        return np.array(linear) if self._dof is None else np.array(linear)[:, self._dof]


def _same_loads(a, b):
    """Whether two (forces, cartesian_force) are the same loads: equal lists, and both None or equal arrays."""
    (forces_a, cart_a), (forces_b, cart_b) = a, b
    if forces_a != forces_b:
        return False
    return cart_a is cart_b or (cart_a is not None and cart_b is not None and np.array_equal(cart_a, cart_b))
