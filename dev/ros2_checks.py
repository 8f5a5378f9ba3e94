"""The checks of `make check-ros2` (dev.check_ros2), each one a function of a
session that returns what it saw (one line) or raises CheckFailed with the reason.

LaunchSession: `ros2 launch robot_control scenario.launch.py scenario:=iiwa mode:=lockstep
namespace:=arm`. RunSession: `ros2 run` of both nodes with config/polar_two_link.yaml at the root.
Lockstep makes the effect of each command visible in the joint_states stamps: they advance while
the loop runs, stand still while the bridge is paused, and restart at 0 after a reset.
"""
import signal

import yaml

from dev.ros2_cli import CheckFailed, parse_rates, parse_value, tail
from robot_control import scenarios
from robot_control.tools.processes import ProcessError
from robot_control.units import seconds

PACKAGE = 'robot_control'
JOINT_STATE = 'sensor_msgs/msg/JointState'
#: s until the first joint_states after a start (PyBullet, Pinocchio and DDS discovery on a busy machine)
STARTUP_TIMEOUT = 90.0
#: s that `ros2 topic hz` listens
HZ_DURATION = 5.0
#: lowest joint_states rate, Hz, that counts as a running lockstep loop (it runs at 1-3 kHz here)
MIN_RATE = 50.0
#: s each of SIGINT, SIGTERM, SIGKILL may take to end `ros2 launch` (it gives its nodes 5 s for SIGINT)
LAUNCH_STOP_WAITS = (15.0, 5.0, 2.0)


class Session:
    """Nodes started by one ros2 command line (`ros2 launch` or `ros2 run`) in `namespace`."""

    scenario = 'polar_two_link'
    namespace = ''

    def __init__(self, ros2, share):
        self.ros2 = ros2
        self.share = share
        self.procs = []

    def name(self, relative):
        """The absolute name of `relative` in the session's namespace."""
        return f'/{self.namespace}/{relative}' if self.namespace else f'/{relative}'

    def config(self):
        return str(self.share / 'config' / f'{self.scenario}.yaml')

    def check_alive(self):
        try:
            for p in self.procs:
                p.check_alive()
        except ProcessError as exc:
            raise CheckFailed(str(exc).replace('\n', ' | ')) from None

    def stamp(self, timeout=None):
        """header.stamp (ns) of the next joint_states; names a dead child in the reason."""
        try:
            return self.ros2.stamp_ns(self.name('joint_states'), JOINT_STATE,
                                      **({} if timeout is None else {'timeout': timeout}))
        except CheckFailed:
            self.check_alive()
            raise

    def advancing(self):
        """Two joint_states stamps (ns), the second later: the loop runs."""
        t0 = self.stamp()
        t1 = self.stamp()
        if t1 <= t0:
            raise CheckFailed(f'{self.name("joint_states")} stands still at t = {seconds(t0):.3f} s')
        return t0, t1

    def wait_for_loop(self):
        """The first joint_states (within STARTUP_TIMEOUT), then two advancing stamps."""
        self.stamp(timeout=STARTUP_TIMEOUT)
        return self.advancing()

    def nodes_listed(self, *nodes):
        listed = self.ros2.names('node', 'list')
        missing = [n for n in nodes if self.name(n) not in listed]
        if missing:
            raise CheckFailed(f'ros2 node list lacks {missing}; it lists {listed}')
        return [self.name(n) for n in nodes]

    def stop(self, waits=LAUNCH_STOP_WAITS):
        """Stop the session's processes with Ctrl-C's SIGINT (escalating); their ManagedProcesses."""
        for p in self.procs:
            p.stop(waits)
        return self.procs

    close = stop


class LaunchSession(Session):
    scenario = 'iiwa'
    namespace = 'arm'

    def start(self):
        self.procs.append(self.ros2.start('launch', PACKAGE, 'scenario.launch.py', f'scenario:={self.scenario}',
                                          'mode:=lockstep', f'namespace:={self.namespace}'))


class RunSession(Session):
    def start(self):
        params = ['--ros-args', '--params-file', self.config()]
        self.procs.append(self.ros2.start('run', PACKAGE, 'sim_bridge_node', *params, '-p', 'mode:=lockstep'))
        self.procs.append(self.ros2.start('run', PACKAGE, 'controller_node', *params))


# -- ros2 launch ------------------------------------------------------------------------------------
def launch_loop(s):
    s.start()
    t0, t1 = s.wait_for_loop()
    topics = s.ros2.names('topic', 'list')
    if s.name('clock') not in topics or '/clock' in topics:
        raise CheckFailed(f'/clock is not remapped into /{s.namespace}: ros2 topic list shows {topics}')
    return (f'{s.scenario} in lockstep under /{s.namespace}: {s.name("joint_states")} advances '
            f'(t = {seconds(t0):.3f} s, then {seconds(t1):.3f} s), simulated time on {s.name("clock")}')


def node_list(s):
    return 'lists ' + ', '.join(s.nodes_listed('controller', 'sim_bridge'))


def topic_echo(s):
    out = s.ros2.run('topic', 'echo', '--once', s.name('joint_states'), JOINT_STATE)
    msg = yaml.safe_load(out.split('\n---', 1)[0])
    joints = list(scenarios.get(s.scenario).joints)
    if not isinstance(msg, dict) or msg.get('name') != joints or len(msg.get('position') or ()) != len(joints):
        raise CheckFailed(f'expected a JointState of {joints}, got: {tail(out)}')
    return f'one JointState of {len(joints)} joints, position[0] = {msg["position"][0]:.4f}'


def topic_hz(s):
    rates = parse_rates(s.ros2.sample('topic', 'hz', s.name('joint_states'), duration=HZ_DURATION))
    if not rates:
        raise CheckFailed(f'ros2 topic hz printed no rate in {HZ_DURATION:g} s')
    if rates[-1] < MIN_RATE:
        raise CheckFailed(f'joint_states at {rates[-1]:.1f} Hz, below {MIN_RATE:g} Hz')
    return f'{s.name("joint_states")} at {rates[-1]:.0f} Hz'


def service_pause(s):
    pause = s.name('sim_bridge/pause')
    said = s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: true}')
    t0, t1 = s.stamp(), s.stamp()
    if t1 != t0:
        raise CheckFailed(f'paused ({said}), yet joint_states moved from {seconds(t0):.3f} to {seconds(t1):.3f} s')
    resumed = s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: false}')
    t2, t3 = s.advancing()
    return f'"{said}": joint_states held at t = {seconds(t1):.3f} s; "{resumed}": advances again ({seconds(t3):.3f} s)'


def param_pause_at(s):
    """pause_at, set while paused to 0.2 s of simulation time ahead: after the resume the bridge stops by
    itself at the first tick at or past it; disarmed again (-1) before the next check."""
    bridge, pause = s.name('sim_bridge'), s.name('sim_bridge/pause')
    with open(s.config(), encoding='utf-8') as f:
        period_ns = round(yaml.safe_load(f)['/**/sim_bridge']['ros__parameters']['control_period'] * 1e9)
    s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: true}')
    at_ns = s.stamp() + 200_000_000
    out = s.ros2.run('param', 'set', bridge, 'pause_at', f'{at_ns / 1e9:.9f}')
    if 'Set parameter successful' not in out:
        raise CheckFailed(f'pause_at {seconds(at_ns):.3f}: {tail(out)}')
    s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: false}')
    t1, t2 = s.stamp(), s.stamp()
    if t2 != t1 or not 0 <= t1 - at_ns < period_ns:
        raise CheckFailed(f'pause_at {seconds(at_ns):.3f} s: joint_states at t = {seconds(t1):.3f}, then '
                          f'{seconds(t2):.3f} s (expected held at the first tick at or past it)')
    s.ros2.run('param', 'set', bridge, 'pause_at', '-1.0')
    resumed = s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: false}')
    s.advancing()
    return (f'pause_at {seconds(at_ns):.3f}: joint_states held at t = {seconds(t1):.3f} s; "{resumed}": '
            'advances again')


def service_reset(s):
    pause = s.name('sim_bridge/pause')
    s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: true}')
    before = s.stamp()
    said = s.ros2.call(s.name('sim_bridge/reset'), 'std_srvs/srv/Trigger')
    after = s.stamp()
    if after >= before:
        raise CheckFailed(f'reset ({said}), yet joint_states went from t = {seconds(before):.3f} '
                          f'to {seconds(after):.3f} s')
    s.ros2.call(pause, 'std_srvs/srv/SetBool', '{data: false}')
    s.advancing()
    return f'"{said}": joint_states back from t = {seconds(before):.3f} to {seconds(after):.3f} s, then running'


def lifecycle(s):
    node = s.name('controller')
    managed = s.ros2.names('lifecycle', 'nodes')
    if node not in managed:
        services = [n for n in s.ros2.names('service', 'list') if n.startswith(node + '/')]
        raise CheckFailed(f'{node} is not a lifecycle node: it offers no {node}/get_state and the other '
                          f'lifecycle services (ros2 lifecycle nodes lists {managed or "none"}; its services: '
                          f'{", ".join(services) or "none"})')
    seen = [_lifecycle_state(s, node, 'active')]
    for transition, state in (('deactivate', 'inactive'), ('activate', 'active')):
        out = s.ros2.run('lifecycle', 'set', node, transition)
        if 'Transitioning successful' not in out:
            raise CheckFailed(f'ros2 lifecycle set {node} {transition}: {tail(out)}')
        seen.append(_lifecycle_state(s, node, state))
    s.advancing()
    return f'{node}: {" -> ".join(seen)}, loop running after activate'


def _lifecycle_state(s, node, want):
    out = s.ros2.run('lifecycle', 'get', node)
    state = out.strip().split()[0] if out.strip() else ''
    if state != want:
        raise CheckFailed(f'ros2 lifecycle get {node}: expected {want}, got: {tail(out)}')
    return out.strip()


def launch_shutdown(s):
    (launch,) = s.stop()
    log = launch.log_path.read_text(errors='replace')
    clean = log.count('process has finished cleanly')
    if launch.stop_signal != signal.SIGINT or launch.returncode != 0 or clean != 2:
        raise CheckFailed(f'ros2 launch ended by {getattr(launch.stop_signal, "name", None)} with status '
                          f'{launch.returncode}, {clean} of 2 nodes finished cleanly: {tail(log)}')
    return 'Ctrl-C (SIGINT): ros2 launch and both nodes finished cleanly'


# -- ros2 run and ros2 param -----------------------------------------------------------------------
def run_loop(s):
    s.start()
    t0, t1 = s.wait_for_loop()
    nodes = s.nodes_listed('controller', 'sim_bridge')
    return (f'sim_bridge_node and controller_node with {s.scenario}.yaml: {", ".join(nodes)}, '
            f'{s.name("joint_states")} advances (t = {seconds(t0):.3f} s, then {seconds(t1):.3f} s)')


def param_get(s):
    with open(s.config(), encoding='utf-8') as f:
        want = yaml.safe_load(f)['/**/controller']['ros__parameters']['zeta']
    got = parse_value(s.ros2.run('param', 'get', s.name('controller'), 'zeta'))
    if float(got) != want:
        raise CheckFailed(f'zeta = {got}, the file says {want}')
    return f'zeta = {got} (as in {s.scenario}.yaml)'


def param_set_accepted(s):
    out = s.ros2.run('param', 'set', s.name('controller'), 'zeta', '1.5')
    got = parse_value(s.ros2.run('param', 'get', s.name('controller'), 'zeta'))
    if 'Set parameter successful' not in out or float(got) != 1.5:
        raise CheckFailed(f'zeta 1.5: {tail(out)}; zeta is now {got}')
    return f'zeta 1.5: {out.strip()}; ros2 param get: {got}'


def param_set_rejected(s):
    out = s.ros2.run('param', 'set', s.name('controller'), 'zeta', '0.5')
    got = parse_value(s.ros2.run('param', 'get', s.name('controller'), 'zeta'))
    failed = [line for line in out.splitlines() if line.startswith('Setting parameter failed')]
    if not failed or 'zeta' not in failed[0].split(':', 1)[1] or float(got) != 1.5:
        raise CheckFailed(f'zeta 0.5 should be refused with a reason naming zeta: {tail(out)}; zeta is now {got}')
    return f'zeta 0.5 refused, zeta stays {got}: "{failed[0]}"'


def run_shutdown(s):
    procs = s.stop(waits=(5.0, 3.0, 2.0))
    bad = [f'{p.name} ended by {getattr(p.stop_signal, "name", None)} with status {p.returncode}'
           for p in procs if p.stop_signal != signal.SIGINT or p.returncode != 0]
    if bad:
        raise CheckFailed('; '.join(bad))
    return 'Ctrl-C (SIGINT): both nodes exited with status 0'


#: (check, function) in order; the first starts the session and the others need it
LAUNCH_CHECKS = (
    ('ros2 launch scenario.launch.py', launch_loop),
    ('ros2 node list', node_list),
    ('ros2 topic echo --once', topic_echo),
    ('ros2 topic hz', topic_hz),
    ('ros2 service call ~/pause', service_pause),
    ('ros2 param set pause_at', param_pause_at),
    ('ros2 service call ~/reset', service_reset),
    ('ros2 lifecycle', lifecycle),
    ('ros2 launch stops on Ctrl-C', launch_shutdown),
)
RUN_CHECKS = (
    ('ros2 run', run_loop),
    ('ros2 param get', param_get),
    ('ros2 param set (accepted)', param_set_accepted),
    ('ros2 param set (rejected)', param_set_rejected),
    ('ros2 run stops on Ctrl-C', run_shutdown),
)
