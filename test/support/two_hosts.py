"""Two hosts on one machine: network namespaces joined by a veth pair, for the two-host tests.

- TwoHosts: two network namespaces (`a`, `b`) with their own addresses in 10.213.<k>.0/24, joined by a
  veth pair, loopback up in each. Names and the subnet come from the creating process's pid, so two
  runs never share them. `link(False)` takes the link down (`b`'s end: the cable pulled at the far side,
  `a` loses the carrier), `link(True)` brings it back. close() stops what still runs inside and deletes
  both namespaces (the veth pair goes with them); nothing outside the namespaces is touched.
- unavailable(): why namespaces cannot be made here (not root, no `ip`), or None.
- Processes inside run `ip netns exec <ns> ...` with /dev/shm of their host bind-mounted over the
  machine's (one directory per namespace), so the two hosts share nothing but the link, as two
  computers would; processes of the same host still share memory, as DDS expects.
- Loop.capture_multicast(): a packet socket (AF_PACKET) on a host's end of the link counting the UDP
  packets to IPv4 multicast addresses that cross it, both ways (to show that none did).
- `python test/support/two_hosts.py capture DEV`: that counter, run on a host; prints the count on SIGINT.
- `python test/support/two_hosts.py observe ...`: an observer node run on a host: receive times and stamps of
  joint_states and robot_joint_commands, the /diagnostics statuses, written as JSON on SIGINT.
- `python test/support/two_hosts.py node --publish-log PATH MODULE ARGS`: MODULE's main(ARGS) with every
  rclpy publish timed (the longest call per topic, and every call over SLOW_NS with its start time).
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

NS = 1_000_000_000
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
#: second octet of the test subnets: 10.213.<k>.0/24, k from the pid
SUBNET_PREFIX = '10.213'


def _ip(*args, check=True):
    return subprocess.run(['ip', *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, check=check)


def unavailable():
    """The reason network namespaces cannot be made here, or None when they can."""
    if not sys.platform.startswith('linux'):
        return 'network namespaces need Linux'
    if os.geteuid() != 0:
        return 'network namespaces need root (CI runs as root)'
    if shutil.which('ip') is None:
        return 'no `ip` command (iproute2)'
    probe = f'rcprobe{os.getpid()}'
    made = _ip('netns', 'add', probe, check=False)
    if made.returncode != 0:
        return f'`ip netns add` failed: {made.stderr.strip()}'
    _ip('netns', 'del', probe, check=False)
    return None


class TwoHosts:
    """Namespaces `a` and `b` joined by a veth pair; `.addr[h]` is host h's address, `.shm[h]` its /dev/shm.

    Use as a context manager: the namespaces exist inside the `with` block and are deleted on leaving
    it, also on failure (processes still inside are killed by pid first).
    """

    def __init__(self, tag=None, multicast=True):
        tag = f'{os.getpid() if tag is None else tag}'
        self.multicast = multicast
        k = 1 + int(tag) % 250 if tag.isdigit() else 1 + sum(map(ord, tag)) % 250
        self.ns = {'a': f'rc{tag}a', 'b': f'rc{tag}b'}
        self.dev = {'a': f'rcv{tag}a'[:15], 'b': f'rcv{tag}b'[:15]}
        self.addr = {'a': f'{SUBNET_PREFIX}.{k}.1', 'b': f'{SUBNET_PREFIX}.{k}.2'}
        self.shm = {}
        self._tmp = None

    def __enter__(self):
        try:
            self.open()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def open(self):
        self._tmp = tempfile.mkdtemp(prefix='robot_control_two_hosts_')
        for h in ('a', 'b'):
            _ip('netns', 'add', self.ns[h])
        _ip('link', 'add', self.dev['a'], 'netns', self.ns['a'], 'type', 'veth',
            'peer', 'name', self.dev['b'], 'netns', self.ns['b'])
        for h in ('a', 'b'):
            _ip('-n', self.ns[h], 'link', 'set', 'lo', 'up')
            _ip('-n', self.ns[h], 'addr', 'add', f'{self.addr[h]}/24', 'dev', self.dev[h])
            _ip('-n', self.ns[h], 'link', 'set', self.dev[h], 'up')
            if self.multicast:  # multicast leaves by the link, as on a host whose default route is its LAN
                _ip('-n', self.ns[h], 'route', 'add', '224.0.0.0/4', 'dev', self.dev[h])
            self.shm[h] = os.path.join(self._tmp, f'shm_{h}')
            os.makedirs(self.shm[h])
        self.wait_carrier()
        return self

    def carrier(self, host):
        """True while host's end of the link is operationally up (both ends up: the cable is in)."""
        link = json.loads(_ip('-n', self.ns[host], '-j', 'link', 'show', self.dev[host]).stdout)[0]
        return link.get('operstate') == 'UP' and 'LOWER_UP' in link.get('flags', ())

    def wait_carrier(self, timeout=10.0):
        """Wait until both ends have the carrier. The kernel reports it a moment after `link set up`, and a
        DDS participant started before that sees no interface but loopback and announces only 127.0.0.1."""
        deadline = time.monotonic() + timeout
        while not (self.carrier('a') and self.carrier('b')):
            if time.monotonic() >= deadline:
                raise RuntimeError(f'the link {self.dev} has no carrier after {timeout} s')
            time.sleep(0.01)

    def link(self, up):
        """Bring the link up or down (at `b`'s end)."""
        _ip('-n', self.ns['b'], 'link', 'set', self.dev['b'], 'up' if up else 'down')

    def counters(self, host):
        """{'rx_packets', 'tx_packets', 'rx_bytes', 'tx_bytes'} of host's end of the link."""
        out = _ip('-n', self.ns[host], '-s', '-j', 'link', 'show', self.dev[host]).stdout
        stats = json.loads(out)[0]['stats64']
        return {'rx_packets': stats['rx']['packets'], 'tx_packets': stats['tx']['packets'],
                'rx_bytes': stats['rx']['bytes'], 'tx_bytes': stats['tx']['bytes']}

    def routes(self, host, address):
        """True if `host` has a route to `address`."""
        return _ip('-n', self.ns[host], 'route', 'get', address, check=False).returncode == 0

    def argv(self, host, argv):
        """argv that runs `argv` on `host`: in its network namespace, with its /dev/shm."""
        return ['ip', 'netns', 'exec', self.ns[host], 'sh', '-c', 'mount --bind "$0" /dev/shm && exec "$@"',
                self.shm[host], *[str(a) for a in argv]]

    def pids(self, host):
        out = _ip('netns', 'pids', self.ns[host], check=False).stdout
        return [int(p) for p in out.split()]

    def close(self):
        """Kill what still runs inside (by pid), delete both namespaces and the /dev/shm directories."""
        for h in ('a', 'b'):
            for pid in self.pids(h):
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        for h in ('a', 'b'):
            _ip('netns', 'del', self.ns[h], check=False)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None


# -- a run of the loop on the two hosts ------------------------------------------------------------------------
def node_env(net, host, domain_id, static_peers=False):
    """Environment of a process on `host`: the run's domain; discovery SUBNET (multicast on the link), or
    with `static_peers` LOCALHOST + ROS_STATIC_PEERS = the other host (unicast discovery, no multicast)."""
    from robot_control.tools.processes import ros_env
    env = ros_env(domain_id)
    env['PYTHONPATH'] = ROOT + os.pathsep + env.get('PYTHONPATH', '')
    env['PYTHONDONTWRITEBYTECODE'] = '1'
    if static_peers:
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        env['ROS_STATIC_PEERS'] = net.addr['b' if host == 'a' else 'a']
    else:
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
    return env


class Loop:
    """The bridge, the controller and observers of one run, on the hosts of `net`; files in `out_dir`
    (emptied first).

    Nodes run timed (see timed_node) with the scenario's config file plus `params`. Every process is
    stopped by pid when the `with` block ends (observers and nodes then write their files); results()
    reads them. Waits are bounded: wait_for() raises TimeoutError with the processes' logs.
    """

    def __init__(self, net, domain_id, out_dir, scenario='polar_two_link', static_peers=False):
        from robot_control.tools.processes import ProcessSet
        self.net = net
        self.domain_id = domain_id
        self.out = str(out_dir)
        shutil.rmtree(self.out, ignore_errors=True)     # a previous run's progress files would fool the waits
        os.makedirs(self.out)
        self.config = os.path.join(ROOT, 'config', f'{scenario}.yaml')
        self.static_peers = static_peers
        self.procs = ProcessSet()
        self.nodes = {}
        self.observers = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
        return False

    def _start(self, name, host, argv):
        env = node_env(self.net, host, self.domain_id, self.static_peers)
        return self.procs.start(name, self.net.argv(host, [sys.executable, *argv]), env,
                                os.path.join(self.out, f'{name}.log'), cwd=ROOT)

    def node(self, name, host, module, **params):
        """Start node `name` ('bridge' or 'controller') on `host`: `module` with the config file and `params`."""
        from support.robustness import ros_args
        argv = [__file__, 'node', '--publish-log', os.path.join(self.out, f'publish_{name}.json'), module,
                *ros_args(self.config, **params)]
        self.nodes[name] = self._start(name, host, argv)
        return self.nodes[name]

    def capture_multicast(self, host, name, timeout=10.0):
        """Start counting the multicast UDP packets on `host`'s end of the link, both directions (`capture`);
        returns once it listens. captured(name) gives the count after stop()."""
        argv = [sys.executable, __file__, 'capture', self.net.dev[host]]
        p = self.procs.start(name, self.net.argv(host, argv), dict(os.environ), os.path.join(self.out, f'{name}.log'))
        self.wait_for(lambda: 'listening on' in p.log_tail(), timeout, f'capture {name} to listen')
        return p

    def captured(self, name):
        """The number of packets capture `name` counted (after stop(): it prints it on exit)."""
        with open(os.path.join(self.out, f'{name}.log')) as f:
            found = re.search(r'^(\d+) packets? captured', f.read(), re.M)
        if found is None:
            raise RuntimeError(f'capture {name}: no packet count in its log')
        return int(found.group(1))

    def observer(self, host, topics, joints=('theta1', 'r')):
        name = f'observer_{host}'
        argv = [__file__, 'observe', '--out', os.path.join(self.out, f'{name}.json'), '--joints', *joints,
                '--topics', *topics, '--progress', os.path.join(self.out, f'{name}.progress.json')]
        self.observers.append(name)
        return self._start(name, host, argv)

    def progress(self, host):
        """The running counts of the observer on `host` (None before its first write)."""
        try:
            with open(os.path.join(self.out, f'observer_{host}.progress.json')) as f:
                return json.load(f)
        except (OSError, ValueError):
            return None

    def wait_for(self, predicate, timeout, what):
        """Poll predicate() every 20 ms for up to `timeout` s of wall time; TimeoutError naming `what`."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.procs.check_alive()
            if predicate():
                return
            time.sleep(0.02)
        logs = '\n'.join(f'--- {p.name}:\n{p.log_tail(8)}' for p in self.procs.procs)
        raise TimeoutError(f'{what}: not within {timeout} s\n{logs}')

    def run_for(self, seconds):
        """Let the run go on for `seconds` s of wall time, failing at once if a process dies."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.procs.check_alive()
            time.sleep(min(0.02, max(deadline - time.monotonic(), 0.0)))

    def outage(self, seconds, until=None, timeout=60.0):
        """Take the link down for `seconds` s of wall time, and on until predicate `until()` holds (at most
        `timeout` s: TimeoutError); (t_down_ns, t_up_ns) on CLOCK_MONOTONIC."""
        t_down = time.monotonic_ns()
        self.net.link(False)
        try:
            self.run_for(seconds)
            if until is not None:
                self.wait_for(until, timeout, 'the outage to show what it must')
        finally:
            t_up = time.monotonic_ns()
            self.net.link(True)
        return t_down, t_up

    def rss_kb(self):
        """{node name: RSS in kB} of the running nodes."""
        from support.robustness import rss_kb
        return {name: rss_kb(p.pid) for name, p in self.nodes.items()}

    def stop(self):
        """Stop every process (SIGINT first: the observers and the timed nodes write their files)."""
        return self.procs.stop_all()

    def results(self):
        """{observer name: its JSON, 'publish_<node>': the node's publish figures} of a stopped run."""
        out = {}
        for name in [*self.observers, *[f'publish_{n}' for n in self.nodes]]:
            with open(os.path.join(self.out, f'{name}.json')) as f:
                out[name] = json.load(f)
        return out


# -- in the namespaces: the observer and the timed node ---------------------------------------------------------
#: what an observer can record: topic key -> topic name
OBSERVED = {'joint_states': 'joint_states', 'commands': 'robot_joint_commands', 'diagnostics': '/diagnostics'}
#: a publish call longer than this is recorded with its start time, ns
SLOW_NS = 100_000
#: s of wall time between two writes of an observer's progress file
PROGRESS_PERIOD = 0.05


def observe(out_path, joints, topics=tuple(OBSERVED), progress_path=None):
    """Record `topics` (keys of OBSERVED) until SIGINT/SIGTERM, then write JSON to `out_path`.

    JSON: states [[t_rx_ns, stamp_ns, q..., qd..., effort...]] (joint order `joints`), commands
    [[t_rx_ns, stamp_ns, effort...]], diagnostics [[t_rx_ns, stamp_ns, name, level, message, {key: value}]];
    t_rx = CLOCK_MONOTONIC, which all namespaces share, so the test process can put them beside the
    times it took the link down and up. Every sample is kept (reliable, a deep queue). `progress_path`:
    {'states', 'commands', 'diagnostics': counts, 'stamp_ns': newest state stamp, 'first_state_ns',
    'first_command_ns': the first stamps seen (None before), 'errors': statuses at ERROR, 'diagnostic_names': the
    status names seen} every PROGRESS_PERIOD.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.clock import Clock, ClockType
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from robot_control.ros import dds, spin
    from robot_control.ros.conversions import diagnostic_values

    dds.apply_defaults()   # as the nodes: a link failure must not block this observer's own DDS threads
    stop = spin.init_with_stop_on_signals()
    node = Node('two_hosts_observer')
    deep = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE)
    rec = {'states': [], 'commands': [], 'diagnostics': []}
    order = list(joints)

    def stamp(msg):
        return msg.header.stamp.sec * NS + msg.header.stamp.nanosec

    def on_state(msg):
        d = dict(zip(msg.name, range(len(msg.name))))
        idx = [d[j] for j in order]
        rec['states'].append([time.monotonic_ns(), stamp(msg), *[msg.position[i] for i in idx],
                              *[msg.velocity[i] for i in idx], *[msg.effort[i] for i in idx]])

    def on_command(msg):
        d = dict(zip(msg.name, msg.effort))
        rec['commands'].append([time.monotonic_ns(), stamp(msg), *[d.get(j, float('nan')) for j in order]])

    names = set()

    def on_diag(msg):
        t = time.monotonic_ns()
        for s in msg.status:
            rec['diagnostics'].append([t, stamp(msg), s.name, *diagnostic_values(s)])
            names.add(s.name)

    def write_progress():
        counts = {k: len(v) for k, v in rec.items()}
        counts['stamp_ns'] = rec['states'][-1][1] if rec['states'] else None
        counts['first_state_ns'] = rec['states'][0][1] if rec['states'] else None
        counts['first_command_ns'] = rec['commands'][0][1] if rec['commands'] else None
        counts['errors'] = sum(1 for d in rec['diagnostics'] if d[3] == 'ERROR')
        counts['diagnostic_names'] = sorted(names)
        with open(progress_path + '.part', 'w') as f:
            json.dump(counts, f)
        os.replace(progress_path + '.part', progress_path)

    callbacks = {'joint_states': (JointState, on_state), 'commands': (JointState, on_command),
                 'diagnostics': (DiagnosticArray, on_diag)}
    for key in topics:
        kind, callback = callbacks[key]
        node.create_subscription(kind, OBSERVED[key], callback, deep)
    if progress_path:
        node.create_timer(PROGRESS_PERIOD, write_progress, clock=Clock(clock_type=ClockType.STEADY_TIME))
    ex = spin.make_executor('single')
    ex.add_node(node)
    try:
        spin.spin(ex, stop=stop)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        with open(out_path + '.part', 'w') as f:
            json.dump({'joints': order, **rec}, f)
        os.replace(out_path + '.part', out_path)


def timed_node(module, log_path, argv):
    """Run `module`.main(argv) with every rclpy Publisher.publish timed; write the figures as JSON.

    JSON: {topic: {'count', 'max_ns', 'slow': [[t_start_ns, duration_ns], ...]}} (slow: over SLOW_NS;
    t_start = CLOCK_MONOTONIC).
    """
    import importlib
    from rclpy.publisher import Publisher

    figures = {}
    publish = Publisher.publish

    def timed(self, msg):
        t0 = time.monotonic_ns()
        try:
            return publish(self, msg)
        finally:
            dt = time.monotonic_ns() - t0
            f = figures.get(self.topic_name)
            if f is None:
                f = figures[self.topic_name] = {'count': 0, 'max_ns': 0, 'slow': []}
            f['count'] += 1
            if dt > f['max_ns']:
                f['max_ns'] = dt
            if dt > SLOW_NS:
                f['slow'].append([t0, dt])

    Publisher.publish = timed
    try:
        return importlib.import_module(module).main([module, *argv])
    finally:
        with open(log_path + '.part', 'w') as f:
            json.dump(figures, f)
        os.replace(log_path + '.part', log_path)


ETH_P_ALL, ETH_P_IP, IPPROTO_UDP = 0x0003, 0x0800, 17


def is_multicast_udp(frame):
    """True for an Ethernet frame carrying IPv4 UDP to a multicast address (224.0.0.0/4)."""
    return (len(frame) >= 34 and int.from_bytes(frame[12:14], 'big') == ETH_P_IP and frame[23] == IPPROTO_UDP
            and 224 <= frame[30] <= 239)


def capture(dev):
    """Count the multicast UDP frames on `dev`, sent and received, until SIGINT; then print
    '<n> packets captured' (root: a packet socket)."""
    import signal
    import socket
    signal.signal(signal.SIGTERM, signal.default_int_handler)   # the stop's SIGTERM too: the count is printed
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    sock.bind((dev, 0))
    count = 0
    print(f'listening on {dev}', flush=True)
    try:
        while True:
            if is_multicast_udp(sock.recv(65535)):
                count += 1
    except KeyboardInterrupt:
        pass
    finally:
        sock.close()
        print(f'{count} packets captured', flush=True)
    return 0


def main(argv=None):
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest='cmd', required=True)
    ob = sub.add_parser('observe', help='record what the nodes publish, on this host')
    ob.add_argument('--out', required=True)
    ob.add_argument('--joints', nargs='+', required=True)
    ob.add_argument('--topics', nargs='+', choices=tuple(OBSERVED), default=tuple(OBSERVED))
    ob.add_argument('--progress', help='file of running counts, rewritten every PROGRESS_PERIOD s')
    nd = sub.add_parser('node', help='run a node with its publish calls timed')
    nd.add_argument('module')
    nd.add_argument('--publish-log', required=True)
    nd.add_argument('args', nargs=argparse.REMAINDER)
    cp = sub.add_parser('capture', help='count the multicast UDP packets on a network device until SIGINT')
    cp.add_argument('dev')
    a = parser.parse_args(argv)
    if a.cmd == 'capture':
        return capture(a.dev)
    if a.cmd == 'observe':
        observe(a.out, a.joints, a.topics, a.progress)
        return 0
    args = a.args[1:] if a.args[:1] == ['--'] else a.args
    return timed_node(a.module, a.publish_log, args)


if __name__ == '__main__':
    sys.path[:0] = [ROOT, os.path.join(ROOT, 'test')]   # the package, and `support` for its helpers
    sys.exit(main())
