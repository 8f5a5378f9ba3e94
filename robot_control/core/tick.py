"""ControllerCore: the law's tick on the controller's time line, without ROS.

robot_control.core.controller.Controller calls update_checked(t, q, qd, f_meas) once per accepted
state (t in s on its time line) and returns the torque as its command. One tick:

  1. measure: the task state x = fk(q), xd = J qd, J, Jdot qd (laws that need a task space) and the
     force on the force axes: measured (f_meas) or the lecture's spring f = k_e (x - x_e), with
     fdot = k_e xd (no differentiation of a noisy sensor), and f + fdot T for force_lead_time T;
  2. start or restart the references when needed (first tick, after stop(), after time went back,
     after a switch to or from a law that does not track the joint reference);
  3. sample the references (robot_control.core.references), guard lost contact on the force axes;
  4. the law's errors, then its integral (robot_control.laws.integral: clamp, anti-windup, integration
     at rest only when integral_rest_velocity is finite, bumpless re-initialisation);
  5. the law's torque, evaluated once; if it fails (a singular task Jacobian, a non-finite result)
     the gravity hold g(q) instead, counted in `fallbacks`; plus the friction compensation when on
     (robot_control.laws.friction_compensation);
  6. saturation to the effort limits, with back-calculation of the integral on saturated ticks
     (from the law's closed-form integral map B = d tau / d int E: no second evaluation).

The law sees immutable inputs made for the tick (robot_control.laws.base: State, Reference) and
answers with its Errors and its torque; nothing it is given is written.

Start and restart: the integral is reset, the joint reference holds the measured position q and
the force reference ramps from the measured force to its target over force_ramp_time.

Bumpless switching: a new configuration (configure) takes effect on the next tick. Changing gains,
the integral flag, the model or the force parameters keeps the references; a switch between two
laws that track the joint reference keeps them too; any other switch restarts them (on the next tick,
or, when a new reference comes first, just before it is taken, from the last tick's state). On the first
tick after a change the integral is re-initialised so that the new law's torque equals the last
torque sent (zero without integral action).

Lost contact (laws that use force): a robot_control.core.contact.ContactGuard watches every force
axis; a tripped axis is held in position until a restart or a new force target.

Not thread-safe: call every method from one thread (the node's executor does).
"""
import numpy as np

from robot_control import validation
from robot_control.core.config import ControllerConfig
from robot_control.core.contact import ContactGuard
from robot_control.core.references import References
from robot_control.core.tolerances import GoalMonitor
from robot_control.laws import Integral, Reference, State
from robot_control.laws.integral import moving
from robot_control.laws.force import _spring_force
from robot_control.laws.saturation import _saturate
from robot_control.validation import ArgumentError

__all__ = ['ControllerConfig', 'ControllerCore']


def _config(config):
    if not isinstance(config, ControllerConfig):
        raise ArgumentError('config', f'expected a ControllerConfig, got {type(config).__name__}')
    return config


def measure_task(cfg, q, qd, f_meas):
    """(x, xd, J, Jdot_qd, f, fdot): the task state, and on the force axes of the law's force setup
    (Law.force_task) f, fdot (N, N/s) (none: None, None). f_meas: the measured force (m,), a finite float64
    array (checked where it entered), or None (ArgumentError with force_feedback 'sensor')."""
    x, J, Jdot_qd = cfg.model._task(q, qd)
    xd = J @ qd
    task = cfg.control_law.force_task
    if not task.force_axes:
        return x, xd, J, Jdot_qd, None, None
    mask = task.mask
    f, fdot = _spring_force(x[mask], xd[mask], task.x_e, task.k_e, 0.0)      # the lecture's f and fdot = k_e xd
    if task.force_feedback == 'sensor':
        if f_meas is None:
            raise ArgumentError('f_meas', "required with force_feedback 'sensor'")
        f = f_meas[mask]
    if task.force_lead_time:
        f = f + task.force_lead_time * fdot
    return x, xd, J, Jdot_qd, f, fdot


def contact_guard(task):
    """The lost-contact guard of the force setup `task` (a ForceTask; None without force axes or bounds)."""
    if not task.force_axes or not (np.isfinite(task.contact_max_travel) or np.isfinite(task.contact_max_speed)):
        return None
    return ContactGuard(task.force_axes, task.k_e, task.x_e, task.contact_max_travel, task.contact_max_speed)


def sample_reference(cfg, refs, guard, state, last=None):
    """The Reference at state.t from the References `refs`: the joint reference (and the force reference,
    guarded by the ContactGuard `guard` or None, for laws that use force), the task target. The arrays are
    the References' own, sampled in place: `last`, the Reference of the last tick, is returned again when
    it holds the same objects."""
    t, law = state.t, cfg.control_law
    force = law.uses_force and refs.k > 0
    pending = refs.force_pending
    refs.sample(t, force)
    target = refs.sample_target(t) if law.tracks == 'task' else None
    if not force:
        return _reference(last, refs.q_d, refs.qd_d, refs.qdd_d, None, None, None, target, refs.wrench)
    if guard is not None:
        if pending is not None and refs.force_pending is None:     # a stamped target took effect
            guard.reset()
        mask = law.force_task.mask
        x_n = state.x[mask]
        guard.check(x_n, state.xd[mask], state.f, refs.f_target)
        if guard.active:     # the force servo holds x_hold: f_d = f + k_e (x_hold - x)
            guard.substitute(x_n, state.f, refs.f_d, refs.fd_d, refs.fdd_d)
    return _reference(last, refs.q_d, refs.qd_d, refs.qdd_d, refs.f_d, refs.fd_d, refs.fdd_d, target, refs.wrench)


def _reference(last, q_d, qd_d, qdd_d, f_d, fd_d, fdd_d, target, wrench):
    """Reference(q_d, ...), or `last` when it holds exactly these objects (the joint and force references'
    three arrays each come and go together)."""
    if last is not None and last.q_d is q_d and last.f_d is f_d and last.target is target and last.wrench is wrench:
        return last
    return Reference(q_d, qd_d, qdd_d, f_d, fd_d, fdd_d, target, wrench)


def restart_references(refs, guard, t, state, cfg=None, f_meas=None):
    """Start the References `refs` again at t (s) from the State's q and f, re-arm the ContactGuard `guard`
    (or None); False: no restart is left pending. With `cfg`, a ControllerConfig newer than the State, f is
    the force its law measures at that state (measure_task, f_meas the measured one)."""
    f = state.f
    if cfg is not None:
        f = measure_task(cfg, state.q, state.qd, f_meas)[4] if cfg.control_law.uses_force else None
    refs.start(t, state.q, f)
    if guard is not None:
        guard.reset()
    return False


def refit_references(refs, task, old_task, move_time):
    """Fit the References `refs` to a new configuration: the force axes of its force setup `task` (a ForceTask;
    `old_task` the last one's) and the durations of a move (s) and of a force ramp. True when the force axes
    changed (the force reference was reset)."""
    changed = task.force_axes != old_task.force_axes
    if changed:
        refs.set_force_axes(len(task.force_axes))
    refs.move_time, refs.force_ramp_time = move_time, task.force_ramp_time
    return changed


def integral_map(law, state, ref, err):
    """(B = d tau / d int E of `law` at this tick, (ki, kv)); B None when the law fails there."""
    try:
        B = law.integral_map(state, ref, err)
    except (ValueError, np.linalg.LinAlgError):
        B = None
    return B, law.integral_gains()


class ControllerCore:
    """Per-tick controller: update(t, q, qd, f_meas) -> tau, saturated and finite (see the module docstring).

    Returned arrays are internal buffers, overwritten next tick.
    """

    def __init__(self, config):
        config = _config(config)
        n, task = config.n, config.control_law.force_task
        self._cfg = config
        self._refs = References(n, len(task.force_axes), config.move_time, task.force_ramp_time)
        self._integral = Integral._of_checked(config.integral_dim, config.integral_limit)
        self._state = self._ref = self._err = self._f_meas = None   # the last tick's State, Reference, Errors, f_meas
        self._tau, self._sat, self._tau_values = np.zeros(n), np.zeros(n, dtype=bool), [0.0] * n
        self._sat_any = self._has_prev = False   # _has_prev: self._tau holds a torque sent (bumpless transfer)
        self._t, self.active, self._reinit, self._restart = None, False, False, False
        self.ticks = self.saturated_ticks = self.fallbacks = self.restarts = 0
        self.saturation_counts = np.zeros(n, dtype=np.int64)
        self.last_fallback = ''
        self._guard = contact_guard(task)
        self.goal = GoalMonitor(config.joints)

    # -- configuration -----------------------------------------------------------------------------
    @property
    def config(self):
        """The active ControllerConfig."""
        return self._cfg

    def configure(self, config):
        """Swap in a new ControllerConfig, effective on the next tick (joints cannot change)."""
        config, old = _config(config), self._cfg
        if config.joints != old.joints:
            raise ArgumentError('joints', f'cannot change at run time ({list(old.joints)} -> {list(config.joints)})')
        keeps = old.control_law.tracks == config.control_law.tracks == 'joint' or config.law == old.law
        if config.integral_dim != self._integral.n or config.integral_limit != old.integral_limit:
            self._integral = self._integral.resized(config.integral_dim, config.integral_limit)
        task = config.control_law.force_task
        axes_changed = refit_references(self._refs, task, old.control_law.force_task, config.move_time)
        self._guard = contact_guard(task)
        config.control_law.continue_from(old.control_law)
        self._cfg = config
        if self.active:
            self._reinit = self._reinit or config.law_key() != old.law_key()
            self._restart = self._restart or not keeps or axes_changed

    # -- references --------------------------------------------------------------------------------
    @property
    def state(self):
        """The State of the last tick (laws.base.State: t, q, qd, ...), None before the first."""
        return self._state

    @property
    def t(self):
        """Time of the last tick, s (None before the first)."""
        return self._t

    def set_trajectory(self, times, positions, velocities=None, accelerations=None, t_start=None):
        """Replace the joint reference by a path through points (References.set_trajectory: the first
        point may be at 0 s, NaN positions hold a joint), checked against the model's position and
        velocity limits; its goal and path tolerances are watched from now on. The start time t_start
        is on the update() time base, None = the last tick. Returns the start time used."""
        self._require_active('trajectory')
        self._settle_restart()
        model = self._cfg.model
        limits = (*model.position_limits, model.velocity_limit, self._cfg.joints)
        traj = self._refs.set_trajectory(self._t, times, positions, velocities, accelerations, t_start, limits)
        self.goal.start(traj.t_end)
        return traj.t0

    def hold_position(self):
        """Cancel the motion: hold the last measured position, at rest (an empty trajectory)."""
        self._require_active('hold')
        self._settle_restart()
        self._refs.hold(self._t, self._state.q.copy())
        self.goal.cancel('cancelled by an empty trajectory')

    def set_goal(self, q_goal, duration=None):
        """Quintic move of the joint reference to q_goal (n,) over `duration` s (default move_time); before
        the first state it becomes the first move from the measured start position."""
        self._refs.set_goal(self._t if self.active else None, q_goal, duration)

    def set_force_reference(self, f_target, t_start=None):
        """Ramp the force reference to f_target (k,) N per force axis over force_ramp_time, from t_start
        (None: now; after the last tick: pending until then). A new target re-arms the contact guard."""
        self._refs.set_force_target(self._t if self.active else None, f_target, t_start)
        if self._guard is not None and self._refs.force_pending is None:
            self._guard.reset()

    def set_target_pose(self, x_d, t_start=None):
        """A task-space target x_d (m,) for the laws that track the task (impedance; hybrid's motion axes),
        at rest, from t_start (None: now; after the last tick: pending until then). Until the first
        target after a (re)start they follow the joint reference in the task space."""
        self._require_active('target_pose')
        self._settle_restart()
        self._refs.set_task_target(self._t, validation.vector('x_d', x_d, self._cfg.model.task_dim), t_start)

    def set_target_wrench(self, wrench):
        """A feed-forward wrench (m,) N, N m on the task axes (impedance), the robot on its environment."""
        self._settle_restart()
        self._refs.wrench = np.array(validation.vector('wrench', wrench, self._cfg.model.task_dim))

    @property
    def force_target(self):
        """The force reference's target per force axis, N (copy)."""
        return self._refs.f_target.copy()

    @property
    def force_pending(self):
        """(t_start s, f_target) of a force target stamped ahead, or None."""
        return self._refs.force_pending

    def reference_at(self, t):
        """(q_d, qd_d, qdd_d) the joint reference would give at time t (new arrays)."""
        self._require_active('reference')
        return self._refs.at(t)

    def _require_active(self, what):
        if not self.active:
            raise ArgumentError(what, 'no state received yet (the current state is the implicit start)')

    def stop(self):
        """Stop (watchdog): the next update() restarts from the then-current state."""
        self.goal.cancel('the controller stopped')
        self.active = False
        self._reinit = self._restart = False

    # -- the tick -----------------------------------------------------------------------------------
    def update(self, t, q, qd, f_meas=None):
        """Torque (n,) for the state (q, qd) at time t (s); f_meas (m,) measured task forces, N (required
        with force_feedback 'sensor' by laws that use force). Checks its arguments (ArgumentError)."""
        n, m = self._cfg.n, self._cfg.model.task_dim
        return self.update_checked(validation.scalar('t', t), validation.vector('q', q, n), validation.vector('qd', qd, n),
                                   None if f_meas is None else validation.vector('f_meas', f_meas, m))

    def update_checked(self, t, q, qd, f_meas=None):
        """update() on a state known to be valid (t a finite float, q and qd finite float64 (n,) arrays,
        as robot_control.core.joint_states.JointStateReader gives them; f_meas None or a finite float64 (m,)
        array, as Controller.step checks it)."""
        law = self._cfg.control_law
        state = State(t, q, qd, *measure_task(self._cfg, q, qd, f_meas)) if law.needs_task_space else State(t, q, qd)
        self._state, self._f_meas = state, f_meas
        dt = self._advance(state)
        self._ref = ref = sample_reference(self._cfg, self._refs, self._guard, state, self._ref)
        if law.tracks == 'joint' and self.goal.active:
            self._watch_goal(state, ref)
        self._err = err = law.errors(state, ref)
        int_E, bumpless = self._integrate(err, dt)
        tau, int_E = self._evaluate(state, ref, err, int_E)
        if self._cfg.friction_compensation is not None:
            tau = tau + self._cfg.friction_compensation.torque(state, ref)
        if bumpless and int_E is not None:
            tau = self._reinitialise(state, ref, err, tau)
        return self._saturate(state, ref, err, tau, int_E, dt)

    def _advance(self, state):
        """dt since the last tick (0 at a start); starts or restarts the references when needed."""
        t = state.t
        if self.active and t >= self._t:
            dt, restart = t - self._t, self._restart
        else:
            if self._t is not None:
                self.restarts += 1
            dt, restart = 0.0, True
            self._integral.reset()
            self._reinit = False
            self.active = True
        if restart:
            self._restart = restart_references(self._refs, self._guard, t, state)
        self._t = t
        return dt

    def _settle_restart(self):
        """A restart configure() left for the next tick is made now, from the last tick's state, before a new
        trajectory, hold or task target is taken (that tick's restart would drop it)."""
        if self._restart:
            self._restart = restart_references(self._refs, self._guard, self._t, self._state, self._cfg, self._f_meas)

    def _watch_goal(self, state, ref):
        """Tolerances of the trajectory followed: a path violation or a missed goal holds the position (the
        reference's arrays are re-sampled in place)."""
        outcome = self.goal.check(state.t, state.q, state.qd, ref.q_d, self._cfg.tolerances)
        if outcome in ('path', 'missed'):
            self._refs.hold(state.t, state.q.copy())
            self._refs.sample(state.t, False)

    def _integrate(self, err, dt):
        """(the integral the law uses this tick or None without integral action, True when it is to be
        re-initialised for a bumpless transfer once the law's torque at zero integral is known)."""
        integral = self._integral
        if not (self._cfg.integral and integral.n):
            if self._reinit:                     # integral action switched off: nothing left to show
                integral.reset()
            self._reinit = False
            return None, False
        bumpless = self._reinit and self._has_prev
        if self._reinit:
            integral.reset()
            self._reinit = False
        elif dt > 0.0:
            integral._update(err.E, dt, self._hold(err))
        return integral.value, bumpless

    def _hold(self, err):
        """Integral entries frozen this tick: all while contact is lost, else those not at rest
        (robot_control.laws.integral.moving) and the law's choice after a saturated tick (self._sat and
        self._tau are still the last tick's)."""
        if self._guard is not None and self._guard.active:
            return np.ones(self._integral.n, dtype=bool)
        held = moving(err.Ed, self._cfg.integral_rest_velocity)
        if not self._sat_any:
            return held
        frozen = self._cfg.control_law.freeze(err.E, self._sat, self._tau)
        return frozen if held is None else frozen | held

    def _reinitialise(self, state, ref, err, tau0):
        """Bumpless transfer: the integral whose torque tau0 + B int E is the last torque sent; that torque."""
        B, (ki, _) = integral_map(self._cfg.control_law, state, ref, err)
        if B is None:
            return tau0
        self._integral.reinitialise(B, tau0, self._tau, ki)
        return tau0 + B @ self._integral.value

    def _evaluate(self, state, ref, err, int_E):
        """(tau, int_E) of the law, or the gravity hold g(q) (and no integral) when the law fails."""
        try:
            tau = self._cfg.control_law.torque(state, ref, err, int_E)
            if validation.finite(tau):
                return tau, int_E
            raise ArgumentError('tau', f'non-finite result {tau.tolist()}')
        except (ValueError, np.linalg.LinAlgError) as exc:
            self.fallbacks += 1
            self.last_fallback = str(exc)
            g = self._cfg.model._g(state.q)
            if not validation.finite(g):
                raise ArgumentError('tau', f'law failed ({exc}) and the gravity-hold fallback is not finite') \
                    from exc
            return g, None

    def _saturate(self, state, ref, err, tau, int_E, dt):
        """Clip to the effort limits into the torque buffer; back-calculate the integral when clipped."""
        _saturate(tau, self._cfg.effort_limit, self._tau, self._sat)
        self._tau_values = self._tau.tolist()
        self._sat_any = sat_any = bool(self._sat.any())
        self._has_prev = True
        self.ticks += 1
        if sat_any:
            self.saturated_ticks += 1
            self.saturation_counts += self._sat
            if int_E is not None and dt > 0.0:
                B, (ki, kv) = integral_map(self._cfg.control_law, state, ref, err)
                if B is not None:
                    self._integral.back_calculate(B, tau, self._tau, ki, kv, dt)
        return self._tau

    # -- what the node publishes -----------------------------------------------------------------------
    @property
    def tau(self):
        """Torque of the last tick, (n,), N m or N."""
        return self._tau

    @property
    def tau_values(self):
        """The same torque as a list of floats (what a serializer takes)."""
        return self._tau_values

    @property
    def saturated(self):
        """Bool (n,): joints at their effort limit on the last tick."""
        return self._sat

    @property
    def reference_names(self):
        """Names of the reference/error entries: the joints, the force axis or the task axes (the law's)."""
        return self._cfg.control_law.reference_names

    @property
    def reference(self):
        """(pos, vel, acc) of the last tick in the law's space: q_d, qd_d, qdd_d for the joint laws; per
        task axis x_d ... on motion axes and f_d, fd_d, fdd_d (N, N/s, N/s^2) on force axes."""
        return None if self._err is None else self._err.ref

    @property
    def joint_reference(self):
        """(q_d, qd_d, qdd_d) of the last tick, (n,) each (for every law)."""
        return self._refs.q_d, self._refs.qd_d, self._refs.qdd_d

    @property
    def error(self):
        """(E, Ed) of the last tick, named like reference."""
        return (None, None) if self._err is None else (self._err.E, self._err.Ed)

    @property
    def integral_value(self):
        """The error integral (integral_dim,) used on the last tick (zeros when integral is off)."""
        return self._integral.value

    @property
    def contact_guard(self):
        """The lost-contact guard (robot_control.core.contact.ContactGuard) of the force axes, or None."""
        return self._guard
