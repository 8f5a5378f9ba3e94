"""Plots from any bag: the recorder's mcap bag and a bag laid out as `ros2 bag record` writes it on
Jazzy (sqlite3 .db3, metadata version 9), read into the tracking figure.

No DDS here: bags are written from serialized messages (rclpy.serialization), the recorder's by
the writer it opens (robot_control.tools.record.open_bag), the ros2-bag-record one row by row
with sqlite3 following rosbag2_storage_sqlite3's schema.
"""
import os
import sqlite3
import subprocess
import sys

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import WrenchStamped
from rclpy.serialization import serialize_message
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from support.figures import axes_by_row, check_no_offset
from robot_control import urdf
from robot_control.tools.bag_tracking import BagError, tracking_data
from robot_control.tools.plot import main as plot_main
from robot_control.tools.plot import tracking_figure
from robot_control.tools.record import open_bag

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DT_NS = 1_000_000        # 1 ms control period
T0_NS = 5_000_000_000    # sim time of the first state
IIWA = [f'lbr_iiwa_joint_{i}' for i in range(1, 8)]


def stamp(ns):
    ns = int(ns)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def joint_state(names, ns, position, velocity=(), effort=()):
    msg = JointState(name=list(names), position=[float(v) for v in position],
                     velocity=[float(v) for v in velocity], effort=[float(v) for v in effort])
    msg.header.stamp = stamp(ns)
    return msg


def status(name, values):
    return DiagnosticStatus(name=name, values=[KeyValue(key=k, value=str(v)) for k, v in values])


def step_run(names, N, q0, q1):
    """A critically damped step (w = 6 rad/s) from q0 toward q1 at tick 50: (stamps, q, q_d, tau)."""
    stamps = T0_NS + DT_NS * np.arange(N)
    t = np.maximum(0.0, (np.arange(N) - 50) * 1e-3)
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    q_d = np.where((np.arange(N) >= 50)[:, None], q1, q0)
    q = q1 - np.outer((1.0 + 6.0 * t) * np.exp(-6.0 * t), q1 - q0)
    q[:50] = q0
    tau = 10.0 + 36.0 * (q_d - q)
    return stamps, q, q_d, tau


def recorder_bag(path, messages):
    """A bag written as the recorder writes it: messages [(topic, msgtype, t_ns, msg)] in order, each
    topic's connection made with its first message."""
    writer, store, conns = open_bag(path), get_typestore(Stores.ROS2_JAZZY), {}
    for topic, msgtype, t_ns, msg in messages:
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
        writer.write(conns[topic], int(t_ns), serialize_message(msg))
    writer.close()
    return path


def polar_messages(N=400, ns=''):
    """The loop's topics of a polar_two_link run in lockstep (the demo's set)."""
    names = ['theta1', 'r']
    stamps, q, q_d, tau = step_run(names, N, [0.0, 0.5], [0.5, 0.7])
    js, ref, err = (f'{ns}/joint_states', f'{ns}/controller/reference', f'{ns}/controller/error')
    msgs = [(f'{ns}/robot_description', 'std_msgs/msg/String', T0_NS - 1,
             String(data=urdf.read('polar_two_link.urdf')[0]))]
    for k, s in enumerate(stamps):
        recv = int(s) + 200_000
        msgs += [(js, 'sensor_msgs/msg/JointState', recv, joint_state(names, s, q[k], effort=tau[k])),
                 (ref, 'sensor_msgs/msg/JointState', recv + 1, joint_state(names, s, q_d[k], [0, 0], [0, 0])),
                 (err, 'sensor_msgs/msg/JointState', recv + 2, joint_state(names, s, q_d[k] - q[k], [0, 0], [0, 0]))]
        if k % 100 == 0:
            diag = DiagnosticArray(status=[
                status('controller: effort saturation', [('effort_limit.theta1', 60.0), ('effort_limit.r', 40.0)]),
                status('controller: control law', [('law', 'computed_torque'), ('force_axes', '')])])
            diag.header.stamp = stamp(int(s))
            msgs.append(('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', recv + 3, diag))
    return msgs, (stamps, q, q_d, tau)


# ---------------------------------------------------------------- the recorder's bag (mcap)
def test_plot_from_a_recorder_bag(tmp_path):
    messages, (stamps, q, q_d, tau) = polar_messages()
    bag = recorder_bag(tmp_path / 'bag', messages)
    data = tracking_data(bag)
    assert data['scenario'] == 'polar_two_link' and 'computed_torque' in data['title']
    assert data['joint_names'] == ['theta1', 'r'] and data['units'] == ['rad', 'm']  # r prismatic in the URDF
    np.testing.assert_allclose(data['t'], (stamps - stamps[0]) * 1e-9)
    np.testing.assert_array_equal(data['q'], q)
    np.testing.assert_array_equal(data['q_d'], q_d)
    np.testing.assert_allclose(data['e'], q_d - q)
    np.testing.assert_array_equal(data['tau'], tau)
    assert list(data['effort_limit']) == [60.0, 40.0] and 'f' not in data

    fig = tracking_figure(data, tmp_path / 'tracking.png')
    assert (tmp_path / 'tracking.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [2, 2, 2]  # one panel per joint in each of position, error, effort
    assert [[a.get_title() for a in r] for r in rows] == [['theta1', 'r']] * 3
    assert [a.get_ylabel() for a in rows[0]] == ['position [rad]', 'position [m]']
    assert [a.get_ylabel() for a in rows[2]] == ['torque [N m]', 'joint force [N]']
    np.testing.assert_array_equal(rows[0][1].get_lines()[0].get_ydata(), q_d[:, 1])
    legends = [[t.get_text() for t in rows[k][0].get_legend().get_texts()] for k in range(3)]
    assert legends == [['desired $q_d$ (/controller/reference)', 'actual $q$ (/joint_states)'],
                       ['$e = q_d - q$ (/controller/error)'], ['$\\tau$ applied (/joint_states)', 'limit \u00b160']]
    assert sorted(line.get_ydata()[0] for line in rows[2][0].get_lines() if line.get_linestyle() == '--') \
        == [-60.0, 60.0]
    check_no_offset(fig)


def test_a_task_space_run_plots_motion_axes_joint_efforts_and_the_force(tmp_path):
    """hybrid_cartesian_xy: x presses on the wall (force axis), y moves; the bag says so on /diagnostics."""
    names = ['x', 'y']
    N = 200
    stamps, q, q_d, tau = step_run(names, N, [0.3, 0.0], [0.3, 0.1])
    f_d = np.where(np.arange(N) >= 20, 10.0, 0.0)
    f = 10.0 * (1 - np.exp(-np.maximum(0, np.arange(N) - 20) * 8e-3)) * (np.arange(N) >= 20)
    msgs = []
    for k, s in enumerate(stamps):
        ref_pos, err_pos = [f_d[k], q_d[k, 1]], [f_d[k] - f[k], q_d[k, 1] - q[k, 1]]
        w = WrenchStamped()
        w.header.stamp = stamp(int(s))
        w.wrench.force.x = float(f[k])
        msgs += [('/joint_states', 'sensor_msgs/msg/JointState', s, joint_state(names, s, q[k], effort=tau[k])),
                 ('/ft_sensor/wrench', 'geometry_msgs/msg/WrenchStamped', s, w),
                 ('/controller/reference', 'sensor_msgs/msg/JointState', s, joint_state(names, s, ref_pos)),
                 ('/controller/error', 'sensor_msgs/msg/JointState', s, joint_state(names, s, err_pos))]
    diag = DiagnosticArray(status=[status('controller: control law', [('law', 'hybrid'), ('force_axes', 'x')])])
    msgs.append(('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', stamps[-1], diag))
    data = tracking_data(recorder_bag(tmp_path / 'bag', msgs))
    assert data['joint_names'] == ['y'] and data['units'] == ['m'] and data['tau_names'] == ['x', 'y']
    np.testing.assert_allclose(data['q'][:, 0], q[:, 1])
    np.testing.assert_array_equal(data['f'][:, 0], f)
    np.testing.assert_array_equal(data['f_d'][:, 0], f_d)
    rows = axes_by_row(tracking_figure(data))
    assert [len(r) for r in rows] == [1, 1, 2, 1]
    assert rows[3][0].get_title() == 'contact force x' and rows[0][0].get_title() == 'y'
    assert [t.get_text() for t in rows[3][0].get_legend().get_texts()] \
        == ['reference $f_d$ (/controller/reference)', 'measured $f$ (/ft_sensor/wrench)']
    assert [t.get_text() for t in rows[0][0].get_legend().get_texts()][1] \
        == 'actual $q$ (/controller/reference \u2212 /controller/error)'


# ---------------------------------------------------------------- a `ros2 bag record` bag (sqlite3)
SQLITE_SCHEMA = '''
CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                    serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL,
                    type_description_hash TEXT NOT NULL);
CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, encoding TEXT NOT NULL,
                                 encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);
CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                      data BLOB NOT NULL);
CREATE INDEX timestamp_idx ON messages (timestamp ASC);
INSERT INTO schema (schema_version, ros_distro) VALUES (4, 'jazzy');
'''
QOS_RELIABLE = [{'history': 'unknown', 'depth': 0, 'reliability': 'reliable', 'durability': 'volatile',
                 'deadline': {'sec': 9223372036, 'nsec': 854775807},
                 'lifespan': {'sec': 9223372036, 'nsec': 854775807}, 'liveliness': 'automatic',
                 'liveliness_lease_duration': {'sec': 9223372036, 'nsec': 854775807},
                 'avoid_ros_namespace_conventions': False}]


def ros2_bag_record(bag, messages):
    """A bag as `ros2 bag record -s sqlite3` writes it on Jazzy: <bag>/<name>_0.db3 and metadata.yaml
    (version 9); messages [(topic, msgtype, receive t_ns, msg)]; QoS as the graph reports it."""
    bag.mkdir()
    db_name = f'{bag.name}_0.db3'
    store = get_typestore(Stores.ROS2_JAZZY)
    topics = {}
    for topic, msgtype, _, _ in messages:
        topics.setdefault(topic, (len(topics) + 1, msgtype))
    counts = {t: sum(1 for m in messages if m[0] == t) for t in topics}
    t_ns = [m[2] for m in messages]
    info = {'version': 9, 'storage_identifier': 'sqlite3', 'duration': {'nanoseconds': max(t_ns) - min(t_ns)},
            'starting_time': {'nanoseconds_since_epoch': min(t_ns)}, 'message_count': len(messages),
            'topics_with_message_count': [
                {'topic_metadata': {'name': t, 'type': ty, 'serialization_format': 'cdr',
                                    'offered_qos_profiles': QOS_RELIABLE,
                                    'type_description_hash': store.hash_rihs01(ty)},
                 'message_count': counts[t]} for t, (_, ty) in topics.items()],
            'compression_format': '', 'compression_mode': '', 'relative_file_paths': [db_name],
            'files': [{'path': db_name, 'starting_time': {'nanoseconds_since_epoch': min(t_ns)},
                       'duration': {'nanoseconds': max(t_ns) - min(t_ns)}, 'message_count': len(messages)}],
            'custom_data': None, 'ros_distro': 'jazzy'}
    con = sqlite3.connect(bag / db_name)
    con.executescript(SQLITE_SCHEMA)
    for t, (i, ty) in topics.items():
        con.execute('INSERT INTO topics (id, name, type, serialization_format, offered_qos_profiles, '
                    'type_description_hash) VALUES (?, ?, ?, ?, ?, ?)',
                    (i, t, ty, 'cdr', yaml.safe_dump(QOS_RELIABLE, sort_keys=False), store.hash_rihs01(ty)))
        msgdef, _ = store.generate_msgdef(ty, ros_version=2)
        con.execute('INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, '
                    'type_description_hash) VALUES (?, ?, ?, ?)', (ty, 'ros2msg', msgdef, store.hash_rihs01(ty)))
    con.executemany('INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)',
                    [(topics[t][0], int(ns), serialize_message(m)) for t, _, ns, m in messages])
    con.execute('INSERT INTO metadata (metadata_version, metadata) VALUES (?, ?)',
                (9, yaml.safe_dump(info, sort_keys=False)))
    con.commit()
    con.close()
    (bag / 'metadata.yaml').write_text(yaml.safe_dump({'rosbag2_bagfile_information': info}, sort_keys=False))
    return bag


def iiwa_messages(N=300, ns='/arm'):
    """A 7-joint arm under a namespace: joint_states (with two extra gripper joints, no effort), the
    controller's reference and its commands; receive times 0.3 ms after the stamps."""
    extra = ['finger_left', 'finger_right']
    q0 = [0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.55]
    stamps, q, q_d, tau = step_run(IIWA, N, q0, np.add(q0, 0.1))
    msgs = []
    for k, s in enumerate(stamps):
        recv = int(s) + 300_000
        msgs += [(f'{ns}/joint_states', 'sensor_msgs/msg/JointState', recv,
                  joint_state(extra + IIWA, s, list(np.zeros(2)) + list(q[k]))),
                 (f'{ns}/controller/reference', 'sensor_msgs/msg/JointState', recv + 10,
                  joint_state(IIWA, s, q_d[k])),
                 (f'{ns}/robot_joint_commands', 'sensor_msgs/msg/JointState', recv + 20,
                  joint_state(IIWA, s, [], effort=tau[k]))]
    return msgs, (stamps, q, q_d, tau)


def test_plot_from_a_ros2_bag_record_sqlite3_bag(tmp_path):
    messages, (stamps, q, q_d, tau) = iiwa_messages()
    bag = ros2_bag_record(tmp_path / 'rosbag2_2026_11_23-18_00_00', messages)
    data = tracking_data(bag)
    assert data['scenario'] == 'iiwa' and data['joint_names'] == IIWA and data['units'] == ['rad'] * 7
    np.testing.assert_array_equal(data['q'], q)
    np.testing.assert_array_equal(data['q_d'], q_d)
    np.testing.assert_array_equal(data['tau'], tau)  # joint_states carry no effort: the commanded one
    np.testing.assert_allclose(data['t'][-1], (stamps[-1] - stamps[0]) * 1e-9)

    out = tmp_path / 'iiwa.png'
    res = subprocess.run([sys.executable, '-m', 'robot_control.plot', str(bag), '-o', str(out)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120, env={**os.environ, 'PYTHONPATH': ROOT})
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == str(out) and out.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'

    fig = tracking_figure(data)
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [4, 3, 4, 3, 4, 3]  # position, error, torque: 4 + 3 panels each
    for block, label in enumerate(['position [rad]', 'error [rad]', 'torque [N m]']):
        panels = rows[2 * block] + rows[2 * block + 1]
        assert [a.get_title() for a in panels] == IIWA and {a.get_ylabel() for a in panels} == {label}
    assert all(a.get_shared_x_axes().joined(a, fig.axes[0]) for a in fig.axes)
    check_no_offset(fig)


def test_a_bag_of_joint_states_and_commands_plots_only_those(tmp_path):
    """No reference or error topic, no effort in joint_states, no wrench: positions and the commanded
    torques, each legend naming its topic; no q_d line, no error block, no force block."""
    messages, (stamps, q, q_d, tau) = iiwa_messages(N=200)
    bag = recorder_bag(tmp_path / 'bag', [m for m in messages if m[0] != '/arm/controller/reference'])
    data = tracking_data(bag)
    assert np.isnan(data['q_d']).all() and np.isnan(data['e']).all() and data['tau_kind'] == 'commanded'
    fig = tracking_figure(data, tmp_path / 'tracking.png')
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [4, 3, 4, 3]  # position and torque, 4 + 3 panels each
    assert {a.get_ylabel() for a in fig.axes} == {'position [rad]', 'torque [N m]'}
    for block, legend in enumerate([['actual $q$ (/arm/joint_states)'],
                                    ['$\\tau$ commanded (/arm/robot_joint_commands)']]):
        panels = rows[2 * block] + rows[2 * block + 1]
        assert [a.get_title() for a in panels] == IIWA
        assert all([t.get_text() for t in a.get_legend().get_texts()] == legend for a in panels)
        assert all([line.get_label() for line in a.get_lines()] == legend for a in panels)
    np.testing.assert_array_equal(rows[0][0].get_lines()[0].get_ydata(), q[:, 0])
    np.testing.assert_array_equal(rows[2][0].get_lines()[0].get_ydata(), tau[:, 0])
    check_no_offset(fig)


def test_default_output_beside_the_bag_and_a_namespace_chosen_in_a_bag_of_two(tmp_path, capsys):
    arm, _ = iiwa_messages(N=50, ns='/arm')
    polar, _ = polar_messages(N=50, ns='/polar')
    bag = ros2_bag_record(tmp_path / 'two', sorted(arm + [m for m in polar if m[0] != '/diagnostics'],
                                                   key=lambda m: m[2]))
    assert plot_main([str(bag)]) == 2
    assert 'several robots' in capsys.readouterr().err
    assert plot_main([str(bag), '--namespace', 'polar']) == 0
    assert (tmp_path / 'two_tracking.png').is_file()
    assert tracking_data(bag, 'arm')['joint_names'] == IIWA


# ---------------------------------------------------------------- bad input
def test_bad_paths_get_a_clear_error(tmp_path, capsys):
    with pytest.raises(BagError, match=r'^bag: .*nowhere does not exist'):
        tracking_data(tmp_path / 'nowhere')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagError, match=r'no metadata\.yaml'):
        tracking_data(tmp_path / 'empty')
    (tmp_path / 'file.txt').write_text('x')
    with pytest.raises(BagError, match='is not a rosbag2 directory'):
        tracking_data(tmp_path / 'file.txt')
    (tmp_path / 'broken').mkdir()
    (tmp_path / 'broken' / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: 9}\n')
    with pytest.raises(BagError, match='cannot read it'):
        tracking_data(tmp_path / 'broken')
    wrench = WrenchStamped()
    other = recorder_bag(tmp_path / 'other', [('/ft_sensor/wrench', 'geometry_msgs/msg/WrenchStamped', 1, wrench)])
    with pytest.raises(BagError, match=r'no joint_states topic .*/ft_sensor/wrench'):
        tracking_data(other)
    assert plot_main([str(tmp_path / 'nowhere')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('plot: bag: ') and 'does not exist' in err
