"""One episode of a sweep, in process: the rclpy-free Controller (robot_control.core.controller) and the
bridge's World and LockstepLoop (sim_bridge), exactly as the two nodes run in lockstep, without DDS.

Per control tick k (stamp t_k, s after the first state): the loop's measured state (q, qd, effort) and
wrench (the sensor model's: noise, encoder, delay), the Controller's step -> Command, the loop's
on_joint_command(t_k, joints, tau), which holds tau for control_period and publishes the state of
t_k+1. The experiment's trajectory is handed to the controller after its first state (start t_start,
as the demo stamps it), force references at their times, the bridge's run-time parameter changes
from the first tick at or past their time (the demo's pause_at).

The episode's metrics (one table row; coordinates as demo_metrics names them: joints, or task axes):
    rms_error, max_error, final_error   the largest over the motion coordinates of sqrt(mean e^2), max |e|,
                                        |e| at the last tick (each coordinate in its own unit: rad or m);
                                        per coordinate as <metric>.<coordinate>
    peak_torque                         max |tau| commanded over joints and ticks, N m or N
    saturated_ticks                     ticks with a command at its effort limit (any joint)
    force_rms_error, force_max_error    the largest over the force axes (N), NaN without force control
    stable                              every error and torque finite, no state refused, and every |e| at
                                        most the spec's stability_limit (rad or m, default 1): bounded
    passed                              stable and every criterion met (metric <= its limit)
"""
import dataclasses
import math
import os
import socket
import time
from pathlib import Path

import numpy as np
import yaml

from robot_control import units
from robot_control.core.controller import Command, Controller
from robot_control.param_table import flatten
from robot_control.ros import controller_params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.tools import demo_experiments, demo_metrics
from robot_control.tools import sweep_spec as specs
from robot_control.tools.demo import config_path, controller_params as experiment_controller_params
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params
from sim_bridge.bridge_loop import make_loop
from sim_bridge.engines import world_of_config

NS = units.NS_PER_S
SECTIONS = {'controller': '/**/controller', 'sim_bridge': '/**/sim_bridge'}
TASK_AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')       # the wrench's six entries (f, m), world axes
#: the columns that say how long and where an episode ran, not what it did (a replay may differ in them)
RUN_COLUMNS = ('wall_s', 'worker')
METRICS = ('rms_error', 'max_error', 'final_error', 'peak_torque', 'saturated_ticks', 'force_rms_error',
           'force_max_error', 'stable', 'passed')


# -- the experiment and the values both nodes start from ---------------------------------------------------
def experiment(spec):
    """The Experiment (demo_experiments) the spec describes: a demo experiment with the spec's changes,
    or one made of the spec's scenario, law, trajectory and duration."""
    t = spec.text
    if t.get('experiment'):
        try:
            exp = demo_experiments.get(t['experiment'])
        except ValueError as exc:
            raise ArgumentError('experiment', str(exc).partition(': ')[2]) from None
        if t.get('scenario', exp.scenario) != exp.scenario:
            raise ArgumentError('scenario', f'experiment {exp.name!r} runs {exp.scenario!r}')
    else:
        if 'duration' not in t:
            raise ArgumentError('duration', 'required when no experiment is named')
        exp = demo_experiments.Experiment(t.get('name', 'sweep'), t['scenario'], t.get('name', 'sweep'),
                                          duration=1.0, trajectory=None, settle_from=None)
    changes = {}
    if 'law' in t:
        changes.update(law=t['law'], controller={**exp.controller, 'law': t['law']})
    if 'duration' in t:
        changes['duration'] = _positive('duration', t['duration'])
    if 'trajectory' in t and t['trajectory'] != 'experiment':
        changes['trajectory'] = trajectory(t['trajectory'])
        changes['settle_from'] = None if changes['trajectory'] is None else changes['trajectory'].t_start
    for key in ('settle_from', 'steady_window'):
        if key in t:
            changes[key] = t[key]
    f_d = t.get('force')
    if f_d is not None:
        changes['force'] = tuple(float(f) for f in f_d)
    return dataclasses.replace(exp, **changes)


def _positive(name, value):
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0 or not math.isfinite(value):
        raise ArgumentError(name, f'expected a number > 0 (s), got {value!r}')
    return float(value)


def trajectory(text):
    """The spec's trajectory: None ('none') or {goal: [...] rad or m, duration: s, start: s (default 0.2)},
    a quintic move from rest to rest (the controller's trajectory through one point)."""
    if text in (None, 'none'):
        return None
    if not isinstance(text, dict) or 'goal' not in text or set(text) - {'goal', 'duration', 'start'}:
        raise ArgumentError('trajectory', "expected 'experiment', 'none' or {goal: [...], duration: s, start: s}")
    goal = tuple(float(v) for v in text['goal'])
    T = _positive('trajectory.duration', text.get('duration', 2.0))
    start = float(text.get('start', 0.2))
    if start < 0:
        raise ArgumentError('trajectory.start', f'expected >= 0 s, got {start}')
    return demo_experiments.TrajectorySpec(start, (T,), (goal,))


def parameter_file(name, scenario):
    """A spec's `config` entry: a file path, else a path under the package's config/ (realism/iiwa_typical.yaml),
    the directory of config/<scenario>.yaml."""
    path = Path(name)
    return path if path.is_file() else config_path(scenario).parent / name


@dataclasses.dataclass
class Plan:
    """What every episode of a spec shares: the spec, its Experiment, the base values of each node
    ({node: {name: value}}) and each node's table rows for the scenario ({node: Rows})."""

    spec: specs.Spec
    experiment: demo_experiments.Experiment
    values: dict
    tables: dict
    builder: ConfigBuilder = dataclasses.field(default_factory=ConfigBuilder)
    coordinates: tuple = ()               # the motion coordinates (per-coordinate metric columns)

    @property
    def ticks(self):
        """Control ticks answered per episode at the base control_period."""
        return ticks(self.experiment.duration, self.values['sim_bridge'].get('control_period', 0.001))


def ticks(duration, control_period):
    """Control ticks answered in an episode: t_k = k control_period for t_k = 0 .. duration (s)."""
    return int(round(duration / control_period)) + 1


TABLES = {'controller': controller_params.TABLE, 'sim_bridge': bridge_params.TABLE}


def plan(spec):
    """The Plan of a checked Spec; ArgumentError naming a bad key or parameter."""
    exp = experiment(spec)
    values = {node: {} for node in specs.NODES}
    for path in [config_path(exp.scenario)] + [parameter_file(f, exp.scenario) for f in spec.text.get('config') or ()]:
        try:
            doc = yaml.safe_load(Path(path).read_text()) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise ArgumentError('config', f'cannot read {path}: {exc}') from None
        for node, key in SECTIONS.items():
            values[node].update(flatten((doc.get(key) or {}).get('ros__parameters') or {}))
    values['controller'].update(experiment_controller_params(exp))
    values['sim_bridge'].update(exp.bridge)
    tables = {}
    for node, key in (('controller', 'controller'), ('sim_bridge', 'bridge')):
        own = dict(spec.text.get(key) or {})
        values[node].update(own)
        tables[node] = TABLES[node].resolve(lambda row, v=values[node]: v.get(row.name, row.default), check=False)[0]
        for name in own:
            if name not in tables[node]:
                raise ArgumentError(f'{key}.{name}', f'not a parameter of {node} for scenario {exp.scenario!r}')
    values['sim_bridge']['mode'] = 'lockstep'
    for dist in spec.samples:
        specs.node_of(dist.name, dist.node, tables)
    p = Plan(spec, exp, values, tables)
    nominal = p.builder(controller_params.TABLE.validate(values['controller']))
    bridge_params.validate(values['sim_bridge'])
    p.coordinates = tuple(a for a in core_names(nominal) if a not in force_axes(nominal))
    episode_values(p, 0)          # every distribution fits its parameter (bounds per entry, scalar or array)
    return p


def columns(p):
    """The table's columns, in order: episode, seed, the sampled values, the metrics, ticks, wall_s, worker,
    error."""
    seed, values, sampled = episode_values(p, 0)
    per = [f'{key}.{c}' for key in ('rms_error', 'max_error', 'final_error') for c in p.coordinates]
    return ['episode', 'seed', *sampled, *METRICS, *per, 'ticks', *RUN_COLUMNS, 'error']


def episode_values(p, k):
    """(seed, {node: values}, {column: sampled value}) of episode k."""
    seed = specs.episode_seed(p.spec.seed, k)
    drawn = specs.sample(p.spec, k, p.values, p.tables)
    bridge = dict(p.values['sim_bridge'])
    if 'seed' not in (p.spec.text.get('bridge') or {}):
        bridge['seed'] = seed
    values = {'controller': {**p.values['controller'], **drawn['controller']},
              'sim_bridge': {**bridge, **drawn['sim_bridge']}}
    return seed, values, specs.flat_columns(p.spec, drawn)


# -- one episode ---------------------------------------------------------------------------------------------
class Trace:
    """The per-tick arrays of an episode (preallocated, `ticks` rows)."""

    def __init__(self, ticks, n, m):
        self.k = 0
        self.t = np.full(ticks, np.nan)
        self.q, self.qd, self.tau_a, self.tau_c = (np.full((ticks, n), np.nan) for _ in range(4))
        self.rp, self.rv, self.ra, self.ep, self.ev = (np.full((ticks, m), np.nan) for _ in range(5))
        self.f = np.full((ticks, 3), np.nan)

    def add(self, t, q, qd, effort, tau, core, force):
        k = self.k
        self.t[k] = t
        self.q[k], self.qd[k], self.tau_a[k], self.tau_c[k] = q, qd, effort, tau
        (self.rp[k], self.rv[k], self.ra[k]), (self.ep[k], self.ev[k]) = core.reference, core.error
        self.f[k] = force
        self.k = k + 1

    def run_data(self, exp, ccfg, ref_names):
        """demo_metrics.RunData of the ticks recorded."""
        k = self.k
        cut = (lambda a: a[:k])
        axes = force_axes(ccfg)
        return demo_metrics.RunData(
            t=cut(self.t), joints=exp.joints, joint_units=exp.units, q=cut(self.q), qd=cut(self.qd),
            tau_applied=cut(self.tau_a), tau_cmd=cut(self.tau_c), ref_names=ref_names, ref_pos=cut(self.rp),
            ref_vel=cut(self.rv), ref_acc=cut(self.ra), err_pos=cut(self.ep), err_vel=cut(self.ev),
            force_xyz=cut(self.f), force_axes=axes, force_axis_index=tuple(TASK_AXES.index(a) for a in axes),
            law=ccfg.law, effort_limit=np.asarray(ccfg.effort_limit))


def simulate(exp, ccfg, bvals, state_timeout, ticks):
    """Run the lockstep loop for `ticks` answered states of the controller of ControllerConfig `ccfg` and
    the bridge of checked values `bvals`: (Trace, refused) where refused is the reason of a state the
    controller refused (the run stops there) or ''."""
    bcfg = bridge_params.build(bvals)
    controller = Controller(ccfg, state_timeout)
    core = controller.core
    names = list(bcfg.joints)
    wrench_index = [TASK_AXES.index(a) for a in ccfg.model.task_axes] if controller.needs_wrench else None
    world = world_of_config(bcfg)
    try:
        loop = make_loop(world, bcfg, publish_state=lambda in_loop, with_clock: 0, count_publishers=lambda: (1, 0),
                         publish_diagnostics=lambda: None, log=lambda level, text: None, clock=lambda: 0)
        loop.start()
        m = loop.measured
        trace = Trace(ticks, bcfg.n, len(core.reference_names))
        forces = list(exp.force_events)
        events = list(exp.bridge_events)
        for k in range(ticks):
            stamp = m.t_ns
            q, qd, effort = m.state_values()
            f, moment = m.contact_wrench()
            wrench = None if wrench_index is None else np.concatenate([f, moment])[wrench_index]
            result = controller.step(stamp, names, q, qd, wrench)
            if not isinstance(result, Command):
                return trace, result.reason
            if k == 0 and exp.trajectory is not None:
                tr = exp.trajectory
                core.set_trajectory(tr.times, tr.positions, tr.velocities, tr.accelerations, t_start=tr.t_start)
            if forces and core.force_pending is None:
                t_f, f_d = forces.pop(0)
                core.set_force_reference(f_d, t_start=t_f)
            trace.add(stamp / NS, q, qd, effort, result.tau, core, f)
            if events and world.t_ns >= units.to_ns(events[0][0]):
                loop.configure(bridge_params.validate({**bvals, **events.pop(0)[1]}))
            loop.on_joint_command(stamp, names, result.values)
        return trace, ''
    finally:
        world.close()


def run(p, k, keep=False):
    """Episode k of Plan p: its table row ({column: value}) and, with `keep`, its demo_metrics.RunData."""
    seed, values, columns = episode_values(p, k)
    row = {'episode': k, 'seed': seed, **columns, 'worker': f'{socket.gethostname()}/{os.getpid()}'}
    t0 = time.perf_counter()
    try:
        cvals = controller_params.TABLE.validate(values['controller'])
        bvals = bridge_params.TABLE.validate(values['sim_bridge'])
        ccfg = p.builder(cvals)
        n = ticks(p.experiment.duration, bvals['control_period'])
        trace, refused = simulate(p.experiment, ccfg, bvals, cvals['state_timeout'], n)
    except ValueError as exc:        # a draw a parameter's rules refuse (ArgumentError naming it), a World refused
        row.update(metrics_of(None, p, error=str(exc)))
        return (row, None) if keep else row
    data = trace.run_data(p.experiment, ccfg, core_names(ccfg))
    row.update(metrics_of(data, p, error=refused and f'state refused: {refused}'))
    row['wall_s'] = time.perf_counter() - t0
    return (row, data) if keep else row


def force_axes(ccfg):
    """The force-controlled axes of a ControllerConfig whose law uses force (demo: the same rule), else ()."""
    return ccfg.control_law.force_task.force_axes


def core_names(ccfg):
    return tuple(ccfg.control_law.reference_names)


def _largest(named):
    """The largest value of a demo_metrics {coordinate: value} dict (NaN when empty or None)."""
    values = [v for v in (named or {}).values() if v is not None]
    return float(np.max(values)) if values else math.nan


def stable(data, limit):
    """The stability verdict of a run: errors and torques finite, every |e| <= limit (rad or m)."""
    e = data.motion_error()
    return bool(np.all(np.isfinite(e)) and np.all(np.isfinite(data.tau_cmd)) and np.all(np.abs(e) <= limit))


def metrics_of(data, p, error=''):
    """The metrics columns of an episode (module docstring); `data` None: it did not run (error says why)."""
    names = [] if data is None else list(data.motion_names)
    out = {name: math.nan for name in METRICS}
    out.update({f'{key}.{c}': math.nan for key in ('rms_error', 'max_error', 'final_error') for c in p.coordinates})
    out.update(stable=False, passed=False, error=error or '', ticks=0, wall_s=math.nan)
    if data is None or not data.samples:
        return out
    exp = p.experiment
    out['ticks'] = int(data.samples)
    s = demo_metrics.summarize(data, exp, 'lockstep', exp.duration)
    for key in ('rms_error', 'max_error', 'final_error', 'force_rms_error', 'force_max_error'):
        out[key] = _largest(s[key])
    out['peak_torque'] = float(np.nanmax(np.abs(data.tau_cmd)))
    out['saturated_ticks'] = int(s['saturated_ticks'] or 0)
    out['stable'] = not error and stable(data, p.spec.stability_limit)
    out['passed'] = out['stable'] and all(out[k] <= limit for k, limit in p.spec.criteria.items())
    for key in ('rms_error', 'max_error', 'final_error'):
        out.update({f'{key}.{c}': math.nan if v is None else float(v) for c, v in zip(names, s[key].values())})
    return out
