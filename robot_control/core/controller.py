"""ControllerCore: the controller's per-tick work, without ROS (DESIGN §2, §4; issue 4).

The node calls `update(t, q, qd, f_meas)` once per joint_states message and publishes the torque
it returns. The core owns everything that persists between ticks:

- the configuration snapshot, `ControllerConfig` (immutable; `configure()` swaps it in one
  assignment, effective on the next tick; the loop never reads anything else),
- the joint reference (robot_control.trajectory: hold / from_points), replaced without a jump,
- the force reference on the force-controlled task axes (the same samplers on forces, N),
- the error integral (robot_control.laws.Integral) with clamp and conditional-integration
  anti-windup, and the effort saturation (robot_control.laws.saturate),
- preallocated buffers for the reference, the errors and the torque.

Laws (`law`):
  computed_torque    tau = M(q) v + C(q, qd) qd + g(q), v = qdd_d + Kv Ed + Kp E (+ Ki int E)
  independent_joint  tau = Kp E + Kv Ed (+ Ki int E) per joint (torque gains, no model)
  force              tau = m v + f, v = (fdd_d + kv Ef_dot + kp Ef (+ ki int Ef)) / k_e (1 DOF)
  hybrid             operational-space hybrid position/force control (laws.hybrid): motion
                     reference x_d = fk(q_d), xd_d = J(q_d) qd_d, xdd_d = J(q_d) qdd_d + Jdot qd_d
                     on the motion axes, force reference on the force axes, posture q_d.
Force feedback on the force axes: 'sensor' uses the measured force f_meas (N, along each task
axis, exerted by the robot on the environment); 'model' the lecture's spring f = k_e (x - x_e).
In both cases fdot = k_e xd (the lecture's f_dot = k_e x_dot; no differentiation of a noisy
sensor); out of contact with sensor feedback this damps the approach velocity.
Sampled force (force_lead_time T > 0): a command is held for a control period while the contact
force keeps changing, and a stiff contact (PyBullet's, a real one) acts with the force at the end
of the hold. The laws then use f + fdot T, the force one period ahead: with T = the control
period the force step of force_1dof follows the continuous design within 0.2 % of f_d (3.5 %
with T = 0; measured, k_e = 1000 N/m, 1 ms). ~/error shows the errors of the predicted force.

Time: `t` is in seconds on any time base that increases (the node uses the joint_states stamps).
If t goes backwards (a simulator reset) the core restarts as after a watchdog trip.

Start and restart (first tick, after `stop()`, after time went backwards): the integral is
reset, the joint reference holds the measured position q (zero velocity and acceleration) and
the force reference ramps from the measured force to its target over `force_ramp_time`.

Bumpless switching (documented behaviour, tested):
- Changing gains, the integral flag, the model or the force parameters keeps the references;
  changing the law between computed_torque and independent_joint keeps them too. Switching
  to or from force/hybrid restarts the references from the current state (the joint reference
  of a force-controlled axis is meaningless), as at start.
- On the first tick after any such change the integral is re-initialised: when the new law has
  integral action it is set (least squares over the entries with ki > 0, then clamped to
  integral_limit) so that the new law's torque equals the last torque sent; without integral
  action it is zero. The torque therefore never jumps by more than what the new law implies:
  it equals the new law evaluated at (state, reference, re-initialised integral).
- Effort limits, move_time and force_ramp_time changes take effect without touching the state.

Anti-windup: entry i of the integral is frozen on a tick if on the previous tick joint i was
saturated and E_i had the sign of its torque (integrating would push further into the limit);
for the task-space integral of the hybrid law every entry is frozen while any joint saturates.
In addition, on every saturated tick the integral is back-calculated toward the value whose law
torque equals the saturated torque, with tracking time constant Tt = sqrt(kv / ki) per entry
(_back_calculate): a saturated step then recovers without the integral's extra overshoot.

Lost contact (force and hybrid laws): a robot_control.core.contact.ContactGuard watches every force axis.
When the axis travels more than contact_max_travel past the surface that the measured force explains,
or moves faster than contact_max_speed, the axis is held in position (latched until a restart or a
new force reference) and `contact_guard.reason` says why.

Fallback: if the law fails (non-finite result, singular task Jacobian) the core sends the
gravity-hold torque g(q) (saturated) instead and counts it (`fallbacks`, `last_fallback`).

Not thread-safe: call every method from one thread (the node's executor does).
"""
import dataclasses
import math

import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.laws import Integral, computed_torque, force_1dof, hybrid, independent_joint
from robot_control.laws.computed_torque import torque_of_errors
from robot_control.laws.saturation import clip_into
from robot_control.laws.servo import limit_vector
from robot_control.models.base import RobotModel
from robot_control.core.contact import ContactGuard
from robot_control.trajectory import from_points, hold
from robot_control.validation import ArgumentError, finite, is_vector

LAWS = ('computed_torque', 'independent_joint', 'force', 'hybrid')
JOINT_LAWS = ('computed_torque', 'independent_joint')
TASK_LAWS = ('force', 'hybrid')
FORCE_FEEDBACK = ('sensor', 'model')


def _frozen(a):
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True, eq=False)
class ControllerConfig:
    """Immutable snapshot of everything the per-tick computation reads (validated on creation).

    model: RobotModel (the controller's own, closed form or URDF).
    law: 'computed_torque' | 'independent_joint' | 'force' | 'hybrid'.
    gains: ServoGains of the motion servo: (n,) for the joint laws (1/s^2, 1/s, 1/s^3 for
      computed torque; N m/rad ... torque gains for independent_joint), (m,) or one per motion
      axis for hybrid; unused by 'force'.
    force_gains: ServoGains (k,) one per force axis (force and hybrid laws), None otherwise.
    integral: integral action on (ki used) or off (ki ignored, no integral state).
    integral_limit: clamp of |int E| per entry (rad s, m s or N s), > 0, inf = none.
    effort_limit: (n,) N m or N, > 0 (inf allowed); None = model.effort_limit.
    joints: joint names in model order; None = model.joint_names.
    force_axes: names of the force-controlled task axes (subset of model.task_axes).
    k_e, x_e: environment stiffness (N/m, > 0) and location (m) per force axis.
    force_feedback: 'sensor' | 'model'.
    force_lead_time: T, s (>= 0): the force laws use the force predicted T ahead, f + fdot T (see the
      module docstring); 0 = the lecture's law on the sampled force.
    posture_gains: (kp0 1/s^2, kv0 1/s) of the null-space posture (hybrid, redundant arms).
    move_time: duration of a set_goal() move, s (> 0).
    force_ramp_time: duration of a force reference change, s (>= 0; 0 = step).
    contact_max_travel, contact_max_speed: lost-contact guard of the force axes (m past the surface the
      measured force explains, m/s along the axis; > 0, inf = off, the library default; the node's
      parameters default to 0.05 m and 0.5 m/s), robot_control.core.contact.ContactGuard.
    """

    model: RobotModel
    law: str = 'computed_torque'
    gains: ServoGains = None
    force_gains: ServoGains = None
    integral: bool = False
    integral_limit: float = math.inf
    effort_limit: np.ndarray = None
    joints: tuple = None
    force_axes: tuple = ()
    k_e: np.ndarray = ()
    x_e: np.ndarray = ()
    force_feedback: str = 'sensor'
    force_lead_time: float = 0.0
    posture_gains: tuple = (25.0, 10.0)
    move_time: float = 2.0
    force_ramp_time: float = 0.5
    contact_max_travel: float = math.inf
    contact_max_speed: float = math.inf

    def __post_init__(self):
        model = self.model
        if not isinstance(model, RobotModel):
            raise ArgumentError('model', f'expected a RobotModel, got {type(model).__name__}')
        n, m = model.n, model.task_dim
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if self.law not in LAWS:
            raise ArgumentError('law', f'unknown {self.law!r}; expected one of {list(LAWS)}')
        if self.force_feedback not in FORCE_FEEDBACK:
            raise ArgumentError('force_feedback', f'unknown {self.force_feedback!r}; expected one of {list(FORCE_FEEDBACK)}')
        joints = model.joint_names if self.joints is None else self.joints
        joints = validation.names('joints', joints)
        if len(joints) != n:
            raise ArgumentError('joints', f'expected {n} names (the model has {n} joints {list(model.joint_names)}), '
                             f'got {list(joints)}')
        set_('joints', joints)
        set_('integral', bool(self.integral))
        set_('force_lead_time', validation.scalar('force_lead_time', self.force_lead_time, nonnegative=True))
        set_('integral_limit', float(limit_vector('integral_limit', self.integral_limit, 1)[0]))
        limit = model.effort_limit if self.effort_limit is None else self.effort_limit
        set_('effort_limit', _frozen(limit_vector('effort_limits', limit, n)))
        axes = tuple(self.force_axes)
        unknown = [a for a in axes if a not in model.task_axes]
        if unknown:
            raise ArgumentError('force_axes', f'{unknown} not among the model\'s task axes {list(model.task_axes)}')
        if len(set(axes)) != len(axes):
            raise ArgumentError('force_axes', f'duplicate axes in {list(axes)}')
        set_('force_axes', tuple(a for a in model.task_axes if a in axes))  # task-axis order
        mask = np.array([a in axes for a in model.task_axes], dtype=bool)
        mask.flags.writeable = False
        set_('_force_mask', mask)
        k = len(axes)
        order = [axes.index(a) for a in self.force_axes]  # k_e, x_e were given in `axes` order
        k_e = validation.vector('k_e', self.k_e, k)[order] if k else np.zeros(0)
        if np.any(k_e <= 0.0):
            raise ArgumentError('k_e', f'expected positive stiffness (N/m), got {k_e.tolist()}')
        set_('k_e', _frozen(k_e))
        set_('x_e', _frozen(validation.vector('x_e', self.x_e, k)[order] if k else np.zeros(0)))
        kp0, kv0 = (validation.scalar(name, v, nonnegative=True)
                    for name, v in zip(('posture_kp', 'posture_kv'), self.posture_gains))
        set_('posture_gains', (kp0, kv0))
        set_('move_time', validation.scalar('move_time', self.move_time, positive=True))
        set_('force_ramp_time', validation.scalar('force_ramp_time', self.force_ramp_time, nonnegative=True))
        for name in ('contact_max_travel', 'contact_max_speed'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0.0:
                raise ArgumentError(name, f'expected a positive bound (inf = off), got {value!r}')
            set_(name, float(value))
        self._check_law(n, m, k)

    def _check_law(self, n, m, k):
        law = self.law
        if law in JOINT_LAWS:
            if not isinstance(self.gains, ServoGains) or self.gains.n != n:
                got = self.gains.n if isinstance(self.gains, ServoGains) else self.gains
                raise ArgumentError('kp', f'expected {n} gains (one per joint) for law {law}, got {got}')
            return
        if m == 0:
            raise ArgumentError('law', f'{law} needs a task space; the model has none (set tip for a URDF model)')
        if law == 'force':
            if n != 1 or m != 1:
                raise ArgumentError('law', f'force is the 1-DOF force servo; the model has {n} joints and '
                                 f'{m} task axes (use hybrid)')
            if k != 1:
                raise ArgumentError('force_axes', f'law force needs its task axis {list(self.model.task_axes)}, '
                                 f'got {list(self.force_axes)}')
        if law == 'hybrid':
            if m > n:
                raise ArgumentError('law', f'hybrid needs task dimension <= joints; the model has {m} task axes '
                                 f'{list(self.model.task_axes)} and {n} joints')
            motion = m - k
            if motion and (not isinstance(self.gains, ServoGains) or self.gains.n not in (m, motion)):
                got = self.gains.n if isinstance(self.gains, ServoGains) else self.gains
                raise ArgumentError('kp', f'expected {m} gains (one per task axis) or {motion} (one per motion '
                                 f'axis) for law hybrid, got {got}')
        if k and (not isinstance(self.force_gains, ServoGains) or self.force_gains.n != k):
            got = self.force_gains.n if isinstance(self.force_gains, ServoGains) else self.force_gains
            raise ArgumentError('force_kp', f'expected {k} gains (one per force axis), got {got}')

    # -- derived -------------------------------------------------------------------------------
    @property
    def n(self):
        """Number of joints."""
        return self.model.n

    @property
    def force_mask(self):
        """Bool (m,) over the model's task axes: True on the force axes (read-only)."""
        return self._force_mask

    @property
    def integral_dim(self):
        """Entries of the error integral: n (joint laws), 1 (force), m (hybrid)."""
        return {'force': 1, 'hybrid': self.model.task_dim}.get(self.law, self.n)

    def integral_ki(self):
        """Ki per integral entry (zeros when integral is off)."""
        return self._integral_gain('ki')

    def integral_kv(self):
        """Kv of the servo loop of each integral entry (zeros when integral is off); the tracking
        time constant of the back-calculation anti-windup is sqrt(kv / ki)."""
        return self._integral_gain('kv')

    def _integral_gain(self, attr):
        dim = self.integral_dim
        if not self.integral:
            return np.zeros(dim)
        if self.law in JOINT_LAWS:
            return np.array(getattr(self.gains, attr))
        if self.law == 'force':
            return np.array(getattr(self.force_gains, attr))
        mask = self.force_mask
        out = np.zeros(dim)
        if self.force_gains is not None and self.force_axes:
            out[mask] = getattr(self.force_gains, attr)
        motion = ~mask
        if motion.any() and self.gains is not None:
            g = np.asarray(getattr(self.gains, attr))
            out[motion] = g[motion] if g.shape[0] == dim else g
        return out

    def law_key(self):
        """What the law computes with; a change triggers bumpless re-initialisation."""
        def arrays(g):
            return None if g is None else (tuple(g.kp), tuple(g.kv), tuple(g.ki))
        return (self.law, self.integral, arrays(self.gains), arrays(self.force_gains), id(self.model),
                self.force_axes, tuple(self.k_e), tuple(self.x_e), self.force_feedback, self.force_lead_time,
                self.posture_gains, self.integral_limit)

    def replace(self, **changes):
        """A copy with `changes` (validated)."""
        return dataclasses.replace(self, **changes)


class ControllerCore:
    """Per-tick controller: update(t, q, qd, f_meas) -> tau, saturated and finite.

    config: ControllerConfig. See the module docstring for start/restart, bumpless switching,
    anti-windup and fallback. Returned arrays are internal buffers, overwritten next tick.
    """

    def __init__(self, config):
        if not isinstance(config, ControllerConfig):
            raise ArgumentError('config', f'expected a ControllerConfig, got {type(config).__name__}')
        self._cfg = config
        n = config.n
        self._q_d, self._qd_d, self._qdd_d = np.zeros(n), np.zeros(n), np.zeros(n)
        self._held = None       # the trajectory whose end state (held after t_end) the three arrays hold
        self._tau = np.zeros(n)
        self._has_prev = False  # self._tau holds a tick's torque: the last one sent, until _saturate
        self._tau_values = [0.0] * n
        self._sat = np.zeros(n, dtype=bool)
        self._sat_any = False
        self._n = n
        self._plan_for = None               # the config the per-config constants below were made for
        self._traj = None
        self._pending = None
        self._goal = None
        self._t = None
        self.active = False
        self._reinit = False
        self._restart = False
        # statistics
        self.ticks = 0
        self.saturated_ticks = 0
        self.saturation_counts = np.zeros(n, dtype=np.int64)
        self.fallbacks = 0
        self.last_fallback = ''
        self.restarts = 0
        self._guard = None                  # ContactGuard of the force axes (made by _plan)
        self._windup_step = None            # anti-windup back-calculation pending for the next tick
        self._setup_force(config, keep_target=False)
        self._setup_buffers(config)
        self._integral = self._make_integral(config)

    # -- configuration -----------------------------------------------------------------------
    @property
    def config(self):
        """The active ControllerConfig."""
        return self._cfg

    def _setup_force(self, cfg, keep_target):
        """Force reference state for cfg.force_axes (the target is kept if the axes are unchanged)."""
        k = len(cfg.force_axes)
        old = getattr(self, '_f_target', None)
        self._f_target = old if keep_target and old is not None and old.shape[0] == k else np.zeros(k)
        self._f_d, self._fd_d, self._fdd_d = np.zeros(k), np.zeros(k), np.zeros(k)
        self._force_traj = hold(self._f_target) if k else None

    def _setup_buffers(self, cfg):
        """Reference/error buffers in the law's space (joints, force axis or task axes)."""
        dim = cfg.integral_dim
        if cfg.law in JOINT_LAWS:   # the reference is the joint reference itself
            self._ref = (self._q_d, self._qd_d, self._qdd_d)
        else:
            self._ref = (np.zeros(dim), np.zeros(dim), np.zeros(dim))
        self._E, self._Ed = np.zeros(dim), np.zeros(dim)
        self._ref_names = cfg.joints if cfg.law in JOINT_LAWS else (
            cfg.force_axes if cfg.law == 'force' else cfg.model.task_axes)

    @staticmethod
    def _make_integral(cfg):
        return Integral(cfg.integral_dim, cfg.integral_limit)

    def configure(self, config):
        """Swap in a new ControllerConfig, effective on the next tick (joints cannot change)."""
        if not isinstance(config, ControllerConfig):
            raise ArgumentError('config', f'expected a ControllerConfig, got {type(config).__name__}')
        old = self._cfg
        if config.joints != old.joints:
            raise ArgumentError('joints', f'cannot change at run time ({list(old.joints)} -> {list(config.joints)})')
        law_changed = config.law != old.law
        restart = law_changed and (old.law in TASK_LAWS or config.law in TASK_LAWS)
        restart = restart or config.force_axes != old.force_axes
        relevant = config.law_key() != old.law_key()
        if config.integral_dim != old.integral_dim or config.integral_limit != old.integral_limit:
            integral = self._make_integral(config)
            if integral.n == self._integral.n:
                integral.preset(self._integral.value)
            self._integral = integral
        if config.force_axes != old.force_axes:
            self._setup_force(config, keep_target=False)
        if config.law != old.law:
            self._setup_buffers(config)
        self._cfg = config
        if self.active:
            self._reinit = self._reinit or relevant
            self._restart = self._restart or restart

    # -- references ----------------------------------------------------------------------------
    @property
    def t(self):
        """Time of the last tick, s (None before the first)."""
        return self._t

    def _require_active(self, what):
        if not self.active:
            raise ArgumentError(what, 'no state received yet (the current state is the implicit start)')

    def set_trajectory(self, times, positions, velocities=None, accelerations=None, t_start=None):
        """Replace the joint reference by a path through points, like joint_trajectory_controller.

        times: time_from_start (k,) s, > 0, increasing; positions (k, n); velocities/accelerations
        (k, n) or None. t_start: start time on the update() time base; None = the last tick.
        The new path starts from the current reference sampled at its start, so the reference
        (q_d, qd_d, qdd_d) is continuous. A start in the future keeps the current reference until
        then; a start in the past drops the points already due (all due: ValueError).
        Returns the start time actually used.
        """
        self._require_active('trajectory')
        n = self._cfg.n
        times = validation.vector('times', times)
        positions = validation.matrix('positions', positions, (times.shape[0], n))
        t_now = self._t
        t_start = t_now if t_start is None else validation.scalar('t_start', t_start)
        if t_start < t_now:
            keep = t_start + times > t_now
            if not keep.any():
                raise ArgumentError('times', f'the trajectory ended {t_now - (t_start + times[-1]):.6g} s ago')
            times = t_start + times[keep] - t_now
            positions = positions[keep]
            velocities = None if velocities is None else np.asarray(velocities, dtype=float)[keep]
            accelerations = None if accelerations is None else np.asarray(accelerations, dtype=float)[keep]
            t_start = t_now
        start = self._traj.sample(t_start)
        traj = from_points(t_start, start, times, positions, velocities, accelerations)
        if t_start > t_now:
            self._pending = traj
        else:
            self._traj, self._pending = traj, None
        return t_start

    def set_goal(self, q_goal, duration=None):
        """Quintic move of the joint reference to q_goal (n,) over `duration` s (default move_time).

        Starts from the current reference (continuous position, velocity, acceleration). Before
        the first state it becomes the first move from the measured start position.
        """
        q_goal = validation.vector('q_goal', q_goal, self._cfg.n)
        duration = self._cfg.move_time if duration is None else validation.scalar('duration', duration, positive=True)
        if not self.active:
            self._goal = (q_goal.copy(), duration)
            return
        start = self._traj.sample(self._t)
        self._traj = from_points(self._t, start, [duration], [q_goal])
        self._pending = None

    def set_force_reference(self, f_target):
        """Ramp the force reference to f_target (k,) N per force axis over force_ramp_time."""
        k = len(self._cfg.force_axes)
        f_target = validation.vector('f_d', f_target, k)
        self._f_target = f_target.copy()
        if self.active and k:
            self._force_traj = self._ramp(self._t, self._force_traj.sample(self._t), f_target)
        if self._guard is not None:
            self._guard.reset()             # a new force reference acknowledges a lost-contact stop

    def _ramp(self, t, start, target):
        ramp = self._cfg.force_ramp_time
        if ramp <= 0.0:
            return hold(target, t)
        return from_points(t, start, [ramp], [target])

    @property
    def force_target(self):
        """The force reference's target per force axis, N (copy)."""
        return self._f_target.copy()

    def reference_at(self, t):
        """(q_d, qd_d, qdd_d) the joint reference would give at time t (new arrays)."""
        self._require_active('reference')
        traj = self._pending if self._pending is not None and t >= self._pending.t0 else self._traj
        return traj.sample(t)

    # -- lifecycle -----------------------------------------------------------------------------
    def stop(self):
        """Stop (watchdog): the next update() restarts from the then-current state."""
        self.active = False
        self._pending = None
        self._reinit = self._restart = False

    def _start_references(self, t, q, f):
        self._traj = hold(q, t)
        self._pending = None
        if self._goal is not None:
            goal, duration = self._goal
            self._goal = None
            self._traj = from_points(t, (q, None, None), [duration], [goal])
        if self._cfg.force_axes:
            start = self._f_target if f is None else f
            self._force_traj = self._ramp(t, (start, None, None), self._f_target)
        if self._guard is not None:
            self._guard.reset()

    # -- the tick --------------------------------------------------------------------------------
    def _plan(self, cfg):
        """Per-config constants of the tick (made once per ControllerConfig, not per tick)."""
        mask = cfg.force_mask
        m = mask.shape[0]
        self._fidx = np.flatnonzero(mask)                     # force axes among the task axes
        self._force_axes = tuple(enumerate(self._fidx.tolist()))   # (j, i): force axis j is task axis i
        self._has_force = self._fidx.size > 0
        self._samples_force = self._has_force and cfg.law in TASK_LAWS   # the joint laws use no force reference
        self._f_m, self._fdot_m = np.zeros(m), np.zeros(m)    # f, fdot on the force axes, 0 elsewhere
        K_e = np.ones(m)
        K_e[self._fidx] = cfg.k_e
        K_e.flags.writeable = False
        self._K_e = K_e
        self._gains_T = cfg.gains if (~mask).any() else None
        self._gains_N = cfg.force_gains if self._has_force else None
        self._neg_limit = -cfg.effort_limit
        self._limit_min = float(np.min(cfg.effort_limit))
        guarded = (self._has_force and cfg.law in TASK_LAWS
                   and (math.isfinite(cfg.contact_max_travel) or math.isfinite(cfg.contact_max_speed)))
        self._guard = ContactGuard(cfg.force_axes, cfg.k_e, cfg.x_e, cfg.contact_max_travel,
                                   cfg.contact_max_speed) if guarded else None
        self._plan_for = cfg

    def update(self, t, q, qd, f_meas=None):
        """Torque (n,) for the state (q, qd) at time t (s); f_meas (m,) measured task forces, N.

        f_meas is required with force_feedback 'sensor' when the law uses forces. The result is
        finite and within +-effort_limit; it is an internal buffer overwritten next tick.
        """
        n = self._n
        if not (type(t) is float and math.isfinite(t)):
            t = validation.scalar('t', t)
        if not (is_vector(q, n) and is_vector(qd, n) and finite(q) and finite(qd)):
            q = validation.vector('q', q, n)
            qd = validation.vector('qd', qd, n)
        return self.update_checked(t, q, qd, f_meas)

    def update_checked(self, t, q, qd, f_meas=None):
        """update() on inputs known to be valid, without checking them again: t a finite float, q and
        qd finite float64 (n,) arrays, as conversions.JointStateReader.read returns them."""
        cfg = self._cfg
        model = cfg.model
        if cfg is not self._plan_for:
            self._plan(cfg)
        law = cfg.law
        if law in TASK_LAWS:
            x, xd, f_axes, fdot_axes = self._task_state(cfg, q, qd, f_meas)
        else:
            x = xd = f_axes = fdot_axes = None
        dt = 0.0
        if not self.active or t < self._t:
            if self._t is not None:
                self.restarts += 1
            self._start_references(t, q, f_axes)
            self._integral.reset()
            self._reinit = self._restart = False
            self.active = True
        else:
            dt = t - self._t
            if self._restart:
                self._start_references(t, q, f_axes)
                self._restart = False
        self._t = t
        if self._pending is not None and t >= self._pending.t0:
            self._traj, self._pending = self._pending, None
        traj = self._traj
        if not (t > traj.t_end and self._held is traj):   # else the buffers hold its end state already
            traj.sample_into(t, self._q_d, self._qd_d, self._qdd_d)
            self._held = traj if t > traj.t_end else None
        if self._samples_force:
            self._force_traj.sample_into(t, self._f_d, self._fd_d, self._fdd_d)
            if self._guard is not None:
                self._guard_contact(x, xd, f_axes)

        # the law's inputs of this tick, read by _evaluate()
        self._tick = (q, qd, x, xd, f_axes, fdot_axes)
        if law in JOINT_LAWS:
            np.subtract(self._q_d, q, out=self._E)
            np.subtract(self._qd_d, qd, out=self._Ed)
        elif law == 'force':
            self._force_errors(f_axes, fdot_axes)
        else:
            self._hybrid_reference(cfg, x, xd, f_axes, fdot_axes)

        int_E = None
        windup_step, self._windup_step = self._windup_step, None
        if cfg.integral:
            if self._reinit:
                self._reinitialise(cfg, self._evaluate)
            elif dt > 0.0:
                if windup_step is not None:         # back-calculation of the last (saturated) tick
                    self._integral.preset(self._integral.value + windup_step)
                self._integral.update(self._E, dt, hold=self._hold_mask(cfg))
            int_E = self._integral.value
        elif self._reinit:
            self._integral.reset()
        self._reinit = False

        try:
            tau = self._evaluate(int_E)
        except (ValueError, np.linalg.LinAlgError) as exc:
            tau = self._fallback(model, q, exc)
            int_E = None
        sat_any = self._saturate(tau, cfg)
        if sat_any and int_E is not None and dt > 0.0:
            self._back_calculate(cfg, np.array(tau, dtype=float), dt)
        self._has_prev = True
        self.ticks += 1
        self._sat_any = sat_any
        if sat_any:
            self.saturated_ticks += 1
            self.saturation_counts += self._sat
        return self._tau

    def _saturate(self, tau, cfg):
        """self._tau = clip(tau, -effort_limit, effort_limit), self._sat = the clipped entries; True if any.

        laws.saturate without its argument checks: tau is finite (law or fallback), the limits were
        checked with the config. Most ticks clip nothing: one Python pass over tau finds that."""
        values = tau.tolist()
        if max(values) <= self._limit_min and min(values) >= -self._limit_min:
            self._tau[:] = tau
            self._tau_values = values
            if self._sat_any:
                self._sat[:] = False
            return False
        clip_into(tau, cfg.effort_limit, self._neg_limit, self._tau, self._sat)
        self._tau_values = self._tau.tolist()
        return bool(np.count_nonzero(self._sat))

    def _fallback(self, model, q, exc):
        self.fallbacks += 1
        self.last_fallback = str(exc)
        g = np.asarray(model.g(q), dtype=float)
        if not np.all(np.isfinite(g)):
            raise ArgumentError('tau', f'law failed ({exc}) and the gravity-hold fallback is not finite') from exc
        return g

    def _task_state(self, cfg, q, qd, f_meas):
        """(x, xd, f, fdot) of the measured state: task position and velocity, force-axis force and rate."""
        model = cfg.model
        x, J, _ = model._task(q, qd)   # cached: the law evaluates the same terms at the same (q, qd)
        xd = J @ qd
        if not self._has_force:
            return x, xd, None, None
        fidx = self._fidx
        if cfg.force_feedback == 'model':
            # the lecture's f = k_e (x - x_e), fdot = k_e xd: laws.spring_force(..., sign=0), inlined
            # because spring_force's argument checks cost more than the rest of the tick
            f = cfg.k_e * (x[fidx] - cfg.x_e)
        else:
            if f_meas is None:
                raise ArgumentError("f_meas", "required with force_feedback 'sensor'")
            f = validation.vector('f_meas', f_meas, model.task_dim)[fidx]
        fdot = cfg.k_e * xd[fidx]
        if cfg.force_lead_time:
            f = f + cfg.force_lead_time * fdot
        return x, xd, f, fdot

    def _evaluate(self, int_E):
        """The configured law at this tick's state and reference, with the error integral int_E."""
        cfg = self._cfg
        q, qd, x, xd, f, fdot = self._tick
        law = cfg.law
        if law == 'computed_torque':
            return self._computed_torque(cfg, q, qd, int_E)
        if law == 'independent_joint':
            return independent_joint(q, qd, self._q_d, self._qd_d, cfg.gains, int_E)
        if law == 'force':
            return force_1dof(self._m_x, f, fdot, self._f_d, self._fd_d, self._fdd_d, float(cfg.k_e[0]),
                              cfg.force_gains, int_E)
        pos, vel, acc = self._ref
        return hybrid(cfg.model, q, qd, pos, vel, acc, pos, vel, acc, self._f_m, self._fdot_m, cfg.force_mask,
                      self._K_e, self._gains_T, self._gains_N, q_posture=self._q_d, k_posture=cfg.posture_gains,
                      int_E=int_E)

    def _computed_torque(self, cfg, q, qd, int_E):
        """laws.computed_torque on this tick's errors E = q_d - q, Ed = qd_d - qd, which update() computed
        from checked inputs (the law's own fast path, without re-checking them). A non-finite result goes
        through the checked law, which names it."""
        gains = cfg.gains
        tau = torque_of_errors(cfg.model, q, qd, self._qdd_d, self._E, self._Ed, (gains.kp, gains.kv, gains.ki),
                               int_E)
        if tau is not None:
            return tau
        return computed_torque(cfg.model, q, qd, self._q_d, self._qd_d, self._qdd_d, gains, int_E)

    def _force_errors(self, f, fdot):
        np.subtract(self._f_d, f, out=self._E)
        np.subtract(self._fd_d, fdot, out=self._Ed)
        ref = self._ref
        ref[0][:], ref[1][:], ref[2][:] = self._f_d, self._fd_d, self._fdd_d
        self._m_x = float(self._cfg.model.M(self._tick[0])[0, 0])

    def _hybrid_reference(self, cfg, x, xd, f, fdot):
        """Task reference (motion axes: fk, J qd, J qdd + Jdot qd of the joint reference; force axes:
        the force reference) and the task errors E, Ed."""
        pos, vel, acc = self._ref
        x_d, xd_d, xdd_d = cfg.model._task_motion(self._q_d, self._qd_d, self._qdd_d)
        pos[:], vel[:], acc[:] = x_d, xd_d, xdd_d
        np.subtract(pos, x, out=self._E)
        np.subtract(vel, xd, out=self._Ed)
        if self._has_force:   # usually one axis: scalar writes beat fancy indexing here
            f_d, fd_d, fdd_d = self._f_d.tolist(), self._fd_d.tolist(), self._fdd_d.tolist()
            f, fdot = f.tolist(), fdot.tolist()
            E, Ed, f_m, fdot_m = self._E, self._Ed, self._f_m, self._fdot_m
            for j, i in self._force_axes:
                pos[i], vel[i], acc[i] = f_d[j], fd_d[j], fdd_d[j]
                f_m[i], fdot_m[i] = f[j], fdot[j]
                E[i], Ed[i] = f_d[j] - f[j], fd_d[j] - fdot[j]

    def _guard_contact(self, x, xd, f):
        """Lost contact: on the force axes the guard trips on, the force reference becomes a position
        hold, f_d = f + k_e (x_hold - x) (the force servo's own gains then hold x_hold)."""
        guard = self._guard
        x_n, xd_n = x[self._fidx], xd[self._fidx]
        guard.check(x_n, xd_n, f, self._f_target)
        if guard.active:
            guard.substitute(x_n, f, self._f_d, self._fd_d, self._fdd_d)

    @property
    def contact_guard(self):
        """The lost-contact guard (robot_control.core.contact.ContactGuard) of the force axes, or None."""
        return self._guard

    def _hold_mask(self, cfg):
        """Anti-windup: which integral entries to freeze this tick (from the last tick's saturation)."""
        if self._guard is not None and self._guard.active:
            return np.ones(self._integral.n, dtype=bool)      # lost contact: the integral waits
        if not self._sat_any:
            return None
        if cfg.law == 'hybrid':
            return np.ones(self._integral.n, dtype=bool)
        return self._sat & (self._E * self._tau > 0.0)      # self._tau: still the last tick's torque

    def _back_calculate(self, cfg, tau_law, dt):
        """Anti-windup by back-calculation (Astrom and Hagglund, Advanced PID Control, sec. 3.5).

        After a saturated tick the integral moves toward the value whose law torque is the saturated
        torque (applied at the start of the next tick): int += min(1, dt / Tt) d, d the least-squares solution of B d = tau_sat - tau_law,
        B = d tau / d int (the laws are affine in the integral), with the tracking time constant
        Tt = sqrt(Ti Td) = sqrt(kv / ki) s per entry. The hold mask alone stops the integral from
        growing while saturated, but not the integral of the large error left once the reference
        has run ahead of the saturated robot: the PID then overshoots far beyond its unsaturated
        response. Costs one law evaluation per integral entry, on saturated ticks only.
        """
        ki = cfg.integral_ki()
        cols = np.flatnonzero(ki > 0.0)
        if cols.size == 0:
            return
        z0 = np.array(self._integral.value)
        z = z0.copy()
        B = np.empty((tau_law.shape[0], cols.size))
        try:
            for c, j in enumerate(cols):
                z[j] = z0[j] + 1.0
                B[:, c] = np.asarray(self._evaluate(z), dtype=float) - tau_law
                z[j] = z0[j]
            d = np.linalg.lstsq(B, self._tau - tau_law, rcond=None)[0]
        except (ValueError, np.linalg.LinAlgError):
            return
        if np.all(np.isfinite(d)):
            tracking = np.sqrt(cfg.integral_kv()[cols] / ki[cols])
            step = np.zeros(z0.shape[0])
            step[cols] = np.minimum(1.0, dt / np.maximum(tracking, dt)) * d
            self._windup_step = step        # applied at the next tick: integral_value stays the one used

    def _reinitialise(self, cfg, evaluate):
        """Bumpless transfer: integral such that the new law's torque equals the last torque sent."""
        dim = self._integral.n
        ki = cfg.integral_ki()
        cols = np.flatnonzero(ki > 0.0)
        self._integral.reset()
        if not self._has_prev or cols.size == 0:
            return
        z = np.zeros(dim)
        try:
            tau0 = np.array(evaluate(z))
            B = np.empty((tau0.shape[0], cols.size))
            for c, j in enumerate(cols):
                z[j] = 1.0
                B[:, c] = evaluate(z) - tau0
                z[j] = 0.0
            sol = np.linalg.lstsq(B, self._tau - tau0, rcond=None)[0]     # the last torque sent
        except (ValueError, np.linalg.LinAlgError):
            return
        if np.all(np.isfinite(sol)):
            z[cols] = sol
            self._integral.preset(z)

    # -- what the node publishes -------------------------------------------------------------------
    @property
    def tau(self):
        """Torque of the last tick, (n,), N m or N."""
        return self._tau

    @property
    def tau_values(self):
        """The same torque as a list of floats (what a serializer wants, without a numpy call)."""
        return self._tau_values

    @property
    def saturated(self):
        """Bool (n,): joints at their effort limit on the last tick."""
        return self._sat

    @property
    def reference_names(self):
        """Names of the reference/error entries: the joints (joint laws) or the task axes (force: force axis)."""
        return self._ref_names

    @property
    def reference(self):
        """(pos, vel, acc) of the last tick: q_d, qd_d, qdd_d (joint laws); per task axis x_d, xd_d,
        xdd_d on motion axes and f_d, fd_d, fdd_d on force axes (N, N/s, N/s^2) for force/hybrid."""
        return self._ref

    @property
    def joint_reference(self):
        """(q_d, qd_d, qdd_d) of the last tick, (n,) each (for every law)."""
        return self._q_d, self._qd_d, self._qdd_d

    @property
    def error(self):
        """(E, Ed) of the last tick, named like reference: q_d - q (joint laws), f_d - f / x_d - x (task)."""
        return self._E, self._Ed

    @property
    def integral_value(self):
        """The error integral (integral_dim,) used on the last tick (zeros when integral is off)."""
        return self._integral.value
