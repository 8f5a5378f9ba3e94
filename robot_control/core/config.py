"""ControllerConfig: the immutable, checked snapshot of everything one control tick reads.

The node builds one from its parameters (robot_control.ros), a library user by hand. Creating it
checks every field (an ArgumentError naming the field) and builds its Law (robot_control.laws.LAWS),
which checks what that law needs. ControllerCore.configure() swaps a new one in, effective on the
next tick.
"""
import dataclasses
import math

import numpy as np

from robot_control import validation
from robot_control.core.tolerances import Tolerances
from robot_control.laws import law_class
from robot_control.laws.friction_compensation import FrictionCompensation
from robot_control.models.base import RobotModel
from robot_control.validation import ArgumentError


@dataclasses.dataclass(frozen=True, eq=False)
class ControllerConfig:
    """Immutable snapshot of everything the per-tick computation reads (checked on creation).

    model: RobotModel (the controller's own, closed form or URDF).
    law: a name of the registry robot_control.laws.LAWS.
    integral: integral action on (ki used) or off (ki ignored, no integral state).
    integral_limit: clamp of |int E| per entry (rad s, m s or N s), > 0, inf = none.
    integral_rest_velocity: v_r, > 0, in units of Ed (rad/s, m/s or N/s): entry i integrates only while
      |Ed_i| <= v_r, the error at rest (robot_control.laws.integral.moving); inf = always.
    effort_limit: (n,) N m or N, > 0 (inf allowed); None = model.effort_limit.
    joints: joint names in model order; None = model.joint_names.
    move_time: duration of a set_goal() move, s (> 0).
    law_params: the parameters only the law reads: a mapping of its parameter names (Law.all_param_rows:
      those of its parts, e.g. kp, kv, ki of the motion servo, force_axes, k_e, x_e, force_kp, ... of the force
      setup or posture_kp, posture_kv, and its own) to values (missing ones at their defaults; None: all), or
      the law's Params; held as that
      law's Params (a frozen dataclass, e.g. robot_control.laws.impedance.ImpedanceParams, its parts fitted
      to the model: the force axes in task-axis order), None for a law without parameters. The law's force
      setup: control_law.force_task (robot_control.laws.force_task.ForceTask).
    trajectory_tolerance, goal_tolerance: per joint (scalar or (n,)), rad or m, >= 0, 0 = not checked;
      goal_time: s >= 0 (0 = no limit); stopped_velocity_tolerance: rad/s or m/s >= 0
      (robot_control.core.tolerances, like joint_trajectory_controller's constraints).
    velocity_cutoff_hz: f_c of the velocity estimated from the positions (robot_control.core.velocity), Hz,
      >= 0; 0 = the joint states' own velocities (a state without velocities: estimated at
      DEFAULT_CUTOFF_HZ).
    friction_compensation: tau_f = Fc tanh(v / v_s) + Fv v added to every law's torque: a mapping of
      coulomb, viscous, velocity_threshold, velocity, or a FrictionCompensation
      (robot_control.laws.friction_compensation); held as that, or None when off (Fc = Fv = 0).
    """

    model: RobotModel
    law: str = 'computed_torque'
    integral: bool = False
    integral_limit: float = math.inf
    integral_rest_velocity: float = math.inf
    effort_limit: np.ndarray = None
    joints: tuple = None
    move_time: float = 2.0
    trajectory_tolerance: np.ndarray = 0.0
    goal_tolerance: np.ndarray = 0.0
    goal_time: float = 0.0
    stopped_velocity_tolerance: float = 0.01
    law_params: object = None
    friction_compensation: object = None
    velocity_cutoff_hz: float = 0.0

    def __post_init__(self):
        model = self.model
        if not isinstance(model, RobotModel):
            raise ArgumentError('model', f'expected a RobotModel, got {type(model).__name__}')
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        law = law_class(self.law)
        joints = validation.names('joints', model.joint_names if self.joints is None else self.joints)
        if len(joints) != model.n:
            raise ArgumentError('joints', f'expected {model.n} names (the model has {model.n} joints '
                                          f'{list(model.joint_names)}), got {list(joints)}')
        set_('joints', joints)
        set_('integral', bool(self.integral))
        set_('integral_limit', float(validation.limit_vector('integral_limit', self.integral_limit, 1)[0]))
        set_('integral_rest_velocity', float(validation.limit_vector('integral_rest_velocity',
                                                                     self.integral_rest_velocity, 1)[0]))
        limit = model.effort_limit if self.effort_limit is None else self.effort_limit
        set_('effort_limit', validation.read_only(validation.limit_vector('effort_limits', limit, model.n)))
        set_('move_time', validation.scalar('move_time', self.move_time, positive=True))
        self._set_tolerances(set_)
        set_('law_params', law.make_params(self.law_params, model))
        set_('friction_compensation', FrictionCompensation.of(self.friction_compensation, model.n))
        set_('velocity_cutoff_hz', validation.scalar('velocity_cutoff_hz', self.velocity_cutoff_hz, nonnegative=True))
        set_('_law', law(self))

    def _set_tolerances(self, set_):
        n = self.model.n
        for name in ('trajectory_tolerance', 'goal_tolerance'):
            value = validation.per_entry(name, getattr(self, name), n)
            if min(value.tolist()) < 0.0:
                raise ArgumentError(name, f'expected tolerances >= 0 (0 = not checked), got {value.tolist()}')
            set_(name, validation.read_only(value))
        set_('goal_time', validation.scalar('goal_time', self.goal_time, nonnegative=True))
        set_('stopped_velocity_tolerance', validation.scalar('stopped_velocity_tolerance',
                                                             self.stopped_velocity_tolerance, nonnegative=True))
        set_('_tolerances', Tolerances(self.trajectory_tolerance, self.goal_tolerance, self.goal_time,
                                       self.stopped_velocity_tolerance))

    # -- derived ---------------------------------------------------------------------------------
    @property
    def tolerances(self):
        """The trajectory's goal and path tolerances (robot_control.core.tolerances.Tolerances)."""
        return self._tolerances

    @property
    def n(self):
        """Number of joints."""
        return self.model.n

    @property
    def control_law(self):
        """The Law (robot_control.laws.base) of this configuration."""
        return self._law

    @property
    def integral_dim(self):
        """Entries of the error integral (0: the law integrates nothing)."""
        return self._law.integral_dim

    def law_key(self):
        """What the law computes with: a change re-initialises the integral (bumpless transfer)."""
        return (self.law, self.integral, id(self.model),
                self.integral_limit, self.integral_rest_velocity, self.law_params,
                self.friction_compensation)

    def replace(self, **changes):
        """A copy with `changes` (checked)."""
        return dataclasses.replace(self, **changes)
