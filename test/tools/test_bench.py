"""The benchmark runs and reports; nothing here is timed.

`python -m benchmarks.bench --quick` must finish and write every key of the interface with a
finite number. The helpers the figures rest on are checked for correctness: the modern_robotics
peer model equals Pinocchio, the real-time metrics count what they claim, stamps are read from
serialized messages correctly.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: the keys every results.json carries (the README table and the targets read them)
KEYS = (
    'law_us_ct_2dof_median', 'law_us_ct_2dof_p99', 'law_us_ct_7dof_median', 'law_us_hybrid_7dof_median',
    'law_us_impedance_7dof_median',
    'mr_ct_7dof_us_median', 'pin_rnea_us_median', 'speedup_vs_modern_robotics',
    'lockstep_steps_per_s_polar', 'lockstep_steps_per_s_iiwa', 'pingpong_roundtrips_per_s',
    'lockstep_vs_pingpong_ratio',
    'realtime_1khz_deadline_hit_ratio', 'realtime_latency_p50_ms', 'realtime_latency_p99_ms', 'realtime_rtf',
    *(f'realtime_{metric}_{run}' for run in ('polar', 'iiwa', 'iiwa_hybrid', 'iiwa_impedance')
      for metric in ('1khz_deadline_hit_ratio', 'latency_p99_ms', 'rtf')),
    'sim_steps_per_s_iiwa',
    'js7_decode_us_cdr_median', 'js7_decode_us_rclpy_median',
    'wrench_decode_us_cdr_median', 'wrench_decode_us_rclpy_median',
)
QUICK_TIMEOUT_S = 300


def test_quick_bench_writes_every_key_as_a_finite_number(tmp_path):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    cmd = [sys.executable, '-m', 'benchmarks.bench', '--quick', '--out', str(tmp_path),
           '--domain-id', os.environ['ROS_DOMAIN_ID']]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=QUICK_TIMEOUT_S)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with open(tmp_path / 'results.json', encoding='utf-8') as f:
        results = json.load(f)
    missing = [k for k in KEYS if k not in results]
    assert not missing, f'missing keys {missing}'
    bad = {k: v for k, v in results.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)}
    assert not bad, f'not finite numbers: {bad}'
    with open(tmp_path / 'machine.json', encoding='utf-8') as f:
        machine = json.load(f)
    assert machine['cores'] >= 1 and machine['cpu_model']
    assert 'law_us_ct_7dof_median' in proc.stdout           # the table is printed


def test_modern_robotics_chain_has_pinocchio_dynamics():
    mr = pytest.importorskip('modern_robotics')
    from benchmarks.bench_mr import mr_chain
    from robot_control.models import for_scenario
    model = for_scenario('iiwa')
    Mlist, Glist, Slist, g = mr_chain(model.model)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, 7), rng.normal(0, 1, 7), rng.normal(0, 1, 7)
        tau = mr.InverseDynamics(q, qd, qdd, g, np.zeros(6), Mlist, Glist, Slist)
        np.testing.assert_allclose(tau, model.inverse_dynamics(q, qd, qdd), rtol=0, atol=1e-8)
        np.testing.assert_allclose(mr.MassMatrix(q, Mlist, Glist, Slist), model.M(q), rtol=0, atol=1e-8)


def test_modern_robotics_chain_rejects_a_tree():
    import pinocchio as pin
    from benchmarks.bench_mr import check_serial_chain
    model = pin.Model()
    j1 = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), 'a')
    model.addJoint(j1, pin.JointModelRZ(), pin.SE3.Identity(), 'b')
    model.addJoint(j1, pin.JointModelRZ(), pin.SE3.Identity(), 'c')
    with pytest.raises(ValueError, match='^model: expected a serial chain'):
        check_serial_chain(model)


def _rows(stamps_ms, times_ms):
    """(stamp, source, received) rows in ns from stamps and one time per row (source = received)."""
    return np.array([(round(s * 1e6), round(t * 1e6), round(t * 1e6)) for s, t in zip(stamps_ms, times_ms)],
                    dtype=np.int64)


def test_realtime_metrics_count_hits_latency_and_rtf():
    from benchmarks.bench_ros import realtime_metrics
    states = _rows(range(5), [0.0, 1.0, 2.0, 3.0, 4.0])            # state k published at k ms
    # command 0 in time (0.5 ms), 1 late (after state 2), 2 missing, 3 in time (0.2 ms)
    commands = _rows([0, 1, 3], [0.5, 2.5, 3.2])
    m = realtime_metrics(states, commands)
    assert m['hit_ratio'] == pytest.approx(2 / 4)                  # periods 0..3 have a next state
    assert m['latency_p50_ms'] == pytest.approx(0.5)
    assert m['rtf'] == pytest.approx(1.0)


def test_realtime_metrics_need_observed_periods():
    from benchmarks.bench_ros import realtime_metrics
    with pytest.raises(RuntimeError, match='control periods'):
        realtime_metrics(_rows([0], [0.0]), _rows([0], [0.5]))


def test_header_stamp_read_from_a_serialized_joint_state():
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from benchmarks.bench_ros import header_stamp_ns
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = 12, 345_000_000
    msg.name = ['a']
    assert header_stamp_ns(serialize_message(msg)) == 12_345_000_000


def test_realtime_runs_of_the_iiwa_take_the_demo_experiments_parameters():
    """B3 runs the iiwa under hybrid control on the table and under impedance with the parameters of the
    demo's iiwa_hybrid_line and impedance_push; each run's figures are held to B3's targets."""
    from benchmarks import bench, bench_ros
    from robot_control.tools import demo_experiments
    (_, bridge), (_, controller) = bench_ros.node_commands('iiwa', 'realtime', 'iiwa_hybrid_line')
    start = demo_experiments.get('iiwa_hybrid_line').bridge['initial_positions']
    assert 'law:=hybrid' in controller and 'f_d:=[-10.0]' in controller
    assert f'initial_positions:={[float(v) for v in start]}' in bridge and bridge[-1] == 'real_time_factor:=1.0'
    (_, bridge), (_, controller) = bench_ros.node_commands('iiwa', 'realtime', 'impedance_push')
    assert 'law:=impedance' in controller and 'task_space:=pose' in controller and 'surface.enable:=false' in bridge
    (_, bridge), (_, controller) = bench_ros.node_commands('iiwa', 'realtime')
    assert not any(a.startswith('law:=') for a in controller)
    for run in bench_ros.REALTIME_RUNS:
        assert bench.TARGETS[f'realtime_rtf_{run}'] == bench.TARGETS['realtime_rtf']
    assert bench.verdict('law_us_impedance_7dof_median', 61.0).startswith('MISSED')
