"""`make check-ros2` without a ROS 2 install: what can be checked with no `ros2` command.

The script's refusal without `ros2`, its process handling (a stand-in `ros2` shell script plays
a command that hangs, one that fails, and a daemon left in the command's process group, as
ros2cli leaves it), the parsers on the Jazzy CLI's printed forms, and the order of the checks.
Driving a real `ros2` is `make check-ros2` itself.
"""
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dev import check_ros2
from dev.ros2_cli import CheckFailed, Ros2, parse_rates, parse_response, parse_stamp_ns, parse_value, sourced_env
from robot_control.tools import processes

ROOT = Path(__file__).resolve().parents[2]

# What Jazzy's ros2cli prints (captured from `ros2 topic echo`, `ros2 service call`, `ros2 topic hz`)
ECHO_STAMP = 'sec: 16\nnanosec: 471000000\n---\n'
SETBOOL = ("waiting for service to become available...\nrequester: making request: "
           "std_srvs.srv.SetBool_Request(data=True)\n\nresponse:\n"
           "std_srvs.srv.SetBool_Response(success=True, message='paused at t = 22.143 s')\n\n")
HZ = ('average rate: 2351.693\n\tmin: 0.000s max: 0.006s std dev: 0.00045s window: 2353\n'
      'average rate: 2213.321\n\tmin: 0.000s max: 0.017s std dev: 0.00058s window: 4429\n')

# A stand-in `ros2`: `hang` never ends (and has a child), `fail` exits 3, `daemon start` leaves a
# "daemon" in its own process group and exits, as ros2cli's spawn_daemon does.
FAKE_ROS2 = '''#!/bin/sh
case "$1 $2" in
  "hang ") sleep 1000 & echo "child $!"; wait ;;
  "fail ") echo "Node not found" >&2; exit 3 ;;
  "daemon start") sleep 1000 >/dev/null 2>&1 & echo "$!" > "$DAEMON_PID_FILE"; echo "The daemon has been started" ;;
  "daemon stop") echo "The daemon is not running" ;;
  *) echo "args: $*" ;;
esac
'''


def _gone(pid, timeout=10.0):
    """True once `pid` has exited (a zombie counts as gone) within `timeout` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with open(f'/proc/{pid}/stat') as f:
                if f.read().rsplit(')', 1)[1].split()[0] == 'Z':
                    return True
        except OSError:
            return True
        time.sleep(0.05)
    return False


@pytest.fixture
def fake_ros2(tmp_path):
    """A Ros2 whose `ros2` is FAKE_ROS2; yields it and stops what it started."""
    bin_dir = tmp_path / 'bin'
    bin_dir.mkdir()
    (bin_dir / 'ros2').write_text(FAKE_ROS2)
    (bin_dir / 'ros2').chmod(0o755)
    env = dict(os.environ, PATH=f'{bin_dir}{os.pathsep}{os.environ["PATH"]}',
               DAEMON_PID_FILE=str(tmp_path / 'daemon.pid'))
    with processes.ProcessSet() as procs:
        ros2 = Ros2(env, tmp_path / 'logs', procs)
        try:
            yield ros2
        finally:
            ros2.stop_daemon()


def test_without_ros2_it_says_what_to_do_and_exits_2(tmp_path):
    env = dict(os.environ, PATH=str(tmp_path))       # an empty directory: no ros2
    proc = subprocess.run([sys.executable, '-m', 'dev.check_ros2'], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == check_ros2.EXIT_NO_ROS2 == 2
    assert 'no `ros2` command on PATH' in proc.stderr and '/opt/ros/jazzy/setup.bash' in proc.stderr
    assert proc.stdout == ''


def test_parsers_read_the_cli_output():
    assert parse_stamp_ns(ECHO_STAMP) == 16_471_000_000
    assert parse_response(SETBOOL) == (True, 'paused at t = 22.143 s')
    assert parse_response("std_srvs.srv.Trigger_Response(success=False, message='no')") == (False, 'no')
    assert parse_rates(HZ) == [2351.693, 2213.321]
    assert parse_value('Double value is: 1.5\n') == '1.5'


@pytest.mark.parametrize('parse, text', [(parse_stamp_ns, 'WARNING: topic does not appear to be published yet'),
                                         (parse_response, 'waiting for service to become available...'),
                                         (parse_value, 'Node not found')])
def test_parsers_fail_quoting_what_was_printed(parse, text):
    with pytest.raises(CheckFailed, match=text.split()[0]):
        parse(text)


def test_sourced_env_is_the_environment_after_sourcing(tmp_path):
    setup = tmp_path / 'setup.bash'
    setup.write_text('export AMENT_PREFIX_PATH="/ws/install:$AMENT_PREFIX_PATH"\nexport ROBOT_CONTROL_PROBE="a b"\n')
    env = sourced_env(setup, {'PATH': os.environ['PATH'], 'AMENT_PREFIX_PATH': '/opt/ros/jazzy', 'ROS_DOMAIN_ID': '94'})
    assert env['AMENT_PREFIX_PATH'] == '/ws/install:/opt/ros/jazzy'
    assert env['ROBOT_CONTROL_PROBE'] == 'a b' and env['ROS_DOMAIN_ID'] == '94'
    (tmp_path / 'broken.bash').write_text('exit 4\n')
    with pytest.raises(CheckFailed, match='broken.bash failed'):
        sourced_env(tmp_path / 'broken.bash', {'PATH': os.environ['PATH']})


def test_a_command_that_hangs_is_stopped_with_its_process_group(fake_ros2):
    with pytest.raises(CheckFailed, match=r'`ros2 hang` gave no result within 1 s'):
        fake_ros2.run('hang', timeout=1.0)
    (log,) = fake_ros2.log_dir.glob('*hang.log')
    child = int(log.read_text().split()[1])
    assert _gone(child), f'the hung command left its child {child}'


def test_a_command_that_fails_is_reported_with_its_output(fake_ros2):
    with pytest.raises(CheckFailed, match=r'`ros2 fail` exited with status 3: Node not found'):
        fake_ros2.run('fail')
    assert 'Node not found' in fake_ros2.run('fail', check=False)
    assert fake_ros2.run('param', 'get', '/controller', 'zeta').strip() == 'args: param get /controller zeta'


def test_the_daemon_outlives_each_command_and_stop_daemon_ends_it(fake_ros2, tmp_path):
    assert 'started' in fake_ros2.start_daemon()
    daemon = int((tmp_path / 'daemon.pid').read_text())
    fake_ros2.run('node', 'list')                   # each command's group is stopped after it ...
    assert not _gone(daemon, timeout=0.5)           # ... and the daemon's group is not that group
    fake_ros2.stop_daemon()                         # `daemon stop` leaves it running: its group is signalled
    assert _gone(daemon)


def test_sample_stops_a_never_ending_command_after_its_duration(fake_ros2):
    t0 = time.monotonic()
    out = fake_ros2.sample('hang', duration=0.5)
    assert out.startswith('child ') and _gone(int(out.split()[1]))
    assert 0.5 <= time.monotonic() - t0 < 10.0


class _Session:
    closed = False

    def __init__(self, ros2, share):
        pass

    def close(self):
        _Session.closed = True


def _fail(_session):
    raise CheckFailed('no joint_states within 90 s')


@pytest.mark.parametrize('start_ok', [True, False])
def test_a_session_reports_every_check_and_is_closed(capsys, start_ok):
    report = check_ros2.Report()
    _Session.closed = False
    checks = (('start', (lambda s: 'up') if start_ok else _fail), ('one', lambda s: 'seen'), ('two', _fail))
    check_ros2.run_session(report, _Session, checks, None, None)
    lines = capsys.readouterr().out.splitlines()
    if start_ok:
        assert lines == ['PASS start: up', 'PASS one: seen', 'FAIL two: no joint_states within 90 s']
    else:
        assert lines == ['FAIL start: no joint_states within 90 s', 'FAIL one: not run: start failed',
                         'FAIL two: not run: start failed']
    assert _Session.closed
    assert report.summary() == ('check-ros2: 3 checks, 1 failed: two' if start_ok else
                                'check-ros2: 3 checks, 3 failed: start, one, two')
