"""rosbag2 recorder (raw rclpy subscriptions + the `rosbags` writer) and a bag reader for analysis.

What it writes: a rosbag2 directory, `<bag_dir>/metadata.yaml` + `<bag_dir>/<name>.mcap`, metadata
version 9 and storage `mcap` -- what `ros2 bag record` writes by default on Jazzy -- so the bag is
read by `ros2 bag info/play` on a real install, by `rosbags`, and by Foxglove. Every topic carries
its type name (`sensor_msgs/msg/JointState`), its full message definition (`ros2msg` schema in the
mcap file, so the bag is self-describing), its RIHS01 type hash (checked against the hash the
publishers announce on the graph) and the QoS profiles its publishers offered (for `ros2 bag play`;
a topic recorded by explicit type before any publisher appeared gets its connection, and those of
the publishers then matched, with its first message). metadata.yaml is written as rosbag2 on Jazzy
writes it: `ros_distro: jazzy`, rosbag2's key order, offered_qos_profiles as a list of profiles with
policy names (finish_metadata).

Timestamps: each message is stamped with its *receive time*, `node.get_clock().now()` in integer
nanoseconds, taken in the subscription callback -- as `ros2 bag record` does. With
`use_sim_time:=true` on the recorder node that is simulation time (/clock), otherwise wall time.
Header stamps are untouched inside the messages.

Cost in the executor: subscriptions are `raw=True`, so a callback receives the serialized CDR bytes
(no deserialization) and only appends `(topic, t_ns, bytes)` to a queue; a writer thread drains
the queue into the bag, so the executor never waits on disk. The command line spins rclpy's
EventsExecutor, which hands each message from C++ to the callback.

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
import collections
import importlib
import math
import os
import re
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from robot_control.tools.taps import WithMessageInfo, spin_for, spin_until_idle

BAG_VERSION = 9  # rosbag2 metadata version written by Jazzy (0.26.x)
ROS_DISTRO = 'jazzy'  # metadata.yaml's ros_distro, as rosbag2 writes it (its ROS_DISTRO)
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
DEFAULT_STORAGE = 'mcap'  # Jazzy's default storage plugin

__all__ = ['Recorder', 'read_bag', 'bag_info', 'parse_topic', 'normalize_type', 'main']


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


def _share_dirs():
    dirs = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    dirs.append(sys.prefix)
    return [Path(d) / 'share' for d in dict.fromkeys(dirs)]


def _referenced_types(fielddef):
    """Type names a rosbags field definition refers to (nested messages)."""
    out = []
    stack = [fielddef]
    while stack:
        node = stack.pop()
        if isinstance(node, tuple):
            is_name = len(node) == 2 and getattr(node[0], 'name', '') == 'NAME' and isinstance(node[1], str)
            if is_name and '/' in node[1]:
                out.append(node[1])
            else:
                stack.extend(node)
        elif isinstance(node, list):
            stack.extend(node)
    return out


def ensure_type(typestore, msgtype):
    """Make sure `typestore` knows `msgtype` (and the types it nests).

    The Jazzy typestore knows every common_interfaces type; anything else is read from the installed
    `share/<pkg>/msg/<Type>.msg` files (AMENT_PREFIX_PATH and this Python prefix), like rosbag2 does.
    """
    todo = [msgtype]
    while todo:
        name = todo.pop()
        if name in typestore.fielddefs:
            continue
        pkg, _, base = name.split('/')
        for share in _share_dirs():
            path = share / pkg / 'msg' / f'{base}.msg'
            if path.is_file():
                typs = get_types_from_msg(path.read_text(encoding='utf-8'), name)
                break
        else:
            raise ValueError(f'msgtype: no definition found for {name!r} (not in the Jazzy typestore, '
                             f'no {pkg}/msg/{base}.msg under {[str(s) for s in _share_dirs()]})')
        missing = [t for t in _referenced_types(typs[name]) if t not in typestore.fielddefs]
        if missing:
            todo.append(name)
            todo.extend(missing)
            continue
        typestore.register(typs)


def _qos_time(duration):
    sec, nsec = divmod(int(duration.nanoseconds), 10**9)
    return QosTime(sec, nsec)


def _offered_qos(qos):
    """rclpy QoSProfile (as announced by a publisher) -> rosbags Qos for metadata.yaml."""
    def enum(cls, value, default):
        try:
            return cls(int(value))
        except ValueError:
            return default
    return Qos(
        history=enum(QosHistory, qos.history, QosHistory.UNKNOWN),
        depth=int(qos.depth),
        reliability=enum(QosReliability, qos.reliability, QosReliability.UNKNOWN),
        durability=enum(QosDurability, qos.durability, QosDurability.UNKNOWN),
        deadline=_qos_time(qos.deadline),
        lifespan=_qos_time(qos.lifespan),
        liveliness=enum(QosLiveliness, qos.liveliness, QosLiveliness.UNKNOWN),
        liveliness_lease_duration=_qos_time(qos.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(qos.avoid_ros_namespace_conventions),
    )


_ADD = object()  # queue marker: add a connection


def _hidden(topic):
    return any(part.startswith('_') for part in topic.split('/') if part)


# ---------------------------------------------------------------- the bag

#: metadata.yaml's keys in the order rosbag2 (Jazzy) writes them
METADATA_KEYS = ('version', 'storage_identifier', 'duration', 'starting_time', 'message_count',
                 'topics_with_message_count', 'compression_format', 'compression_mode', 'relative_file_paths',
                 'files', 'custom_data', 'ros_distro')
TOPIC_KEYS = ('name', 'type', 'serialization_format', 'offered_qos_profiles', 'type_description_hash')


def finish_metadata(bag_dir):
    """Rewrite `bag_dir`/metadata.yaml as rosbag2 on Jazzy writes it: ros_distro 'jazzy' (rosbags
    writes 'rosbags') and rosbag2's key order. Each topic's offered_qos_profiles (a list of profiles
    with policy names, `reliability: best_effort`, durations as sec/nsec) stays as written: the
    storage file's channels carry the same, and readers match the two. The copy of the metadata
    inside the storage file keeps ros_distro 'rosbags'; rosbag2 reads metadata.yaml."""
    import yaml
    path = Path(bag_dir) / 'metadata.yaml'
    info = yaml.safe_load(path.read_text(encoding='utf-8'))['rosbag2_bagfile_information']
    info['ros_distro'] = ROS_DISTRO
    for entry in info['topics_with_message_count']:
        entry['topic_metadata'] = {k: entry['topic_metadata'][k] for k in TOPIC_KEYS}
        entry['message_count'] = entry.pop('message_count')
    ordered = {'rosbag2_bagfile_information': {k: info[k] for k in METADATA_KEYS}}
    tmp = path.with_suffix('.yaml.tmp')
    tmp.write_text(yaml.safe_dump(ordered, sort_keys=False, default_flow_style=False), encoding='utf-8')
    tmp.replace(path)


class BagWriter:
    """A rosbag2 directory written by a thread of its own: the executor never waits on disk.

    `queue` takes `(topic, t_ns, data)` items (serialized CDR bytes); a topic's connection, which
    add() queues, precedes its messages. The thread owns the rosbags Writer from open() to close()
    (sqlite3 objects must stay in the thread that made them) and writes what is queued every
    20 ms. `counts` {topic: messages written} and `types` {topic: msgtype} grow as it goes.
    """

    def __init__(self, path, storage, typestore, log, qos_of=None):
        self.path = Path(path)
        self.storage = storage
        self.typestore = typestore
        self.queue = collections.deque()  # (topic, t_ns, bytes) or (_ADD, topic, (msgtype, qos))
        self.types = {}
        self.counts = {}
        self.qos_of = qos_of if qos_of is not None else (lambda topic: [])
        self.error = None        # what stopped the writing (disk full, ...), reported by the recorder
        self._log = log
        self._wake = threading.Event()
        self._opened = threading.Event()
        self._closing = False
        self._thread = None

    def remove_old(self):
        """Delete the rosbag2 directory at `path`; ValueError if it holds anything but a bag's files."""
        entries = list(self.path.iterdir()) if self.path.is_dir() else None
        looks_like_bag = entries is not None and all(
            e.is_file() and (e.name == 'metadata.yaml' or e.suffix in ('.mcap', '.db3', '.zstd', '.tmp'))
            for e in entries)
        if not looks_like_bag:
            raise ValueError(f'bag_dir: {self.path} exists and is not a rosbag2 directory; not replacing it')
        shutil.rmtree(self.path)

    def open(self):
        """Create the bag and start the writer thread; raises what rosbags raised."""
        writer = Writer(self.path, version=BAG_VERSION, storage_plugin=STORAGES[self.storage])
        writer.set_custom_data('recorder', 'robot_control.record')
        writer.set_custom_data('timestamps', 'receive time, node clock, ns')
        self._thread = threading.Thread(target=self._write_loop, args=(writer,), name='recorder-writer',
                                        daemon=True)
        self._thread.start()
        self._opened.wait()
        if self.error is not None:
            self._thread.join()
            raise self.error
        atexit.register(self.close)  # a forgotten stop() still leaves a readable bag

    def add(self, topic, msgtype, offered=()):
        """Queue the connection of `topic` (once), with the QoS profiles its publishers offered."""
        if topic in self.types:
            return
        ensure_type(self.typestore, msgtype)
        self.types[topic] = msgtype
        self.counts[topic] = 0
        self.queue.append((_ADD, topic, (msgtype, list(offered))))

    def queued(self):
        """Messages queued but not written yet."""
        return sum(1 for item in list(self.queue) if item[0] is not _ADD)

    def close(self):
        """Let the thread write the queue and close the bag; also run at interpreter exit."""
        self._closing = True
        atexit.unregister(self.close)
        self._wake.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()

    def _connect(self, writer, conns, topic, msgtype, offered):
        conns[topic] = writer.add_connection(topic, msgtype, typestore=self.typestore, offered_qos_profiles=offered)
        return conns[topic]

    def _drain(self, writer, conns, waiting):
        """Write what is queued. A connection queued without offered QoS waits in `waiting` for its
        first message, when its publishers are known: qos_of(topic) gives their profiles then."""
        queue = self.queue
        counts = self.counts
        write = writer.write
        while queue:
            item = queue.popleft()
            if item[0] is _ADD:
                _, topic, (msgtype, offered) = item
                if offered:
                    self._connect(writer, conns, topic, msgtype, offered)
                else:
                    waiting[topic] = msgtype
            else:
                topic, t_ns, data = item
                conn = conns.get(topic)
                if conn is None:
                    conn = self._connect(writer, conns, topic, waiting.pop(topic), self._qos_of(topic))
                write(conn, t_ns, data)
                counts[topic] += 1

    def _qos_of(self, topic):
        try:
            return list(self.qos_of(topic))
        except Exception as exc:  # node or context gone: the topic is listed without offered QoS
            self._log.debug(f'recorder: offered QoS of {topic}: {exc!r}')
            return []

    def _write_loop(self, writer):
        try:
            writer.open()
        except BaseException as exc:
            self.error = exc
            self._opened.set()
            return
        self._opened.set()
        conns, waiting = {}, {}
        try:
            while not self._closing:
                self._wake.wait(0.02)
                self._drain(writer, conns, waiting)
            self._drain(writer, conns, waiting)
            for topic, msgtype in waiting.items():  # no message came: listed with what is known
                self._connect(writer, conns, topic, msgtype, self._qos_of(topic))
            writer.close()
            finish_metadata(self.path)
        except BaseException as exc:  # disk full, ...: stop writing, report at stop()
            self.error = exc
            self._log.error(f'recorder: writing {self.path} failed: {exc!r}')
            try:
                writer.close()
            except BaseException:
                writer.abort()


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
        storage: 'mcap' (default, Jazzy's) or 'sqlite3'.
        depth: subscription queue depth (KEEP_LAST); messages beyond it are dropped by DDS if the
            executor falls that far behind.
        overwrite: replace `bag_dir` if it is an existing rosbag2 directory (never anything else).
        typestore: rosbags typestore used for definitions/hashes (default: ROS2_JAZZY).

    start() opens the bag and subscribes (explicitly typed topics at once, untyped ones when they are
    on the graph); stop() lets the node's executor hand over what DDS has delivered, unsubscribes,
    writes what is queued and closes the bag (idempotent, returns {topic: message count}). Also a
    context manager. The subscription QoS follows the publishers seen, as rosbag2 does: best
    effort if any publisher is best effort, transient local if all are. Spin the node with rclpy's
    EventsExecutor for high rates (see robot_control.tools.taps).
    """

    def __init__(self, node, bag_dir, topics=(), *, all_topics=False, exclude=None, discovery_timeout=5.0,
                 discovery_period=0.1, storage=DEFAULT_STORAGE, depth=10000, overwrite=False, typestore=None):
        if storage not in STORAGES:
            raise ValueError(f'storage: expected one of {sorted(STORAGES)}, got {storage!r}')
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
        self._bag = BagWriter(self.path, storage, self.typestore, self._log, qos_of=self._publisher_qos)
        self._lock = threading.RLock()  # guards the subscription tables (executor thread vs. stop())
        self._timer = None
        self._running = False
        self._closed = False
        self._received = 0
        self._until_ns = math.inf   # messages received (system clock, ns) after this are not recorded
        self._subs = {}         # topic -> Subscription
        self._best_effort = {}  # topic -> bool (reliability of our subscription)
        self._failed = set()    # topics --all cannot record (no definition or class): not retried
        self.types = self._bag.types    # topic -> msgtype, every topic with a connection in the bag
        self.counts = self._bag.counts  # topic -> messages written
        self.t_start = None     # monotonic s at start() / stop()
        self.t_stop = None

    # -- life cycle

    def start(self):
        """Open the bag, resolve topics (waiting at most discovery_timeout for untyped ones), subscribe."""
        if self._running or self._closed:
            raise RuntimeError('Recorder.start: already started')
        try:
            if self.path.exists() and self.overwrite:
                self._bag.remove_old()
            self._bag.open()
        except BaseException:
            self._closed = True
            raise
        self._running = True
        self.t_start = time.monotonic()
        try:
            for topic, msgtype in self._requested.items():
                if msgtype is not None:
                    self._add_topic(topic, msgtype)
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
        """Record what this process received before the call, unsubscribe, write what is queued, close
        the bag. Safe to call twice. Returns counts. The bag is closed even if the node or its context
        is already gone."""
        if self._closed:
            return dict(self.counts)
        self._running = False
        self._until_ns = time.time_ns()   # the reception clock of MessageInfo: what comes later is not recorded
        self._hand_over_waiting()         # before unsubscribing: a subscription's queue goes with it
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
            self._bag.close()
        self.t_stop = time.monotonic()
        if self._bag.error is not None:
            raise RuntimeError(f'recorder: writing {self.path} failed: {self._bag.error!r}') from self._bag.error
        return dict(self.counts)

    def _hand_over_waiting(self):
        """Spin the node's executor until it hands over no more messages received before stop() (at
        most 1 s): an executor that fell behind under load would otherwise lose the run's last
        messages. Call stop() outside that executor's callbacks, or this is skipped."""
        executor = self.node.executor
        if executor is None or not self._subs:
            return
        try:
            spin_until_idle(executor, lambda: self._received)
        except Exception as exc:  # context shut down, or called from inside a callback of the executor
            self._log.debug(f'recorder: handing over the waiting messages: {exc!r}')

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

    @property
    def message_count(self):
        """Messages written so far."""
        return sum(dict(self.counts).values())  # copy: the writer thread updates the counts

    def queued(self):
        """Messages received but not written yet."""
        return self._bag.queued()

    @property
    def received(self):
        """Messages received so far (written or queued)."""
        return self._received

    # -- internals

    def _publisher_qos(self, topic):
        """The QoS profiles (rosbags Qos) of the publishers of `topic` with its recorded type, now."""
        return [_offered_qos(i.qos_profile) for i in self.node.get_publishers_info_by_topic(topic)
                if normalize_type(i.topic_type) == self.types[topic]]

    def _add_topic(self, topic, msgtype, offered=()):
        """Give `topic` a connection in the bag (once), ahead of its messages."""
        _message_class(msgtype)  # fail here, before the bag gets a connection it cannot fill
        self._bag.add(topic, msgtype, offered)

    def _subscribe(self, topic, best_effort, transient_local):
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=self.depth,
            reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if transient_local else DurabilityPolicy.VOLATILE)
        append = self._bag.queue.append
        now = self.node.get_clock().now

        def keep(data, info):  # raw=True: `data` is the serialized CDR message (bytes)
            if info['received_timestamp'] <= self._until_ns:
                append((topic, now().nanoseconds, data))
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
        for topic, explicit in self._wanted(graph).items():
            if topic in self._failed:
                continue
            infos = self.node.get_publishers_info_by_topic(topic) if topic in graph else []
            if topic in self._subs:
                # A reliable subscription never matches a best-effort publisher: downgrade if one appears.
                if not self._best_effort[topic] and any(int(i.qos_profile.reliability) == 2 for i in infos):
                    self._log.warning(f'{topic}: best-effort publisher seen, resubscribing best effort')
                    self._subscribe(topic, True, False)
            elif explicit is not None or infos:  # an untyped topic waits for a publisher to tell its type
                self._start_topic(topic, explicit, infos, graph.get(topic, []))

    def _wanted(self, graph):
        """{topic: explicit type or None} to record: the requested ones, and with all_topics the graph's."""
        wanted = dict(self._requested)
        if self.all_topics:
            for topic in graph:
                if topic not in wanted and not _hidden(topic) and not (self.exclude and self.exclude.search(topic)):
                    wanted[topic] = None
        return wanted

    def _start_topic(self, topic, explicit, infos, graph_types):
        """Give `topic` its bag connection and subscription, with the QoS of the publishers `infos`."""
        msgtype = explicit
        if msgtype is None:
            if len(graph_types) > 1:
                self._log.warning(f'{topic}: several types {graph_types}; recording {graph_types[0]}')
            msgtype = normalize_type(graph_types[0])
        matching = [i for i in infos if normalize_type(i.topic_type) == msgtype]
        if explicit is not None and infos and not matching:
            self._log.warning(f'{topic}: publishers offer {sorted({i.topic_type for i in infos})}, '
                              f'not {msgtype}; nothing will be recorded until one does')
        try:
            self._add_topic(topic, msgtype, [_offered_qos(i.qos_profile) for i in matching])
        except ValueError as exc:
            if explicit is not None:
                raise
            self._log.error(f'{topic}: cannot record: {exc}')
            self._failed.add(topic)
            return
        announced = {h for h in (str(i.topic_type_hash) for i in matching)
                     if h.startswith('RIHS01_') and h[len('RIHS01_'):].strip('0')}  # 0...0: unknown
        ours = self.typestore.hash_rihs01(msgtype)
        if announced and ours not in announced:
            self._log.warning(f'{topic}: type hash {ours} differs from the publishers\' {sorted(announced)}')
        best_effort = any(int(i.qos_profile.reliability) == 2 for i in matching)
        transient_local = bool(matching) and all(int(i.qos_profile.durability) == 1 for i in matching)
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
    p.add_argument('-s', '--storage', choices=sorted(STORAGES), default=DEFAULT_STORAGE,
                   help='storage plugin (default: mcap, as ros2 bag on Jazzy)')
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
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import remove_ros_args
    from robot_control.ros.spin import make_executor

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

    stop = threading.Event()
    old = {s: signal.signal(s, lambda _signum, _frame: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    node = recorder = executor = None
    counts = {}
    try:
        node = Node(opts.node_name)
        executor = make_executor('events')
        executor.add_node(node)
        recorder = Recorder(node, opts.output, opts.topics, all_topics=opts.all, exclude=opts.exclude,
                            discovery_timeout=opts.discovery_timeout, storage=opts.storage,
                            overwrite=opts.overwrite)
        recorder.start()
        print(f'record: writing {opts.output} ({opts.storage}); topics: '
              f'{", ".join(recorder.subscribed) or "(waiting)"}'
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
            for s, h in old.items():
                signal.signal(s, h)
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
