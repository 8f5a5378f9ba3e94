"""The demo: the lecture's control laws driving a simulated robot over DDS.

    python -m robot_control.demo --scenario polar_two_link          # what `make demo` runs
    python -m robot_control.demo --scenario iiwa --mode realtime --duration 5
    python -m robot_control.demo --experiment disturbance_pid --no-plot
    python -m robot_control.demo --all                               # every experiment, for docs/results.md
    python -m robot_control.demo --experiment iiwa_ptp --realism typical   # the arm as published, not as modelled
    python -m robot_control.demo --all --engine both                 # every experiment on PyBullet and MuJoCo

A run starts two OS processes, `sim_bridge_node` (the robot, on PyBullet or `--engine mujoco`) and `controller_node`,
each with `--ros-args --params-file config/<scenario>.yaml` plus the experiment's overrides, on a
DDS domain of its own with discovery limited to this machine. In this process it runs the
experiment's reference publisher, the metrics collector and the rosbag2 recorder. It prints a
progress line per second, stops every process it started (by pid, also on Ctrl-C, SIGTERM or an
error), prints a summary table and writes `out/demo/<name>/`: `summary.json` (the metrics of
robot_control.tools.demo_metrics, the run's domain, expected ticks and lost messages),
`tracking.png`, `bag/` (mcap, every topic) and `logs/` (the two nodes' output).
`--realism typical` also gives the bridge config/realism/<scenario>_typical.yaml after the scenario's file
(friction, masses, sensor noise and delay; the controller keeps its model), into out/demo/<name>_typical/.
`--engine mujoco` runs the bridge on MuJoCo (its parameter `engine`), into out/demo/<name>_mujoco/; `--engine
both` runs each experiment on both engines and ends with a side-by-side table (side_by_side): tracking RMS and
steady contact force per engine, flagged where they differ by more than RMS_ATOL and RMS_RTOL / FORCE_RTOL.

Modes: `lockstep` (the default) is deterministic -- the bridge steps only when the command for the
current state has arrived, so the same run gives the same numbers every time, on any machine; it
runs as fast as the three processes allow (the progress line shows the rate of control ticks per
second). It always shows the lecture's result (the step follows e0 (1 + 6t) exp(-6t) within
0.2 %), however loaded the machine. `realtime` paces the physics to the wall clock with the latest
command held (brakes if commands go stale): what a real robot would see, timing included; a
controller that cannot answer every 1 ms tick degrades the response accordingly.

A run, all waits bounded: start the recorder; start the bridge and pause it; start the controller
and wait until it is connected; wait for the first tick of every stream (t = 0 is the origin in
lockstep); send the experiment's references stamped at origin + t (the controller confirms in its
log) and resume; run for `duration` s of simulation, sending the later force references and changing
the bridge's run-time parameters while the bridge stands still at simulation times (pause_at, make the
change, resume: Schedule); pause, wait for the last tick, stop the recorder and the processes; align the
collected messages per control tick; compute the metrics, plot (robot_control.tools.plot.tracking_figure),
write the files.
"""
import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from robot_control import scenarios, units
from robot_control.laws import LAWS
from robot_control.tools import demo_experiments as experiments
from robot_control.tools.demo_experiments import realism_profile
from robot_control.tools import demo_metrics
from robot_control.tools import processes as procs

NS = units.NS_PER_S
ROOT = experiments.ROOT
#: extra arguments of sim_bridge_node before --ros-args (e.g. ('--executor', 'single'))
BRIDGE_ARGS = ()
STARTUP_TIMEOUT = 60.0    # s of wall time for a node to come up (Pinocchio/PyBullet imports)
STALL_TIMEOUT = 20.0      # s of wall time without simulation progress -> error
#: s of wall time to wait for the run's last tick. A sample the collector missed (its process starved of
#: CPU) is re-sent only after the writer's next heartbeat, every 3 s in Fast DDS, and the reliable reader
#: holds every later sample until then: waiting longer than a heartbeat period turns a "lost" tail
#: into a complete run (see robot_control.ros.qos.PUBLISHER_DEPTH).
REPAIR_TIMEOUT = 8.0
#: the streams of a tick, each seen once before the run starts (see _run)
FIRST_TICK = ('/joint_states', '/robot_joint_commands', '/controller/reference', '/controller/error',
              '/ft_sensor/wrench')
CONFIRM_TIMEOUT = 10.0    # s for the controller to confirm a reference
CALL_TIMEOUT = 600.0      # s of wall time for a service call of the experiment to answer (payload_service.TIMEOUT)
#: the physics engines of --engine (the first is the bridge's default); 'both' runs each
ENGINES = ('pybullet', 'mujoco')
#: engines agree on tracking when their RMS differ by < RMS_ATOL (rad or m) or < RMS_RTOL of the larger,
#: on force when their steady forces differ by < FORCE_RTOL of the larger
RMS_ATOL, RMS_RTOL, FORCE_RTOL = 1e-3, 0.10, 0.05


@dataclass
class RunResult:
    summary: dict
    data: object = None                 # demo_metrics.RunData
    out_dir: Path = None
    bag: Path = None
    bag_counts: dict = field(default_factory=dict)
    exit_codes: dict = field(default_factory=dict)


def config_path(scenario):
    """config/<scenario>.yaml of this checkout, else of the installed package (share/robot_control/config);
    a `scenario` ending in .yaml is the path of a parameter file of one's own (a robot of no scenario)."""
    if str(scenario).endswith('.yaml'):
        return Path(scenario)
    path = experiments.config_file(f'{scenario}.yaml')
    if path is None:
        raise ValueError(f'scenario: no parameter file {scenario}.yaml in {ROOT / "config"} or the install')
    return path


def param_value(value):
    """A parameter value as a `-p name:=value` YAML literal (numbers are doubles with a decimal point, but an
    experiments.Integer)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, experiments.Integer):
        return str(int(value))
    if isinstance(value, (int, float)):
        return repr(float(value))
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(param_value(v) for v in value) + ']'
    return str(value)


def node_argv(module, scenario, params, extra=(), profiles=()):
    """The command line of `module` with the scenario's parameter file, then each of `profiles` (stacked: a later
    file sets only the names it holds), then `params` as -p overrides (they win over every file)."""
    argv = procs.python_module(module, *extra, '--ros-args', '--params-file', str(config_path(scenario)))
    for path in profiles:
        argv += ['--params-file', str(path)]
    for name, value in params.items():
        argv += ['-p', f'{name}:={param_value(value)}']
    return argv


def force_axes_of(scenario):
    """(names, wrench index 0..2) of the scenario's force-controlled task axes."""
    from robot_control.models import CLOSED_FORM
    from robot_control.ros.conversions import WRENCH_AXES
    sc = scenarios.get(scenario)
    task_axes = ('x', 'y', 'z') if sc.model == 'urdf' else CLOSED_FORM[sc.model].task_axes
    names = tuple(task_axes[i] for i in sc.force_axes)
    return names, tuple(WRENCH_AXES.index(a) for a in names)


def effort_limit_fallback(scenario):
    """{joint: limit} from the scenario's YAML (controller effort_limits) or the model."""
    import yaml
    sc = scenarios.get(scenario)
    try:
        doc = yaml.safe_load(config_path(scenario).read_text())
        limits = doc['controller']['ros__parameters'].get('effort_limits')
    except (OSError, KeyError, TypeError, yaml.YAMLError):
        limits = None
    if not limits:
        from robot_control import models
        limits = models.for_scenario(sc).effort_limit.tolist()
    return dict(zip(sc.joints, (float(v) for v in limits)))


def time_ranges(times, step=0.001 + 1e-9):
    """[[first, last], ...] runs of consecutive tick times (s)."""
    out = []
    for t in times:
        if out and t - out[-1][1] <= step:
            out[-1][1] = t
        else:
            out.append([t, t])
    return out


class Progress:
    """One line per second of wall time: simulation time, tracking error, force, rate."""

    def __init__(self, collector, origin_ns, units, force_axes, write=print):
        self.collector = collector
        self.origin_ns = origin_ns
        self.units = units
        self.force_axes = force_axes
        self.write = write
        self.last_wall = time.monotonic()
        self.last_ticks = collector.count('/robot_joint_commands')

    def maybe(self):
        now = time.monotonic()
        if now - self.last_wall < 1.0 or self.write is None:
            return
        ticks = self.collector.count('/robot_joint_commands')
        rate = (ticks - self.last_ticks) / (now - self.last_wall)
        self.last_wall, self.last_ticks = now, ticks
        err, ref = self.collector.latest('/controller/error'), self.collector.latest('/controller/reference')
        stamp = self.collector.last_stamp_ns()
        if err is None or stamp is None:
            return
        t = (stamp - self.origin_ns) / NS
        parts = []
        for i, name in enumerate(err.name):
            if name in self.force_axes:
                f_d = ref.position[i] if ref is not None and len(ref.position) > i else math.nan
                parts.append(f'f_{name} {f_d - err.position[i]:7.3f} N (f_d {f_d:.2f})')
            else:
                parts.append(f'e_{name} {err.position[i]:+.2e} {self.units.get(name, "")}'.rstrip())
        self.write(f'  t = {t:6.2f} s  ' + '  '.join(parts) + f'  | {rate:5.0f} ticks/s', flush=True)


def output_name(name, realism='ideal', engine='pybullet'):
    """Directory name of a run's outputs: demo_experiments.output_name, with _<engine> but for the default engine."""
    base = experiments.output_name(name, realism)
    return base if engine == ENGINES[0] else f'{base}_{engine}'


def run(experiment, mode='lockstep', duration=None, out_dir=None, record=True, plot=True, domain_id=None,
        write=print, keep_data=True, realism='ideal', engine='pybullet'):
    """Run `experiment` (an Experiment or a name) end to end; returns a RunResult. See the module docstring.

    mode 'lockstep' | 'realtime'; duration s of simulation (default the experiment's); out_dir default
    out/demo/<name>; record: bag/; plot: tracking.png; domain_id: ROS_DOMAIN_ID of the run (default: a
    free one of procs.PRIVATE_DOMAIN_IDS); write: print-like function for progress (None: quiet);
    keep_data: keep the per-tick RunData in the result; realism: 'ideal' or 'typical' (the bridge also reads
    realism_profile(scenario, realism); out_dir default out/demo/<name>_typical); engine: the bridge's physics
    engine, one of ENGINES (out_dir default out/demo/<name>_<engine> but for pybullet).
    """
    if isinstance(experiment, str):
        experiment = experiments.get(experiment)
    if mode not in ('lockstep', 'realtime'):
        raise ValueError(f"mode: expected 'lockstep' or 'realtime', got {mode!r}")
    if engine not in ENGINES:
        raise ValueError(f'engine: expected one of {list(ENGINES)}, got {engine!r}')
    duration = experiment.duration if duration is None else float(duration)
    if not duration > 0:
        raise ValueError(f'duration: expected > 0 s, got {duration}')
    profile = realism_profile(experiment.scenario, realism)
    out_dir = Path(out_dir if out_dir is not None
                   else ROOT / 'out' / 'demo' / output_name(experiment.name, realism, engine))
    out_dir.mkdir(parents=True, exist_ok=True)
    claim = None
    if domain_id is None:   # a private id, claimed for the run
        claim = procs.private_domain()
        domain_id = claim.acquire()
    try:
        return _run(experiment, mode, duration, out_dir, record, plot, int(domain_id), write, keep_data,
                    (realism, profile), engine)
    finally:
        if claim is not None:
            claim.release()


def _run(experiment, mode, duration, out_dir, record, plot, domain_id, write, keep_data, realism, engine):
    from robot_control.tools import demo_ros
    env = procs.ros_env(domain_id)
    # this process joins the same private domain, loopback only, before rclpy reads the environment
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_STATIC_PEERS', None)
    scenario = experiment.scenario
    joints = experiment.joints
    units = dict(zip(joints, experiment.units))
    law = experiment.law
    f_names, f_index = force_axes_of(scenario) if LAWS[law].uses_force else ((), ())
    if LAWS[law].tracks == 'task':
        units = dict(zip(experiment.task_axes, demo_metrics.task_units(experiment.task_axes)))

    say = write or (lambda *a, **k: None)
    result = RunResult(summary={}, out_dir=out_dir)
    t_wall0 = time.monotonic()
    with LiveRun(domain_id, env, out_dir / 'logs', say) as live:
        if record:
            live.start_recording(out_dir / 'bag')
        say(f'[demo] {experiment.name} ({scenario}, {mode}, {duration:g} s, {describe_realism(*realism)}, {engine}): '
            f'ROS_DOMAIN_ID={domain_id}, discovery LOCALHOST', flush=True)
        live.start_nodes(scenario, {'mode': mode, 'engine': engine, **experiment.bridge}, controller_params(experiment),
                         [realism[1]] if realism[1] else [])
        origin_ns = live.wait_for_first_tick(mode)
        live.send_references(joints, experiment.trajectory, origin_ns)
        changes = Schedule(experiment.bridge_events, origin_ns, say, experiment.force_events, f_names,
                           experiment.service_calls)
        changes.arm(live)
        live.resume()
        end_ns = origin_ns + int(round(duration * NS))
        progress = Progress(live.collector, origin_ns, units, f_names, say if write else None)
        say(f'[demo] running {duration:g} s of simulation from t = {origin_ns / NS:.3f} s', flush=True)
        live.run_until(end_ns, (changes,), progress)
        live.pause()
        wall = time.monotonic() - t_wall0
        live.wait_for_last_tick(end_ns)
        limits, _ = demo_ros.controller_diagnostics(live.collector)
        if not limits:
            limits = effort_limit_fallback(scenario)
        if record:
            result.bag_counts, result.bag = live.stop_recording(), out_dir / 'bag'
        result.exit_codes = live.stop_nodes()
        data = demo_ros.align(live.collector, joints, experiment.units, f_names, f_index, law, origin_ns, end_ns,
                              limits, lockstep=mode == 'lockstep')
        data.events, data.calls = changes.applied, changes.calls
    result.summary = summarize_run(data, experiment, mode, duration, wall, domain_id, record, plot, say)
    result.summary['realism'] = realism[0]
    result.summary['engine'] = engine
    result.summary['realism_profile'] = None if realism[1] is None else relative_to_root(realism[1])
    title = f'{law}, {mode}' + ('' if realism[0] == 'ideal' else f', {realism[0]} robot') + \
        ('' if engine == ENGINES[0] else f', {engine}')
    write_outputs(out_dir, result.summary, data, experiment, title if plot else None)
    result.data = data if keep_data else None
    return result


def describe_realism(realism, profile):
    """'ideal', or the profile stacked on the bridge (a scenario without one runs as its ideal robot)."""
    if realism == 'ideal':
        return 'ideal robot'
    if profile is None:
        return f'{realism}: no realism profile for this scenario, the ideal robot'
    return f'{realism} robot: {relative_to_root(profile)}'


def relative_to_root(path):
    """`path` relative to the checkout (config/realism/...) when inside it, else as it is."""
    path = Path(path)
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def controller_params(experiment):
    """The controller's parameter overrides of `experiment`: its own, and f_d of its initial force."""
    params = dict(experiment.controller)
    if experiment.force is not None:
        params['f_d'] = list(experiment.force)
    return params


class Schedule:
    """The experiment's timed changes, each made while the bridge stands still: changes of its run-time
    parameters ((t, {name: value}), ...), force references ((t, f per axis), ...) and service calls ((t,
    std_srvs/Trigger service, started, (controller parameter, ...)), ...). The bridge pauses itself at the next change's
    time (its pause_at, armed for the next change), the changes due are made and it resumes.

    A service call is made while the bridge stands at the tick it paused at, and once the controller has logged
    the call's `started` text (the work begins at that tick: runs repeat exactly) the bridge runs on, pause_at
    disarmed, until the service answers (its work may need the simulation: ~/identify_payload moves the arm);
    then the named parameters of the controller are read and pause_at is armed for the next change (one already
    past is made at once). `calls` lists them: [{'t': t s, 't_called': the tick (s) the bridge stood at,
    't_answered': the tick the answer names (robot_control.ros.payload_service.answered_text; else the newest tick seen when
    it arrived, which a busy machine makes late), 'service', 'success', 'message', 'parameters': {name: value}}].

    A parameter change acts from the tick the bridge paused at (its step to the next tick is the first with
    it), the first tick at or past t; `applied` lists them: [{'t': t s, 't_applied': that tick, s,
    'parameters': {name: value}}]. A force reference is sent stamped with its time t while the bridge stands
    before t (the first by `arm`, before the run starts; each later one at the midpoint between the one
    before it and t) and the controller confirms that it holds it: it applies it at exactly the first tick at
    or past t, however late the wall clock would have delivered it, so lockstep runs repeat exactly."""

    BRIDGE, FORCE, CALL = 1, 0, 2     # the order of changes at one time: force reference, parameters, call

    def __init__(self, events, origin_ns, say, forces=(), axes=(), calls=()):
        self.origin_ns = origin_ns
        self.say = say
        self.axes = axes
        forces = sorted(forces)
        sent = [0.0] + [0.5 * (a[0] + b[0]) for a, b in zip(forces, forces[1:])]
        changes = ([(s, self.FORCE, t, f) for s, (t, f) in zip(sent, forces)]
                   + [(t, self.BRIDGE, t, values) for t, values in events]
                   + [(t, self.CALL, t, (service, started, tuple(names))) for t, service, started, names in calls])
        self.events = sorted(changes, key=lambda change: change[:2])
        self.applied = []
        self.calls = []

    def _due_ns(self):
        """The simulation time, ns, of the next change."""
        return self.origin_ns + int(round(self.events[0][0] * NS))

    def _pause_at(self):
        """{'pause_at': the next change's simulation time, s (-1: none left)}."""
        return {'pause_at': self._due_ns() / NS if self.events else -1.0}

    def arm(self, live):
        """Make the changes due at the origin and set the bridge's pause_at for the next (before the run
        resumes)."""
        if self.events:
            self._make_due(live, self.origin_ns)

    def send_due(self, live, stamp_ns):
        """Make what is due once the simulation has reached `stamp_ns` (ns), through `live` (a LiveRun)."""
        if self.events and stamp_ns >= self._due_ns():
            live.pause()                     # paused already by pause_at; a no-op then
            self._make_due(live, live.paused_at())
            live.resume()

    def _make_due(self, live, paused_ns):
        """The changes due at the tick `paused_ns` (ns) the bridge stands at, and pause_at for the next."""
        values = {}
        while self.events and paused_ns >= self._due_ns():
            _, kind, t_ev, change = self.events.pop(0)
            t_now = (paused_ns - self.origin_ns) / NS
            if kind == self.FORCE:
                live.send_force(self.axes, change, self.origin_ns + int(round(t_ev * NS)))
                self.say(f'[demo] force reference {dict(zip(self.axes, change))} N from t = {t_ev:.3f} s (sent at '
                         f't = {t_now:.3f} s)', flush=True)
                continue
            if kind == self.CALL:
                live.control.set_bridge_parameters({**values, 'pause_at': -1.0}, poll=live.alive)
                values = {}
                self._call(live, t_ev, t_now, *change)
                continue
            values.update(change)
            self.applied.append({'t': t_ev, 't_applied': t_now, 'parameters': dict(change)})
            self.say(f'[demo] bridge parameters {change} from t = {t_now:.3f} s (due at t = {t_ev:.3f} s)',
                     flush=True)
        live.control.set_bridge_parameters({**values, **self._pause_at()}, poll=live.alive)

    def _call(self, live, t_ev, t_now, service, started, names):
        """Call `service`, the bridge standing until the controller logs `started` and then running until the
        service answers; record the answer and the controller's parameters `names` in `calls`."""
        from robot_control.ros.payload_service import answered_stamp_ns
        self.say(f'[demo] calling {service} at t = {t_now:.3f} s (due at t = {t_ev:.3f} s)', flush=True)
        control, mark = live.control, len(live.control.log)
        future = control.call_trigger(service, poll=live.alive)
        control.spin_until(lambda: future.done() or control.controller_said(started, mark) is not None,
                           CONFIRM_TIMEOUT, live.alive, f'the controller to start {service}')
        live.resume()
        control.spin_until(future.done, CALL_TIMEOUT, live.alive, f'{service} to answer')
        success, message = bool(future.result().success), future.result().message
        answered_ns = answered_stamp_ns(message)
        if answered_ns is None:                  # an answer naming no tick: the newest the collector has seen
            answered_ns = live.collector.last_stamp_ns() or 0
        t_answered = (answered_ns - self.origin_ns) / NS
        params = live.control.get_parameters('controller', names, poll=live.alive) if names else {}
        self.calls.append({'t': t_ev, 't_called': t_now, 't_answered': t_answered, 'service': service,
                           'success': success, 'message': message, 'parameters': params})
        self.say(f'[demo] {service} answered by t = {t_answered:.3f} s: {"" if success else "failed: "}{message}',
                 flush=True)


class LiveRun:
    """This process's side of a run on a private domain: the collector and the run control spun by
    one EventsExecutor, the recorder, and the two node processes. Leaving the `with` block stops
    the recorder and every child and shuts the context down, also on an error or an interrupt."""

    def __init__(self, domain_id, env, logs, say):
        from robot_control.ros.spin import make_executor
        from robot_control.tools import demo_ros
        self.env, self.logs, self.say = env, logs, say
        self.children = procs.ProcessSet()
        self.bridge = self.controller = None
        self.collector = self.control = self.recorder = self.executor = None
        self.ctx = demo_ros.context_with_domain(domain_id)
        try:
            self.executor = make_executor('events', context=self.ctx)
            self.collector = demo_ros.Collector(self.ctx, self.executor, name=f'demo_collector_{domain_id}')
            self.control = demo_ros.RunControl(self.ctx, self.executor, name=f'demo_{domain_id}')
        except BaseException:
            self.close()
            raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def alive(self):
        """Raise the interruption of a signal received, or ProcessError if a child has exited."""
        procs.check_interrupted()
        self.children.check_alive()

    def start_recording(self, bag):
        """Record every topic of the run (and any other that appears) into `bag`, replacing an old bag."""
        from robot_control.tools import demo_ros
        from robot_control.tools.record import Recorder
        self.recorder = Recorder(self.control.node, bag, [f'{t}:{ty}' for t, ty in demo_ros.RUN_TOPICS.items()],
                                 all_topics=True, discovery_timeout=0.0, overwrite=True, depth=demo_ros.DEPTH)
        self.recorder.start()

    def stop_recording(self):
        """Close the bag; {topic: messages written}."""
        return self.recorder.stop()

    def start_nodes(self, scenario, bridge_params, controller_params, bridge_profiles=()):
        """Start the bridge (the scenario's file, then `bridge_profiles`, stacked) and pause it once it is up,
        start the controller (in lockstep with wrench_wait 0: each state waits for its own tick's wrench however
        late a busy machine hands it over), wait until it is connected."""
        control, collector = self.control, self.collector
        if bridge_params.get('mode') == 'lockstep':    # the bridge waits for the command: no hurry for a wrench
            controller_params = {'wrench_wait': 0.0, **controller_params}
        self.bridge = self._start('sim_bridge', 'sim_bridge.bridge_node', scenario, bridge_params, BRIDGE_ARGS,
                                  bridge_profiles)
        control.spin_until(lambda: (collector.publishers('/joint_states') > 0
                                    and control.pause_client.service_is_ready()),
                           STARTUP_TIMEOUT, self.alive, 'the simulator bridge to start')
        self.pause()
        self.controller = self._start('controller', 'robot_control.ros.controller_node', scenario, controller_params)
        self.say(f'[demo] started sim_bridge (pid {self.bridge.pid}) and controller (pid {self.controller.pid})',
                 flush=True)
        control.spin_until(self._connected, STARTUP_TIMEOUT, self.alive, 'the controller to connect')

    def _start(self, name, module, scenario, params, extra=(), profiles=()):
        """Start `python -m module` with the scenario's parameter file, `profiles` and `params`; output to
        logs/<name>.log."""
        return self.children.start(name, node_argv(module, scenario, params, extra, profiles), self.env,
                                   self.logs / f'{name}.log', cwd=ROOT)

    def _connected(self):
        return (all(self.collector.publishers(t) > 0 for t in
                    ('/robot_joint_commands', '/controller/reference', '/controller/error'))
                and self.control.traj_pub.get_subscription_count() > 0
                and self.control.subscribed('/joint_states', 'controller'))

    def wait_for_first_tick(self, mode):
        """Wait until a sample of every stream of a tick has arrived; returns the run's origin, ns."""
        # the paused bridge re-publishes its state every 0.1 s: the controller answers while the world stands still.
        # A sample of every stream of the tick must have arrived: a publisher sends ~/reference, ~/error and the
        # wrench only once its own side has matched the collector (DDS discovers the two sides independently), so
        # seeing the publisher here is not enough to be sure the first tick's samples are sent
        self.control.spin_until(lambda: all(self.collector.count(t) > 0 for t in FIRST_TICK), STARTUP_TIMEOUT,
                                self.alive, 'the first state, command, reference, error and wrench')
        if mode == 'lockstep':
            return 0   # the bridge steps only once the command for t = 0 has arrived
        # physics ran (braked) from the bridge's start until the pause: start 50 ms on
        return (self.collector.last_stamp_ns() or 0) + NS // 20

    def send_references(self, joints, trajectory, origin_ns):
        """Send `trajectory` (a TrajectorySpec or None) stamped at origin + its t_start and wait for the
        controller to accept it (RuntimeError if it rejects it)."""
        control = self.control
        mark = len(control.log)
        if trajectory is not None:
            stamp = origin_ns + int(round(trajectory.t_start * NS))
            last = self.collector.last_stamp_ns() or 0
            if stamp <= last:
                raise RuntimeError(f'trajectory start {stamp / NS:.3f} s is already past (t = {last / NS:.3f} s)')
            control.send_trajectory(joints, trajectory, stamp)
            control.spin_until(lambda: control.controller_said('trajectory accepted', mark) is not None
                               or control.controller_rejections(mark), CONFIRM_TIMEOUT, self.alive,
                               'the controller to accept the trajectory')
            if control.controller_rejections(mark):
                raise RuntimeError(f'controller rejected the trajectory: {control.controller_rejections(mark)}')

    def send_force(self, axes, values, stamp_ns):
        """Send a force reference (f per axis of `axes`, N) stamped `stamp_ns` and wait for the controller to
        log that it took it (RuntimeError if it rejects it)."""
        control = self.control
        control.spin_until(lambda: control.wrench_pub.get_subscription_count() > 0, STARTUP_TIMEOUT, self.alive,
                           'the controller to subscribe to its wrench reference')
        mark = len(control.log)
        control.send_force(axes, values, stamp_ns=stamp_ns)
        control.spin_until(lambda: control.controller_said('force reference', mark) is not None
                           or control.controller_rejections(mark), CONFIRM_TIMEOUT, self.alive,
                           'the controller to take the force reference')
        if control.controller_rejections(mark):
            raise RuntimeError(f'controller rejected the force reference: {control.controller_rejections(mark)}')

    def pause(self):
        """Pause the bridge (its physics stands still; it re-publishes the state every 0.1 s)."""
        self.control.pause(True, poll=self.alive)

    def resume(self):
        self.control.pause(False, poll=self.alive)

    def paused_at(self, timeout=5.0):
        """The stamp (ns) of the state the paused bridge holds: the one it re-publishes every 0.1 s."""
        collector, seen = self.collector, self.collector.count('/joint_states')

        def republished():
            stamps = collector.last_stamps_ns('/joint_states', 2)
            return collector.count('/joint_states') > seen and len(stamps) == 2 and stamps[0] == stamps[1]
        self.control.spin_until(republished, timeout, self.alive, 'the paused bridge to re-publish its state')
        return collector.last_stamp_ns()

    def run_until(self, end_ns, schedules, progress):
        """Spin until the command of the tick at `end_ns` has arrived, sending the force references and the
        bridge's parameter changes (`schedules`: Schedule objects) as they fall due;
        RuntimeError when the simulation stalls for STALL_TIMEOUT s."""
        collector = self.collector
        last_progress_wall, last_stamp = time.monotonic(), -1
        while True:
            self.control.spin(0.002)
            self.alive()
            cmds = collector.raw['/robot_joint_commands']
            stamp = collector.last_stamp_ns('/robot_joint_commands') if cmds else -1
            if stamp >= end_ns:
                return
            if stamp != last_stamp:
                last_stamp, last_progress_wall = stamp, time.monotonic()
            elif time.monotonic() - last_progress_wall > STALL_TIMEOUT:
                raise RuntimeError(f'the simulation stalled at t = {stamp / NS:.3f} s for {STALL_TIMEOUT:g} s\n'
                                   f'sim_bridge log:\n{self.bridge.log_tail()}\n'
                                   f'controller log:\n{self.controller.log_tail()}')
            for schedule in schedules:
                schedule.send_due(self, stamp)
            progress.maybe()

    def wait_for_last_tick(self, end_ns):
        """Wait, at most REPAIR_TIMEOUT s, for every stream of the tick at `end_ns` (a tick still missing
        then is reported as lost)."""
        collector = self.collector
        # the last tick's reference and error follow its command; its wrench precedes its state (when the
        # bridge publishes wrenches at all: the collector subscribes, so it does from the start)
        last_ticks = ['/controller/reference', '/controller/error', '/joint_states']
        if collector.count('/ft_sensor/wrench'):
            last_ticks.append('/ft_sensor/wrench')

        def tick_complete():
            return all(collector.last_stamp_ns(t) is not None and collector.last_stamp_ns(t) >= end_ns
                       for t in last_ticks)
        try:
            self.control.spin_until(tick_complete, REPAIR_TIMEOUT, self.alive, 'the last tick')
        except TimeoutError:
            pass

    def stop_nodes(self):
        """Stop the bridge and the controller; {name: exit status}."""
        return self.children.stop_all()

    def close(self):
        """Stop the recorder and every child, destroy this process's nodes, shut the context down."""
        import rclpy
        try:
            if self.recorder is not None:
                self.recorder.stop()
        finally:
            self.children.stop_all()
            for part in (self.control, self.collector):
                if part is not None:
                    part.destroy()
            if self.executor is not None:
                self.executor.shutdown()
            rclpy.try_shutdown(context=self.ctx)


def summarize_run(data, experiment, mode, duration, wall, domain_id, record, plot, say):
    """The summary.json dict of a run: the metrics of demo_metrics.summarize, the domain, the
    expected ticks and the lost messages (warned about through `say`), the names of the outputs."""
    from robot_control.tools import demo_metrics
    summary = demo_metrics.summarize(data, experiment, mode, duration, wall_time_s=wall)
    summary['domain_id'] = domain_id
    summary['expected_ticks'] = int(data.expected_ticks)
    summary['lost_messages'] = {topic: {'count': len(times), 'ranges_s': time_ranges(times)}
                                for topic, times in data.lost.items()}
    if data.lost:
        worst = max(data.lost, key=lambda k: len(data.lost[k]))
        spans = ', '.join(f'{a:.3f}-{b:.3f}' for a, b in time_ranges(data.lost[worst])[:5])
        say(f'[demo] warning: {len(data.lost[worst])} of {data.expected_ticks} ticks did not reach the '
            f'collector ({worst}, t = {spans} s); the metrics use the others', flush=True)
    summary['bridge_events'] = list(data.events)
    if data.calls:
        summary['service_calls'] = list(data.calls)
    summary['bag'] = 'bag' if record else None
    summary['figure'] = 'tracking.png' if plot else None
    return summary


def write_outputs(out_dir, summary, data, experiment, plot_title=None):
    """Write out_dir/summary.json and, given a plot title, out_dir/tracking.png."""
    with open(out_dir / 'summary.json', 'w') as f:
        json.dump(summary, f, indent=2, allow_nan=False)
        f.write('\n')
    if plot_title is not None:
        from robot_control.tools import demo_metrics
        from robot_control.tools.plot import tracking_figure
        tracking_figure(demo_metrics.plot_data(data, experiment, plot_title), out_dir / 'tracking.png')


def interrupted(exc):
    """The KeyboardInterrupt (Ctrl-C, or SIGTERM/SIGHUP via robot_control.tools.processes) behind `exc`, or None.

    A signal can arrive inside a C extension (e.g. rclpy's deserializer), which re-raises it as
    another exception caused by the KeyboardInterrupt: follow the cause/context chain.
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc if str(exc) else 'Ctrl-C'
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _parser():
    p = argparse.ArgumentParser(
        prog='python -m robot_control.demo',
        description='Run a scenario end to end over DDS: PyBullet bridge + controller as separate processes, '
                    'with references, metrics, a rosbag2 recording and a tracking plot.')
    what = p.add_mutually_exclusive_group()
    what.add_argument('--scenario', default=None, choices=sorted(experiments.DEFAULT_FOR_SCENARIO),
                      help='scenario to run with its default experiment (default: polar_two_link)')
    what.add_argument('--experiment', default=None, choices=list(experiments.EXPERIMENTS),
                      help='run a named experiment (the lecture\'s experiments)')
    what.add_argument('--all', action='store_true', help='run every experiment (lockstep), one after the other')
    p.add_argument('--mode', choices=('lockstep', 'realtime'), default='lockstep',
                   help='lockstep: deterministic, as fast as possible (default); realtime: paced to the wall clock')
    p.add_argument('--duration', type=float, default=None, help='simulated seconds (default: the experiment\'s)')
    p.add_argument('--realism', choices=experiments.REALISM, default='ideal',
                   help='ideal: the robot the controller models (default); typical: the bridge also reads '
                        'config/realism/<scenario>_typical.yaml (friction, masses, noise, delay; a scenario '
                        'without a profile runs ideal); outputs in out/demo/<name>_typical')
    p.add_argument('--engine', choices=(*ENGINES, 'both'), default=ENGINES[0],
                   help='physics engine of the bridge (default pybullet); both: each experiment on each engine, '
                        'then a side-by-side table; outputs of mujoco in out/demo/<name>_mujoco')
    p.add_argument('--no-plot', action='store_true', help='do not write tracking.png')
    p.add_argument('--no-record', action='store_true', help='do not record bag/')
    p.add_argument('--out', default=None, help='output directory (default out/demo/<name>; with --all or '
                                               '--engine both, the parent of the per-run directories)')
    p.add_argument('--domain-id', type=int, default=None,
                   help='ROS_DOMAIN_ID of the run (default: the first free of 101, 100, ..., 1)')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    return p


def _one(name, opts, out_dir, engine):
    from robot_control.tools.demo_metrics import format_summary
    result = run(name, mode=opts.mode if not opts.all else 'lockstep', duration=opts.duration, out_dir=out_dir,
                 record=not opts.no_record, plot=not opts.no_plot, domain_id=opts.domain_id,
                 write=None if opts.quiet else print, keep_data=False, realism=opts.realism, engine=engine)
    print(f'\n[demo] {name} ({engine}): summary\n{format_summary(result.summary)}')
    files = ['summary.json'] + (['tracking.png'] if not opts.no_plot else []) + (['bag/'] if not opts.no_record else [])
    print(f'[demo] wrote {out_dir}/ {" ".join(files)}', flush=True)
    return result


def tracking_rms(summary):
    """The largest RMS tracking error of a run's summary over its coordinates, rad or m, or None."""
    values = [v for v in summary['rms_error'].values() if v is not None]
    return max(values) if values else None


def steady_force(summary):
    """The steady contact force of a run's summary on its first force axis, N (the reference less the steady-state
    error), or None without force control."""
    if not summary.get('force_axes'):
        return None
    axis = summary['force_axes'][0]
    return summary['force_reference'][axis] - summary['force_steady_state_error'][axis]


def relative_difference(a, b):
    """|a - b| / max(|a|, |b|) of two figures of the engines; 0 when both are 0."""
    larger = max(abs(a), abs(b))
    return abs(a - b) / larger if larger else 0.0


def differs(a, b, atol, rtol):
    """'' when a and b (or either missing) agree within atol or rtol of the larger magnitude
    (relative_difference), else 'differs'."""
    if a is None or b is None or abs(a - b) < atol or relative_difference(a, b) < rtol:
        return ''
    return 'differs'


def side_by_side(summaries, names):
    """A Markdown table of {(experiment, engine): summary}: per experiment the tracking RMS (tracking_rms) and the
    steady force (steady_force) on each engine of ENGINES, and where they differ more than RMS_ATOL / RMS_RTOL or
    FORCE_RTOL."""
    head = ['experiment'] + [f'RMS {e}' for e in ENGINES] + ['RMS'] + [f'force {e} N' for e in ENGINES] + ['force']
    lines = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    fmt = (lambda v, spec: '-' if v is None else format(v, spec))
    for name in names:
        runs = [summaries.get((name, e)) for e in ENGINES]
        rms = [None if r is None else tracking_rms(r) for r in runs]
        force = [None if r is None else steady_force(r) for r in runs]
        cells = [name] + [fmt(v, '.3e') for v in rms] + [differs(*rms, RMS_ATOL, RMS_RTOL)]
        cells += [fmt(v, '.3f') for v in force] + [differs(*force, 0.0, FORCE_RTOL)]
        lines.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def main(argv=None):
    opts = _parser().parse_args(argv)
    if opts.duration is not None and not opts.duration > 0:
        _parser().error('--duration must be > 0')
    engines = ENGINES if opts.engine == 'both' else (opts.engine,)
    names = list(experiments.EXPERIMENTS) if opts.all else [opts.experiment or opts.scenario or 'polar_two_link']
    runs = [(name, engine) for name in names for engine in engines]
    if opts.out and len(runs) == 1:
        dirs = {runs[0]: Path(opts.out)}
    else:      # --out: the parent of the per-run directories
        base = Path(opts.out) if opts.out else ROOT / 'out' / 'demo'
        dirs = {r: base / output_name(r[0], opts.realism, r[1]) for r in runs}
    old = procs.install_signal_handlers()
    code, summaries = 0, {}
    try:
        for name, engine in runs:
            try:
                summaries[name, engine] = _one(name, opts, dirs[name, engine], engine).summary
            except (TimeoutError, RuntimeError, procs.ProcessError) as exc:
                if interrupted(exc):
                    raise
                print(f'[demo] {name} ({engine}) failed: {exc}', file=sys.stderr, flush=True)
                code = 1
                if not opts.all:
                    break
        if len(engines) > 1:
            print('\n[demo] the engines side by side\n' + side_by_side(summaries, names), flush=True)
    except BaseException as exc:
        if not interrupted(exc):
            raise
        print(f'\n[demo] interrupted ({interrupted(exc)}): stopped every process', file=sys.stderr, flush=True)
        code = 130
    finally:
        procs.stop_all_children()
        procs.restore_signal_handlers(old)
    return code


if __name__ == '__main__':
    sys.exit(main())
