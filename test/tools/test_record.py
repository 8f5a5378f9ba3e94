"""The rosbag2 recorder over real DDS (loopback, private domain): what goes in comes back out exactly.

In-process tests put a publisher node and the recorder node in one fresh context and spin them with
deadlines; CLI tests run `python -m robot_control.record` as a subprocess against a publisher here.
"""
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from robot_control.ros.spin import make_executor
from robot_control.tools.record import Recorder, bag_info, normalize_type, parse_topic, read_bag

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

ROOT = Path(__file__).resolve().parents[2]
# Nodes live in a namespace of their own so that anything else on the domain cannot leak in.
NS = f'/rec_test_{os.getpid()}'
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
#: what rosbag2 on Jazzy reads of a version-9 metadata.yaml (rosbag2_storage/yaml.hpp), of the bag, of each
#: topic and of each offered QoS profile; ros2 bag info/play fail on a bag that lacks one
ROSBAG2_KEYS = {'version', 'storage_identifier', 'duration', 'starting_time', 'message_count',
                'topics_with_message_count', 'relative_file_paths', 'compression_format', 'compression_mode',
                'files', 'custom_data', 'ros_distro'}
ROSBAG2_TOPIC_KEYS = {'name', 'type', 'serialization_format', 'offered_qos_profiles', 'type_description_hash'}
ROSBAG2_QOS_KEYS = {'history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
                    'liveliness_lease_duration', 'avoid_ros_namespace_conventions'}
WAIT = 30.0   # s of wall time a condition may take: generous, a busy machine only waits longer


# ------------------------------------------------------------------ helpers

def spin_until(executor, predicate, timeout):
    """Spin `executor` until predicate() is true or `timeout` s pass; returns predicate()."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return predicate()
        executor.spin_once(timeout_sec=0.02)
    return True


def joint_state(i):
    m = JointState()
    m.header.stamp.sec = 100 + i
    m.header.stamp.nanosec = 1000 * i
    m.header.frame_id = 'base'
    m.name = ['theta1', 'r']
    m.position = [0.1 * i, -0.25 * i]
    m.velocity = [1.5 + i, 2.5]
    m.effort = [3.0e-3 * i, -7.0]
    return m


def wrench(i):
    m = WrenchStamped()
    m.header.stamp.sec = i
    m.header.frame_id = 'tool0'
    m.wrench.force.x, m.wrench.force.y, m.wrench.force.z = 10.0 + i, -0.5, 1e-9 * i
    m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z = 0.0, 0.125 * i, -3.0
    return m


def commands(i):
    m = Float64MultiArray()
    m.layout.dim = [MultiArrayDimension(label='joints', size=3, stride=3)]
    m.layout.data_offset = 0
    m.data = [float(i), 2.0 * i, -1.0 / (i + 1)]
    return m


def diagnostics(i):
    m = DiagnosticArray()
    m.header.stamp.sec = i
    m.status = [DiagnosticStatus(level=DiagnosticStatus.WARN, name='controller: watchdog',
                                 message=f'stale state {i}', hardware_id='sim',
                                 values=[KeyValue(key='age_ms', value=str(10 * i)),
                                         KeyValue(key='limit_ms', value='50')])]
    return m


SOURCES = {  # topic as published (relative where the node would use a relative name) -> (class, factory, type)
    'joint_states': (JointState, joint_state, 'sensor_msgs/msg/JointState'),
    'ft_sensor/wrench': (WrenchStamped, wrench, 'geometry_msgs/msg/WrenchStamped'),
    'effort_controller/commands': (Float64MultiArray, commands, 'std_msgs/msg/Float64MultiArray'),
    f'{NS}/diagnostics': (DiagnosticArray, diagnostics, 'diagnostic_msgs/msg/DiagnosticArray'),
}
DIAG = f'{NS}/diagnostics'


def check_joint_state(got, want):
    assert (got.header.stamp.sec, got.header.stamp.nanosec) == (want.header.stamp.sec, want.header.stamp.nanosec)
    assert got.header.frame_id == want.header.frame_id
    assert list(got.name) == list(want.name)
    for field in ('position', 'velocity', 'effort'):
        assert list(getattr(got, field)) == list(getattr(want, field)), field


def check_wrench(got, want):
    assert got.header.stamp.sec == want.header.stamp.sec and got.header.frame_id == want.header.frame_id
    for part in ('force', 'torque'):
        g, w = getattr(got.wrench, part), getattr(want.wrench, part)
        assert (g.x, g.y, g.z) == (w.x, w.y, w.z), part


def check_commands(got, want):
    assert list(got.data) == list(want.data)
    assert [(d.label, d.size, d.stride) for d in got.layout.dim] == [('joints', 3, 3)]
    assert got.layout.data_offset == 0


def check_diagnostics(got, want):
    assert got.header.stamp.sec == want.header.stamp.sec
    assert len(got.status) == 1
    g, w = got.status[0], want.status[0]
    assert g.level == w.level[0]  # `byte`: bytes in rclpy, int in rosbags
    assert (g.name, g.message, g.hardware_id) == (w.name, w.message, w.hardware_id)
    assert [(kv.key, kv.value) for kv in g.values] == [(kv.key, kv.value) for kv in w.values]


CHECKS = {'joint_states': check_joint_state, 'ft_sensor/wrench': check_wrench,
          'effort_controller/commands': check_commands, DIAG: check_diagnostics}


def absolute(topic):
    return topic if topic.startswith('/') else f'{NS}/{topic}'


class Rig:
    """A publisher node and a recorder node in one context, one executor spun by the test
    ('single': SingleThreadedExecutor, 'events': the EventsExecutor the tools spin)."""

    def __init__(self, ctx, executor='single'):
        self.pub_node = Node('rec_test_pub', namespace=NS, context=ctx)
        self.rec_node = Node('rec_test_recorder', namespace=NS, context=ctx)
        self.executor = make_executor(executor, context=ctx)
        self.executor.add_node(self.pub_node)
        self.executor.add_node(self.rec_node)
        self.pubs = {}

    def publisher(self, topic, cls, qos=RELIABLE):
        self.pubs[topic] = self.pub_node.create_publisher(cls, topic, qos)
        return self.pubs[topic]

    def wait_matched(self, timeout=WAIT):
        assert spin_until(self.executor, lambda: all(p.get_subscription_count() >= 1 for p in self.pubs.values()),
                          timeout), {t: p.get_subscription_count() for t, p in self.pubs.items()}

    def close(self):
        self.executor.shutdown()
        self.pub_node.destroy_node()
        self.rec_node.destroy_node()


@pytest.fixture
def rig(ros_context):
    r = Rig(ros_context)
    try:
        yield r
    finally:
        r.close()


@pytest.fixture(params=['single', 'events'])
def any_rig(request, ros_context):
    r = Rig(ros_context, request.param)
    try:
        yield r
    finally:
        r.close()


def received(recorder):
    return recorder.received


# ------------------------------------------------------------------ pure helpers

def test_parse_topic_and_normalize_type():
    assert parse_topic('joint_states') == ('joint_states', None)
    assert parse_topic('/a/b:sensor_msgs/JointState') == ('/a/b', 'sensor_msgs/msg/JointState')
    assert normalize_type('std_msgs/msg/Float64MultiArray') == 'std_msgs/msg/Float64MultiArray'
    for bad in ('sensor_msgs', 'a/srv/B', 'x/msg/', 'a b/msg/C'):
        with pytest.raises(ValueError, match='^msgtype'):
            normalize_type(bad)
    with pytest.raises(ValueError, match='^topics'):
        parse_topic(':std_msgs/msg/String')


# ------------------------------------------------------------------ in-process recording

def test_records_four_topics_with_exact_contents(rig, tmp_path):
    K = 25
    for topic, (cls, _, _) in SOURCES.items():
        rig.publisher(topic, cls)
    bag = tmp_path / 'bag'
    # Two topics by name only (type from the graph), two as name:type pairs.
    specs = ['joint_states', DIAG,
             'ft_sensor/wrench:geometry_msgs/msg/WrenchStamped',
             'effort_controller/commands:std_msgs/msg/Float64MultiArray']
    clock = rig.rec_node.get_clock()
    t_before = clock.now().nanoseconds
    recorder = Recorder(rig.rec_node, bag, specs, discovery_timeout=5.0)
    with recorder:
        assert recorder.pending == []
        assert recorder.subscribed == sorted(absolute(t) for t in SOURCES)
        rig.wait_matched()
        sent = {t: [] for t in SOURCES}
        for i in range(K):
            for topic, (_, make, _) in SOURCES.items():
                msg = make(i)
                rig.pubs[topic].publish(msg)
                sent[topic].append(msg)
            rig.executor.spin_once(timeout_sec=0.0)
        assert spin_until(rig.executor, lambda: received(recorder) == K * len(SOURCES), WAIT), recorder.counts
    t_after = clock.now().nanoseconds
    assert recorder.counts == {absolute(t): K for t in SOURCES}

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['storage_identifier'] == 'mcap' and meta['version'] == 9
    assert ROSBAG2_KEYS <= set(meta) and isinstance(meta['ros_distro'], str)
    assert all(set(x['topic_metadata']) >= ROSBAG2_TOPIC_KEYS for x in meta['topics_with_message_count'])
    assert meta['relative_file_paths'] == ['bag.mcap'] and (bag / 'bag.mcap').is_file()
    assert meta['message_count'] == K * len(SOURCES)
    assert {x['topic_metadata']['name']: (x['topic_metadata']['type'], x['message_count'])
            for x in meta['topics_with_message_count']} == {absolute(t): (ty, K) for t, (_, _, ty) in SOURCES.items()}

    # rosbags' own Reader + the Jazzy typestore, message by message.
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(bag) as reader:
        expected = {absolute(t): ty for t, (_, _, ty) in SOURCES.items()}
        assert {c.topic: c.msgtype for c in reader.connections} == expected
        got = {absolute(t): [] for t in SOURCES}
        for conn, t_ns, raw in reader.messages():
            got[conn.topic].append((t_ns, store.deserialize_cdr(raw, conn.msgtype)))
    for topic, check in CHECKS.items():
        msgs = got[absolute(topic)]
        assert len(msgs) == K
        stamps = [t for t, _ in msgs]
        assert stamps == sorted(stamps) and t_before <= stamps[0] and stamps[-1] <= t_after
        for (_, g), w in zip(msgs, sent[topic]):
            check(g, w)

    # read_bag returns the same, and selected topics only.
    js = absolute('joint_states')
    sel = read_bag(bag, [js, DIAG])
    assert sorted(sel) == sorted([js, DIAG])
    assert [t for t, _ in sel[js]] == [t for t, _ in got[js]]
    for (_, g), w in zip(sel[js], sent['joint_states']):
        check_joint_state(g, w)
    assert bag_info(bag)[absolute('ft_sensor/wrench')] == ('geometry_msgs/msg/WrenchStamped', K)
    with pytest.raises(ValueError, match='^topics'):
        read_bag(bag, ['no_such_topic'])


def test_bag_is_self_describing_and_hashes_match_the_graph(rig, tmp_path):
    rig.publisher('ft_sensor/wrench', WrenchStamped)
    rig.publisher(DIAG, DiagnosticArray)
    bag = tmp_path / 'bag'
    with Recorder(rig.rec_node, bag, ['ft_sensor/wrench', DIAG]) as recorder:
        rig.wait_matched()
        rig.pubs['ft_sensor/wrench'].publish(wrench(3))
        rig.pubs[DIAG].publish(diagnostics(4))
        assert spin_until(rig.executor, lambda: received(recorder) == 2, WAIT)
        announced = {t: {str(i.topic_type_hash) for i in rig.rec_node.get_publishers_info_by_topic(t)}
                     for t in (absolute('ft_sensor/wrench'), DIAG)}
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    hashes = {x['topic_metadata']['name']: x['topic_metadata']['type_description_hash']
              for x in meta['topics_with_message_count']}
    assert {t: {h} for t, h in hashes.items()} == announced  # RIHS01 equals what the publishers announce
    with Reader(bag) as reader:
        defs = {c.topic: c.msgdef.data for c in reader.connections}
    assert 'MSG: geometry_msgs/Vector3' in defs[absolute('ft_sensor/wrench')]
    assert 'MSG: diagnostic_msgs/KeyValue' in defs[DIAG]
    # A reader that knows no types at all decodes it from the definitions stored in the bag.
    data = read_bag(bag, typestore=get_typestore(Stores.EMPTY))
    check_wrench(data[absolute('ft_sensor/wrench')][0][1], wrench(3))
    check_diagnostics(data[DIAG][0][1], diagnostics(4))


def test_definitions_from_installed_msg_files_when_typestore_lacks_them(rig, tmp_path):
    rig.publisher('joint_states', JointState)
    bag = tmp_path / 'bag'
    empty = get_typestore(Stores.EMPTY)  # forces share/<pkg>/msg/*.msg lookup for every type
    with Recorder(rig.rec_node, bag, ['joint_states'], typestore=empty) as recorder:
        rig.wait_matched()
        rig.pubs['joint_states'].publish(joint_state(7))
        assert spin_until(rig.executor, lambda: received(recorder) == 1, WAIT)
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    assert empty.hash_rihs01('sensor_msgs/msg/JointState') == jazzy.hash_rihs01('sensor_msgs/msg/JointState')
    check_joint_state(read_bag(bag)[absolute('joint_states')][0][1], joint_state(7))


def test_bursts_are_recorded_complete_and_in_order(any_rig, tmp_path):
    rig = any_rig
    rig.publisher('joint_states', JointState, QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000))
    bag = tmp_path / 'bag'
    N, BURST = 3000, 500  # bursts below the subscription depth (1000): nothing may be dropped
    with Recorder(rig.rec_node, bag, ['joint_states']) as recorder:
        rig.wait_matched()
        t0 = time.perf_counter()
        for start in range(0, N, BURST):
            for i in range(start, start + BURST):
                rig.pubs['joint_states'].publish(joint_state(i))
            assert spin_until(rig.executor, lambda: received(recorder) == start + BURST, WAIT), received(recorder)
        rate = N / (time.perf_counter() - t0)
    seq = [m.header.stamp.nanosec // 1000 for _, m in read_bag(bag)[absolute('joint_states')]]
    assert seq == list(range(N))
    print(f'in-process publish+record, {type(rig.executor).__name__}: {rate:.0f} msg/s')


def test_stop_writes_what_dds_delivered_but_the_executor_had_not_handed_over(any_rig, tmp_path):
    """An executor that falls behind (here: not spun at all after the match) must not cost the bag the
    run's last messages: stop() has the node's executor hand them over before it unsubscribes."""
    rig = any_rig
    rig.publisher('joint_states', JointState, QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000))
    bag = tmp_path / 'bag'
    with Recorder(rig.rec_node, bag, ['joint_states']) as recorder:
        rig.wait_matched()
        for i in range(200):
            rig.pubs['joint_states'].publish(joint_state(i))
        assert rig.pubs['joint_states'].wait_for_all_acked(Duration(seconds=30))   # delivered by DDS (acknowledged)
        assert received(recorder) == 0                   # no spin: no callback ran
    seq = [m.header.stamp.nanosec // 1000 for _, m in read_bag(bag)[absolute('joint_states')]]
    assert seq == list(range(200))


def test_stop_records_nothing_received_after_it_was_called(any_rig, tmp_path):
    """A publisher that never pauses (a timer at 2 kHz, run by the very executor stop() spins to hand over
    what is waiting) neither keeps stop() busy nor gets messages received after the call into the bag."""
    rig = any_rig
    pub = rig.publisher('joint_states', JointState, QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000))
    sent = []

    def tick():
        pub.publish(joint_state(len(sent)))
        sent.append(time.time_ns())
    recorder = Recorder(rig.rec_node, tmp_path / 'bag', ['joint_states:sensor_msgs/msg/JointState']).start()
    rig.wait_matched()
    rig.pub_node.create_timer(0.0005, tick)
    assert spin_until(rig.executor, lambda: received(recorder) >= 200, WAIT)
    t0 = time.monotonic()
    count = recorder.stop()[absolute('joint_states')]
    # it returns (a bound generous for a busy machine); a stop chasing the publisher would take messages
    # received after the call, which the check below refuses
    assert time.monotonic() - t0 < 10.0
    msgs = read_bag(tmp_path / 'bag')[absolute('joint_states')]
    assert len(msgs) == count >= 200
    assert [m.header.stamp.nanosec // 1000 for _, m in msgs] == list(range(count))
    # nothing received after the call: the bag holds joint_state(0 .. count-1), and the last of them was
    # received after its publish call began, so after the call before it had returned (sent[count - 2]);
    # that must not be later than the stop (the bag's times are those of handing over, which a busy
    # machine delays: not the measure)
    until = recorder._until_ns          # when stop() was called, on the reception clock (system time)
    assert sent[count - 2] <= until
    assert len(sent) > count             # the publisher went on meanwhile


def test_untyped_topic_waits_boundedly_then_records_once_it_appears(rig, tmp_path):
    bag = tmp_path / 'bag'
    recorder = Recorder(rig.rec_node, bag, ['late_topic', 'joint_states'], discovery_timeout=0.3,
                        discovery_period=0.05)
    t0 = time.monotonic()
    with recorder:
        waited = time.monotonic() - t0
        assert 0.3 <= waited < 10.0     # bounded (generously: a busy machine is slower), not for ever
        assert recorder.pending == [absolute('joint_states'), absolute('late_topic')]
        rig.publisher('late_topic', Float64MultiArray)  # appears after start(): the timer picks it up
        assert spin_until(rig.executor, lambda: recorder.subscribed == [absolute('late_topic')], WAIT)
        rig.wait_matched()
        rig.pubs['late_topic'].publish(commands(1))
        assert spin_until(rig.executor, lambda: received(recorder) == 1, WAIT)
        assert recorder.pending == [absolute('joint_states')]
    info = bag_info(bag)
    assert info == {absolute('late_topic'): ('std_msgs/msg/Float64MultiArray', 1)}  # never seen: not in the bag


def test_all_topics_picks_up_new_topics_and_honours_exclude(rig, tmp_path):
    bag = tmp_path / 'bag'
    # Everything outside this test's namespace (/rosout, /parameter_events, other runs) is excluded.
    with Recorder(rig.rec_node, bag, all_topics=True, exclude=f'^(?!{NS}/)',
                  discovery_period=0.05) as recorder:
        rig.publisher('joint_states', JointState)
        rig.publisher('ignored/wrench', WrenchStamped)
        assert spin_until(rig.executor, lambda: absolute('ignored/wrench') in recorder.subscribed, WAIT)
        rig.wait_matched()
        rig.pubs['joint_states'].publish(joint_state(1))
        rig.pubs['ignored/wrench'].publish(wrench(1))
        assert spin_until(rig.executor, lambda: received(recorder) == 2, WAIT)
        assert '/rosout' not in recorder.subscribed and '/parameter_events' not in recorder.subscribed
    assert bag_info(bag) == {absolute('joint_states'): ('sensor_msgs/msg/JointState', 1),
                             absolute('ignored/wrench'): ('geometry_msgs/msg/WrenchStamped', 1)}


def test_best_effort_publisher_is_recorded_and_its_qos_stored(rig, tmp_path):
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,
                     durability=DurabilityPolicy.VOLATILE)
    rig.publisher('ft_sensor/wrench', WrenchStamped, qos)
    bag = tmp_path / 'bag'
    with Recorder(rig.rec_node, bag, ['ft_sensor/wrench']) as recorder:
        rig.wait_matched()  # a reliable subscription would never match a best-effort publisher
        n = 0
        # best effort may drop in principle: publish until a few arrive, within a deadline
        deadline = time.monotonic() + WAIT
        while received(recorder) < 3 and time.monotonic() < deadline:
            rig.pubs['ft_sensor/wrench'].publish(wrench(n))
            n += 1
            rig.executor.spin_once(timeout_sec=0.01)
        assert received(recorder) >= 3
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    (topic,) = meta['topics_with_message_count']
    (profile,) = topic['topic_metadata']['offered_qos_profiles']
    assert set(profile) == ROSBAG2_QOS_KEYS and profile['reliability'] == 'best_effort'
    assert profile['durability'] == 'volatile' and profile['deadline'] == {'sec': 9223372036, 'nsec': 854775807}


def test_a_topic_typed_before_its_publisher_appears_gets_the_qos_it_offers(rig, tmp_path):
    """As ros2 bag record lists them: the offered QoS of the publishers the topic's messages came from."""
    bag = tmp_path / 'bag'
    latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    with Recorder(rig.rec_node, bag, ['ft_sensor/wrench:geometry_msgs/msg/WrenchStamped']) as recorder:
        assert recorder.subscribed == [absolute('ft_sensor/wrench')]  # typed: subscribed with no publisher yet
        rig.publisher('ft_sensor/wrench', WrenchStamped, latched)
        rig.wait_matched()
        for i in range(3):
            rig.pubs['ft_sensor/wrench'].publish(wrench(i))
        assert spin_until(rig.executor, lambda: received(recorder) == 3, WAIT)
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['version'] == 9
    (topic,) = meta['topics_with_message_count']
    assert topic['message_count'] == 3
    assert [(q['reliability'], q['durability']) for q in topic['topic_metadata']['offered_qos_profiles']] \
        == [('reliable', 'transient_local')]
    assert len(read_bag(bag)[absolute('ft_sensor/wrench')]) == 3


def test_context_manager_closes_the_bag_on_error(rig, tmp_path):
    rig.publisher('joint_states', JointState)
    bag = tmp_path / 'bag'
    with pytest.raises(ZeroDivisionError):
        with Recorder(rig.rec_node, bag, ['joint_states']) as recorder:
            rig.wait_matched()
            rig.pubs['joint_states'].publish(joint_state(0))
            assert spin_until(rig.executor, lambda: received(recorder) == 1, WAIT)
            1 / 0
    assert recorder.stop() == {absolute('joint_states'): 1}  # idempotent
    assert len(read_bag(bag)[absolute('joint_states')]) == 1


def test_stop_after_context_shutdown_still_closes_the_bag(ros_context, tmp_path):
    import rclpy
    r = Rig(ros_context)
    r.publisher('joint_states', JointState)
    recorder = Recorder(r.rec_node, tmp_path / 'bag', ['joint_states']).start()
    r.wait_matched()
    r.pubs['joint_states'].publish(joint_state(2))
    assert spin_until(r.executor, lambda: received(recorder) == 1, WAIT)
    rclpy.try_shutdown(context=ros_context)  # e.g. Ctrl-C handled by rclpy before our stop()
    try:
        assert recorder.stop() == {absolute('joint_states'): 1}
    finally:
        r.executor.shutdown()
    check_joint_state(read_bag(tmp_path / 'bag')[absolute('joint_states')][0][1], joint_state(2))


FORGETFUL = """
import sys, time, rclpy
from rclpy.node import Node
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import Float64MultiArray
from robot_control.tools.record import Recorder
rclpy.init()
node = Node('forgetful', namespace=sys.argv[2])
ex = SingleThreadedExecutor(); ex.add_node(node)
pub = node.create_publisher(Float64MultiArray, 'data', 10)
rec = Recorder(node, sys.argv[1], ['data']).start()
deadline = time.monotonic() + 20
while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
    ex.spin_once(timeout_sec=0.02)
for i in range(5):
    pub.publish(Float64MultiArray(data=[float(i)]))
while rec.received < 5 and time.monotonic() < deadline:
    ex.spin_once(timeout_sec=0.02)
print('received', rec.received, flush=True)
# no rec.stop(), no shutdown: the interpreter exits with the bag still open
"""


def test_forgotten_stop_still_leaves_a_readable_bag_at_exit(tmp_path):
    env = {**os.environ, 'PYTHONPATH': str(ROOT)}
    res = subprocess.run([sys.executable, '-c', FORGETFUL, str(tmp_path / 'bag'), NS], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and 'received 5' in res.stdout, res.stdout + res.stderr
    msgs = read_bag(tmp_path / 'bag')[f'{NS}/data']
    assert [list(m.data) for _, m in msgs] == [[float(i)] for i in range(5)]


def test_existing_output_is_refused_unless_overwrite_of_a_bag(rig, tmp_path):
    rig.publisher('joint_states', JointState)
    bag = tmp_path / 'bag'
    with Recorder(rig.rec_node, bag, ['joint_states']):
        pass
    with pytest.raises(Exception, match='exists'):
        Recorder(rig.rec_node, bag, ['joint_states']).start()
    with Recorder(rig.rec_node, bag, ['joint_states'], overwrite=True):
        pass
    assert bag_info(bag) == {absolute('joint_states'): ('sensor_msgs/msg/JointState', 0)}
    other = tmp_path / 'not_a_bag'
    other.mkdir()
    (other / 'notes.txt').write_text('keep me')
    with pytest.raises(ValueError, match='^bag_dir'):
        Recorder(rig.rec_node, other, ['joint_states'], overwrite=True).start()
    assert (other / 'notes.txt').read_text() == 'keep me'
    with pytest.raises(ValueError, match='^topics'):
        Recorder(rig.rec_node, tmp_path / 'x', [])


# ------------------------------------------------------------------ command line

def start_cli(args):
    env = dict(os.environ)
    env['PYTHONPATH'] = str(ROOT) + os.pathsep + env.get('PYTHONPATH', '')
    env['PYTHONUNBUFFERED'] = '1'
    args = [*args, '--ros-args', '-r', f'__ns:={NS}']
    return subprocess.Popen([sys.executable, '-m', 'robot_control.record', *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def read_available(proc, chunks):
    """Appends what proc's stdout holds now (without blocking) to `chunks`; returns all read so far."""
    fd = proc.stdout.fileno()
    while select.select([fd], [], [], 0)[0]:
        data = os.read(fd, 65536)
        if not data:
            break
        chunks.append(data.decode(errors='replace'))
    return ''.join(chunks)


def stop_proc(proc):
    if proc.poll() is None:
        proc.kill()
    proc.wait(timeout=10)
    return proc.stdout.read() if proc.stdout else ''


@pytest.fixture
def ticker(ros_context):
    """A node publishing joint_state(i) at 200 Hz while the test spins it."""
    node = Node('rec_cli_pub', namespace=NS, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    pub = node.create_publisher(JointState, 'joint_states', RELIABLE)
    state = {'i': 0}

    def tick():
        pub.publish(joint_state(state['i']))
        state['i'] += 1
    node.create_timer(0.005, tick)
    try:
        yield executor, pub, state
    finally:
        executor.shutdown()
        node.destroy_node()


def test_cli_records_for_duration_and_exits_zero(ticker, tmp_path):
    executor, pub, state = ticker
    bag = tmp_path / 'bag'
    duration = 4.0  # DDS matching of a new process can take a second or two; leave room for it
    t0 = time.monotonic()
    proc = start_cli(['--output', str(bag), '--duration', str(duration), 'joint_states:sensor_msgs/msg/JointState'])
    try:
        stopped = spin_until(executor, lambda: proc.poll() is not None, 40.0)
        elapsed = time.monotonic() - t0
    finally:
        out = stop_proc(proc)
    assert stopped and proc.returncode == 0, out
    assert elapsed >= duration
    assert f'{absolute("joint_states")} matched 1 publisher(s)' in out
    msgs = read_bag(bag)[absolute('joint_states')]
    assert len(msgs) >= 1, out
    seq = [m.header.stamp.nanosec // 1000 for _, m in msgs]
    assert seq == list(range(seq[0], seq[0] + len(seq)))  # consecutive: nothing lost once matched
    for (_, got), i in zip(msgs, seq):
        check_joint_state(got, joint_state(i))
    # the bag's times are those of handing over: the last ones at the stop, which a busy machine may make
    # late; the margin is generous, and a recorder that ignored --duration would not have stopped at all
    span_s = (msgs[-1][0] - msgs[0][0]) * 1e-9
    assert span_s <= duration + 2.0, out


@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGINT])
def test_cli_signal_closes_a_readable_bag(ticker, tmp_path, signum):
    executor, pub, state = ticker
    bag = tmp_path / 'bag'
    proc = start_cli(['-o', str(bag), 'joint_states'])
    early = []
    try:
        # the recorder's own subscription must have matched (it says so): our writer seeing its reader does
        # not mean its reader sees our writer yet, DDS discovers the two sides apart
        assert spin_until(executor, lambda: 'matched 1 publisher' in read_available(proc, early)
                          or proc.poll() is not None, 30.0)
        assert proc.poll() is None
        # and our writer must have matched its reader: what it publishes before that reaches nobody
        assert spin_until(executor, lambda: pub.get_subscription_count() >= 1, 30.0)
        first = state['i']
        assert spin_until(executor, lambda: state['i'] >= first + 40, WAIT)
        proc.send_signal(signum)
        stopped = spin_until(executor, lambda: proc.poll() is not None, 20.0)
    finally:
        out = read_available(proc, early) + stop_proc(proc)
    assert stopped and proc.returncode == 0 and 'closed' in out, out
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['storage_identifier'] == 'mcap'
    msgs = read_bag(bag)[absolute('joint_states')]
    assert len(msgs) >= 30 and meta['message_count'] == len(msgs)


def test_cli_refuses_existing_output(tmp_path):
    (tmp_path / 'bag').mkdir()
    proc = start_cli(['-o', str(tmp_path / 'bag'), 'joint_states'])
    try:
        proc.wait(timeout=60)
    finally:
        out = stop_proc(proc)
    assert proc.returncode == 2 and 'exists' in out
