"""Helpers of test_robustness.py: node processes, a monitoring node, fault generators.

- NodeProcess: `python -m <module> --ros-args ...` as a child process on a private ROS domain,
  loopback discovery, output to a log file; stop() = SIGINT, then SIGKILL after a deadline;
  kill() = SIGKILL. Every process is stopped by its own pid, also when a test fails.
- Monitor: a node of the test process that records what the nodes publish (joint_states,
  commands, references, errors, /diagnostics), with receive times, and checks every effort it
  sees against the limits (finite, |effort| <= limit).
- Hypothesis strategies of bad messages, one per subscribed topic of the two nodes; each
  example carries at least one fault (`kind`) and, where the fault is one the node must reject,
  `must_reject` is True (the test oracle).
- Tally: the figures of the table in docs/robustness.md, written to out/robustness/summary.json.
- `python test/support/robustness.py flood ...`: a joint_states flood publisher (its own process).
"""
import contextlib
import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT_DIR = os.path.join(ROOT, 'out', 'robustness')
NS = 1_000_000_000
INT32_MAX = 2 ** 31 - 1


# -- processes ---------------------------------------------------------------------------------------------------
def ros_env(domain_id, **extra):
    """Environment of a child process: loopback discovery, `domain_id`, unbuffered output."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID=str(int(domain_id)),
               PYTHONUNBUFFERED='1', PYTHONDONTWRITEBYTECODE='1')
    env.pop('ROS_STATIC_PEERS', None)
    pp = env.get('PYTHONPATH', '')
    env['PYTHONPATH'] = ROOT + (os.pathsep + pp if pp else '')
    env.update({k: str(v) for k, v in extra.items()})
    return env


def ros_args(params_file=None, **params):
    """--ros-args list: the params file, then `-p name:=value` (value YAML: lists, floats with a point)."""
    args = ['--ros-args']
    if params_file:
        args += ['--params-file', params_file]
    for name, value in params.items():
        args += ['-p', f'{name.replace("__", ".")}:={yaml_value(value)}']
    return args


def yaml_value(value):
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ('.nan' if math.isnan(value) else
                                                         ('.inf' if value > 0 else '-.inf'))
    if isinstance(value, (list, tuple)):
        return '[' + ','.join(yaml_value(v) for v in value) + ']'
    if isinstance(value, str):
        return f"'{value}'" if value else "''"
    return str(value)


def config(scenario):
    return os.path.join(ROOT, 'config', f'{scenario}.yaml')


class NodeProcess:
    """One node as a child process; output in `log_path`. Use as a context manager (always stopped)."""

    def __init__(self, module, args, domain_id, log_dir, name=None, pre_args=()):
        self.module = module
        self.name = name or module.rsplit('.', 1)[-1]
        os.makedirs(log_dir, exist_ok=True)
        self.log_path = os.path.join(log_dir, f'{self.name}.{time.monotonic_ns()}.log')
        self._log = open(self.log_path, 'w')
        target = [module] if module.endswith('.py') else ['-m', module]     # a script file, or a module
        cmd = [sys.executable, *target, *pre_args, *args]
        self.proc = subprocess.Popen(cmd, cwd=ROOT, env=ros_env(domain_id), stdout=self._log,
                                     stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        self.pid = self.proc.pid

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

    def alive(self):
        return self.proc.poll() is None

    def kill(self):
        """SIGKILL (no clean-up in the node: a crash)."""
        if self.alive():
            os.kill(self.pid, signal.SIGKILL)
        self.proc.wait(timeout=10)
        return self.proc.returncode

    def stop(self, timeout=5.0):
        """SIGINT, then SIGKILL if still running after `timeout` s; returns the exit code."""
        try:
            if self.alive():
                os.kill(self.pid, signal.SIGINT)
                try:
                    self.proc.wait(timeout=timeout)
                except subprocess.TimeoutExpired:
                    os.kill(self.pid, signal.SIGKILL)
                    self.proc.wait(timeout=10)
            return self.proc.returncode
        finally:
            self._log.close()

    def wait(self, timeout):
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None

    def output(self):
        self._log.flush()
        with open(self.log_path) as f:
            return f.read()

    def rss_kb(self):
        """Resident set size of the process, kB."""
        return rss_kb(self.pid)


def rss_kb(pid):
    """Resident set size of process `pid`, kB (VmRSS of /proc/<pid>/status)."""
    with open(f'/proc/{pid}/status') as f:
        for line in f:
            if line.startswith('VmRSS:'):
                return int(line.split()[1])
    raise RuntimeError(f'no VmRSS for pid {pid}')


@contextlib.contextmanager
def processes():
    """A list to append NodeProcess objects to; all stopped (by pid) on exit, whatever happens."""
    procs = []
    try:
        yield procs
    finally:
        for p in reversed(procs):
            with contextlib.suppress(Exception):
                p.stop()


def namespace_args(namespace):
    """-r rules putting a node in `namespace` ('/r1'; None or '' = none) with /clock moved to <namespace>/clock,
    so several robots with their own simulated time share one domain."""
    if not namespace:
        return []
    return ['-r', f'__ns:={namespace}', '-r', f'/clock:={namespace}/clock']


def bridge(domain_id, log_dir, scenario='polar_two_link', namespace=None, **params):
    """The bridge process with config/<scenario>.yaml (its /**/sim_bridge section applies in any namespace),
    then `params`; in `namespace` (namespace_args)."""
    args = ros_args(config(scenario), **params) + namespace_args(namespace)
    return NodeProcess('sim_bridge.bridge_node', args, domain_id, log_dir, name=_log_name('sim_bridge', namespace))


def controller(domain_id, log_dir, scenario='polar_two_link', namespace=None, **params):
    """The controller process with config/<scenario>.yaml (its /**/controller section), then `params`; in
    `namespace` (namespace_args)."""
    args = ros_args(config(scenario), **params) + namespace_args(namespace)
    return NodeProcess('robot_control.ros.controller_node', args, domain_id, log_dir,
                       name=_log_name('controller', namespace))


def _log_name(node, namespace):
    return node + (namespace or '').replace('/', '_')


# -- waiting -------------------------------------------------------------------------------------------------------
def spin_until(executor, predicate, timeout, every=None, action=None, step=0.002):
    """Spin `executor` until predicate() or `timeout` s of wall time; action() every `every` s."""
    deadline = time.monotonic() + timeout
    next_action = time.monotonic() + (every if every else math.inf)
    while True:
        if predicate():
            return True
        now = time.monotonic()
        if now >= deadline:
            return bool(predicate())
        if action is not None and now >= next_action:
            action()
            next_action = now + every
        executor.spin_once(timeout_sec=min(step, max(deadline - now, 0.0)))


# -- figures -------------------------------------------------------------------------------------------------------
class Tally:
    """Figures of the table in docs/robustness.md, accumulated over the tests of one run and written as JSON."""

    def __init__(self):
        self.faults = []            # {'fault', 'survived', 'detail'}
        self.bad_inputs = {}        # topic -> count
        self.efforts_checked = 0
        self.unsafe = 0
        self.figures = {}           # item -> {name: value}

    def fault(self, name, survived, **detail):
        self.faults.append({'fault': name, 'survived': bool(survived), **detail})

    def inputs(self, topic, count):
        self.bad_inputs[topic] = self.bad_inputs.get(topic, 0) + int(count)

    def efforts(self, checked, unsafe):
        self.efforts_checked += int(checked)
        self.unsafe += int(unsafe)

    def figure(self, item, **values):
        self.figures.setdefault(item, {}).update(values)

    def as_dict(self):
        return {
            'faults_injected': len(self.faults),
            'faults_survived': sum(f['survived'] for f in self.faults),
            'faults': self.faults,
            'bad_inputs_per_topic': dict(sorted(self.bad_inputs.items())),
            'bad_inputs_total': sum(self.bad_inputs.values()),
            'efforts_checked': self.efforts_checked,
            'unsafe_commands_published': self.unsafe,
            'figures': self.figures,
        }

    def table(self):
        d = self.as_dict()
        rows = [('faults injected / survived', f"{d['faults_injected']} / {d['faults_survived']}")]
        for topic, count in d['bad_inputs_per_topic'].items():
            rows.append((f'bad inputs tried: {topic}', f'{count}'))
        rows.append(('bad inputs tried: total', f"{d['bad_inputs_total']}"))
        rows.append(('efforts checked (finite, within limits)', f"{d['efforts_checked']}"))
        rows.append(('unsafe commands published (must be 0)', f"{d['unsafe_commands_published']}"))
        width = max(len(r[0]) for r in rows)
        lines = [f'| {"figure".ljust(width)} | value |', f'|{"-" * (width + 2)}|-------|']
        lines += [f'| {a.ljust(width)} | {b} |' for a, b in rows]
        return '\n'.join(lines)

    def write(self, path=None):
        path = path or os.path.join(OUT_DIR, 'summary.json')
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, 'w') as f:
            json.dump(self.as_dict(), f, indent=2, default=float)
        with open(os.path.splitext(path)[0] + '.md', 'w') as f:
            f.write(self.table() + '\n')
        return path


def check_efforts(efforts, limit, slack=1e-9):
    """(checked, unsafe) for an (k, n) array of efforts against the (n,) limit: unsafe = non-finite or over."""
    e = np.asarray(efforts, dtype=float).reshape(-1, len(limit)) if np.size(efforts) else np.zeros((0, len(limit)))
    bad = ~np.isfinite(e) | (np.abs(np.nan_to_num(e, nan=np.inf)) > np.asarray(limit) * (1 + slack))
    return e.shape[0], int(np.count_nonzero(bad.any(axis=1)))


# -- bad messages (hypothesis) ---------------------------------------------------------------------------------------
def _strategies():
    """Imported lazily: the flood entry point below runs without hypothesis."""
    from hypothesis import strategies as st
    return st


#: faults a node must reject (never act on), per topic family
JOINT_STATE_REJECT = ('nan', 'inf', 'huge', 'empty', 'length', 'duplicate', 'missing', 'unknown', 'stamp_past',
                      'stamp_future', 'stamp_negative')
TRAJECTORY_REJECT = ('nan', 'inf', 'length', 'duplicate', 'unknown', 'missing', 'times', 'partial',
                     'stamp_past', 'huge')
WRENCH_REJECT = ('nan', 'inf', 'huge')
COMMAND_REJECT = ('nan', 'inf', 'empty', 'length', 'duplicate', 'unknown', 'missing', 'extra')
ARRAY_REJECT = ('nan', 'inf', 'empty', 'length')

NONFINITE = (math.nan, math.inf, -math.inf)
HUGE = (1e300, -1e300, 1.7976931348623157e308, -1.7976931348623157e308, 1e30, -1e30, 1e12, -1e12)


def floats_any():
    """Any double: NaN, inf, huge, subnormal, ordinary."""
    st = _strategies()
    return st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(NONFINITE + HUGE),
                     st.floats(-10.0, 10.0))


def floats_ok(bound=2.0):
    return _strategies().floats(-bound, bound, allow_nan=False, allow_infinity=False)


class Bad:
    """A generated bad input: the message fields (plain Python), its fault kind and the oracle."""

    __slots__ = ('kind', 'must_reject', 'fields')

    def __init__(self, kind, must_reject, **fields):
        self.kind = kind
        self.must_reject = must_reject
        self.fields = fields

    def __repr__(self):
        return f'Bad({self.kind!r}, must_reject={self.must_reject}, {self.fields!r})'


def name_variants(joints, unknown=('gripper', 'theta1 ', '', 'R', 'x2', '\u00e9')):
    """Name lists per fault: 'ok' (permutations), 'duplicate', 'missing', 'unknown' (an unknown name
    instead of a controlled one: the set is wrong) and 'extra' (unknown names besides all joints)."""
    import itertools
    joints = list(joints)
    perms = [list(p) for p in itertools.islice(itertools.permutations(joints), 24)]
    out = {'ok': perms, 'duplicate': [], 'missing': [], 'unknown': [], 'extra': []}
    for p in perms[:6]:
        for i in range(len(p)):
            out['duplicate'].append(p[:i + 1] + [p[i]] + p[i + 1:])
            out['missing'].append(p[:i] + p[i + 1:])
            for u in unknown:
                out['unknown'].append(p[:i] + [u] + p[i + 1:])
                out['extra'].append(p[:i] + [u] + p[i:])
    return out


def _nonfinite(kind):
    return (math.nan,) if kind == 'nan' else (math.inf, -math.inf)


def _lists(st, n, bound):
    return st.lists(st.floats(-bound, bound), min_size=n, max_size=n)


def joint_states(joints):
    """sensor_msgs/JointState fields for the controller's joint_states, each with at least one fault.

    Faults: nan, inf (in a controlled joint), huge (finite, 1e12..1.8e308), empty arrays, length
    (position or velocity not one per name), duplicate / missing / unknown names, extra unknown
    names carrying NaN, stamps far in the past (1 ns), future (2^31 - 1 s) or negative. A stamp of
    None means: the publisher's running clock. Positions under valid names with no velocities at all are
    a valid state (a driver that sends none: the controller estimates qd), not a fault.
    """
    st = _strategies()
    names = name_variants(joints)
    kinds = ('nan', 'inf', 'huge', 'empty', 'length', 'duplicate', 'missing', 'unknown', 'extra', 'stamp_past',
             'stamp_future', 'stamp_negative')

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(kinds))
        nm = list(draw(st.sampled_from(names.get(kind, names['ok']))))
        n = len(nm)
        pos, vel = draw(_lists(st, n, 2.0)), draw(_lists(st, n, 5.0))
        eff = list(draw(st.sampled_from(([], [math.nan], [1e300] * n, [0.0] * (n + 1)))))  # never read
        stamp = None
        if kind in ('nan', 'inf', 'huge'):
            arr = draw(st.sampled_from((pos, vel)))
            i = draw(st.integers(0, n - 1))
            arr[i] = draw(st.sampled_from(HUGE if kind == 'huge' else _nonfinite(kind)))
        elif kind == 'extra':
            for i, s in enumerate(nm):
                if s not in joints:
                    pos[i] = draw(st.sampled_from(NONFINITE + HUGE))
        elif kind == 'empty':
            which = draw(st.integers(0, 3))
            if which == 0:
                nm, pos, vel, eff = [], [], [], []
            if which in (0, 1):
                pos, vel = [], []
            elif which == 2:
                pos = []
            else:
                vel = []
        elif kind == 'length':
            arr = draw(st.sampled_from((pos, vel)))
            cut = draw(st.integers(-2, 2).filter(bool))
            if cut < 0:
                del arr[cut:]
            else:
                arr.extend([math.nan] * cut)
        elif kind == 'stamp_past':
            stamp = (0, 1)
        elif kind == 'stamp_future':
            stamp = (INT32_MAX, draw(st.integers(0, NS - 1)))
        elif kind == 'stamp_negative':
            stamp = (draw(st.integers(-2 ** 31, -1)), draw(st.integers(0, NS - 1)))
        # positions without velocities, under valid names: a driver that sends none (the controller estimates qd)
        positions_only = kind in ('empty', 'length') and n > 0 and vel == [] and len(pos) == n
        return Bad(kind, kind in JOINT_STATE_REJECT and not positions_only, name=nm, position=pos, velocity=vel,
                   effort=eff, stamp=stamp)
    return build()


def trajectories(joints):
    """trajectory_msgs/JointTrajectory fields for ~/joint_trajectory, each with at least one fault.

    Faults: nan, inf, huge positions (1e6 and beyond: outside any joint's travel), empty points (a
    cancel, accepted), length (positions not one per joint), duplicate / unknown / missing
    joint_names, times (a single point at 0 s, negative, equal or decreasing), partial (velocities in
    some points only), stamp_past (the whole trajectory ended long ago), stamp_future (starts in 2^31 s).
    """
    st = _strategies()
    names = name_variants(joints)
    kinds = ('nan', 'inf', 'huge', 'empty', 'length', 'duplicate', 'unknown', 'missing', 'times', 'partial',
             'stamp_past', 'stamp_future')

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(kinds))
        nm = list(draw(st.sampled_from(names.get(kind, names['ok']))))
        n = len(nm)
        k = draw(st.integers(1, 3))
        times = [0.1 * (i + 1) + draw(st.floats(0.0, 2.0)) * (i + 1) for i in range(k)]
        pos = [draw(_lists(st, n, 1.0)) for _ in range(k)]
        vel = [[0.0] * n for _ in range(k)] if draw(st.booleans()) else None
        stamp = None
        if kind in ('nan', 'inf', 'huge'):
            field = pos if (vel is None or draw(st.booleans())) else vel
            row = field[draw(st.integers(0, k - 1))]
            row[draw(st.integers(0, n - 1))] = draw(st.sampled_from(
                (1e300, -1e300, 1e30, 1e7, -1e7) if kind == 'huge' else _nonfinite(kind)))
        elif kind == 'empty':
            times, pos, vel = [], [], None
        elif kind == 'length':
            row = pos[draw(st.integers(0, k - 1))]
            if draw(st.booleans()):
                row.append(0.0)
            else:
                row.pop()
        elif kind == 'times':
            how = draw(st.sampled_from(('zero', 'negative', 'equal', 'decreasing')))
            if how in ('equal', 'decreasing'):
                times.append(times[-1] if how == 'equal' else times[-1] / 2.0)
                pos.append(list(pos[-1]))
                if vel is not None:
                    vel.append(list(vel[-1]))
            elif how == 'zero':            # nothing after 0 s: a jump, refused
                times, pos, vel = [0.0], pos[:1], None if vel is None else vel[:1]
            else:
                times[0] = -draw(st.floats(0.001, 1e4))
        elif kind == 'partial':
            times.append(times[-1] + 0.5)
            pos.append(list(pos[-1]))
            vel = [[0.0] * n] + [[] for _ in range(len(times) - 1)]
        elif kind == 'stamp_past':
            stamp = 'past'
        elif kind == 'stamp_future':
            stamp = (INT32_MAX, 0)
        return Bad(kind, kind in TRAJECTORY_REJECT, joint_names=nm, times=times, positions=pos,
                   velocities=vel, accelerations=None, stamp=stamp)
    return build()


def wrenches(force_axes):
    """geometry_msgs/WrenchStamped fields, each with a fault on a force axis: nan, inf (must be
    rejected) or huge finite; the other components carry NaN/inf/huge noise (not read)."""
    st = _strategies()
    idx = [('x', 'y', 'z').index(a) for a in force_axes]
    noise = NONFINITE + HUGE + (0.0, 1.0)

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(('nan', 'inf', 'huge')))
        force = [draw(st.sampled_from(noise)) for _ in range(3)]
        torque = list(draw(st.sampled_from(((0.0,) * 3, (math.nan,) * 3, (1e300, -math.inf, 0.0)))))
        for i in idx:
            force[i] = draw(st.floats(-50.0, 50.0))
        i = draw(st.sampled_from(idx))
        force[i] = draw(st.sampled_from(HUGE if kind == 'huge' else _nonfinite(kind)))
        stamp = draw(st.sampled_from(((0, 0), (0, 1), (INT32_MAX, 0), (-5, 0), None)))
        return Bad(kind, kind in WRENCH_REJECT, force=force, torque=torque, stamp=stamp,
                   frame_id=draw(st.sampled_from(('world', '', 'no_such_frame'))))
    return build()


#: faults of ~/target_pose and ~/target_wrench the controller must refuse
POSE_REJECT = ('nan', 'inf', 'huge', 'quat_zero', 'quat_far', 'frame')
TARGET_WRENCH_REJECT = ('nan', 'inf', 'huge', 'frame')
#: frames other than a URDF's base the fuzzers try (the base's own name is added per robot)
OTHER_FRAMES = ('world', 'map', 'base_link', 'lbr_iiwa_link_7', ' ', 'BASE', 'lbr_iiwa_link_0 ', '\u00e9')


def _unit_quaternion(draw, st):
    """A unit quaternion (x, y, z, w) from four drawn components (the identity when they nearly vanish)."""
    quat = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(4)])
    norm = float(np.linalg.norm(quat))
    return (quat / norm).tolist() if norm > 0.1 else [0.0, 0.0, 0.0, 1.0]


def target_poses(base_frame):
    """geometry_msgs/PoseStamped fields for the controller's ~/target_pose (impedance, hybrid), each with a fault
    or an edge case. Refused: nan, inf (in the position or the orientation), huge (a position beyond 1e6 m),
    quat_zero (a quaternion of norm 0 or nearly), quat_far (norm outside [0.5, 2]), frame (header.frame_id
    other than `base_frame` or ''). Accepted: quat_scaled (norm in (0.5, 2): normalised), stamp (past, far
    future, negative: at once or pending). The position lies within 1 m of the base otherwise."""
    st = _strategies()
    kinds = ('nan', 'inf', 'huge', 'quat_zero', 'quat_far', 'quat_scaled', 'frame', 'stamp')

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(kinds))
        position = [draw(st.floats(-1.0, 1.0)) for _ in range(3)]
        quat = _unit_quaternion(draw, st)
        frame = draw(st.sampled_from(('', base_frame)))
        stamp = None
        if kind in ('nan', 'inf'):
            i = draw(st.integers(0, 6))
            value = draw(st.sampled_from(_nonfinite(kind)))
            if i < 3:
                position[i] = value
            else:
                quat[i - 3] = value
        elif kind == 'huge':
            position[draw(st.integers(0, 2))] = draw(st.sampled_from(HUGE))
        elif kind == 'quat_zero':
            quat = draw(st.sampled_from(([0.0] * 4, [0.0, 0.0, 0.0, 1e-300], [1e-9, -1e-9, 0.0, 0.0])))
        elif kind == 'quat_far':
            scale = draw(st.sampled_from((0.1, 0.49, 2.01, 10.0, 1e6, 1e300)))
            quat = [v * scale for v in quat]
        elif kind == 'quat_scaled':
            scale = draw(st.floats(0.51, 1.99))
            quat = [v * scale for v in quat]
        elif kind == 'frame':
            frame = draw(st.sampled_from(OTHER_FRAMES))
        else:
            stamp = draw(st.sampled_from(((0, 1), (INT32_MAX, 0), (-5, 0), 'past')))
        return Bad(kind, kind in POSE_REJECT, position=position, orientation=quat, frame_id=frame, stamp=stamp)
    return build()


def target_wrenches(base_frame):
    """geometry_msgs/WrenchStamped fields for the controller's ~/target_wrench (six task axes: force and
    torque), each with a fault or an edge case. Refused: nan, inf, huge (beyond 1e6) in a component, frame
    (header.frame_id other than `base_frame` or ''). Accepted: ok (finite, up to 20 N and 2 N m)."""
    st = _strategies()

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(('nan', 'inf', 'huge', 'frame', 'ok')))
        six = [draw(st.floats(-20.0, 20.0)) for _ in range(3)] + [draw(st.floats(-2.0, 2.0)) for _ in range(3)]
        frame = draw(st.sampled_from(('', base_frame)))
        if kind in ('nan', 'inf', 'huge'):
            six[draw(st.integers(0, 5))] = draw(st.sampled_from(HUGE if kind == 'huge' else _nonfinite(kind)))
        elif kind == 'frame':
            frame = draw(st.sampled_from(OTHER_FRAMES))
        stamp = draw(st.sampled_from(((0, 0), (INT32_MAX, 0), (-5, 0), None)))
        return Bad(kind, kind in TARGET_WRENCH_REJECT, force=six[:3], torque=six[3:], stamp=stamp, frame_id=frame)
    return build()


def commands(joints):
    """sensor_msgs/JointState effort commands for the bridge's robot_joint_commands, each with a fault.

    Faults: nan, inf, huge (finite: applied clipped to the effort limit), empty, length,
    duplicate / unknown / missing names, stamp_past / stamp_future (lockstep: not the state's stamp).
    """
    st = _strategies()
    names = name_variants(joints)
    kinds = ('nan', 'inf', 'huge', 'empty', 'length', 'duplicate', 'unknown', 'missing', 'extra', 'stamp_past',
             'stamp_future')

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(kinds))
        nm = list(draw(st.sampled_from(names.get(kind, names['ok']))))
        n = len(nm)
        eff = draw(_lists(st, n, 20.0))
        pos = list(draw(st.sampled_from(([], [math.nan], [1e300, 2.0]))))     # not read by the bridge
        stamp = None
        if kind in ('nan', 'inf', 'huge'):
            eff[draw(st.integers(0, n - 1))] = draw(st.sampled_from(HUGE if kind == 'huge' else _nonfinite(kind)))
        elif kind == 'empty':
            nm, eff = draw(st.sampled_from(((list(joints), []), ([], []))))
        elif kind == 'length':
            if draw(st.booleans()):
                eff.pop()
            else:
                eff.extend([draw(st.sampled_from(NONFINITE + HUGE))] * draw(st.integers(1, 3)))
        elif kind in ('stamp_past', 'stamp_future'):
            stamp = kind[6:]
        return Bad(kind, kind in COMMAND_REJECT, name=nm, effort=eff, position=pos, stamp=stamp)
    return build()


def effort_arrays(n):
    """std_msgs/Float64MultiArray data for effort_controller/commands, each with a fault:
    nan, inf, huge (finite: applied clipped), empty, length."""
    st = _strategies()

    @st.composite
    def build(draw):
        kind = draw(st.sampled_from(('nan', 'inf', 'huge', 'empty', 'length')))
        data = draw(_lists(st, n, 20.0))
        if kind in ('nan', 'inf', 'huge'):
            data[draw(st.integers(0, n - 1))] = draw(st.sampled_from(HUGE if kind == 'huge' else _nonfinite(kind)))
        elif kind == 'empty':
            data = []
        elif draw(st.booleans()):
            data = data + [draw(st.sampled_from(NONFINITE + HUGE + (0.0,)))] * draw(st.integers(1, 4))
        else:
            data = data[:-1]
        return Bad(kind, kind in ARRAY_REJECT, data=data)
    return build()


# -- Bad -> message ---------------------------------------------------------------------------------------------------
def _stamp(msg_stamp, stamp, now_ns):
    if stamp is None:
        sec, nsec = divmod(int(now_ns), NS)
    else:
        sec, nsec = stamp
    msg_stamp.sec, msg_stamp.nanosec = int(sec), int(nsec)


def joint_state_msg(bad, now_ns):
    from sensor_msgs.msg import JointState
    f = bad.fields
    msg = JointState()
    _stamp(msg.header.stamp, f['stamp'], now_ns)
    msg.name = list(f['name'])
    msg.position = [float(v) for v in f['position']]
    msg.velocity = [float(v) for v in f['velocity']]
    msg.effort = [float(v) for v in f['effort']]
    return msg


def _reference_stamp(msg_stamp, stamp, now_ns):
    """A reference's stamp: (sec, nanosec), 'past' (an hour before now_ns) or None (zero: at once)."""
    if stamp == 'past':
        stamp = divmod(max(int(now_ns) - 3600 * NS, 1), NS)
    _stamp(msg_stamp, stamp if stamp is not None else (0, 0), now_ns)


def trajectory_msg(bad, now_ns):
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    f = bad.fields
    msg = JointTrajectory()
    _reference_stamp(msg.header.stamp, f['stamp'], now_ns)
    msg.joint_names = list(f['joint_names'])
    for i, t in enumerate(f['times']):
        p = JointTrajectoryPoint()
        ns = int(round(t * NS))
        sec, nsec = divmod(ns, NS)
        p.time_from_start = Duration(sec=max(min(sec, INT32_MAX), -2 ** 31), nanosec=nsec)
        p.positions = [float(v) for v in f['positions'][i]]
        if f['velocities'] is not None:
            p.velocities = [float(v) for v in f['velocities'][i]]
        msg.points.append(p)
    return msg


def wrench_msg(bad, now_ns):
    from geometry_msgs.msg import WrenchStamped
    f = bad.fields
    msg = WrenchStamped()
    _stamp(msg.header.stamp, f['stamp'], now_ns)
    msg.header.frame_id = f['frame_id']
    msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in f['force'])
    msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = (float(v) for v in f['torque'])
    return msg


def pose_msg(bad, now_ns):
    """The PoseStamped of a target_poses example; a 'past' stamp is an hour before `now_ns`."""
    from geometry_msgs.msg import PoseStamped
    f = bad.fields
    msg = PoseStamped()
    _reference_stamp(msg.header.stamp, f['stamp'], now_ns)
    msg.header.frame_id = f['frame_id']
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in f['position'])
    o.x, o.y, o.z, o.w = (float(v) for v in f['orientation'])
    return msg


def command_msg(bad, expected_ns):
    """The command; its stamp is the state's (`expected_ns`) unless the fault is the stamp."""
    from sensor_msgs.msg import JointState
    f = bad.fields
    msg = JointState()
    stamp = {'past': expected_ns - 1_000_000, 'future': expected_ns + 1_000_000}.get(f['stamp'], expected_ns)
    _stamp(msg.header.stamp, None, max(stamp, 0))
    msg.name = list(f['name'])
    msg.effort = [float(v) for v in f['effort']]
    msg.position = [float(v) for v in f['position']]
    return msg


def array_msg(bad):
    from std_msgs.msg import Float64MultiArray
    msg = Float64MultiArray()
    msg.data = [float(v) for v in bad.fields['data']]
    return msg


def _qos(depth):
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)


# -- monitoring node ---------------------------------------------------------------------------------------------------
class Monitor:
    """A node of the test process recording what bridge and controller publish (receive times: monotonic s).

    states: (stamp_ns, t_rx, q, qd, effort) from joint_states; commands: (stamp_ns, t_rx, names, effort);
    references / errors: controller ~/reference, ~/error as (stamp_ns, names, pos, vel, eff);
    diagnostics: (stamp_ns, t_rx, {status name: (level, message, values)}); wrenches: (stamp_ns, force (3,)).
    The 1 kHz streams are sampled (KEEP_LAST 1: always the newest sample, so the monitor never lags behind
    the loop it watches); watch(key, depth) subscribes with a queue instead, e.g. to catch the first
    messages of a restarted node, and unwatch(key) stops.
    """

    def __init__(self, context, joints, controller='controller', name='robustness_monitor',
                 record=('joint_states', 'commands')):
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import WrenchStamped
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        self.node = Node(name, context=context)
        self.joints = tuple(joints)
        self.states, self.commands, self.references, self.errors, self.diagnostics, self.wrenches = \
            [], [], [], [], [], []
        self._topics = {'joint_states': (JointState, 'joint_states', self._on_state),
                        'commands': (JointState, 'robot_joint_commands', self._on_command),
                        'reference': (JointState, f'{controller}/reference', self._joint_state_to(self.references)),
                        'error': (JointState, f'{controller}/error', self._joint_state_to(self.errors)),
                        'wrench': (WrenchStamped, 'ft_sensor/wrench', self._on_wrench)}
        self._subs = {}
        for key in record:
            self.watch(key, depth=1)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, _qos(1000))

    def watch(self, key, depth=5000):
        self.unwatch(key)
        kind, topic, callback = self._topics[key]
        self._subs[key] = self.node.create_subscription(kind, topic, callback, _qos(depth))

    def matched(self, key):
        """Publishers matched by the subscription of `key` (0 when not watched)."""
        sub = self._subs.get(key)
        return 0 if sub is None else sub.get_publisher_count()

    def unwatch(self, key):
        sub = self._subs.pop(key, None)
        if sub is not None:
            self.node.destroy_subscription(sub)

    @staticmethod
    def _stamp(msg):
        return msg.header.stamp.sec * NS + msg.header.stamp.nanosec

    def _on_state(self, msg):
        self.states.append((self._stamp(msg), time.monotonic(), np.array(msg.position), np.array(msg.velocity),
                            np.array(msg.effort)))

    def _on_command(self, msg):
        self.commands.append((self._stamp(msg), time.monotonic(), tuple(msg.name), np.array(msg.effort)))

    def _joint_state_to(self, store):
        def callback(msg):
            store.append((self._stamp(msg), tuple(msg.name), np.array(msg.position), np.array(msg.velocity),
                          np.array(msg.effort)))
        return callback

    def _on_wrench(self, msg):
        f = msg.wrench.force
        self.wrenches.append((self._stamp(msg), np.array([f.x, f.y, f.z])))

    def _on_diag(self, msg):
        from robot_control.ros.conversions import diagnostic_values
        self.diagnostics.append((self._stamp(msg), time.monotonic(),
                                 {s.name: diagnostic_values(s) for s in msg.status}))

    def status(self, suffix, since=0.0):
        """The latest (level, message, values) of the status whose name ends with `suffix`, received after `since`."""
        for _, t_rx, d in reversed(self.diagnostics):
            if t_rx < since:
                break
            for name, v in d.items():
                if name.endswith(suffix):
                    return v
        return None

    def statuses(self, suffix):
        """All (stamp_ns, t_rx, (level, message, values)) of the status named ...`suffix`."""
        return [(s, t, v) for s, t, d in self.diagnostics for name, v in d.items() if name.endswith(suffix)]

    def command_efforts(self):
        """(k, n) efforts of every command received, in the monitor's joint order."""
        rows = []
        for _, _, names, eff in self.commands:
            if len(names) != len(eff):
                rows.append([math.nan] * len(self.joints))
                continue
            d = dict(zip(names, eff))
            rows.append([d.get(j, math.nan) for j in self.joints])
        return np.array(rows).reshape(-1, len(self.joints))

    def destroy(self):
        self.node.destroy_node()


@contextlib.contextmanager
def ros_test_context(domain_id):
    """A fresh rclpy context on `domain_id` (loopback discovery from the environment) and an executor."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(domain_id))
    executor = SingleThreadedExecutor(context=ctx)
    try:
        yield ctx, executor
    finally:
        executor.shutdown()
        rclpy.try_shutdown(context=ctx)


# -- flood publisher (run as its own process) -------------------------------------------------------------------------
def flood(domain_id, joints, seconds, rate, out_path, topic='joint_states', stop_file=None):
    """Publish valid joint_states as fast as `rate` Hz allows for `seconds` s, or until `stop_file` exists
    (looked for every 10 ms), busy-waiting on the monotonic clock, no sleeps; header.stamp = CLOCK_MONOTONIC
    at publication, so a subscriber in another process can tell the age of the state a command answers.
    Writes {'sent', 'seconds', 'rate', 'last_stamp_ns'}."""
    import rclpy
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from robot_control.ros.qos import CONTROL_QOS
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(domain_id))
    node = Node('flood', context=ctx)
    try:
        pub = node.create_publisher(JointState, topic, CONTROL_QOS)
        deadline = time.monotonic() + 30.0
        while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
            time.monotonic()                          # busy wait for discovery (bounded)
        msg = JointState()
        msg.name = list(joints)
        n = len(joints)
        msg.velocity = [0.0] * n
        msg.effort = []
        period = 1.0 / rate
        t0 = time.monotonic()
        t_end = t0 + seconds
        next_look = t0
        sent = 0
        stamp = msg.header.stamp
        while True:
            now = time.monotonic()
            if now >= t_end:
                break
            if stop_file and now >= next_look:
                if os.path.exists(stop_file):
                    break
                next_look = now + 0.01
            if now < t0 + sent * period:
                continue
            ns = time.monotonic_ns()
            stamp.sec, stamp.nanosec = divmod(ns, NS)
            msg.position = [0.1 * math.sin(1e-9 * ns)] + [0.5] * (n - 1)
            pub.publish(msg)
            sent += 1
        elapsed = time.monotonic() - t0
        with open(out_path, 'w') as f:
            json.dump({'sent': sent, 'seconds': elapsed, 'rate': sent / elapsed,
                       'last_stamp_ns': stamp.sec * NS + stamp.nanosec}, f)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)


if __name__ == '__main__':
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest='cmd', required=True)
    fp = sub.add_parser('flood', help='joint_states flood publisher')
    fp.add_argument('--domain', type=int, required=True)
    fp.add_argument('--joints', nargs='+', required=True)
    fp.add_argument('--seconds', type=float, default=5.0)
    fp.add_argument('--rate', type=float, default=20000.0)
    fp.add_argument('--out', required=True)
    fp.add_argument('--stop-file', default=None)
    a = parser.parse_args()
    flood(a.domain, a.joints, a.seconds, a.rate, a.out, stop_file=a.stop_file)
