"""The demo: the lecture's control laws driving a simulated robot over DDS (issue 5).

    python -m robot_control.demo --scenario polar_two_link          # what `make demo` runs
    python -m robot_control.demo --scenario iiwa --mode realtime --duration 5
    python -m robot_control.demo --experiment disturbance_pid --no-plot
    python -m robot_control.demo --all                               # every experiment, for the README table

A run starts two OS processes, `sim_bridge_node` (PyBullet: the robot) and `controller_node`,
each with `--ros-args --params-file config/<scenario>.yaml` plus the experiment's overrides, on a
DDS domain of its own with discovery limited to this machine. In this process it runs the
experiment's reference publisher, the metrics collector and the rosbag2 recorder. It prints a
progress line per second, stops every process it started (by pid, also on Ctrl-C, SIGTERM or an
error), prints a summary table and writes `out/demo/<name>/`: `summary.json`, `tracking.png`,
`bag/` (mcap, every topic) and `logs/` (the two nodes' output).

Modes: `lockstep` (the default) is deterministic -- the bridge steps only when the command for the
current state has arrived, so the same run gives the same numbers every time, on any machine, and
it runs as fast as the three processes allow (measured on 2 cores: 500-800 control ticks per
second, 0.5-0.8x real time; the progress line shows the rate), so a 4 s run takes ~10 s. It is
the default because it always shows the lecture's result (the step follows e0 (1 + 6t) exp(-6t)
within 0.2 %), however loaded the machine. `realtime` paces the physics to the wall clock with the
latest command held (brakes if commands go stale): what a real robot would see, timing included;
when the controller cannot answer every 1 ms tick (measured here: about half of them), the
response degrades accordingly.

Sequence of a run (all waits bounded): start the recorder; start the bridge and pause it; start
the controller and wait until it is connected; resume and wait for its first command (t = 0 is
the origin in lockstep); pause, send the experiment's references stamped at origin + t (the
controller confirms in its log), resume; run for `duration` s of simulation; pause, stop the
recorder and the processes; align the collected messages per control tick; compute the metrics
(robot_control.tools.demo_metrics), plot (robot_control.tools.plot.tracking_figure), write the files.
"""
import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from robot_control import units
from robot_control.tools import demo_experiments as experiments
from robot_control.tools import demo_procs as procs
from robot_control import scenarios

NS = units.NS_PER_S
ROOT = Path(__file__).resolve().parents[2]
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


@dataclass
class RunResult:
    summary: dict
    data: object = None                 # demo_metrics.RunData
    out_dir: Path = None
    bag: Path = None
    bag_counts: dict = field(default_factory=dict)
    exit_codes: dict = field(default_factory=dict)


def config_path(scenario):
    """config/<scenario>.yaml of this checkout, else of the installed package (share/robot_control/config)."""
    for base in (ROOT / 'config', Path(sys.prefix) / 'share' / 'robot_control' / 'config'):
        path = base / f'{scenario}.yaml'
        if path.is_file():
            return path
    raise ValueError(f'scenario: no parameter file {scenario}.yaml in {ROOT / "config"} or the install')


def param_value(value):
    """A parameter value as a `-p name:=value` YAML literal (doubles keep a decimal point)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, (int, float)):
        return repr(float(value))
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(param_value(v) for v in value) + ']'
    return str(value)


def node_argv(module, scenario, params, extra=()):
    argv = procs.python_module(module, *extra, '--ros-args', '--params-file', str(config_path(scenario)))
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


def run(experiment, mode='lockstep', duration=None, out_dir=None, record=True, plot=True, domain_id=None,
        write=print, keep_data=True):
    """Run `experiment` (an Experiment or a name) end to end; returns a RunResult. See the module docstring.

    mode 'lockstep' | 'realtime'; duration s of simulation (default the experiment's); out_dir default
    out/demo/<name>; record: bag/; plot: tracking.png; domain_id: ROS_DOMAIN_ID of the run (default: a
    free one in DEMO_DOMAIN_RANGE); write: print-like function for progress (None: quiet);
    keep_data: keep the per-tick RunData in the result.
    """
    if isinstance(experiment, str):
        experiment = experiments.get(experiment)
    if mode not in ('lockstep', 'realtime'):
        raise ValueError(f"mode: expected 'lockstep' or 'realtime', got {mode!r}")
    duration = experiment.duration if duration is None else float(duration)
    if not duration > 0:
        raise ValueError(f'duration: expected > 0 s, got {duration}')
    out_dir = Path(out_dir if out_dir is not None else ROOT / 'out' / 'demo' / experiments.output_name(experiment.name))
    out_dir.mkdir(parents=True, exist_ok=True)
    claim = None
    if domain_id is None:   # a private id: the first free one from the pid-derived offset
        lo, hi = procs.DEMO_DOMAIN_RANGE
        claim = procs.DomainClaim(range(lo, hi + 1), start=procs.pick_domain_id() - lo)
        domain_id = claim.acquire()
    try:
        return _run(experiment, mode, duration, out_dir, record, plot, int(domain_id), write, keep_data)
    finally:
        if claim is not None:
            claim.release()


def _run(experiment, mode, duration, out_dir, record, plot, domain_id, write, keep_data):
    from robot_control.tools import demo_metrics, demo_ros
    env = procs.ros_env(domain_id)
    # this process joins the same private domain, loopback only, before rclpy reads the environment
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_STATIC_PEERS', None)
    scenario = experiment.scenario
    joints = experiment.joints
    units = dict(zip(joints, experiment.units))
    law = experiment.law
    f_names, f_index = force_axes_of(scenario) if law in ('force', 'hybrid') else ((), ())
    if law == 'hybrid':
        units = {a: 'm' for a in ('x', 'y', 'z')}

    bridge_params = {'mode': mode, **experiment.bridge}
    ctrl_params = dict(experiment.controller)
    if experiment.force is not None:
        ctrl_params['f_d'] = list(experiment.force)

    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from robot_control.tools.record import Recorder

    say = write or (lambda *a, **k: None)
    ctx = demo_ros.context_with_domain(domain_id)
    executor = SingleThreadedExecutor(context=ctx)
    control = collector = recorder = None
    children = procs.ProcessSet()
    bag = out_dir / 'bag'
    result = RunResult(summary={}, out_dir=out_dir)
    t_wall0 = time.monotonic()
    try:
        collector = demo_ros.Collector(ctx, name=f'demo_collector_{domain_id}')
        control = demo_ros.RunControl(ctx, executor, name=f'demo_{domain_id}')
        poll = collector.poll
        if record:
            recorder = Recorder(control.node, bag, [f'{t}:{ty}' for t, ty in demo_ros.RUN_TOPICS.items()],
                                all_topics=True, discovery_timeout=0.0, overwrite=True)
            recorder.start()
        logs = out_dir / 'logs'
        say(f'[demo] {experiment.name} ({scenario}, {mode}, {duration:g} s): ROS_DOMAIN_ID={domain_id}, '
            'discovery LOCALHOST', flush=True)
        bridge = children.start('sim_bridge', node_argv('sim_bridge.bridge_node', scenario, bridge_params,
                                                        BRIDGE_ARGS), env, logs / 'sim_bridge.log', cwd=ROOT)

        def alive():
            procs.check_interrupted()
            poll()
            children.check_alive()

        control.spin_until(lambda: collector.publishers('/joint_states') > 0 and control.pause_client.service_is_ready(),
                           STARTUP_TIMEOUT, alive, 'the simulator bridge to start')
        control.pause(True, poll=alive)
        controller = children.start('controller', node_argv('robot_control.ros.controller_node', scenario, ctrl_params),
                                    env, logs / 'controller.log', cwd=ROOT)
        say(f'[demo] started sim_bridge (pid {bridge.pid}) and controller (pid {controller.pid})', flush=True)

        def connected():
            return (all(collector.publishers(t) > 0 for t in
                        ('/robot_joint_commands', '/controller/reference', '/controller/error'))
                    and control.traj_pub.get_subscription_count() > 0
                    and control.subscribed('/joint_states', 'controller'))
        control.spin_until(connected, STARTUP_TIMEOUT, alive, 'the controller to connect')
        # the paused bridge re-publishes its state every 0.1 s: the controller answers while the world stands still.
        # A sample of every stream of the tick must have arrived: a publisher sends ~/reference, ~/error and the
        # wrench only once its own side has matched the collector (DDS discovers the two sides independently), so
        # seeing the publisher here is not enough to be sure the first tick's samples are sent
        control.spin_until(lambda: all(collector.count(t) > 0 for t in FIRST_TICK), STARTUP_TIMEOUT, alive,
                           'the first state, command, reference, error and wrench')
        if mode == 'lockstep':
            origin_ns = 0   # the bridge steps only once the command for t = 0 has arrived
        else:
            # physics ran (braked) from the bridge's start until the pause: start 50 ms on
            origin_ns = (collector.last_stamp_ns() or 0) + NS // 20
        # -- references, stamped on the simulation clock, confirmed by the controller
        mark = len(control.log)
        if experiment.trajectory is not None:
            spec = experiment.trajectory
            stamp = origin_ns + int(round(spec.t_start * NS))
            last = collector.last_stamp_ns() or 0
            if stamp <= last:
                raise RuntimeError(f'trajectory start {stamp / NS:.3f} s is already past (t = {last / NS:.3f} s)')
            control.send_trajectory(joints, spec, stamp)
            control.spin_until(lambda: control.controller_said('trajectory accepted', mark) is not None
                               or control.controller_rejections(mark), CONFIRM_TIMEOUT, alive,
                               'the controller to accept the trajectory')
            if control.controller_rejections(mark):
                raise RuntimeError(f'controller rejected the trajectory: {control.controller_rejections(mark)}')
        control.pause(False, poll=alive)

        # -- the run
        end_ns = origin_ns + int(round(duration * NS))
        events = sorted(experiment.force_events)
        next_event_send_ns = origin_ns
        progress = Progress(collector, origin_ns, units, f_names, say if write else None)
        last_progress_wall, last_stamp = time.monotonic(), -1
        say(f'[demo] running {duration:g} s of simulation from t = {origin_ns / NS:.3f} s', flush=True)
        while True:
            control.spin(0.002)
            alive()
            cmds = collector.raw['/robot_joint_commands']
            stamp = collector.last_stamp_ns('/robot_joint_commands') if cmds else -1
            if stamp >= end_ns:
                break
            if stamp != last_stamp:
                last_stamp, last_progress_wall = stamp, time.monotonic()
            elif time.monotonic() - last_progress_wall > STALL_TIMEOUT:
                raise RuntimeError(f'the simulation stalled at t = {stamp / NS:.3f} s for {STALL_TIMEOUT:g} s\n'
                                   f'sim_bridge log:\n{bridge.log_tail()}\ncontroller log:\n{controller.log_tail()}')
            # each force step is sent as soon as the one before it is due (the first at once), stamped with
            # its time: the controller holds it and applies it at exactly that tick (repeatable in lockstep)
            while events and stamp >= next_event_send_ns:
                t_ev, f_ev = events.pop(0)
                next_event_send_ns = origin_ns + int(round(t_ev * NS))
                control.send_force(f_names, f_ev, stamp_ns=next_event_send_ns)
                say(f'[demo] force reference {dict(zip(f_names, f_ev))} N from t = {t_ev:.3f} s (sent at '
                    f't = {(stamp - origin_ns) / NS:.3f} s)', flush=True)
            progress.maybe()
        control.pause(True, poll=alive)
        wall = time.monotonic() - t_wall0

        # the last tick's reference and error follow its command; its wrench precedes its state (when the
        # bridge publishes wrenches at all: the collector subscribes, so it does from the start)
        last_ticks = ['/controller/reference', '/controller/error', '/joint_states']
        if collector.count('/ft_sensor/wrench'):
            last_ticks.append('/ft_sensor/wrench')

        def tick_complete():
            return all(collector.last_stamp_ns(t) is not None and collector.last_stamp_ns(t) >= end_ns
                       for t in last_ticks)
        try:
            control.spin_until(tick_complete, REPAIR_TIMEOUT, alive, 'the last tick')
        except TimeoutError:
            pass  # reported as lost messages
        limits, _ = demo_ros.controller_diagnostics(collector)
        if not limits:
            limits = effort_limit_fallback(scenario)
        if recorder is not None:
            result.bag_counts = recorder.stop()
            result.bag = bag
        result.exit_codes = children.stop_all()
        data = demo_ros.align(collector, joints, experiment.units, f_names, f_index, law, origin_ns, end_ns, limits,
                              lockstep=mode == 'lockstep')
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
        summary['bag'] = 'bag' if record else None
        summary['figure'] = 'tracking.png' if plot else None
        with open(out_dir / 'summary.json', 'w') as f:
            json.dump(summary, f, indent=2, allow_nan=False)
            f.write('\n')
        if plot:
            from robot_control.tools.plot import tracking_figure
            tracking_figure(demo_metrics.plot_data(data, experiment, f'{law}, {mode}'),
                            out_dir / 'tracking.png')
        result.summary = summary
        result.data = data if keep_data else None
        return result
    finally:
        try:
            if recorder is not None:
                recorder.stop()
        finally:
            codes = children.stop_all()
            if not result.exit_codes:
                result.exit_codes = codes
            for part in (control, collector):
                if part is not None:
                    part.destroy()
            executor.shutdown()
            rclpy.try_shutdown(context=ctx)


def interrupted(exc):
    """The KeyboardInterrupt (Ctrl-C, or SIGTERM/SIGHUP via demo_procs) behind `exc`, or None.

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
                      help='run a named experiment (the lecture experiments of issue 5)')
    what.add_argument('--all', action='store_true', help='run every experiment (lockstep), one after the other')
    p.add_argument('--mode', choices=('lockstep', 'realtime'), default='lockstep',
                   help='lockstep: deterministic, as fast as possible (default); realtime: paced to the wall clock')
    p.add_argument('--duration', type=float, default=None, help='simulated seconds (default: the experiment\'s)')
    p.add_argument('--no-plot', action='store_true', help='do not write tracking.png')
    p.add_argument('--no-record', action='store_true', help='do not record bag/')
    p.add_argument('--out', default=None, help='output directory (default out/demo/<name>; with --all, '
                                               'the parent of the per-experiment directories)')
    p.add_argument('--domain-id', type=int, default=None,
                   help=f'ROS_DOMAIN_ID of the run (default: private, from the pid, in {procs.DEMO_DOMAIN_RANGE})')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    return p


def _one(name, opts, out_dir):
    from robot_control.tools.demo_metrics import format_summary
    result = run(name, mode=opts.mode if not opts.all else 'lockstep', duration=opts.duration, out_dir=out_dir,
                 record=not opts.no_record, plot=not opts.no_plot, domain_id=opts.domain_id,
                 write=None if opts.quiet else print, keep_data=False)
    print(f'\n[demo] {name}: summary\n{format_summary(result.summary)}')
    files = ['summary.json'] + (['tracking.png'] if not opts.no_plot else []) + (['bag/'] if not opts.no_record else [])
    print(f'[demo] wrote {out_dir}/ {" ".join(files)}', flush=True)
    return result


def main(argv=None):
    opts = _parser().parse_args(argv)
    if opts.duration is not None and not opts.duration > 0:
        _parser().error('--duration must be > 0')
    if opts.all:
        names = list(experiments.EXPERIMENTS)
        base = Path(opts.out) if opts.out else ROOT / 'out' / 'demo'
        dirs = {n: base / experiments.output_name(n) for n in names}
    else:
        name = opts.experiment or opts.scenario or 'polar_two_link'
        names = [name]
        dirs = {name: Path(opts.out) if opts.out else ROOT / 'out' / 'demo' / experiments.output_name(name)}
    old = procs.install_signal_handlers()
    code = 0
    try:
        for name in names:
            try:
                _one(name, opts, dirs[name])
            except (TimeoutError, RuntimeError, procs.ProcessError) as exc:
                if interrupted(exc):
                    raise
                print(f'[demo] {name} failed: {exc}', file=sys.stderr, flush=True)
                code = 1
                if not opts.all:
                    break
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
