"""The demo as a user runs it (`python -m robot_control.demo`), its process handling and its metrics.
The lecture's experiments themselves are in test_experiments.py; the docs generator that tabulates
the demo's summaries is tested in test_docs.py.

Process tests start the demo as a subprocess on a claimed private domain (support.e2e) and check
that every process it started is gone afterwards: after a normal end, after Ctrl-C (SIGINT) and
after SIGTERM. All waits are bounded by deadlines.
"""
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from support.e2e import E2E_DOMAINS
from robot_control import scenarios
from robot_control.tools import bag_tracking, demo, demo_experiments, demo_metrics, processes
from robot_control.tools.processes import DomainClaim
from robot_control.ros.payload_service import answered_text

ROOT = Path(__file__).resolve().parents[2]
SUMMARY_KEYS = ('scenario', 'mode', 'duration_s', 'samples', 'rms_error', 'max_error', 'final_error',
                'steady_state_error', 'settling_time_s', 'force_rms_error', 'saturated_ticks', 'loop_rate_hz',
                'latency_p50_ms', 'latency_p99_ms')


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is gone for our purpose
        with open(f'/proc/{pid}/stat') as f:
            return f.read().split(')')[-1].split()[0] != 'Z'
    except OSError:
        return False


def _wait_gone(pids, timeout=15.0):
    deadline = time.monotonic() + timeout
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    return [p for p in pids if _alive(p)]


def _child_pids(text):
    m = re.search(r'started sim_bridge \(pid (\d+)\) and controller \(pid (\d+)\)', text)
    return [int(m.group(1)), int(m.group(2))] if m else []


class DemoProcess:
    """`python -m robot_control.demo ...` in its own session, output collected line by line."""

    def __init__(self, args, domain_id):
        self.proc = subprocess.Popen([sys.executable, '-m', 'robot_control.demo', '--domain-id', str(domain_id),
                                      *args], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, start_new_session=True)
        os.set_blocking(self.proc.stdout.fileno(), False)
        self.out = ''

    def read(self):
        try:
            chunk = self.proc.stdout.read()
        except (TypeError, OSError):
            chunk = None
        if chunk:
            self.out += chunk
        return self.out

    def wait_for(self, pattern, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if re.search(pattern, self.read()):
                return True
            if self.proc.poll() is not None:
                return bool(re.search(pattern, self.read()))
            time.sleep(0.05)
        return False

    def wait(self, timeout):
        deadline = time.monotonic() + timeout
        while self.proc.poll() is None and time.monotonic() < deadline:
            self.read()
            time.sleep(0.05)
        self.read()
        return self.proc.poll()

    def kill(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=10)


@pytest.fixture
def domain():
    with DomainClaim(E2E_DOMAINS, start=5) as claim:
        yield claim.domain_id


# -- the command line, end to end --------------------------------------------------------------------
def test_demo_command_writes_summary_plot_and_bag_and_stops_its_processes(tmp_path, domain):
    out = tmp_path / 'single_link'
    p = DemoProcess(['--scenario', 'single_link', '--duration', '0.8', '--out', str(out)], domain)
    try:
        code = p.wait(240.0)
    finally:
        p.kill()
    text = p.read()
    assert code == 0, text
    assert re.search(r'^\s+t = \s*\d+\.\d+ s .*ticks/s', text, re.M) or 'running 0.8 s' in text  # progress
    assert 'RMS error' in text and 'settling time' in text                              # the summary table
    pids = _child_pids(text)
    assert len(pids) == 2 and not _wait_gone(pids, 5.0)
    summary = json.loads((out / 'summary.json').read_text())
    for key in SUMMARY_KEYS:
        assert key in summary, key
    assert summary['scenario'] == 'single_link' and summary['mode'] == 'lockstep'
    assert summary['duration_s'] == 0.8 and summary['expected_ticks'] == 801
    assert summary['samples'] >= 0.8 * 801
    assert set(summary['rms_error']) == {'theta'} and summary['units'] == {'theta': 'rad'}
    assert summary['loop_rate_hz'] > 0 and 0 < summary['latency_p50_ms'] <= summary['latency_p99_ms']
    assert summary['domain_id'] == domain
    assert (out / 'tracking.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    meta = (out / 'bag' / 'metadata.yaml').read_text()
    assert 'version: 9' in meta and 'storage_identifier: mcap' in meta
    # the recorder's bag plots as the run did: the joint, its reference and error, the applied torque
    plot = bag_tracking.tracking_data(out / 'bag')
    assert plot['scenario'] == 'single_link' and plot['joint_names'] == ['theta'] and plot['units'] == ['rad']
    assert plot['t'].size >= summary['samples'] and np.isfinite(plot['q_d']).sum() >= summary['samples']
    assert np.nanmax(np.abs(plot['e'][:, 0])) == pytest.approx(summary['max_error']['theta'], rel=1e-9)
    assert (out / 'logs' / 'sim_bridge.log').is_file() and (out / 'logs' / 'controller.log').is_file()


@pytest.mark.parametrize('sig,code', [(signal.SIGINT, 130), (signal.SIGTERM, 130)])
def test_demo_stops_every_process_on_a_signal(tmp_path, domain, sig, code):
    p = DemoProcess(['--scenario', 'polar_two_link', '--duration', '600', '--no-plot', '--out',
                     str(tmp_path / 'run')], domain)
    try:
        assert p.wait_for(r'running 600 s of simulation', 120.0), p.read()
        pids = _child_pids(p.read())
        assert len(pids) == 2 and all(_alive(q) for q in pids)
        os.kill(p.proc.pid, sig)
        assert p.wait(30.0) == code, p.read()
    finally:
        p.kill()          # its children die with it (processes.die_with_parent)
    assert 'interrupted' in p.read()
    assert not _wait_gone(pids, 5.0), 'a child of the demo survived it'


def test_the_children_die_with_a_killed_demo(tmp_path, domain):
    """SIGKILL runs no `finally`: the bridge and the controller (each in a session of its own) are
    killed by the kernel with the demo (PR_SET_PDEATHSIG) instead of running on in its domain."""
    p = DemoProcess(['--scenario', 'polar_two_link', '--duration', '600', '--no-plot', '--no-record', '--out',
                     str(tmp_path / 'run')], domain)
    pids = []
    try:
        assert p.wait_for(r'running 600 s of simulation', 120.0), p.read()
        pids = _child_pids(p.read())
        assert len(pids) == 2 and all(_alive(q) for q in pids)
        os.kill(p.proc.pid, signal.SIGKILL)          # the demo alone, not its process group
        assert p.wait(10.0) == -signal.SIGKILL
        assert not _wait_gone(pids, 5.0), 'a child of the demo survived its SIGKILL'
    finally:
        p.kill()
        for q in pids:                              # only if the test failed: still one of the demo's nodes
            if _alive(q) and _is_node(q):
                os.kill(q, signal.SIGKILL)


def _is_node(pid):
    """True when process `pid` runs the bridge or the controller node (not a reused pid)."""
    try:
        cmdline = Path(f'/proc/{pid}/cmdline').read_bytes()
    except OSError:
        return False
    return b'sim_bridge.bridge_node' in cmdline or b'robot_control.ros.controller_node' in cmdline


# -- process management ------------------------------------------------------------------------------
@pytest.mark.filterwarnings('ignore::pytest.PytestUnraisableExceptionWarning')   # the swallowed one, on purpose
def test_a_signal_whose_exception_a_finalizer_swallowed_still_interrupts():
    """Python drops an exception raised inside __del__ (an rclpy Future's, say): the demo then ran on
    after a SIGTERM. The handler also remembers the signal, and the polling loops raise it again."""
    class Finalized:
        def __del__(self):
            signal.raise_signal(signal.SIGTERM)
            for _ in range(1000):     # the handler runs here, and its Interrupted goes nowhere
                pass

    old = processes.install_signal_handlers()
    try:
        processes.check_interrupted()          # nothing received yet
        Finalized()
        with pytest.raises(processes.Interrupted, match='SIGTERM'):
            processes.check_interrupted()
    finally:
        processes.restore_signal_handlers(old)
    processes.check_interrupted()              # restored: forgotten


def test_a_process_that_hangs_after_a_signal_is_ended_with_its_children(tmp_path):
    """The interruption lands where nothing polls and the code waits on (here: it is caught and ignored):
    force_exit_after s after SIGTERM the stacks are printed, the child is stopped and the exit status is 130.
    The pid is printed inside the `try`, so the SIGTERM sent after reading it always lands where it is caught."""
    script = ('import sys, time\n'
              'from robot_control.tools import processes\n'
              'processes.install_signal_handlers(force_exit_after=1.0)\n'
              'child = processes.ProcessSet().start("sleeper", [sys.executable, "-c", "import time; time.sleep(600)"],'
              ' dict(__import__("os").environ), sys.argv[1])\n'
              'ready = False\n'
              'while True:\n'
              '    try:\n'
              '        if not ready:\n'
              '            ready = True\n'
              '            print("child", child.pid, flush=True)\n'
              '        time.sleep(600)\n'
              '    except KeyboardInterrupt:\n'
              '        pass\n')
    p = subprocess.Popen([sys.executable, '-c', script, str(tmp_path / 'sleeper.log')], cwd=ROOT, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        child = int(p.stdout.readline().split()[1])
        assert _alive(child)
        t0 = time.monotonic()
        os.kill(p.pid, signal.SIGTERM)
        assert p.wait(timeout=20) == 130
        took = time.monotonic() - t0
        out = p.stdout.read()
        assert 1.0 <= took < 15.0 and 'still running 1 s after SIGTERM' in out and 'Thread' in out, out
        assert not _alive(child)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=10)


def test_managed_process_escalates_to_sigkill_and_reports_death(tmp_path):
    stubborn = ('import signal, time\n'
                'signal.signal(signal.SIGINT, signal.SIG_IGN)\n'
                'signal.signal(signal.SIGTERM, signal.SIG_IGN)\n'
                'print("ready", flush=True)\n'
                'time.sleep(600)\n')
    p = processes.ManagedProcess('stubborn', [sys.executable, '-c', stubborn], dict(os.environ),
                                  tmp_path / 'stubborn.log').start()
    try:
        deadline = time.monotonic() + 30
        while 'ready' not in p.log_tail() and time.monotonic() < deadline:
            time.sleep(0.05)
        p.check_alive()
        code = p.stop(waits=(0.5, 0.5, 5.0))
    finally:
        if p.running():
            os.killpg(p.pid, signal.SIGKILL)
    assert code == -signal.SIGKILL and p.stop_signal == signal.SIGKILL and not p.running()
    dead = processes.ManagedProcess('dies', [sys.executable, '-c', 'print("bye"); raise SystemExit(3)'],
                                     dict(os.environ), tmp_path / 'dies.log').start()
    dead.proc.wait(timeout=30)
    with pytest.raises(processes.ProcessError, match=r'(?s)dies \(pid \d+\) exited with status 3.*bye'):
        dead.check_alive()
    dead.stop()


def test_ros_env_keeps_dds_on_this_machine():
    env = processes.ros_env(77, {'ROS_DOMAIN_ID': '0', 'ROS_STATIC_PEERS': '10.0.0.2', 'PATH': '/bin'})
    assert env['ROS_DOMAIN_ID'] == '77' and env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert 'ROS_STATIC_PEERS' not in env and env['PATH'] == '/bin'
    with pytest.raises(ValueError, match='^domain_id'):
        processes.ros_env(300)


def test_private_domains_are_claimed_from_the_top_of_ros_safe_range(tmp_path):
    """Demo and bench runs take 101, 100, ... (ROS's Linux-safe 0..101, clear of the tests' 1..92)."""
    ids = processes.PRIVATE_DOMAIN_IDS
    assert max(ids) == 101 and min(ids) >= 1 and list(ids) == sorted(ids, reverse=True)
    with processes.private_domain(directory=tmp_path) as a, processes.private_domain(directory=tmp_path) as b:
        assert (a.domain_id, b.domain_id) == (101, 100)


def test_domain_claims_are_exclusive(tmp_path):
    with DomainClaim([5, 6], directory=tmp_path) as a, DomainClaim([5, 6], directory=tmp_path) as b:
        assert {a.domain_id, b.domain_id} == {5, 6}
        with pytest.raises(TimeoutError, match='^domain_id'):
            DomainClaim([5, 6], directory=tmp_path, timeout=0.0).acquire()
    with DomainClaim([5, 6], directory=tmp_path) as c:
        assert c.domain_id == 5


def test_node_command_lines_use_the_scenario_file_and_typed_overrides():
    argv = demo.node_argv('sim_bridge.bridge_node', 'force_1dof',
                          {'mode': 'lockstep', 'initial_positions': [0.1], 'surface.enable': False,
                           'disturbance.joint_torque': [-2]}, demo.BRIDGE_ARGS)
    assert argv[:3] == [sys.executable, '-m', 'sim_bridge.bridge_node']
    i = argv.index('--ros-args')
    assert argv[i + 1] == '--params-file' and argv[i + 2].endswith('config/force_1dof.yaml')
    assert Path(argv[i + 2]).is_file()
    overrides = [argv[k + 1] for k in range(i, len(argv)) if argv[k] == '-p']
    assert overrides == ['mode:=lockstep', 'initial_positions:=[0.1]', 'surface.enable:=false',
                         'disturbance.joint_torque:=[-2.0]']
    with pytest.raises(ValueError, match='^scenario'):
        demo.config_path('no_such_scenario')


# -- experiments and metrics (no DDS) ----------------------------------------------------------------
def test_every_scenario_has_an_experiment_with_valid_references():
    from robot_control import scenarios
    from robot_control.trajectory import from_points
    assert set(demo_experiments.DEFAULT_FOR_SCENARIO) == set(scenarios.SCENARIOS)
    for name in demo_experiments.EXPERIMENTS:
        exp = demo_experiments.get(name)
        assert exp.scenario in scenarios.SCENARIOS and exp.duration > 0
        assert demo.config_path(exp.scenario).is_file()
        spec = exp.trajectory
        if spec is not None:
            n = len(exp.joints)
            start = (np.array(exp.bridge.get('initial_positions', scenarios.get(exp.scenario).q0)), None, None)
            traj = from_points(spec.t_start, start, spec.times, spec.positions, spec.velocities, spec.accelerations)
            assert traj.n == n and traj.t0 == spec.t_start
        if exp.law in ('force', 'hybrid'):
            assert exp.force is not None and len(exp.force) == len(scenarios.get(exp.scenario).force_axes)
    assert demo_experiments.output_name('polar_step') == 'polar_two_link'
    assert demo_experiments.output_name('iiwa') == 'iiwa'
    assert demo_experiments.output_name('disturbance_pd') == 'disturbance_pd'
    with pytest.raises(ValueError, match='^experiment'):
        demo_experiments.get('nope')


@pytest.mark.parametrize('name,line', [('iiwa_hybrid_line', demo_experiments.IIWA_LINE),
                                       ('panda_hybrid_line', demo_experiments.PANDA_LINE)])
def test_hybrid_line_references_keep_the_tip_on_the_table(name, line):
    model = line.model()
    exp = demo_experiments.get(name)
    assert exp.scenario == line.scenario and line.z == scenarios.get(line.scenario).surface.x_e
    start = np.array(exp.bridge['initial_positions'])
    assert np.allclose(model.fk(start), [*line.start, line.z], atol=1e-9)
    tips = np.array([model.fk(np.array(q)) for q in exp.trajectory.positions])
    assert np.allclose(tips[:, 2], line.z, atol=1e-9)
    assert np.allclose(tips[:, 0], line.start[0], atol=1e-9)
    assert tips[-1, 1] - line.start[1] == pytest.approx(line.length, abs=1e-9)
    lower, upper = model.position_limits
    assert np.all((np.array(exp.trajectory.positions) > lower) & (np.array(exp.trajectory.positions) < upper))


def test_iiwa_pose_references_hold_the_tool_vertical_and_turn_the_wrist_on_the_circle():
    """The pose-space references: the line keeps the tool at IIWA_DOWN on the table; the circle has radius
    IIWA_CIRCLE and turns the wrist out to IIWA_WRIST about world z; the velocities are the positions'
    derivatives (J qd matches the task path's central difference)."""
    import pinocchio as pin
    model = demo_experiments.IIWA_LINE.model('pose')
    line = demo_experiments.get('iiwa_hybrid_vertical')
    down = pin.exp3(np.array(demo_experiments.IIWA_DOWN))
    for q in (line.bridge['initial_positions'], *line.trajectory.positions):
        x = model.fk(np.array(q))
        assert x[2] == pytest.approx(demo_experiments.IIWA_LINE.z, abs=1e-9)
        assert np.linalg.norm(pin.log3(pin.exp3(x[3:]) @ down.T)) < 1e-9
    spec = demo_experiments.get('pose_tracking').trajectory
    x = np.array([model.fk(np.array(q)) for q in spec.positions])
    start = model.fk(np.array(demo_experiments.IIWA_POSTURE))
    centre = start[:3] - (demo_experiments.IIWA_CIRCLE, 0.0, 0.0)
    assert np.allclose(np.linalg.norm(x[:, :3] - centre, axis=1), demo_experiments.IIWA_CIRCLE, atol=1e-9)
    assert np.allclose(x[:, 2], start[2], atol=1e-9) and np.allclose(x[-1], start, atol=1e-9)
    turns = [pin.log3(pin.exp3(r) @ pin.exp3(start[3:]).T) for r in x[:, 3:]]
    assert np.allclose(np.array(turns)[:, :2], 0.0, atol=1e-9)
    assert max(t[2] for t in turns) == pytest.approx(demo_experiments.IIWA_WRIST, abs=1e-6)
    dt = spec.times[1] - spec.times[0]
    for k in range(1, len(spec.times) - 1, 25):
        q, qd = np.array(spec.positions[k]), np.array(spec.velocities[k])
        rate = model.task_difference(x[k + 1], x[k - 1]) / (2 * dt)
        assert np.allclose(model.J(q) @ qd, rate, atol=2e-3 * max(1.0, np.abs(rate).max()))


def test_settling_time_of_the_critically_damped_step():
    t = np.arange(0.0, 3.0, 0.001)
    e = demo_metrics.critically_damped(t, 0.5, 6.0)
    assert demo_metrics.settling_time(t, e, 0.0, e_final=0.0) == pytest.approx(5.834 / 6.0, abs=2e-3)
    assert demo_metrics.settling_time(t, np.zeros_like(t), 0.0) == 0.0
    assert demo_metrics.settling_time(t, np.sin(t * 50), 0.0, e_final=0.0) is None   # never settles


def _synthetic_run(law='computed_torque'):
    t = np.arange(0, 1001) * 0.001
    e = np.stack([demo_metrics.critically_damped(t, 0.2, 6.0), np.zeros_like(t)], axis=1)
    q_d = np.tile([0.2, 0.5], (t.size, 1))
    return demo_metrics.RunData(
        t=t, joints=('theta1', 'r'), joint_units=('rad', 'm'), q=q_d - e, qd=np.zeros_like(e),
        tau_applied=np.zeros_like(e), tau_cmd=np.where(t[:, None] < 0.01, 200.0, 1.0) * np.ones_like(e),
        ref_names=('theta1', 'r'), ref_pos=q_d, ref_vel=np.zeros_like(e), ref_acc=np.zeros_like(e), err_pos=e,
        err_vel=np.zeros_like(e), force_xyz=np.zeros((t.size, 3)), force_axes=(), force_axis_index=(), law=law,
        effort_limit=[200.0, 200.0], state_wall_ns=np.arange(t.size) * 2_000_000,
        cmd_wall_ns=np.arange(t.size) * 2_000_000 + 500_000)


def test_summary_metrics_on_a_synthetic_run():
    exp = demo_experiments.get('polar_step')
    s = demo_metrics.summarize(_synthetic_run(), exp, 'lockstep', 1.0)
    for key in SUMMARY_KEYS:
        assert key in s
    e = demo_metrics.critically_damped(np.arange(0, 1001) * 0.001, 0.2, 6.0)
    assert s['rms_error']['theta1'] == pytest.approx(np.sqrt(np.mean(e ** 2)))
    assert s['max_error'] == {'theta1': 0.2, 'r': 0.0}
    assert s['final_error']['theta1'] == pytest.approx(e[-1])
    assert s['saturated_ticks'] == 10
    assert s['loop_rate_hz'] == pytest.approx(500.0)
    assert s['latency_p50_ms'] == pytest.approx(0.5) and s['latency_p99_ms'] == pytest.approx(0.5)
    assert s['units'] == {'theta1': 'rad', 'r': 'm'}
    json.dumps(s, allow_nan=False)
    text = demo_metrics.format_summary(s)
    assert 'theta1' in text and 'rad' in text and 'saturated ticks' in text


def test_push_figures_on_a_synthetic_response():
    """A 10 mm step down along z while pushed, back with an overshoot of 0.1 mm (0.5-1 s after the release);
    x moves 1 mm during the push's onset only; a rotation error of 2 mrad."""
    exp = demo_experiments.get('impedance_push')
    t = np.arange(0, 3501) * 0.001
    on, off = 0.502, 2.003
    dz = np.where((t >= on) & (t < off), -0.01 * (1 - np.exp(-(t - on) * 30)), 0.0)
    dz = np.where(t >= off, -0.01 * np.exp(-(t - off) * 30) + 1e-4 * np.sin(np.pi * np.clip(t - off - 0.5, 0, 0.5) / 0.5),
                  dz)
    e = np.zeros((t.size, 6))
    e[:, 2] = -dz
    e[:, 0] = np.where((t > on) & (t < on + 0.1), 1e-3, 0.0)
    e[:, 4] = np.where((t > on) & (t < on + 0.1), 2e-3, 0.0)
    run = demo_metrics.RunData(
        t=t, joints=('a',), joint_units=('rad',), q=np.zeros((t.size, 1)), qd=np.zeros((t.size, 1)),
        tau_applied=np.zeros((t.size, 1)), tau_cmd=np.zeros((t.size, 1)), ref_names=('x', 'y', 'z', 'rx', 'ry', 'rz'),
        ref_pos=np.zeros_like(e), ref_vel=np.zeros_like(e), ref_acc=np.zeros_like(e), err_pos=e,
        err_vel=np.zeros_like(e), force_xyz=np.zeros((t.size, 3)), force_axes=(), force_axis_index=(), law='impedance')
    run.events = [{'t': 0.5, 't_applied': on, 'parameters': {}}, {'t': 2.0, 't_applied': off, 'parameters': {}}]
    fig = demo_metrics.summarize(run, exp, 'lockstep', 3.5)['figures']
    assert fig['push_deflection_m'] == pytest.approx(-0.01, rel=1e-6)
    assert fig['push_other_axes_m'] == 0.0 and fig['push_other_axes_peak_m'] == pytest.approx(1e-3)
    assert fig['push_rotation_max_rad'] == pytest.approx(2e-3)
    assert fig['push_return_overshoot'] == pytest.approx(0.01, rel=1e-3)
    assert (fig['push_on_s'], fig['push_off_s']) == (on, off)
    run.events = []                 # no push recorded: no figures
    assert demo_metrics.summarize(run, exp, 'lockstep', 3.5)['figures'] == {}


class _FakeLive:
    """A LiveRun's side the schedule uses: it records the calls."""

    def __init__(self, paused_ns=1_000_000_000 + 503_000_000):
        self.calls = []
        self.control = self.collector = self
        self.log = []
        self.paused_ns = paused_ns

    def pause(self):
        self.calls.append('pause')

    def paused_at(self):
        self.calls.append('paused_at')
        return self.paused_ns

    def set_bridge_parameters(self, values, poll=None):
        self.calls.append(('set', values))

    def resume(self):
        self.calls.append('resume')

    def send_force(self, axes, values, stamp_ns):
        self.calls.append(('force', dict(zip(axes, values)), stamp_ns))

    def call_trigger(self, service, poll=None):
        self.calls.append(('call', service))
        self.log.append(('controller', 20, 'started'))
        return self

    def controller_said(self, text, since=0):
        return next((i for i, (_, _, m) in enumerate(self.log[since:], since) if text in m), None)

    def spin_until(self, predicate, timeout, poll=None, what=''):
        self.calls.append(('wait', what))
        assert predicate()

    def done(self):            # the call's future: answered once the bridge has run on
        self.answered_ns = self.paused_ns + 12_000_000_000    # the service's work moved the simulation on
        return self.calls[-1][0] == 'wait' and self.calls[-1][1].endswith('to answer')

    def result(self):
        return self

    success, message = True, 'done'

    def last_stamp_ns(self):
        return self.answered_ns

    def get_parameters(self, node_name, names, poll=None):
        self.calls.append(('get', node_name, tuple(names)))
        return {name: 1.0 for name in names}

    def alive(self):
        pass


def test_bridge_parameter_changes_arm_pause_at_then_set_and_resume_when_due():
    """The bridge's pause_at is armed for the first change (origin 1 s + 0.5 s), set with each change for the
    next one (1 s + 2 s), and disarmed (-1) with the last."""
    push = {'disturbance.cartesian_force': [0.0, 0.0, -10.0]}
    schedule = demo.Schedule(((2.0, {}), (0.5, push)), 1_000_000_000, lambda *a, **k: None)
    live = _FakeLive()
    schedule.arm(live)
    assert live.calls == [('set', {'pause_at': 1.5})]
    schedule.send_due(live, 1_000_000_000 + 499_000_000)
    assert len(live.calls) == 1 and schedule.applied == []
    schedule.send_due(live, 1_000_000_000 + 501_000_000)
    assert live.calls[1:] == ['pause', 'paused_at', ('set', {**push, 'pause_at': 3.0}), 'resume']
    assert schedule.applied == [{'t': 0.5, 't_applied': 0.503, 'parameters': push}]
    live.paused_ns = 3_000_000_000
    schedule.send_due(live, 3_000_000_000)
    assert live.calls[-2] == ('set', {'pause_at': -1.0}) and len(schedule.applied) == 2
    empty = _FakeLive()
    demo.Schedule((), 0, lambda *a, **k: None).arm(empty)
    assert empty.calls == []


def test_force_references_are_sent_while_the_bridge_stands_before_their_time():
    """The first force reference goes out before the run starts (origin 1 s), stamped with its time; the next at a
    pause the bridge makes itself at the midpoint (1 s + 3 s), and a parameter change at the same time follows it
    at that pause."""
    push = {'disturbance.joint_torque': [1.0]}
    schedule = demo.Schedule(((3.0, push),), 1_000_000_000, lambda *a, **k: None, ((4.0, (15.0,)), (2.0, (5.0,))),
                             ('z',))
    live = _FakeLive(paused_ns=4_000_000_000)
    schedule.arm(live)
    assert live.calls == [('force', {'z': 5.0}, 3_000_000_000), ('set', {'pause_at': 4.0})]
    schedule.send_due(live, 3_999_000_000)
    assert len(live.calls) == 2
    schedule.send_due(live, 4_000_000_000)
    assert live.calls[2:] == ['pause', 'paused_at', ('force', {'z': 15.0}, 5_000_000_000),
                              ('set', {**push, 'pause_at': -1.0}), 'resume']


def test_a_service_call_runs_the_bridge_until_it_answers_then_arms_the_next_change():
    """A call due at 1 s + 2 s: pause_at disarmed, the call made, the bridge resumed once the controller has logged
    that it started, the call answered 12 s later, the controller's parameters read, pause_at armed for the parameter change at 1 s + 3 s (past already: made at the
    next send_due)."""
    change = {'disturbance.joint_torque': [1.0]}
    schedule = demo.Schedule(((3.0, change),), 1_000_000_000, lambda *a, **k: None,
                             calls=((2.0, '/controller/identify_payload', 'started', ('payload.mass',)),))
    live = _FakeLive(paused_ns=3_000_000_000)
    schedule.arm(live)
    assert live.calls == [('set', {'pause_at': 3.0})]
    schedule.send_due(live, 3_000_000_000)
    assert live.calls[1:] == ['pause', 'paused_at', ('set', {'pause_at': -1.0}), ('call', '/controller/identify_payload'),
                              ('wait', 'the controller to start /controller/identify_payload'), 'resume',
                              ('wait', '/controller/identify_payload to answer'), ('get', 'controller', ('payload.mass',)),
                              ('set', {'pause_at': 4.0}), 'resume']
    assert schedule.calls == [{'t': 2.0, 't_called': 2.0, 't_answered': 14.0, 'service': '/controller/identify_payload',
                               'success': True, 'message': 'done', 'parameters': {'payload.mass': 1.0}}]
    live.paused_ns = 15_000_000_000
    schedule.send_due(live, 15_000_000_000)
    assert schedule.applied == [{'t': 3.0, 't_applied': 14.0, 'parameters': change}]


def test_a_call_answered_with_its_tick_is_timed_by_that_tick_not_by_when_the_answer_arrived():
    """An answer naming the joint state it was reached at (payload_service.answered_text: 9.5 s) is timed by it,
    8.5 s after the origin at 1 s, though the bridge ran on to 15 s while the answer travelled."""
    schedule = demo.Schedule((), 1_000_000_000, lambda *a, **k: None,
                             calls=((2.0, '/controller/identify_payload', 'started', ()),))
    live = _FakeLive(paused_ns=3_000_000_000)
    live.message = answered_text('mass 2.0000 kg', 9_500_000_000)
    schedule.arm(live)
    schedule.send_due(live, 3_000_000_000)
    assert live.last_stamp_ns() == 15_000_000_000
    assert schedule.calls[0]['t_answered'] == 8.5 and schedule.calls[0]['message'] == live.message


def test_lost_ticks_are_reported_as_time_ranges():
    assert demo.time_ranges([]) == []
    assert demo.time_ranges([0.679, 0.68, 0.681, 0.9, 0.901, 1.5]) == [[0.679, 0.681], [0.9, 0.901], [1.5, 1.5]]


def test_an_interrupt_inside_a_c_extension_still_counts_as_an_interrupt():
    try:
        try:
            raise processes.Interrupted('signal SIGTERM')
        except KeyboardInterrupt as exc:
            raise TypeError('Unable to convert function return value to a Python type!') from exc
    except TypeError as exc:
        assert str(demo.interrupted(exc)) == 'signal SIGTERM'
    assert demo.interrupted(RuntimeError('x')) is None
    assert demo.interrupted(KeyboardInterrupt()) == 'Ctrl-C'
