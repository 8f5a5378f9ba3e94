"""Benchmarks B2 and B3 of benchmarks.bench: closed loops over DDS between separate processes.

The bridge (`python -m sim_bridge.bridge_node`) and the controller (`python -m
robot_control.ros.controller_node`) run as the user runs them, `--ros-args --params-file
config/<scenario>.yaml`, with a 1 ms control period; their output goes to <logdir>/<kind>_<mode>/.
The bench watches `joint_states` and `robot_joint_commands` through raw subscriptions
(robot_control.tools.taps): each sample with its header stamp and the DDS source (publish) and
reception timestamps (ns, the system clock, shared by all processes of this machine). The
samples wait in DDS until the bench asks for them every few ms, and nothing is deserialized, so
watching costs the loop next to nothing.

B2 lockstep: steps/s = (stamp advance / control period) / (reception time advance) over a
window, for polar_two_link, iiwa, the iiwa on its typical realism profile (config/realism/iiwa_typical.yaml
stacked on the bridge: friction, rotor inertia, masses, sensor noise, encoder, delay) and the bare ping-pong
(benchmarks.bench_pingpong) with the same messages, QoS and executors, interleaved round by round; medians
over the rounds; the cost of the realism as the median of the rounds' typical / ideal iiwa ratios.
B3 realtime at 1 kHz, per run of REALTIME_RUNS (the polar arm; the iiwa under computed torque, under hybrid
control pressing on the table and under Cartesian impedance, with the parameters of the demo's
experiments iiwa_hybrid_line and impedance_push; the iiwa under computed torque on its typical realism
profile), from the samples of the whole run:
- latency of period k = reception of command k (at the bench) - publication of state k (bridge);
- deadline hit: command k received before state k+1 was published (the bridge publishes
  right after the physics step, so this is "before the next step" up to that step's duration);
  a period whose command never arrives is a miss (a missed period);
- real-time factor = simulated time advance / publication time advance of the states.
The floor of B3: the same figures, counted the same way by the same observer, of the bare exchange
(benchmarks.bench_pingpong tick / echo: the bridge's pacing, messages, QoS and executors, no
physics, no law), run with each run of REALTIME_RUNS with that run's messages: states and commands,
and ft_sensor/wrench too for a run whose law reads the measured force (reads_wrench: the hybrid run),
since each message costs both processes a wake-up. A run is measured in rounds, each the floor then the
run (plan.realtime_rounds, realtime_s / rounds each), so that both see the load the shared machine has in
the same minute; the rounds are pooled (missed periods and periods summed, pooled()), and each run's missed
periods are held against its floor's over as many periods (missed_vs_floor).
Headline B3 keys are the worst of the runs; per-run keys carry _polar, _iiwa, _iiwa_hybrid, _iiwa_impedance,
_iiwa_typical (computed torque on the iiwa's typical profile), _iiwa_joint_impedance_typical (joint impedance, its
integral and friction compensation on that profile: the demo's iiwa_real_move), _iiwa_mujoco.
Engines: the runs of RUN_ENGINES (B2's and B3's iiwa_mujoco: the iiwa under computed torque) give the bridge another
physics engine (its `engine` parameter); every other run is on the bridge's default, PyBullet.
"""
import importlib
import math
import os
import signal
import struct
import subprocess
import sys
import time

import numpy as np

from robot_control import units
from robot_control import scenarios
from robot_control.tools.processes import die_with_parent

NS = units.NS_PER_S
PERIOD_NS = 1_000_000                 # control period of every DDS run, 1 ms
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STOP_GRACE_S = 2.0                    # SIGTERM -> SIGKILL
START_TIMEOUT_S = 60.0                # first sample after the processes start
POLL_S = 0.01
OBSERVER_DEPTH = 1000
SHORT = {'polar_two_link': 'polar', 'iiwa': 'iiwa'}


def ros_env(domain_id):
    """Environment of every DDS process: discovery on this machine, a domain of this run's own."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID=str(domain_id),
               PYTHONUNBUFFERED='1')
    env.pop('ROS_STATIC_PEERS', None)
    return env


# -- child processes -----------------------------------------------------------------------------
class Children:
    """The processes of one run; leaving the `with` block stops every one (SIGTERM, then SIGKILL)."""

    def __init__(self, env, logdir):
        self.env, self.logdir = env, logdir
        self.procs = []            # (name, Popen, log file)
        self.killed = []           # names that ignored SIGTERM

    def start(self, name, argv):
        os.makedirs(self.logdir, exist_ok=True)
        log = open(os.path.join(self.logdir, f'{name}.log'), 'w', encoding='utf-8')
        try:
            proc = subprocess.Popen([sys.executable, *argv], env=self.env, cwd=ROOT, stdout=log,
                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, preexec_fn=die_with_parent)
        except BaseException:
            log.close()
            raise
        self.procs.append((name, proc, log))

    def check_alive(self):
        """RuntimeError naming a process that exited, with the end of its log."""
        for name, proc, log in self.procs:
            if proc.poll() is not None:
                log.flush()
                with open(log.name, encoding='utf-8', errors='replace') as f:
                    tail = f.read()[-2000:]
                raise RuntimeError(f'{name} exited with code {proc.returncode}:\n{tail}')

    def stop(self):
        for _, proc, _ in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + STOP_GRACE_S
        for name, proc, log in self.procs:
            try:
                proc.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
                self.killed.append(name)
            log.close()
        self.procs = []


def node_executor(module):
    """The executor `module`'s main() spins by default: the default of its --executor option
    ('events' or 'single'; a node's ENTRY, robot_control.ros.entry), 'single' (SingleThreadedExecutor)
    for a module without one."""
    node_entry = getattr(importlib.import_module(module), 'ENTRY', None)
    return node_entry.options([module]).executor if node_entry else 'single'


#: B3's runs: key suffix -> (scenario, the demo experiment whose parameters the two nodes take, or None)
REALTIME_RUNS = {'polar': ('polar_two_link', None), 'iiwa': ('iiwa', None),
                 'iiwa_hybrid': ('iiwa', 'iiwa_hybrid_line'), 'iiwa_impedance': ('iiwa', 'impedance_push'),
                 'iiwa_typical': ('iiwa', None), 'iiwa_joint_impedance_typical': ('iiwa', 'iiwa_real_move'),
                 'iiwa_mujoco': ('iiwa', None)}
#: the runs (B2's and B3's keys) whose bridge stacks a realism profile after the scenario's file: key suffix ->
#: the profile (robot_control.tools.demo.realism_profile); the others simulate the ideal twin
REALISM = {'iiwa_typical': 'typical', 'iiwa_joint_impedance_typical': 'typical'}
#: the runs (B2's and B3's keys) whose bridge runs on another engine than its default: key suffix -> engine
#: (sim_bridge.engines.ENGINES)
RUN_ENGINES = {'iiwa_mujoco': 'mujoco'}


def experiment_params(name):
    """(bridge, controller) parameter overrides of demo experiment `name` ({}, {} for None), as -p arguments."""
    if name is None:
        return [], []
    from robot_control.tools import demo, demo_experiments
    exp = demo_experiments.get(name)

    def args(params):
        return [a for k, v in params.items() for a in ('-p', f'{k}:={demo.param_value(v)}')]
    return args(exp.bridge), args(demo.controller_params(exp))


#: the bare exchanges of benchmarks.bench_pingpong: kind -> (the scenario whose joints the messages
#: carry, the role that stands for the bridge, the role that stands for the controller)
BARE = {'pingpong': ('polar_two_link', 'ping', 'pong'), 'floor': ('iiwa', 'tick', 'echo')}


def reads_wrench(scenario, experiment=None):
    """Whether the controller of `scenario` with the parameters of demo experiment `experiment` (None: the
    scenario's file alone) reads the measured force: its loop then carries ft_sensor/wrench beside the states."""
    from robot_control.core.status import needs_wrench
    from robot_control.ros import controller_params
    from robot_control.tools import sweep_episode, sweep_spec
    p = sweep_episode.plan(sweep_spec.load({'experiment': experiment} if experiment else
                                           {'scenario': scenario, 'duration': 1.0}))
    return needs_wrench(p.builder(controller_params.TABLE.validate(p.values['controller'])))


def node_commands(kind, mode, experiment=None, realism='ideal', engine=None, wrench=False):
    """[(name, argv)] of the two processes of a run: a kind of BARE or a scenario name, with the parameters of
    demo experiment `experiment` (None: the scenario's file alone); the bridge stacks the scenario's profile of
    `realism` ('ideal': none) after the scenario's file and runs on physics engine `engine` (None: its default).
    The ends of a bare exchange use the executors of the nodes they stand for, and carry ft_sensor/wrench too
    when `wrench` (the messages of a loop whose law reads the force)."""
    if kind in BARE:
        scenario, *roles = BARE[kind]
        joints = list(scenarios.get(scenario).joints)
        ends = zip(roles, ('sim_bridge.bridge_node', 'robot_control.ros.controller_node'))
        return [(role, ['-m', 'benchmarks.bench_pingpong', role, '--joints', *joints, '--period',
                        str(PERIOD_NS / NS), '--executor', node_executor(module), *(['--wrench'] if wrench else [])])
                for role, module in ends]
    from robot_control.tools import demo
    params = os.path.join(ROOT, 'config', f'{kind}.yaml')
    profile = demo.realism_profile(kind, realism)
    bridge_extra, controller_extra = experiment_params(experiment)
    bridge = ['-m', 'sim_bridge.bridge_node', '--ros-args', '--params-file', params,
              *(['--params-file', str(profile)] if profile is not None else []), *bridge_extra,
              '-p', f'mode:={mode}', '-p', 'physics_step:=0.001', '-p', f'control_period:={PERIOD_NS / NS}',
              '-p', 'real_time_factor:=1.0', *(['-p', f'engine:={engine}'] if engine else [])]
    controller = ['-m', 'robot_control.ros.controller_node', '--ros-args', '--params-file', params, *controller_extra]
    return [('sim_bridge', bridge), ('controller', controller)]


# -- observing DDS -------------------------------------------------------------------------------
def header_stamp_ns(cdr):
    """header.stamp of a serialized (CDR) message whose first field is a Header, ns."""
    sec, nanosec = struct.unpack_from('<iI' if cdr[1] & 1 else '>iI', cdr, 4)   # encapsulation: CDR_LE / CDR_BE
    return sec * NS + nanosec


class Observer:
    """joint_states and robot_joint_commands, raw with their DDS timestamps (robot_control.tools.taps),
    on a node of its own spun only when take() asks for what has arrived."""

    TOPICS = ('joint_states', 'robot_joint_commands')

    def __init__(self, context):
        from rclpy.node import Node
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from robot_control.ros.spin import make_executor
        from robot_control.tools.taps import Tap
        self.node = Node('bench_observer', context=context)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=OBSERVER_DEPTH,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
        self.tap = Tap(self.node, {t: JointState for t in self.TOPICS}, qos)
        self.executor = make_executor('events', context=context)
        self.executor.add_node(self.node)

    def take(self, topic):
        """Every sample of `topic` received since the last take, as (stamp, source, received) rows, ns;
        shape (0, 3) when none. The executor first hands over everything DDS holds (in rounds of 0 s:
        what is ready)."""
        from robot_control.tools.taps import spin_until_idle
        spin_until_idle(self.executor, self.tap.count, round_s=0.0)
        rows = [(header_stamp_ns(cdr), source, received) for cdr, source, received in self.tap.pop(topic)]
        return np.array(rows, dtype=np.int64).reshape(-1, 3)

    def drain(self):
        for topic in self.TOPICS:
            self.take(topic)

    def wait_for(self, topic, procs, timeout=START_TIMEOUT_S):
        """The first sample of `topic` (after draining older ones); RuntimeError on timeout or a dead child."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            rows = self.take(topic)
            if len(rows):
                return rows[-1]
            procs.check_alive()
            time.sleep(POLL_S)
        raise RuntimeError(f'no {topic} within {timeout:g} s')

    def destroy(self):
        self.executor.shutdown()
        self.node.destroy_node()


def ros_context(env):
    """A fresh rclpy context on env's domain; SIGINT/SIGTERM stay with Python (cleanup in finally)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = env['ROS_AUTOMATIC_DISCOVERY_RANGE']
    os.environ['ROS_DOMAIN_ID'] = env['ROS_DOMAIN_ID']
    os.environ.pop('ROS_STATIC_PEERS', None)
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(env['ROS_DOMAIN_ID']), signal_handler_options=SignalHandlerOptions.NO)
    return ctx


class Session:
    """An rclpy context with one Observer, for all runs of B2 or B3."""

    def __init__(self, env, logdir):
        self.env, self.logdir = env, logdir
        self.ctx = ros_context(env)
        try:
            self.observer = Observer(self.ctx)
        except BaseException:
            self.close(observer=False)
            raise
        self.killed = set()

    def close(self, observer=True):
        import rclpy
        if observer:
            self.observer.destroy()
        rclpy.try_shutdown(context=self.ctx)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def run(self, kind, mode, measure, experiment=None, label=None, realism='ideal', wrench=False, part=''):
        """Start the two processes of `kind` (with the parameters of demo experiment `experiment`, the bridge on
        the profile of `realism` and on the engine RUN_ENGINES names for `label`, else on its default; a bare
        exchange with ft_sensor/wrench when `wrench`), wait for the loop to answer, return measure(observer,
        procs); logs in <logdir>/<label or kind>_<mode><part>/."""
        procs = Children(self.env, os.path.join(self.logdir, f'{label or kind}_{mode}{part}'))
        try:
            for name, argv in node_commands(kind, mode, experiment, realism, RUN_ENGINES.get(label), wrench):
                procs.start(name, argv)
            self.observer.drain()
            self.observer.wait_for('robot_joint_commands', procs)
            return measure(self.observer, procs)
        finally:
            procs.stop()
            self.killed.update(procs.killed)


# -- B2 ------------------------------------------------------------------------------------------
def cpu_seconds(pids):
    """User + system CPU time consumed so far by processes `pids` (all threads), s."""
    total = 0
    for pid in pids:
        with open(f'/proc/{pid}/stat', encoding='ascii') as f:
            fields = f.read().rpartition(')')[2].split()
        total += int(fields[11]) + int(fields[12])          # utime, stime (fields 14, 15)
    return total / os.sysconf('SC_CLK_TCK')


def steps_per_s(first, last):
    """Control steps per second between two joint_states samples (stamp, source, received)."""
    wall = (last[2] - first[2]) / NS
    return (last[0] - first[0]) / PERIOD_NS / wall if wall > 0 else 0.0


def lockstep_window(plan):
    """measure() -> (steps/s, CPU us of both processes per step) over one window."""
    def measure(observer, procs):
        pids = [proc.pid for _, proc, _ in procs.procs]
        time.sleep(plan.dds_warmup_s)
        observer.drain()
        first, cpu0 = observer.wait_for('joint_states', procs), cpu_seconds(pids)
        time.sleep(plan.dds_window_s)
        procs.check_alive()
        last, cpu1 = observer.wait_for('joint_states', procs), cpu_seconds(pids)
        steps = (last[0] - first[0]) / PERIOD_NS
        return steps_per_s(first, last), (cpu1 - cpu0) * 1e6 / steps if steps > 0 else math.inf
    return measure


#: B2's runs, each round in this order: label -> kind (node_commands); a label in REALISM runs on its profile, one
#: in RUN_ENGINES on its engine
LOCKSTEP_RUNS = {'pingpong': 'pingpong', 'polar_two_link': 'polar_two_link', 'iiwa': 'iiwa', 'iiwa_typical': 'iiwa',
                 'iiwa_mujoco': 'iiwa'}


def bench_lockstep(plan, env, log, logdir):
    """B2 metrics: the LOCKSTEP_RUNS interleaved for plan.dds_rounds rounds."""
    runs = {label: [] for label in LOCKSTEP_RUNS}
    with Session(env, logdir) as session:
        for r in range(plan.dds_rounds):
            for label, kind in LOCKSTEP_RUNS.items():
                runs[label].append(session.run(kind, 'lockstep', lockstep_window(plan), label=label,
                                               realism=REALISM.get(label, 'ideal')))
                rate, cpu = runs[label][-1]
                log(f'  round {r + 1}/{plan.dds_rounds} {label}: {rate:.0f} steps/s, {cpu:.0f} us CPU per step')
        warn_killed(session.killed, log)
    med = {k: np.median(np.array(v), axis=0) for k, v in runs.items()}
    out = {'lockstep_steps_per_s_polar': med['polar_two_link'][0], 'lockstep_steps_per_s_iiwa': med['iiwa'][0],
           'pingpong_roundtrips_per_s': med['pingpong'][0]}
    ratios = {s: med[s][0] / med['pingpong'][0] for s in ('polar_two_link', 'iiwa')}
    out['lockstep_vs_pingpong_ratio'] = min(ratios.values())
    out.update({f'lockstep_vs_pingpong_ratio_{SHORT[s]}': v for s, v in ratios.items()})
    # CPU per step of both processes: what a step costs, whatever else runs on the machine
    out.update({f'lockstep_cpu_us_per_step_{SHORT[s]}': med[s][1] for s in ('polar_two_link', 'iiwa')})
    out['pingpong_cpu_us_per_roundtrip'] = med['pingpong'][1]
    out.update(realism_cost(runs))
    out.update(engine_lockstep(med, RUN_ENGINES))
    return {k: float(v) for k, v in out.items()}


def realism_cost(runs):
    """B2's cost of the realism: the iiwa on its typical profile against the ideal iiwa, from `runs` (label ->
    [(steps/s, CPU us per step)] per round): the medians of both, and the median over the rounds of the ratio
    typical / ideal of the same round (the two runs follow each other, under the same load)."""
    typical, ideal = np.array(runs['iiwa_typical']), np.array(runs['iiwa'])
    return {'lockstep_steps_per_s_iiwa_typical': np.median(typical[:, 0]),
            'lockstep_cpu_us_per_step_iiwa_typical': np.median(typical[:, 1]),
            'lockstep_typical_vs_ideal_ratio_iiwa': np.median(typical[:, 0] / ideal[:, 0])}


def engine_lockstep(med, engines):
    """B2's figures of the runs on another engine (`engines`: label -> engine): steps/s, their ratio to the
    ping-pong of the same run (B2's target holds for each) and the CPU per step, from `med` (label -> median
    (steps/s, CPU us per step) over the rounds)."""
    out = {}
    for label in engines:
        rate, cpu = med[label]
        out.update({f'lockstep_steps_per_s_{label}': rate,
                    f'lockstep_vs_pingpong_ratio_{label}': rate / med['pingpong'][0],
                    f'lockstep_cpu_us_per_step_{label}': cpu})
    return out


# -- B3 ------------------------------------------------------------------------------------------
def realtime_metrics(states, commands, period_ns=PERIOD_NS):
    """{periods, missed, hit_ratio, latency_p50_ms, latency_p99_ms, rtf} from (stamp, source, received) rows:
    `periods` observed (a state with a next state), `missed` of them (no command received before the next
    state was published), hit_ratio = 1 - missed / periods."""
    published = {}
    for stamp, source, _ in states:
        published.setdefault(int(stamp), int(source))
    received = {}
    for stamp, _, recv in commands:
        received.setdefault(int(stamp), int(recv))
    stamps = sorted(published)
    periods = [k for k in stamps if k + period_ns in published]
    if len(periods) < 2:
        raise RuntimeError(f'realtime: only {len(periods)} control periods observed')
    hits = sum(1 for k in periods if k in received and received[k] < published[k + period_ns])
    latency = np.array([received[k] - published[k] for k in stamps if k in received], dtype=float) / 1e6
    if not len(latency):
        raise RuntimeError('realtime: no command answered an observed state')
    rtf = (stamps[-1] - stamps[0]) / (published[stamps[-1]] - published[stamps[0]])
    return {'periods': len(periods), 'missed': len(periods) - hits, 'hit_ratio': hits / len(periods),
            'latency_p50_ms': float(np.median(latency)),
            'latency_p99_ms': float(np.percentile(latency, 99)), 'rtf': float(rtf)}


def _wait_for_loop(observer, timeout_s=30.0):
    """Block until the observer receives both states and commands, at most timeout_s: the controller
    answers (start-up, discovery, model loading) and the observer has matched both writers (DDS
    discovers each writer on its own, sometimes seconds apart)."""
    deadline = time.monotonic() + timeout_s
    seen = set()
    while time.monotonic() < deadline:
        time.sleep(POLL_S)
        seen.update(t for t in observer.TOPICS if len(observer.take(t)))
        if len(seen) == len(observer.TOPICS):
            return
    raise RuntimeError(f'realtime: no {" and no ".join(sorted(set(observer.TOPICS) - seen))} within {timeout_s:g} s')


def realtime_run(plan, periods=None, timeout_s=START_TIMEOUT_S, seconds=None):
    """measure() -> realtime_metrics of the running loop after plan.dds_warmup_s: over `seconds` (None:
    plan.realtime_s) of wall time, or (`periods` given) until that many control periods were observed
    (RuntimeError when they were not within timeout_s)."""
    seconds = plan.realtime_s if seconds is None else seconds
    def measure(observer, procs):
        _wait_for_loop(observer)            # measure the running loop, not its start-up
        time.sleep(plan.dds_warmup_s)
        observer.drain()
        states, commands, seen = [], [], 0
        start = time.monotonic()
        while (time.monotonic() - start < seconds) if periods is None else seen <= periods:
            if time.monotonic() - start > timeout_s:
                raise RuntimeError(f'realtime: {seen} of {periods} periods within {timeout_s:g} s')
            time.sleep(POLL_S)
            states.append(observer.take('joint_states'))
            commands.append(observer.take('robot_joint_commands'))
            seen += len(states[-1])
        procs.check_alive()
        return realtime_metrics(np.concatenate(states), np.concatenate(commands))
    return measure


def pooled(runs):
    """The realtime_metrics of several runs as one: periods and missed summed (hit_ratio from them), the
    median p50 latency, the worst p99 latency and real-time factor."""
    periods, missed = sum(m['periods'] for m in runs), sum(m['missed'] for m in runs)
    return {'periods': periods, 'missed': missed, 'hit_ratio': 1.0 - missed / periods,
            'latency_p50_ms': float(np.median([m['latency_p50_ms'] for m in runs])),
            'latency_p99_ms': max(m['latency_p99_ms'] for m in runs), 'rtf': min(m['rtf'] for m in runs)}


def missed_vs_floor(missed, periods, floor_missed, floor_periods):
    """A run's missed periods over the floor's in as many periods:
    missed / max(floor_missed * periods / floor_periods, 1); a floor that missed none allows one."""
    return missed / max(floor_missed * periods / floor_periods, 1.0)


def bench_realtime(plan, env, log, logdir):
    """B3 metrics per run of REALTIME_RUNS: plan.realtime_rounds rounds, each the floor with the run's messages
    (the wrench stream too when its law reads the force) then the run, each for realtime_s / rounds; a run's
    rounds pooled are held against its floor's rounds pooled, and the worst of the runs are the headline keys."""
    per, floors, seconds = {}, {}, plan.realtime_s / plan.realtime_rounds
    with Session(env, logdir) as session:
        for key, (scenario, experiment) in REALTIME_RUNS.items():
            wrench, runs, bare = reads_wrench(scenario, experiment), [], []
            for r in range(plan.realtime_rounds):
                bare.append(session.run('floor', 'realtime', realtime_run(plan, seconds=seconds),
                                        label=f'floor_before_{key}', wrench=wrench, part=f'_{r}'))
                runs.append(session.run(scenario, 'realtime', realtime_run(plan, seconds=seconds), experiment,
                                        label=key, realism=REALISM.get(key, 'ideal'), part=f'_{r}'))
            floors[key], per[key] = pooled(bare), pooled(runs)
            log(f'  floor ({plan.realtime_rounds} rounds{", with the wrench" if wrench else ""}): '
                + ', '.join(f'{k} {v:.4g}' for k, v in floors[key].items()))
            log(f'  {key}: ' + ', '.join(f'{k} {v:.4g}' for k, v in per[key].items()))
        warn_killed(session.killed, log)
    return realtime_results(per, floors)


def realtime_results(per, floors):
    """B3's keys from the metrics of each run and of its floor (`per`, `floors`: run -> realtime_metrics); each
    run is held against its own floor; the realtime_floor_* keys pool every floor."""
    floor = pooled(list(floors.values()))
    vs_floor = {s: missed_vs_floor(m['missed'], m['periods'], floors[s]['missed'], floors[s]['periods'])
                for s, m in per.items()}
    out = {'realtime_missed_vs_floor': max(vs_floor.values()),
           'realtime_1khz_deadline_hit_ratio': min(m['hit_ratio'] for m in per.values()),
           'realtime_latency_p50_ms': max(m['latency_p50_ms'] for m in per.values()),
           'realtime_latency_p99_ms': max(m['latency_p99_ms'] for m in per.values()),
           'realtime_rtf': min(m['rtf'] for m in per.values()),
           'realtime_floor_missed_periods': floor['missed'], 'realtime_floor_periods': floor['periods'],
           'realtime_floor_1khz_deadline_hit_ratio': floor['hit_ratio'],
           'realtime_floor_latency_p50_ms': floor['latency_p50_ms'],
           'realtime_floor_latency_p99_ms': floor['latency_p99_ms'], 'realtime_floor_rtf': floor['rtf']}
    for s, m in per.items():
        out.update({f'realtime_missed_vs_floor_{s}': vs_floor[s], f'realtime_missed_periods_{s}': m['missed'],
                    f'realtime_periods_{s}': m['periods'], f'realtime_floor_missed_periods_{s}': floors[s]['missed'],
                    f'realtime_floor_periods_{s}': floors[s]['periods'],
                    f'realtime_1khz_deadline_hit_ratio_{s}': m['hit_ratio'],
                    f'realtime_latency_p50_ms_{s}': m['latency_p50_ms'],
                    f'realtime_latency_p99_ms_{s}': m['latency_p99_ms'], f'realtime_rtf_{s}': m['rtf']})
    return {k: float(v) for k, v in out.items()}


def warn_killed(names, log):
    if names:
        log(f'  warning: {sorted(names)} ignored SIGTERM for {STOP_GRACE_S:g} s and were killed (SIGKILL)')
