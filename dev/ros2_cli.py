"""The `ros2` command line driven from Python, as a user types it: each call a child process in a
process group of its own (robot_control.tools.processes), bounded by a timeout, its output
(stdout and stderr together) kept in a log file and returned as text.

The parsers read the CLI's own printed forms (Jazzy's ros2cli):
    ros2 topic echo --once --field header.stamp T   ->  'sec: 16\\nnanosec: 471000000\\n---'
    ros2 service call S std_srvs/srv/Trigger        ->  '... Trigger_Response(success=True, message='...')'
    ros2 topic hz T                                 ->  'average rate: 2351.693\\n\\tmin: ...'
    ros2 param get N p                              ->  'Double value is: 1.0'
"""
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

from robot_control.tools.processes import ManagedProcess
from robot_control.units import stamp_ns

#: s a one-shot command (topic echo, param get, service call, ...) may take
COMMAND_TIMEOUT = 30.0

_STAMP = re.compile(r'^sec:\s*(-?\d+)\s*\nnanosec:\s*(\d+)', re.MULTILINE)
_RESPONSE = re.compile(r"_Response\(success=(True|False), message=(['\"])(.*?)\2\)", re.DOTALL)
_RATE = re.compile(r'^average rate:\s*([0-9.]+)', re.MULTILINE)
_VALUE = re.compile(r'^\w+ value is: (.*)$', re.MULTILINE)


class CheckFailed(Exception):
    """Why a check failed: printed after 'FAIL <check>: '."""


def parse_stamp_ns(text):
    """Integer ns of the first header.stamp printed by `ros2 topic echo --field header.stamp`."""
    m = _STAMP.search(text)
    if m is None:
        raise CheckFailed(f'no header.stamp in the echoed message: {tail(text)}')
    return stamp_ns(int(m.group(1)), int(m.group(2)))


def parse_response(text):
    """(success, message) of a std_srvs Trigger or SetBool response printed by `ros2 service call`."""
    m = _RESPONSE.search(text)
    if m is None:
        raise CheckFailed(f'no response printed: {tail(text)}')
    return m.group(1) == 'True', m.group(3)


def parse_rates(text):
    """Every 'average rate' (messages per second) printed by `ros2 topic hz`, in order."""
    return [float(r) for r in _RATE.findall(text)]


def parse_value(text):
    """The value printed by `ros2 param get` ('Double value is: 1.0' -> '1.0')."""
    m = _VALUE.search(text)
    if m is None:
        raise CheckFailed(f'no parameter value printed: {tail(text)}')
    return m.group(1).strip()


def tail(text, lines=4):
    """The last non-empty `lines` lines of `text`, joined with ' | ' (for one-line reasons)."""
    kept = [line.strip() for line in text.splitlines() if line.strip()]
    return ' | '.join(kept[-lines:]) or '(no output)'


def sourced_env(setup_bash, base):
    """The environment after `source setup_bash` in bash, starting from `base` (a dict)."""
    proc = subprocess.run(['bash', '-c', 'source "$1" >/dev/null 2>&1 && env -0', 'bash', str(setup_bash)],
                          env=base, capture_output=True, timeout=60)
    if proc.returncode != 0:
        raise CheckFailed(f'sourcing {setup_bash} failed ({proc.returncode}): {tail(proc.stderr.decode())}')
    return dict(item.split('=', 1) for item in proc.stdout.decode().split('\0') if '=' in item)


def run_to_end(name, argv, env, log_path, timeout, cwd=None):
    """Run `argv` in a process group of its own, output to `log_path`; (exit status, output).
    CheckFailed when it takes longer than `timeout` s; the group is stopped in every case."""
    p = ManagedProcess(name, argv, env, log_path, cwd=cwd).start()
    try:
        p.proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        raise CheckFailed(f'`{name}` gave no result within {timeout:g} s: {tail(p.log_tail())}') from None
    finally:
        p.stop()
    return p.returncode, p.log_path.read_text(errors='replace')


class Ros2:
    """`ros2 ...` in environment `env`; logs in `log_dir`; long-running children join `procs`
    (a processes.ProcessSet, whose stop_all() ends them)."""

    def __init__(self, env, log_dir, procs):
        self.env = env
        self.log_dir = Path(log_dir)
        self.procs = procs
        self._count = 0
        self.daemon_group = None    # process group of the daemon start_daemon() spawned

    def _log_path(self, args):
        self._count += 1
        words = [a for a in args[:3] if re.fullmatch(r'[\w.:-]+', a)]
        return self.log_dir / f'{self._count:02d}-{"-".join(words)}.log'

    def run(self, *args, timeout=COMMAND_TIMEOUT, check=True):
        """Run `ros2 args...` to its end and return its output. CheckFailed when it takes longer
        than `timeout` s (it is stopped) or, with `check`, when it exits non-zero."""
        command = 'ros2 ' + ' '.join(args)
        status, out = run_to_end(command, ['ros2', *args], self.env, self._log_path(args), timeout)
        if check and status != 0:
            raise CheckFailed(f'`{command}` exited with status {status}: {tail(out)}')
        return out

    def sample(self, *args, duration):
        """Run a command that never ends by itself (`ros2 topic hz`) for `duration` s, stop it as
        Ctrl-C does, and return its output."""
        command = 'ros2 ' + ' '.join(args)
        p = ManagedProcess(command, ['ros2', *args], self.env, self._log_path(args)).start()
        try:
            p.proc.wait(timeout=duration)
            raise CheckFailed(f'`{command}` ended early with status {p.returncode}: {tail(p.log_tail())}')
        except subprocess.TimeoutExpired:
            pass
        finally:
            p.stop()
        return p.log_path.read_text(errors='replace')

    def start(self, *args):
        """Start a long-running `ros2 args...` (launch, run); returns its ManagedProcess."""
        return self.procs.start('ros2 ' + ' '.join(args), ['ros2', *args], self.env, self._log_path(args))

    def stamp_ns(self, topic, msg_type='sensor_msgs/msg/JointState', timeout=COMMAND_TIMEOUT):
        """header.stamp (int ns) of the next message on `topic`."""
        return parse_stamp_ns(self.run('topic', 'echo', '--once', '--field', 'header.stamp', topic, msg_type,
                                       timeout=timeout))

    def call(self, service, srv_type, request='{}'):
        """The response's message of one `ros2 service call` (std_srvs Trigger or SetBool);
        CheckFailed when it answers success=False."""
        success, message = parse_response(self.run('service', 'call', service, srv_type, request))
        if not success:
            raise CheckFailed(f'{service} answered success=False: {message}')
        return message

    def start_daemon(self, timeout=COMMAND_TIMEOUT):
        """`ros2 daemon start`, leaving the daemon in a process group of its own.

        ros2cli spawns its daemon inside the process group of the command that needed it, so the
        group cleanup of that command would kill it. Started here, it stays in the group of this
        `ros2 daemon start` (session leader, then gone), which nothing else signals, until
        stop_daemon(). Returns the output.
        """
        log = self._log_path(('daemon', 'start'))
        log.parent.mkdir(parents=True, exist_ok=True)
        with open(log, 'wb') as f:
            proc = subprocess.Popen(['ros2', 'daemon', 'start'], env=self.env, stdin=subprocess.DEVNULL, stdout=f,
                                    stderr=subprocess.STDOUT, start_new_session=True)
        self.daemon_group = proc.pid
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.stop_daemon()      # signals the group, this command included
            proc.wait()
            raise CheckFailed(f'`ros2 daemon start` gave no result within {timeout:g} s') from None
        out = log.read_text(errors='replace')
        if proc.returncode != 0:
            raise CheckFailed(f'`ros2 daemon start` exited with status {proc.returncode}: {tail(out)}')
        return out

    def stop_daemon(self, wait=5.0):
        """`ros2 daemon stop`; whatever is left of the daemon's process group is then signalled
        (SIGTERM, SIGKILL). Returns what `ros2 daemon stop` printed."""
        out = self.run('daemon', 'stop', check=False)
        group, self.daemon_group = self.daemon_group, None
        if group is not None:
            deadline = time.monotonic() + wait
            for sig in (None, signal.SIGTERM, signal.SIGKILL):
                if sig is not None:
                    _signal_group(group, sig)
                while _group_alive(group) and time.monotonic() < deadline:
                    time.sleep(0.1)
                if not _group_alive(group):
                    break
                deadline = time.monotonic() + 2.0
        return out

    def names(self, *args):
        """The lines `ros2 args...` prints, as a list (node list, topic list, lifecycle nodes)."""
        return self.run(*args).split()


def _group_alive(pgid):
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _signal_group(pgid, sig):
    try:
        os.killpg(pgid, sig)
    except ProcessLookupError:
        pass


def colcon_command():
    """colcon of the PATH (a Jazzy install's, as users build), else the one beside this Python."""
    import shutil
    found = shutil.which('colcon') or shutil.which('colcon', path=os.path.dirname(sys.executable))
    if found is None:
        raise CheckFailed('no colcon on PATH nor beside this Python (pip install colcon-common-extensions)')
    return found
