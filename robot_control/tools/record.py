"""rosbag2 recorder (raw rclpy subscriptions written by the `rosbags` writer) and a bag reader.

What it writes is what rosbags' Writer writes: a rosbag2 directory, `<bag_dir>/metadata.yaml` +
`<bag_dir>/<name>.mcap`, metadata version 9 and storage `mcap` (Jazzy's defaults), read by
`ros2 bag info/play`, by rosbags and by Foxglove. Each topic carries its type name
(`sensor_msgs/msg/JointState`), its full message definition (in the mcap file: the bag describes
itself), its RIHS01 type hash and the QoS profiles its publishers offered when its first message
came (what `ros2 bag play` offers again).

Timestamps: each message is stamped with its *receive time*, `node.get_clock().now()` in integer
nanoseconds, taken in the subscription callback, as `ros2 bag record` does (simulation time with
`use_sim_time:=true` on the node, else wall time). Header stamps inside the messages are untouched.

Subscriptions are `raw=True`: the callback hands the serialized CDR bytes to the writer as they
came (about 4 us a message; rosbags' mcap writer buffers chunks in memory).

Library use (the node is spun by the caller's executor)::

    with Recorder(node, 'out/bag', ['joint_states', 'ft_sensor/wrench:geometry_msgs/msg/WrenchStamped']):
        executor.spin_until_future_complete(done)
    data = read_bag('out/bag')          # {'/joint_states': [(t_ns, msg), ...], ...}

Command line, also the `record` console script (stops on --duration, Ctrl-C or SIGTERM; the bag
is always closed; prints each topic's matched publishers, then the message count per topic)::

    python -m robot_control.record --output DIR [--duration S] [--all | TOPIC[:TYPE] ...]
"""
import argparse
import atexit
import importlib
import math
import os
import re
import shutil
import sys
import threading
import time
from pathlib import Path

from rosbags.interfaces import Nodetype, Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from robot_control.tools.taps import WithMessageInfo, spin_for, spin_until_idle

BAG_VERSION = 9  # rosbag2 metadata version written by Jazzy

__all__ = ['Recorder', 'open_bag', 'read_bag', 'bag_info', 'parse_topic', 'normalize_type', 'main']


# ---------------------------------------------------------------- names and types

def normalize_type(msgtype):
    """'sensor_msgs/JointState' or 'sensor_msgs/msg/JointState' -> 'sensor_msgs/msg/JointState'."""
    parts = str(msgtype).strip().split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or parts[1] != 'msg' or not all(re.fullmatch(r'[A-Za-z_]\w*', p) for p in parts):
        raise ValueError(f'msgtype: expected "pkg/msg/Type", got {msgtype!r}')
    return '/'.join(parts)


def parse_topic(spec):
    """'name' -> ('name', None); 'name:pkg/msg/Type' -> ('name', 'pkg/msg/Type')."""
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f'topics: expected "name" or "name:pkg/msg/Type", got {spec!r}')
    name, sep, msgtype = spec.strip().partition(':')
    if not name:
        raise ValueError(f'topics: empty topic name in {spec!r}')
    return name, (normalize_type(msgtype) if sep else None)


def _message_class(msgtype):
    """The generated Python class of 'pkg/msg/Type' (needed for the type support of a raw subscription)."""
    pkg, _, name = msgtype.split('/')
    try:
        return getattr(importlib.import_module(f'{pkg}.msg'), name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f'msgtype: no Python message class for {msgtype!r} ({exc})') from exc


def _msg_file(msgtype):
    """The installed `share/<pkg>/msg/<Type>.msg` of `msgtype` (AMENT_PREFIX_PATH, then this Python prefix)."""
    pkg, _, base = msgtype.split('/')
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p] + [sys.prefix]
    for prefix in dict.fromkeys(prefixes):
        path = Path(prefix) / 'share' / pkg / 'msg' / f'{base}.msg'
        if path.is_file():
            return path
    raise ValueError(f'msgtype: no definition found for {msgtype!r} (not in the typestore, no '
                     f'share/{pkg}/msg/{base}.msg under {list(dict.fromkeys(prefixes))})')


def ensure_type(typestore, msgtype):
    """Register `msgtype` and the types it nests in `typestore` where it lacks them, from their
    installed .msg files, as rosbag2 does (the Jazzy typestore knows every common_interfaces type)."""
    found, todo = {}, [msgtype]
    while todo:
        name = todo.pop()
        if name in found or name in typestore.fielddefs:
            continue
        found.update(get_types_from_msg(_msg_file(name).read_text(encoding='utf-8'), name))
        for _, (kind, spec) in found[name][1]:
            kind, spec = spec[0] if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) else (kind, spec)
            if kind == Nodetype.NAME:
                todo.append(spec)
    if found:
        typestore.register(found)


def _offered_qos(qos):
    """rclpy QoSProfile (as a publisher announces it) -> rosbags Qos (the policies' values are rmw's in both)."""
    def duration(d):
        return QosTime(*divmod(int(d.nanoseconds), 10**9))
    return Qos(QosHistory(int(qos.history)), int(qos.depth), QosReliability(int(qos.reliability)),
               QosDurability(int(qos.durability)), duration(qos.deadline), duration(qos.lifespan),
               QosLiveliness(int(qos.liveliness)), duration(qos.liveliness_lease_duration),
               bool(qos.avoid_ros_namespace_conventions))


def _hidden(topic):
    return any(part.startswith('_') for part in topic.split('/') if part)


def _hand_over(node, count, log):
    """Spin the executor of `node` until it hands over no more messages (count(): messages received so
    far), at most 1 s: an executor that fell behind under load would otherwise lose a run's last
    messages. Skipped when called from inside that executor's callbacks."""
    if node.executor is None:
        return
    try:
        spin_until_idle(node.executor, count)
    except Exception as exc:  # context shut down, or called from inside a callback of the executor
        log.debug(f'recorder: handing over the waiting messages: {exc!r}')


# ---------------------------------------------------------------- the bag

def open_bag(bag_dir):
    """A rosbags Writer of a new rosbag2 directory as the recorder writes it (mcap, metadata version 9),
    opened; raises rosbags' WriterError if `bag_dir` exists."""
    writer = Writer(bag_dir, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    return writer


def _remove_old_bag(path):
    """Delete the rosbag2 directory `path`; ValueError if it holds anything but a bag's files."""
    entries = list(path.iterdir()) if path.is_dir() else []
    if not path.is_dir() or not all(e.is_file() and (e.name == 'metadata.yaml' or e.suffix in ('.mcap', '.db3'))
                                    for e in entries):
        raise ValueError(f'bag_dir: {path} exists and is not a rosbag2 directory; not replacing it')
    shutil.rmtree(path)


# ---------------------------------------------------------------- the recorder

class Recorder:
    """Record topics seen by `node` into a rosbag2 directory `bag_dir`.

    Args:
        node: an rclpy Node; the caller spins it (subscriptions and the discovery timer live on it).
        bag_dir: output directory; must not exist (or pass overwrite=True to replace an old bag).
        topics: iterable of "name" (type resolved from the graph) or "name:pkg/msg/Type" (explicit).
            Relative names are resolved against the node's namespace; the bag stores absolute names.
        all_topics: also record every (non-hidden) topic that appears on the graph, as `ros2 bag -a`.
        exclude: regular expression (re.search); matching topic names are not recorded by `all_topics`.
        discovery_timeout: s, how long start() waits for untyped topics to appear on the graph;
            topics still unknown then stay pending and are subscribed as soon as they appear.
        discovery_period: s, how often the graph is polled after start() (steady clock).
        depth: subscription queue depth (KEEP_LAST); messages beyond it are dropped by DDS if the
            executor falls that far behind.
        overwrite: replace `bag_dir` if it is an existing rosbag2 directory (never anything else).
        typestore: rosbags typestore of the definitions and hashes (default: ROS2_JAZZY).

    start() opens the bag and subscribes (explicitly typed topics at once, untyped ones when they are
    on the graph); stop() lets the node's executor hand over what DDS delivered before the call,
    unsubscribes and closes the bag (idempotent, returns {topic: message count}); a bag not stopped
    is closed at interpreter exit. Also a context manager. The subscription QoS follows the
    publishers seen, as rosbag2's: best effort if any publisher is, transient local if all are.
    """

    def __init__(self, node, bag_dir, topics=(), *, all_topics=False, exclude=None, discovery_timeout=5.0,
                 discovery_period=0.1, depth=10000, overwrite=False, typestore=None):
        if isinstance(topics, str):
            topics = [topics]
        self.node = node
        self.path = Path(bag_dir)
        self.all_topics = bool(all_topics)
        self.exclude = re.compile(exclude) if exclude else None
        self.discovery_timeout = float(discovery_timeout)
        self.discovery_period = float(discovery_period)
        self.depth = int(depth)
        self.overwrite = bool(overwrite)
        self.typestore = typestore if typestore is not None else get_typestore(Stores.ROS2_JAZZY)
        self._requested = {}  # absolute name -> explicit type or None
        for spec in topics:
            name, msgtype = parse_topic(spec)
            self._requested[node.resolve_topic_name(name)] = msgtype
        if not self._requested and not self.all_topics:
            raise ValueError('topics: give at least one topic or all_topics=True')
        self._log = node.get_logger()
        self._lock = threading.RLock()  # the writer and the subscriptions: executor thread vs. stop()
        self._writer = None     # rosbags Writer, from start() until the bag is closed
        self._conns = {}        # topic -> rosbags Connection, made with the topic's first message
        self._timer = None
        self._running = False
        self._closed = False
        self._received = 0
        self._until_ns = math.inf   # messages received (system clock, ns) after this are not recorded
        self._subs = {}         # topic -> Subscription
        self._best_effort = {}  # topic -> bool (reliability of our subscription)
        self._failed = set()    # topics --all cannot record (no definition or class): not retried
        self.types = {}         # topic -> msgtype of every topic subscribed: each gets a connection
        self.t_start = None     # monotonic s at start() / stop()
        self.t_stop = None

    # -- life cycle

    def start(self):
        """Open the bag, resolve topics (waiting at most discovery_timeout for untyped ones), subscribe."""
        if self._running or self._closed:
            raise RuntimeError('Recorder.start: already started')
        try:
            if self.path.exists() and self.overwrite:
                _remove_old_bag(self.path)
            self._writer = open_bag(self.path)
        except BaseException:
            self._closed = True
            raise
        atexit.register(self._close_bag)  # a forgotten stop() still leaves a readable bag
        self._running = True
        self.t_start = time.monotonic()
        try:
            for topic, msgtype in self._requested.items():
                if msgtype is not None:
                    self._start_topic(topic, msgtype, self._publishers(topic, msgtype))
            self._wait_for_untyped_topics()
            from rclpy.clock import Clock, ClockType
            self._timer = self.node.create_timer(self.discovery_period, self._discover_safe,
                                                 clock=Clock(clock_type=ClockType.STEADY_TIME))
        except BaseException:
            self.stop()
            raise
        return self

    def _wait_for_untyped_topics(self):
        deadline = time.monotonic() + self.discovery_timeout
        idle = threading.Event()
        while True:
            self._discover()
            if not any(self._requested[t] is None for t in self.pending) or time.monotonic() >= deadline:
                break
            idle.wait(0.02)  # the graph cache is filled by the RMW's own threads
        for topic in self.pending:
            self._log.warning(f'{topic}: not on the graph after {self.discovery_timeout:g} s; '
                              'recording it once a publisher appears')

    def stop(self):
        """Record what this process received before the call, unsubscribe, close the bag. Safe to call
        twice; returns counts. The bag is closed even if the node or its context is already gone."""
        if self._closed:
            return self.counts
        self._running = False
        self._until_ns = time.time_ns()   # the reception clock of MessageInfo: what comes later is not recorded
        if self._subs:                    # before unsubscribing: a subscription's queue goes with it
            _hand_over(self.node, lambda: self._received, self._log)
        with self._lock:
            self._closed = True
            subs, self._subs = dict(self._subs), {}
        try:
            if self._timer is not None:
                self.node.destroy_timer(self._timer)
            for sub in subs.values():
                self.node.destroy_subscription(sub)
        except Exception as exc:  # context already shut down: nothing left to unsubscribe from
            self._log.debug(f'recorder: unsubscribing: {exc!r}')
        finally:
            self._timer = None
            self._close_bag()
        self.t_stop = time.monotonic()
        return self.counts

    def _close_bag(self):
        """Give every subscribed topic its connection (one without messages too) and close the bag."""
        atexit.unregister(self._close_bag)
        with self._lock:
            writer, self._writer = self._writer, None
            if writer is not None:
                for topic in self.types.keys() - self._conns.keys():
                    self._connect(writer, topic)
                writer.close()

    def __enter__(self):
        return self.start()

    def __exit__(self, exc_type, exc, tb):
        self.stop()
        return False

    # -- state

    @property
    def pending(self):
        """Requested topics not subscribed yet (type unknown, or no publisher seen)."""
        return sorted(t for t in self._requested if t not in self._subs)

    @property
    def subscribed(self):
        return sorted(self._subs)

    @property
    def counts(self):
        """{topic: messages written} of every topic subscribed."""
        with self._lock:
            written = {t: c.owner.counts[c.id] for t, c in self._conns.items()}
        return {t: written.get(t, 0) for t in self.types}

    @property
    def received(self):
        """Messages received and written so far."""
        return self._received

    def publisher_counts(self):
        """{topic: publishers matched by our subscription}. DDS matching can lag discovery by a second
        or more: wait for this (or for a first message) before starting what must be recorded."""
        with self._lock:
            subs = dict(self._subs)
        out = {}
        for topic, sub in subs.items():
            try:
                out[topic] = sub.get_publisher_count()
            except Exception:  # destroyed meanwhile
                out[topic] = 0
        return out

    # -- internals

    def _publishers(self, topic, msgtype):
        """The publishers of `topic` with type `msgtype` on the graph now (their endpoint infos)."""
        return [i for i in self.node.get_publishers_info_by_topic(topic) if normalize_type(i.topic_type) == msgtype]

    def _connect(self, writer, topic):
        """The bag's connection of `topic`, with the QoS its publishers offer now (none if the node is gone)."""
        try:
            offered = [_offered_qos(i.qos_profile) for i in self._publishers(topic, self.types[topic])]
        except Exception as exc:
            self._log.debug(f'recorder: offered QoS of {topic}: {exc!r}')
            offered = []
        self._conns[topic] = writer.add_connection(topic, self.types[topic], typestore=self.typestore,
                                                   offered_qos_profiles=offered)
        return self._conns[topic]

    def _subscribe(self, topic, best_effort, transient_local):
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=self.depth,
            reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if transient_local else DurabilityPolicy.VOLATILE)
        now = self.node.get_clock().now

        def keep(data, info):  # raw=True: `data` is the serialized CDR message (bytes)
            if info['received_timestamp'] > self._until_ns:
                return
            t_ns = now().nanoseconds
            with self._lock:
                writer = self._writer
                if writer is not None:
                    writer.write(self._conns.get(topic) or self._connect(writer, topic), t_ns, data)
                    self._received += 1

        with self._lock:
            if self._closed:
                return
            old = self._subs.get(topic)
            if old is not None:
                self.node.destroy_subscription(old)
            self._subs[topic] = self.node.create_subscription(_message_class(self.types[topic]), topic,
                                                              WithMessageInfo(keep), qos, raw=True)
            self._best_effort[topic] = best_effort

    def _discover_safe(self):
        """Timer callback: a failing graph poll must not take the caller's executor down."""
        try:
            self._discover()
        except Exception as exc:
            self._log.error(f'recorder: topic discovery failed: {exc!r}')

    def _discover(self):
        """Poll the graph: subscribe to topics that appeared, adapt QoS to the publishers seen."""
        if not self._running:
            return
        try:
            graph = dict(self.node.get_topic_names_and_types())
        except Exception:  # context shutting down
            return
        wanted = set(self._requested)
        if self.all_topics:
            wanted.update(t for t in graph if not _hidden(t) and not (self.exclude and self.exclude.search(t)))
        for topic in wanted - self._failed:
            if topic in self._subs:
                # A reliable subscription never matches a best-effort publisher: downgrade if one appears.
                infos = self._publishers(topic, self.types[topic])
                if not self._best_effort[topic] and any(int(i.qos_profile.reliability) == 2 for i in infos):
                    self._log.warning(f'{topic}: best-effort publisher seen, resubscribing best effort')
                    self._subscribe(topic, True, False)
            elif topic in graph:
                self._start_untyped(topic, graph[topic])

    def _start_untyped(self, topic, graph_types):
        """Record `topic`, on the graph with `graph_types`, as the first of them once a publisher of it is
        seen (it tells the type); a topic that cannot be recorded is logged and left alone."""
        msgtype = normalize_type(graph_types[0])
        publishers = self._publishers(topic, msgtype)
        if not publishers:
            return
        if len(graph_types) > 1:
            self._log.warning(f'{topic}: several types {graph_types}; recording {graph_types[0]}')
        try:
            self._start_topic(topic, msgtype, publishers)
        except ValueError as exc:
            self._log.error(f'{topic}: cannot record: {exc}')
            self._failed.add(topic)

    def _start_topic(self, topic, msgtype, publishers):
        """Subscribe to `topic` as `msgtype`, with the QoS that matches its `publishers`."""
        _message_class(msgtype)           # fail here, before the bag lists a topic it cannot fill
        ensure_type(self.typestore, msgtype)
        announced = {h for h in (str(i.topic_type_hash) for i in publishers)
                     if h.startswith('RIHS01_') and h[len('RIHS01_'):].strip('0')}  # 0...0: unknown
        ours = self.typestore.hash_rihs01(msgtype)
        if announced and ours not in announced:
            self._log.warning(f'{topic}: type hash {ours} differs from the publishers\' {sorted(announced)}')
        self.types[topic] = msgtype
        best_effort = any(int(i.qos_profile.reliability) == 2 for i in publishers)
        transient_local = bool(publishers) and all(int(i.qos_profile.durability) == 1 for i in publishers)
        self._subscribe(topic, best_effort, transient_local)
        if self.all_topics and topic not in self._requested:
            self._log.info(f'recording {topic} [{msgtype}]')


# ---------------------------------------------------------------- reading bags

def _typestore_for(reader, typestore):
    store = typestore if typestore is not None else get_typestore(Stores.ROS2_JAZZY)
    typs = {}
    for conn in reader.connections:
        if conn.msgtype not in store.fielddefs and conn.msgdef.data:
            typs.update(get_types_from_msg(conn.msgdef.data, conn.msgtype))
    if typs:
        store.register({k: v for k, v in typs.items() if k not in store.fielddefs})
    return store


def bag_info(bag_dir):
    """{topic: (msgtype, message count)} of a rosbag2 directory, from its metadata."""
    with Reader(bag_dir) as reader:
        return {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}


def read_bag(bag_dir, topics=None, typestore=None):
    """Deserialize a rosbag2 directory: {topic: [(t_ns, msg), ...]} in time order per topic.

    Messages are rosbags dataclasses with the ROS field names (`msg.position`, `msg.header.stamp.sec`);
    numeric arrays (float64[] etc.) come back as numpy arrays, string[] as lists. Types missing from
    the Jazzy typestore are registered from the definitions stored in the bag. `topics`: names to
    read (relative names get a leading '/'); a name not in the bag is a ValueError.
    """
    with Reader(bag_dir) as reader:
        by_topic = {c.topic: c for c in reader.connections}
        if topics is None:
            wanted = list(by_topic)
        else:
            if isinstance(topics, str):
                topics = [topics]
            wanted = [t if t.startswith('/') else '/' + t for t in topics]
            missing = [t for t in wanted if t not in by_topic]
            if missing:
                raise ValueError(f'topics: {missing} not in {bag_dir} (has {sorted(by_topic)})')
        store = _typestore_for(reader, typestore)
        out = {t: [] for t in wanted}
        conns = [by_topic[t] for t in wanted]
        for conn, t_ns, raw in reader.messages(connections=conns):
            out[conn.topic].append((t_ns, deserialize(store, raw, conn.msgtype)))
    return out


def deserialize(store, raw, msgtype):
    """CDR bytes -> a rosbags message of `msgtype`, ignoring bytes past the message's end.

    rmw_fastrtps' rmw_serialize (hence rclpy.serialization.serialize_message, and bags a Python
    rosbag2_py writer filled) sizes the buffer by its estimate, which counts alignment padding for
    empty sequences: such a message carries up to 8 bytes more than it holds, which rosbags' strict
    size check refuses and rosbag2 reads.
    """
    try:
        return store.deserialize_cdr(raw, msgtype)
    except SerdeError as exc:
        if 'size mismatch' not in str(exc):
            raise
    msgdef = store.get_msgdef(msgtype)
    decode = msgdef.deserialize_cdr_le if raw[1] else msgdef.deserialize_cdr_be
    return decode(memoryview(raw)[4:], 0, msgdef.cls, store)[0]


# ---------------------------------------------------------------- command line

def _parser():
    p = argparse.ArgumentParser(
        prog='python -m robot_control.record',
        description='Record ROS 2 topics into a rosbag2 directory (mcap, metadata v9), like `ros2 bag record`.')
    p.add_argument('topics', nargs='*', metavar='TOPIC[:TYPE]',
                   help='topic names, optionally with the type (joint_states:sensor_msgs/msg/JointState)')
    p.add_argument('-o', '--output', required=True, help='bag directory to create (must not exist)')
    p.add_argument('-a', '--all', action='store_true', help='record every topic that appears (not hidden ones)')
    p.add_argument('-x', '--exclude', default=None, help='regular expression of topics not recorded by --all')
    p.add_argument('-d', '--duration', type=float, default=None, help='stop after this many seconds (wall clock)')
    p.add_argument('--discovery-timeout', type=float, default=5.0,
                   help='s to wait for untyped topics to appear before recording starts (default 5)')
    p.add_argument('--overwrite', action='store_true', help='replace an existing bag directory')
    p.add_argument('--node-name', default='recorder')
    return p


def main(args=None):
    """Entry point of `python -m robot_control.record` / the `record` console script."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.utilities import remove_ros_args
    from robot_control.ros.spin import init_with_stop_on_signals, make_executor

    argv = sys.argv if args is None else ['record', *args]
    opts = _parser().parse_args(remove_ros_args(argv)[1:])
    if not opts.topics and not opts.all:
        _parser().error('give topics or --all')
    if opts.all and opts.topics:
        _parser().error('--all records every topic: give no topic names with it')
    if opts.duration is not None and not opts.duration > 0:
        _parser().error('--duration must be > 0')
    if Path(opts.output).exists() and not opts.overwrite:
        print(f'record: {opts.output} exists already (use --overwrite or another --output)', file=sys.stderr)
        return 2

    stop = init_with_stop_on_signals(argv)
    node = recorder = executor = None
    counts = {}
    try:
        node = Node(opts.node_name)
        executor = make_executor('events')
        executor.add_node(node)
        recorder = Recorder(node, opts.output, opts.topics, all_topics=opts.all, exclude=opts.exclude,
                            discovery_timeout=opts.discovery_timeout, overwrite=opts.overwrite)
        recorder.start()
        print(f'record: writing {opts.output}; topics: {", ".join(recorder.subscribed) or "(waiting)"}'
              + (f'; pending: {", ".join(recorder.pending)}' if recorder.pending else ''), flush=True)
        _record(executor, recorder, stop, opts.duration)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        try:
            if recorder is not None:
                counts = recorder.stop()
        finally:
            if executor is not None:
                executor.shutdown()
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
    _report(opts.output, recorder, counts)
    return 0


def _record(executor, recorder, stop, duration=None):
    """Spin until `stop` is set or `duration` s have passed; print each change of a topic's matched
    publishers (a parent process waits for these lines before it starts what must be recorded)."""
    deadline = None if duration is None else time.monotonic() + duration
    matched = {}
    while not stop.is_set() and (deadline is None or time.monotonic() < deadline):
        spin_for(executor, 0.1 if deadline is None else max(0.0, min(0.1, deadline - time.monotonic())))
        for topic, count in recorder.publisher_counts().items():
            if count != matched.get(topic, 0):
                print(f'record: {topic} matched {count} publisher(s)', flush=True)
            matched[topic] = count


def _report(output, recorder, counts):
    elapsed = (recorder.t_stop - recorder.t_start) if recorder and recorder.t_start else 0.0
    for topic in sorted(counts):
        print(f'  {topic:40s} {recorder.types[topic]:40s} {counts[topic]:8d}')
    print(f'record: closed {output}: {sum(counts.values())} messages in {elapsed:.2f} s', flush=True)


if __name__ == '__main__':
    sys.exit(main())
