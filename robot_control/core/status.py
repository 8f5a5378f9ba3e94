"""What the controller reports on /diagnostics, as plain data (the node turns it into messages).

Five statuses, each (name, level, message, values) with level 'OK' | 'WARN' | 'ERROR' and values
(key, value) pairs: the joint_states watchdog, effort saturation, rejected inputs, the control law,
the trajectory (its goal and path tolerances). LawWatch says, for the node's log, when the law keeps
saturating or falling back.
"""
import dataclasses

#: s of wall time between two warnings about the law (LawWatch)
LAW_WARN_PERIOD = 5.0
#: a window in which at least this fraction of the ticks saturated a joint "keeps saturating" (a few
#: ticks at the limit while a fast move starts are the saturation doing its job, not a failure)
SATURATION_WARN_FRACTION = 0.01


@dataclasses.dataclass
class Counters:
    """The node's own counts: commands sent, trajectories, target poses and wrenches accepted, rejected inputs
    per source (and
    the last reason), the wall time of answering a state (ns), whether a wrench was ever measured, where the
    last state's velocities came from."""

    sources: tuple
    commands_sent: int = 0
    trajectories_accepted: int = 0
    target_poses_accepted: int = 0
    target_wrenches_accepted: int = 0
    last_rejection: str = ''
    velocity_source: str = 'measured'    # the last state's qd: measured, or estimated from q (core.velocity)
    wrench_seen: bool = False
    tick_count: int = 0
    tick_total_ns: int = 0
    tick_max_ns: int = 0

    def __post_init__(self):
        self.rejected = dict.fromkeys(self.sources, 0)

    def reject(self, source, reason):
        self.rejected[source] += 1
        self.last_rejection = f'{source}: {reason}'

    def tick(self, ns):
        """One state answered in `ns` of wall time (message in -> command out)."""
        self.tick_count += 1
        self.tick_total_ns += ns
        self.tick_max_ns = max(self.tick_max_ns, ns)

    @property
    def tick_mean_us(self):
        return self.tick_total_ns / self.tick_count / 1e3 if self.tick_count else 0.0


def controller_statuses(name, core, watchdog, age, counters):
    """The statuses of controller `name` (its core, StateWatchdog, the age of the last state in s or
    None, Counters)."""
    return [_watchdog(name, core, watchdog, age, counters), _saturation(name, core),
            _rejected(name, counters), _law(name, core, counters), _trajectory(name, core)]


#: the level of each trajectory outcome: a path violation is an error, a missed goal a warning
OUTCOME_LEVEL = {'': 'OK', 'succeeded': 'OK', 'cancelled': 'OK', 'missed': 'WARN', 'path': 'ERROR'}


def _trajectory(name, core):
    goal = core.goal
    if goal.active:
        message = f'following trajectory {goal.goals} (ends at t = {goal.t_end:.3f} s)'
    elif goal.outcome:
        message = f'trajectory {goal.goals} {goal.outcome}: {goal.reason}'
    else:
        message = 'no trajectory yet'
    tol = core.config.tolerances
    return (f'{name}: trajectory', 'OK' if goal.active else OUTCOME_LEVEL[goal.outcome], message,
            [('goals', goal.goals), ('outcome', goal.outcome or ('executing' if goal.active else 'none')),
             ('goal_time', tol.goal_time), ('stopped_velocity_tolerance', tol.stopped_velocity)]
            + [(f'trajectory_tolerance.{j}', float(v)) for j, v in zip(core.config.joints, tol.trajectory)]
            + [(f'goal_tolerance.{j}', float(v)) for j, v in zip(core.config.joints, tol.goal)])


def _watchdog(name, core, watchdog, age, counters):
    if watchdog.tripped:
        level, message = 'ERROR', (f'no joint_states for {age:.3f} s (state_timeout {watchdog.timeout:g} s): '
                                   'not commanding')
    elif age is None:
        level, message = 'WARN', 'waiting for the first joint_states'
    else:
        level, message = 'OK', 'receiving joint_states'
    return (f'{name}: joint_states watchdog', level, message,
            [('state_timeout_s', watchdog.timeout), ('trips', watchdog.trips), ('late_checks', watchdog.late_checks),
             ('restarts', core.restarts),
             ('commands_sent', counters.commands_sent)])


def _saturation(name, core):
    cfg = core.config
    sat = [j for j, s in zip(cfg.joints, core.saturated) if s]
    return (f'{name}: effort saturation', 'WARN' if sat else 'OK',
            f'saturated: {sat}' if sat else 'within effort limits',
            [('saturated_ticks', core.saturated_ticks), ('ticks', core.ticks)]
            + [(f'saturated_ticks.{j}', int(c)) for j, c in zip(cfg.joints, core.saturation_counts)]
            + [(f'effort_limit.{j}', float(v)) for j, v in zip(cfg.joints, cfg.effort_limit)])


def _rejected(name, counters):
    total = sum(counters.rejected.values())
    return (f'{name}: rejected inputs', 'WARN' if total else 'OK',
            f'{total} rejected; last {counters.last_rejection}' if total else 'no rejected input',
            [(f'rejected.{k}', v) for k, v in counters.rejected.items()] + [('last_reason', counters.last_rejection)])


def _law(name, core, counters):
    cfg = core.config
    level, message = 'OK', f'{cfg.law}{" PID" if cfg.integral else ""}'
    if core.fallbacks:
        level, message = 'WARN', f'{message}; gravity-hold fallbacks: {core.fallbacks} (last: {core.last_fallback})'
    if needs_wrench(cfg) and not counters.wrench_seen:
        level, message = 'WARN', f'{message}; no ft_sensor/wrench received (force taken as 0)'
    guard = core.contact_guard
    if guard is not None and guard.active:
        level, message = 'ERROR', f'{message}; {guard.reason}'
    law = cfg.control_law
    task = law.force_task
    gains = [(f'{label}.{g}', getattr(servo, g).tolist()) for label, servo in (('gains', law.motion_gains),
                                                                                ('force_gains', task.gains))
             if servo is not None for g in ('kp', 'kv', 'ki')]
    axes = ','.join(task.force_axes)
    return (f'{name}: control law', level, message,
            gains + [('law', cfg.law), ('force_axes', axes), ('integral', cfg.integral),
             ('velocity', counters.velocity_source),
             ('fallbacks', core.fallbacks),
             ('contact_trips', guard.trips if guard is not None else 0),
             ('tick_mean_us', round(counters.tick_mean_us, 1)), ('tick_max_us', round(counters.tick_max_ns / 1e3, 1)),
             ('ticks', counters.tick_count)])


def needs_wrench(cfg):
    """True when the configured law reads the measured contact force (ft_sensor/wrench)."""
    task = cfg.control_law.force_task
    return bool(task.force_axes) and task.force_feedback == 'sensor'


class LawWatch:
    """Whether the law keeps saturating or falling back, for the node's log: report() gives a warning at
    most once per `period_ns` of wall time.

    The counts are the core's (ControllerCore: ticks, saturated_ticks, saturation_counts per joint,
    fallbacks, last_fallback). Windows of period_ns of wall time follow each other from the first call;
    the first call at or after a window's end compares the counts with those at its start and starts
    the next: a warning when the law fell back on a tick of the window, or when at least
    SATURATION_WARN_FRACTION of its ticks saturated a joint (law_warning)."""

    def __init__(self, period_ns):
        self.period_ns = int(period_ns)
        self._end = None
        self._start = None

    def report(self, core, wall_ns):
        """The warning of the window that ended by wall_ns (ns, a monotonic clock), or None."""
        if self._end is not None and wall_ns < self._end:
            return None
        counts = (core.ticks, core.saturated_ticks, core.saturation_counts.copy(), core.fallbacks)
        start, self._start, self._end = self._start, counts, wall_ns + self.period_ns
        if start is None:
            return None
        ticks, saturated, per_joint, fallbacks = (now - then for now, then in zip(counts, start))
        return law_warning(core.config, ticks, saturated, per_joint, fallbacks, core.last_fallback)


def law_warning(cfg, ticks, saturated, per_joint, fallbacks, reason):
    """The warning about the last `ticks` ticks of the law of ControllerConfig `cfg`: `saturated` of them
    at an effort limit, per_joint (n,) the saturated ticks of each joint, `fallbacks` of them the gravity
    hold after the law failed (the last failure: `reason`); None when there is nothing to say."""
    parts = []
    if fallbacks:
        parts.append(f'law {cfg.law} failed and fell back to the gravity hold g(q) in {fallbacks} of the last '
                     f'{ticks} ticks (last: {reason})')
    if ticks and saturated >= SATURATION_WARN_FRACTION * ticks:
        joints = ', '.join(f'{j} in {int(c)}' for j, c in zip(cfg.joints, per_joint) if c)
        parts.append(f'law {cfg.law} saturated the effort limits in {saturated} of the last {ticks} ticks '
                     f'({joints})')
    return '; '.join(parts) or None
