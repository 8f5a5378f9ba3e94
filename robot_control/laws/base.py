"""A control law as the controller core runs it: the Law interface and what one tick gives it.

Each law module holds its equation (a function of checked arrays), the checked public function
around it, and a Law subclass that the registry (robot_control.laws.LAWS) names. A Law says what it
needs, so that nothing else has to know the law by its name:

  tracks            'joint': it follows the joint reference (switching between two such laws keeps
                    the reference); 'task': a task-space or force reference; None: no reference.
                    A switch that is not joint -> joint restarts the references from the current state.
  needs_task_space  the model must have a task space (fk, J): the core then measures x, xd, J and
                    Jdot qd once per tick.
  torque_gains      its designed gains are torques (N m/rad ...), not accelerations: the parameter
                    layer scales the designed kp, kv, ki by the joint inertia M_ii(q0).
  motion_servo      it has the motion servo (kp, kv, ki per joint, an integral per joint): it has the
                    MotionServo among its parts (set from parts, not declared); False: no motion-servo
                    gains and, unless integral_dim says otherwise, no integral.
  param_rows        the law's own parameters (robot_control.param_table.Row): the controller's parameter
                    table gathers them from the registry; Params: a frozen dataclass with one field per
                    row, checked on creation (ArgumentError naming the field), which the configuration
                    holds as law_params. Parameters every law shares stay in ControllerConfig.
  parts             the parameter groups the law shares with others: classes such as
                    robot_control.laws.force_task.ForceTask (the force setup),
                    robot_control.laws.servo.MotionServo (the motion servo's gains) or
                    robot_control.laws.operational_space.Posture, each a frozen dataclass with its
                    param_rows, one field per row, `field` (the name of the law's Params field that
                    holds it) and fitted(model). The table lists a group's rows once.
  uses_force        it reads the force reference and the measured force on the force axes: it has the
                    ForceTask among its parts (set from parts, not declared).

An instance is made for one ControllerConfig: its constructor checks what the law needs of the
configuration (ArgumentError naming the field) and keeps what the tick reads. Per tick the core hands
it immutable inputs, made for that tick: the measured State and the Reference; the law answers with
its Errors and its torque. Every law is affine in its error integral, tau = tau(0) + B int E: the law
gives B = d tau / d int E in closed form (integral_map), so that the core's anti-windup and bumpless
transfer never evaluate the law a second time.
"""
import dataclasses
from typing import NamedTuple

import numpy as np

from robot_control.laws.force_task import NO_FORCE_TASK, ForceTask
from robot_control.laws.servo import MotionServo
from robot_control.validation import ArgumentError


class State(NamedTuple):
    """The measured state of one tick. t (s); q, qd (n,). Task state (needs_task_space, else None): x, xd
    (m,), J (m, n), Jdot_qd (m,). On the force axes (uses_force, else None): f, fdot (k,) N and N/s, the
    force the robot exerts on the environment."""

    t: float
    q: np.ndarray
    qd: np.ndarray
    x: np.ndarray = None
    xd: np.ndarray = None
    J: np.ndarray = None
    Jdot_qd: np.ndarray = None
    f: np.ndarray = None
    fdot: np.ndarray = None


class Reference(NamedTuple):
    """The references of one tick. q_d, qd_d, qdd_d (n,) the joint reference; f_d, fd_d, fdd_d (k,) the
    force reference (uses_force, else None); target (x_d, xd_d, xdd_d) (m,) each, a task-space target when
    one was given (~/target_pose), else None; wrench (m,) a feed-forward wrench (N, N m) or None."""

    q_d: np.ndarray
    qd_d: np.ndarray
    qdd_d: np.ndarray
    f_d: np.ndarray = None
    fd_d: np.ndarray = None
    fdd_d: np.ndarray = None
    target: tuple = None
    wrench: np.ndarray = None


class Errors(NamedTuple):
    """What a law derives from a State and a Reference (Law.errors), in its own space (Law.reference_names):
    ref = (pos, vel, acc), the errors E and Ed (the core integrates E; the node publishes them on
    ~/reference and ~/error); force: the measured force on every task axis (m,), 0 on the motion axes, for
    the laws that use force (else None)."""

    ref: tuple
    E: np.ndarray
    Ed: np.ndarray
    force: np.ndarray = None


class Law:
    """One control law of the registry; see the module docstring for the class attributes."""

    name = ''
    tracks = 'joint'
    needs_task_space = False
    uses_force = False
    torque_gains = False
    motion_servo = False
    param_rows = ()
    Params = None
    parts = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.uses_force = ForceTask in cls.parts
        cls.motion_servo = MotionServo in cls.parts

    @classmethod
    def all_param_rows(cls):
        """The rows of its parts, then its own (param_rows)."""
        return tuple(row for part in cls.parts for row in part.param_rows) + tuple(cls.param_rows)

    @classmethod
    def make_params(cls, values, model):
        """The law's Params from `values` (a mapping of its parameter names, all_param_rows, to values,
        missing ones at their defaults; None: all defaults) or a Params already made, its parts fitted to
        `model`; None for a law without parameters. ArgumentError naming law_params for a name the law
        does not have, or the parameter a check refused."""
        if cls.Params is None or not isinstance(values, cls.Params):
            values = cls._params_of(values)
        if values is None:
            return None
        if not cls.parts:
            return values
        return dataclasses.replace(values, **{p.field: getattr(values, p.field).fitted(model) for p in cls.parts})

    @classmethod
    def _params_of(cls, values):
        if values is not None and not hasattr(values, 'keys'):
            raise ArgumentError('law_params', f'expected a mapping of the parameters of law {cls.name}, got '
                                              f'{type(values).__name__}')
        values = dict(values or {})
        known = [row.name for row in cls.all_param_rows()]
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ArgumentError('law_params', f'{unknown} are not parameters of law {cls.name} (it has {known})')
        if cls.Params is None:
            return None
        for part in cls.parts:
            values[part.field] = part(**{row.name: values.pop(row.name) for row in part.param_rows
                                         if row.name in values})
        return cls.Params(**values)

    @property
    def force_task(self):
        """The force setup (robot_control.laws.force_task.ForceTask) of a law that uses force, fitted to the
        model's task axes; NO_FORCE_TASK (no force axes) for the others."""
        return self.config.law_params.force_task if self.uses_force else NO_FORCE_TASK

    @property
    def motion_gains(self):
        """The motion servo's ServoGains as the configuration gives them (robot_control.laws.servo.MotionServo),
        None for a law without the motion servo or without gains."""
        return self.config.law_params.motion_servo.gains if self.motion_servo else None

    def __init__(self, config):
        self.config = config
        self.model = config.model
        if self.needs_task_space and not self.model.task_dim:
            raise ArgumentError('law', f'{self.name} needs a task space; the model has none (set tip for a '
                                       'URDF model)')
        dim = len(self.reference_names)
        self.E, self.Ed = np.zeros(dim), np.zeros(dim)
        self._errors = None       # the joint laws' Errors: the same arrays every tick while the Reference's are

    @classmethod
    def servo_sizes(cls, model, force_axes):
        """The numbers of motion-servo gains (kp, kv, ki each) the law accepts, the designed one first
        (empty: no motion servo): one per joint when the law has the motion servo."""
        return (model.n,) if cls.motion_servo else ()

    @property
    def integral_dim(self):
        """Entries of the error integral (0: the law has no integral action): one per joint with the
        motion servo."""
        return self.model.n if self.motion_servo else 0

    @property
    def reference_names(self):
        """Names of the entries of ref, E and Ed: the joints by default."""
        return self.config.joints

    def integral_gains(self):
        """(ki, kv) per integral entry (zeros when integral action is off); the core's anti-windup
        tracks with the time constant sqrt(kv / ki)."""
        dim = self.integral_dim
        if not self.config.integral:
            return np.zeros(dim), np.zeros(dim)
        gains = self.motion_gains
        return np.array(gains.ki), np.array(gains.kv)

    def errors(self, state, ref):
        """Errors of this tick (the joint laws: E = q_d - q, Ed = qd_d - qd; arrays of the law, overwritten
        next tick)."""
        np.subtract(ref.q_d, state.q, out=self.E)
        np.subtract(ref.qd_d, state.qd, out=self.Ed)
        err = self._errors
        if err is None or err.ref[0] is not ref.q_d:
            self._errors = err = Errors((ref.q_d, ref.qd_d, ref.qdd_d), self.E, self.Ed)
        return err

    def torque(self, state, ref, err, int_E):
        """tau (n,) for this tick: State, Reference, its Errors, the error integral int_E (integral_dim,) or None."""
        raise NotImplementedError

    def integral_map(self, state, ref, err):
        """B = d tau / d int E, (n, integral_dim), at this tick: tau = tau(int_E = 0) + B int_E."""
        raise NotImplementedError

    def continue_from(self, old):
        """Take over what the Law `old`, the one before a new configuration, learned (none by default)."""

    def freeze(self, E, saturated, tau):
        """Anti-windup by conditional integration: the integral entries to hold this tick, given this tick's
        error E, the joints saturated on the last tick (bool (n,)) and its torque tau (n,). Joint-space laws
        hold entry i when joint i saturated and E_i pushes further into the limit."""
        return saturated & (E * tau > 0.0)

    def check_servo_gains(self, field, gains, size):
        """ArgumentError naming `field` unless gains is a ServoGains of `size` entries."""
        got = getattr(gains, 'n', None)
        if got != size:
            raise ArgumentError(field, f'expected {size} gains for law {self.name}, got '
                                       f'{got if got is not None else gains!r}')
