"""Metrics of a demo run, from the time series the collector aligned per control tick (no rclpy).

One sample per control tick k (the ticks the controller answered), at simulation time t_k (s,
after the run's origin). Coordinates are what the law servoes: the joints for computed_torque
and independent_joint (rad or m as the joint is), the motion-controlled task axes for hybrid (m);
force-controlled axes carry forces (N).

Definitions (per coordinate, e = reference - actual as the controller publishes on ~/error):
  rms_error            sqrt(mean(e^2)) over the whole run
  max_error            max |e| over the whole run
  final_error          |e| at the last tick
  steady_state_error   mean of e (signed) over the last `steady_window` s
  settling_time_s      time from `settle_from` until |e - e_final| stays within 2 % of the largest
                       |e - e_final| after settle_from (the classic 2 % settling time of a step, of a
                       disturbance response alike), up to the next force reference event; the largest
                       over the coordinates; null when the experiment has no change to settle from, or
                       the band is never reached
  force_rms_error      sqrt(mean((f_d - f)^2)) over t >= force_window ("after settling"; or over the
                       experiment's settled intervals), N; f is the contact force the simulator
                       published for that tick (ft_sensor/wrench, same stamp)
  force_max_error, force_steady_state_error, force_settling_time_s: the same on the force axes
  saturated_ticks      ticks with a command at its effort limit (any joint)
  loop_rate_hz         control ticks per second of wall-clock time (1000 in realtime; lockstep runs as
                       fast as the processes go)
  latency_p50_ms/p99   command publication - state publication (source timestamps of the same stamp):
                       the controller's reaction time through DDS, wall clock
"""
import numpy as np

from robot_control.laws import LAWS
from robot_control.units import EFFORT_UNIT

SETTLING_BAND = 0.02


def joint_space(law):
    """True when law `law` (a name of robot_control.laws.LAWS) has its reference and errors in joint space."""
    return LAWS[law].tracks != 'task'


def task_units(axes):
    """The unit of each task axis: m for x, y, z; rad for rx, ry, rz."""
    return tuple('rad' if a.startswith('r') else 'm' for a in axes)


class RunData:
    """Per-tick arrays of one run (see the module docstring). Shapes: N ticks, n joints, m entries."""

    def __init__(self, *, t, joints, joint_units, q, qd, tau_applied, tau_cmd, ref_names, ref_pos, ref_vel,
                 ref_acc, err_pos, err_vel, force_xyz, force_axes, force_axis_index, law, effort_limit=None,
                 state_wall_ns=None, cmd_wall_ns=None):
        self.t = np.asarray(t, dtype=float)
        self.joints = tuple(joints)
        self.joint_units = tuple(joint_units)
        self.q, self.qd = np.asarray(q, float), np.asarray(qd, float)
        self.tau_applied, self.tau_cmd = np.asarray(tau_applied, float), np.asarray(tau_cmd, float)
        self.ref_names = tuple(ref_names)
        self.ref_pos, self.ref_vel, self.ref_acc = (np.asarray(a, float) for a in (ref_pos, ref_vel, ref_acc))
        self.err_pos, self.err_vel = np.asarray(err_pos, float), np.asarray(err_vel, float)
        self.force_xyz = np.asarray(force_xyz, float)           # (N, 3) world force published by the bridge
        self.force_axes = tuple(force_axes)                     # names of the force-controlled entries
        self.force_axis_index = tuple(force_axis_index)         # their index 0..2 in the wrench
        self.law = law
        self.effort_limit = None if effort_limit is None else np.asarray(effort_limit, float)
        self.state_wall_ns = None if state_wall_ns is None else np.asarray(state_wall_ns, dtype=np.int64)
        self.cmd_wall_ns = None if cmd_wall_ns is None else np.asarray(cmd_wall_ns, dtype=np.int64)
        self.events = []    # the bridge's parameter changes: [{'t', 't_applied', 'parameters'}] (demo.Schedule)
        self.calls = []     # the service calls: [{'t', 't_called', 't_answered', 'service', 'success', 'message',
                            # 'parameters'}] (demo.Schedule)

    @property
    def samples(self):
        return self.t.shape[0]

    # -- coordinates ---------------------------------------------------------------------------
    @property
    def motion_index(self):
        """Indices into ref_names of the motion-controlled entries."""
        return [i for i, a in enumerate(self.ref_names) if a not in self.force_axes]

    @property
    def force_index(self):
        """Indices into ref_names of the force-controlled entries (same order as force_axes)."""
        return [self.ref_names.index(a) for a in self.force_axes]

    @property
    def motion_names(self):
        return tuple(self.ref_names[i] for i in self.motion_index)

    @property
    def motion_units(self):
        if joint_space(self.law):
            units = dict(zip(self.joints, self.joint_units))
            return tuple(units[a] for a in self.motion_names)
        return task_units(self.motion_names)

    def motion_error(self):
        return self.err_pos[:, self.motion_index]

    def force_reference(self):
        return self.ref_pos[:, self.force_index]

    def force_measured(self):
        """Contact force along each force axis, N (the bridge's ft_sensor/wrench of the tick)."""
        return self.force_xyz[:, list(self.force_axis_index)]

    def window(self, t0=None, t1=None):
        """Boolean mask of the ticks with t0 <= t <= t1; t0 may be ((a, b), ...): the union of [a, b]."""
        if isinstance(t0, (tuple, list)):
            mask = np.zeros(self.samples, dtype=bool)
            for a, b in t0:
                mask |= self.window(a, b)
            return mask
        mask = np.ones(self.samples, dtype=bool)
        if t0 is not None:
            mask &= self.t >= t0 - 1e-9
        if t1 is not None:
            mask &= self.t <= t1 + 1e-9
        return mask


# -- elementary metrics ----------------------------------------------------------------------------
def rms(x, axis=0):
    """Root mean square along `axis`, ignoring NaN (a message lost on the way to the collector)."""
    x = np.asarray(x, dtype=float)
    if not x.size:
        return np.full(x.shape[1:], np.nan)
    with np.errstate(invalid='ignore'):
        return np.sqrt(np.nanmean(x * x, axis=axis))


def _nanmax_abs(x):
    x = np.abs(np.asarray(x, dtype=float))
    return np.nanmax(x, axis=0) if x.size and not np.isnan(x).all() else np.full(x.shape[1:], np.nan)


def _nanmean(x):
    x = np.asarray(x, dtype=float)
    return np.nanmean(x, axis=0) if x.size and not np.isnan(x).all() else np.full(x.shape[1:], np.nan)


def settling_time(t, e, t_from, band=SETTLING_BAND, e_final=None, floor=1e-12):
    """Time after t_from from which |e - e_final| stays <= band * max|e - e_final| (t >= t_from).

    e: (N,) one coordinate. Returns 0.0 when the error never leaves a negligible band, None when
    there is nothing after t_from or the band is not reached before the end.
    """
    t = np.asarray(t, dtype=float)
    e = np.asarray(e, dtype=float)
    sel = (t >= t_from - 1e-9) & np.isfinite(e)
    if not sel.any():
        return None
    ts, es = t[sel], e[sel]
    final = es[-1] if e_final is None else e_final
    dev = np.abs(es - final)
    peak = dev.max()
    if peak <= floor:
        return 0.0
    outside = np.flatnonzero(dev > band * peak)
    if outside.size == 0:
        return 0.0
    last = outside[-1]
    if last + 1 >= ts.size:
        return None
    return float(ts[last + 1] - t_from)


def _named(names, values, digits=None):
    return {str(n): (None if not np.isfinite(v) else float(v)) for n, v in zip(names, values)}


def critically_damped(t, e0, omega):
    """e(t) of e'' + 2 omega e' + omega^2 e = 0 from e(0) = e0, e'(0) = 0: e0 (1 + omega t) exp(-omega t)."""
    t = np.asarray(t, dtype=float)
    return e0 * (1.0 + omega * t) * np.exp(-omega * t)


# -- the experiments' own figures (Experiment.figures) ----------------------------------------------
def _translation_rotation(data):
    """(index of the x, y, z entries, index of the rx, ry, rz entries) among the motion entries."""
    names = data.motion_names
    return ([i for i, a in enumerate(names) if a in ('x', 'y', 'z')],
            [i for i, a in enumerate(names) if a in ('rx', 'ry', 'rz')])


def push_figures(data, experiment):
    """The response to a push on and off (the first two bridge events), along `experiment.response_axis`:
    push_deflection_m (mean x - x_d over the steady_window before the release), push_other_axes_m (the
    largest |mean x_d - x| over that window on the other translation axes: the static deflection) and
    push_other_axes_peak_m (their largest |x_d - x| over the run: the transient of the coupled inertia),
    push_rotation_max_rad (the largest norm of the rotation error over the run), push_return_overshoot
    (the largest excursion past the target after the release, over the deflection)."""
    if len(data.events) < 2:
        return {}
    on, off = data.events[0]['t_applied'], data.events[1]['t_applied']
    e = data.motion_error()
    trans, rot = _translation_rotation(data)
    axis = data.motion_names.index(experiment.response_axis)
    deflection = -e[:, axis]                             # x - x_d
    held = data.window(off - experiment.steady_window, off)
    d_push = float(np.mean(deflection[held]))
    after = deflection[data.window(off)]
    overshoot = max(0.0, float(np.max(-np.sign(d_push) * after))) / abs(d_push) if d_push else None
    others = [i for i in trans if i != axis]
    return {'push_deflection_m': d_push, 'push_other_axes_m': float(np.max(np.abs(np.mean(e[held][:, others], axis=0)))),
            'push_other_axes_peak_m': float(np.max(np.abs(e[:, others]))),
            'push_rotation_max_rad': float(np.max(np.linalg.norm(e[:, rot], axis=1))) if rot else None,
            'push_return_overshoot': overshoot, 'push_on_s': on, 'push_off_s': off}


def pose_figures(data, experiment):
    """position_rms_m, orientation_rms_rad: RMS over the run of |x_d - x| and of the rotation error's norm."""
    e = data.motion_error()
    trans, rot = _translation_rotation(data)
    return {'position_rms_m': float(rms(np.linalg.norm(e[:, trans], axis=1))),
            'orientation_rms_rad': float(rms(np.linalg.norm(e[:, rot], axis=1)))}


def orientation_figures(data, experiment):
    """orientation_max_rad, orientation_rms_rad: the rotation error's norm over the run, largest and RMS."""
    _, rot = _translation_rotation(data)
    norm = np.linalg.norm(data.motion_error()[:, rot], axis=1)
    return {'orientation_max_rad': float(np.max(norm)), 'orientation_rms_rad': float(rms(norm))}


#: rad, the joint drift whose first crossing drift_figures times
DRIFT_MARK = 1e-3


def drift_figures(data, experiment):
    """joint_drift_max_rad: the largest |q - q(0)| over the joints and the run; drift_1mrad_after_s: when it
    first exceeded DRIFT_MARK (None: never); tip_drop_m: how far the tip went down over the run,
    tip_displacement_m: how far it went (the scenario's model, m)."""
    from robot_control import models, scenarios
    model = models.for_scenario(scenarios.get(experiment.scenario))
    p0, p1 = model.fk(data.q[0]), model.fk(data.q[-1])
    drift = np.max(np.abs(data.q - data.q[0]), axis=1)
    crossed = np.flatnonzero(drift > DRIFT_MARK)
    return {'joint_drift_max_rad': float(np.max(drift)),
            'drift_1mrad_after_s': float(data.t[crossed[0]] - data.t[0]) if crossed.size else None,
            'tip_drop_m': float(p0[2] - p1[2]), 'tip_displacement_m': float(np.linalg.norm(p1 - p0))}


HOLD_WINDOW = 10.0    # s: the end of a hold over which hold_figures measures the travel


def hold_figures(data, experiment):
    """last_10_s_travel_rad: the largest travel (max - min of the measured position) of a joint over the run's
    last HOLD_WINDOW s."""
    last = data.q[data.t >= data.t[-1] - HOLD_WINDOW]
    return {'last_10_s_travel_rad': float(np.max(np.ptp(last, axis=0)))}


def repetition_figures(data, experiment):
    """repetition_<i>_rms_rad: the RMS error over every joint of each out-and-back pair of the experiment's
    trajectory segments (i from 1; times after the run's origin), rad."""
    tr = experiment.trajectory
    ends = (0.0,) + tuple(tr.times)
    e, t = data.motion_error(), data.t
    out = {}
    for i in range(len(tr.times) // 2):
        inside = (t >= tr.t_start + ends[2 * i]) & (t < tr.t_start + ends[2 * i + 2])
        out[f'repetition_{i + 1}_rms_rad'] = float(np.sqrt(np.mean(e[inside] ** 2)))
    return out


IDENTIFY_WINDOW = 0.25   # s: the hold before the call and the run's end over which identify_figures measures the error


def identify_figures(data, experiment):
    """The first service call's payload (the controller's payload.mass and .com read after it) against the
    bridge's (experiment.bridge): payload_mass_kg, payload_mass_error (relative), payload_com_error_m (the
    distance); hold_error_before_rad / _after_rad: the largest RMS error of a joint over the IDENTIFY_WINDOW s
    before the call and over the run's last IDENTIFY_WINDOW s (None: the answer came after it began)."""
    call = data.calls[0]
    mass, com = call['parameters']['payload.mass'], np.asarray(call['parameters']['payload.com'])
    true_mass, true_com = experiment.bridge['payload.mass'], np.asarray(experiment.bridge['payload.com'])
    e, t = data.motion_error(), data.t

    def hold_error(t0, t1):
        inside = (t >= t0) & (t < t1)
        return float(np.max(rms(e[inside]))) if np.any(inside) else None
    after = t[-1] - IDENTIFY_WINDOW
    return {'payload_mass_kg': float(mass), 'payload_mass_error': float(mass / true_mass - 1.0),
            'payload_com_error_m': float(np.linalg.norm(com - true_com)),
            'hold_error_before_rad': hold_error(call['t_called'] - IDENTIFY_WINDOW, call['t_called']),
            'hold_error_after_rad': hold_error(after, t[-1] + 1.0) if call['t_answered'] <= after else None}


#: Experiment.figures name -> fn(data, experiment) -> {figure: value (SI; the name ends with its unit)}
FIGURES = {'push': push_figures, 'pose': pose_figures, 'orientation': orientation_figures, 'drift': drift_figures,
           'hold': hold_figures, 'repetitions': repetition_figures, 'identify': identify_figures}


def summarize(data, experiment, mode, duration, wall_time_s=None):
    """The summary.json dict of a run: the metrics of the module docstring plus the run's context."""
    motion_names, units = data.motion_names, data.motion_units
    e = data.motion_error()
    last = data.window(data.t[-1] - experiment.steady_window if data.samples else None)
    out = {
        'scenario': experiment.scenario,
        'experiment': experiment.name,
        'title': experiment.title,
        'mode': mode,
        'law': data.law,
        'duration_s': float(duration),
        'samples': int(data.samples),
        'coordinates': list(motion_names),
        'units': dict(zip(motion_names, units)),
        'rms_error': _named(motion_names, rms(e)),
        'max_error': _named(motion_names, np.max(np.abs(e), axis=0) if e.size else []),
        'final_error': _named(motion_names, np.abs(e[-1]) if e.size else []),
        'steady_state_error': _named(motion_names, np.mean(e[last], axis=0) if e.size else []),
        'settling_time_s': None,
        'force_axes': list(data.force_axes),
        'force_rms_error': None,
        'force_max_error': None,
        'force_steady_state_error': None,
        'force_settling_time_s': None,
        'saturated_ticks': None,
        'loop_rate_hz': None,
        'latency_p50_ms': None,
        'latency_p99_ms': None,
        'wall_time_s': None if wall_time_s is None else float(wall_time_s),
        'real_time_factor': None,
    }
    # the settling time refers to the change at settle_from, up to the next force reference event
    later = [t for t, _ in experiment.force_events if experiment.settle_from is not None and t > experiment.settle_from]
    until = data.window(None, min(later) - 1e-6) if later else np.ones(data.samples, dtype=bool)
    if experiment.settle_from is not None and e.size:
        times = [settling_time(data.t[until], e[until, i], experiment.settle_from) for i in range(e.shape[1])]
        out['settling_time_s'] = None if any(s is None for s in times) else max(times)
    if data.force_axes:
        f_d, f = data.force_reference(), data.force_measured()
        ef = f_d - f
        win = data.window(experiment.force_window)
        axes = data.force_axes
        out['force_rms_error'] = _named(axes, rms(ef[win]))
        out['force_max_error'] = _named(axes, _nanmax_abs(ef[win]))
        out['force_steady_state_error'] = _named(axes, _nanmean(ef[last]))
        if experiment.settle_from is not None:
            times = [settling_time(data.t[until], ef[until, i], experiment.settle_from) for i in range(ef.shape[1])]
            out['force_settling_time_s'] = None if any(s is None for s in times) else max(times)
        out['force_reference'] = _named(axes, f_d[-1])
    out['figures'] = {}
    for name in experiment.figures:
        out['figures'].update(FIGURES[name](data, experiment))
    if data.effort_limit is not None:
        sat = np.abs(data.tau_cmd) >= data.effort_limit * (1.0 - 1e-9)
        out['saturated_ticks'] = int(np.count_nonzero(sat.any(axis=1)))
    if data.cmd_wall_ns is not None and data.samples > 1:
        span = (data.cmd_wall_ns[-1] - data.cmd_wall_ns[0]) * 1e-9
        if span > 0:
            out['loop_rate_hz'] = float((data.samples - 1) / span)
            out['real_time_factor'] = float((data.t[-1] - data.t[0]) / span)
    if data.cmd_wall_ns is not None and data.state_wall_ns is not None and data.samples:
        lat = (data.cmd_wall_ns - data.state_wall_ns) * 1e-6
        lat = lat[np.isfinite(lat)]
        if lat.size:
            out['latency_p50_ms'] = float(np.percentile(lat, 50))
            out['latency_p99_ms'] = float(np.percentile(lat, 99))
    return out


def plot_data(data, experiment, title=''):
    """The input of robot_control.tools.plot.tracking_figure for a run."""
    mi = data.motion_index
    out = {'scenario': experiment.scenario, 't': data.t, 'title': title or experiment.name,
           'tau': data.tau_applied, 'tau_names': list(data.joints),
           'tau_units': [EFFORT_UNIT[u] for u in data.joint_units]}
    if data.effort_limit is not None:
        out['effort_limit'] = data.effort_limit
    if joint_space(data.law):
        out.update(joint_names=list(data.joints), units=list(data.joint_units), q=data.q,
                   q_d=data.ref_pos, e=data.err_pos)
    elif mi:
        x_d = data.ref_pos[:, mi]
        e = data.err_pos[:, mi]
        out.update(joint_names=list(data.motion_names), units=list(data.motion_units), q=x_d - e, q_d=x_d, e=e)
    else:  # 1-DOF force control: the joint's position, no position reference
        out.update(joint_names=list(data.joints), units=list(data.joint_units), q=data.q,
                   q_d=np.full_like(data.q, np.nan), e=np.full_like(data.q, np.nan))
    if data.force_axes:
        out.update(f=data.force_measured(), f_d=data.force_reference(), force_names=list(data.force_axes))
    return out


def format_summary(summary):
    """A human-readable table of a summary (the demo prints it)."""
    def fmt(v, unit=''):
        if v is None:
            return '-'
        if isinstance(v, dict):
            units = summary.get('units', {})
            parts = []
            for k, x in v.items():
                u = unit or units.get(k, '')
                parts.append(f'{k} {fmt(x)}{(" " + u) if u and x is not None else ""}')
            return ', '.join(parts) if parts else '-'
        if isinstance(v, float):
            if v == 0.0 or (1e-3 <= abs(v) < 1e5):
                return f'{v:.4g}'
            return f'{v:.3e}'
        return str(v)
    rows = [
        ('scenario', summary['scenario']), ('experiment', summary.get('experiment', '')),
        ('mode', summary['mode']), ('law', summary.get('law', '')),
        ('duration', f'{summary["duration_s"]:g} s sim, {summary["samples"]} ticks'),
        ('RMS error', fmt(summary['rms_error'])), ('max error', fmt(summary['max_error'])),
        ('final error', fmt(summary['final_error'])), ('steady-state error', fmt(summary['steady_state_error'])),
        ('settling time (2 %)', fmt(summary['settling_time_s'], 's') + (' s' if summary['settling_time_s'] is not None else '')),
    ]
    if summary.get('force_axes'):
        rows += [('force RMS error', fmt(summary['force_rms_error'], 'N')),
                 ('force max error', fmt(summary['force_max_error'], 'N')),
                 ('force steady-state error', fmt(summary['force_steady_state_error'], 'N'))]
    rows += [('saturated ticks', fmt(summary['saturated_ticks'])),
             ('loop rate', fmt(summary['loop_rate_hz']) + ' Hz' if summary['loop_rate_hz'] else '-'),
             ('real-time factor', fmt(summary.get('real_time_factor'))),
             ('latency p50 / p99', f'{fmt(summary["latency_p50_ms"])} / {fmt(summary["latency_p99_ms"])} ms')]
    width = max(len(r[0]) for r in rows)
    return '\n'.join(f'  {k:<{width}}  {v}' for k, v in rows)

