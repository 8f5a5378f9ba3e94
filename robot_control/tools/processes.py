"""Child processes of the demo and the end-to-end tests: started in process groups of their own,
stopped by pid, also on failure, Ctrl-C, SIGTERM and interpreter exit.

Every child runs with the DDS environment of a private run: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST,
no static peers, and the ROS_DOMAIN_ID of the run (never the caller's, which may be a robot's).
A child is a session leader (``start_new_session``), so stopping it signals its process group
(pgid = its pid): whatever it spawned goes too, and nothing else is ever signalled.

Stopping escalates: SIGINT (what Ctrl-C sends; rclpy shuts down cleanly), then SIGTERM, then
SIGKILL, each after a bounded wait. The exit status is kept, and a child's output goes to a log
file whose tail is quoted when it dies early.
"""
import atexit
import ctypes
import faulthandler
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

#: domain ids a demo or benchmark run claims when none is given: ROS's safe range on Linux (0..101),
#: tried from the top so that they stay clear of the test suite's 1..92 (and of the default domain 0)
PRIVATE_DOMAIN_IDS = tuple(range(101, 0, -1))
#: s to wait after each signal of the SIGINT -> SIGTERM -> SIGKILL escalation
STOP_WAITS = (3.0, 2.0, 2.0)

_live = {}              # pid -> ManagedProcess, every child not yet reaped
_lock = threading.Lock()


def ros_env(domain_id, base=None):
    """A copy of `base` (default os.environ) with the DDS settings of a private run."""
    domain_id = int(domain_id)
    if not 0 <= domain_id <= 232:
        raise ValueError(f'domain_id: expected 0..232 (Fast DDS port range), got {domain_id}')
    env = dict(os.environ if base is None else base)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_STATIC_PEERS', None)
    env.pop('ROS_LOCALHOST_ONLY', None)  # deprecated in Jazzy; the discovery range says it all
    env['PYTHONUNBUFFERED'] = '1'
    env.setdefault('RCUTILS_COLORIZED_OUTPUT', '0')
    return env


def private_domain(timeout=120.0, directory=None):
    """A DomainClaim on the first free id of PRIVATE_DOMAIN_IDS (101, 100, ...), exclusive among the
    demo, benchmark and check runs of this machine (lock files in `directory`, default the temp dir)."""
    return DomainClaim(PRIVATE_DOMAIN_IDS, timeout=timeout, directory=directory)


class DomainClaim:
    """An exclusive claim on one ROS_DOMAIN_ID among `candidates`, across processes of this machine.

    Each id is a lock file (fcntl.flock, released by the kernel when the holder dies) in the temp
    directory; the first free id of `candidates` (tried from `start`) is taken. Use as a context
    manager; `.domain_id` is the claimed id. Raises TimeoutError if none frees within `timeout` s.
    """

    def __init__(self, candidates, start=0, timeout=120.0, directory=None):
        import tempfile
        self.candidates = [int(c) for c in candidates]
        self.start = int(start)
        self.timeout = float(timeout)
        self.directory = Path(directory or tempfile.gettempdir())
        self.domain_id = None
        self._file = None

    def acquire(self):
        import fcntl
        deadline = time.monotonic() + self.timeout
        k = len(self.candidates)
        while True:
            for i in range(k):
                d = self.candidates[(self.start + i) % k]
                f = open(self.directory / f'robot_control_ros_domain_{d}.lock', 'a+')
                try:
                    fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    f.close()
                    continue
                self._file, self.domain_id = f, d
                return d
            if time.monotonic() >= deadline:
                raise TimeoutError(f'domain_id: all of {self.candidates} are in use')
            time.sleep(0.2)

    def release(self):
        if self._file is not None:
            self._file.close()   # closing drops the flock
            self._file = None

    def __enter__(self):
        self.acquire()
        return self

    def __exit__(self, *exc):
        self.release()
        return False


class ProcessError(RuntimeError):
    """A child failed to start or died; the message quotes the end of its log."""


class ManagedProcess:
    """One child process: `argv` with `env`, output to `log_path`, in its own process group."""

    def __init__(self, name, argv, env, log_path, cwd=None):
        self.name = name
        self.argv = [str(a) for a in argv]
        self.env = env
        self.log_path = Path(log_path)
        self.cwd = cwd
        self.proc = None
        self.stop_signal = None   # the signal that finally ended it (None: exited by itself)

    @property
    def pid(self):
        return None if self.proc is None else self.proc.pid

    @property
    def returncode(self):
        return None if self.proc is None else self.proc.poll()

    def running(self):
        return self.proc is not None and self.proc.poll() is None

    def start(self):
        if self.proc is not None:
            raise RuntimeError(f'{self.name}: already started')
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, 'wb') as log:
            self.proc = subprocess.Popen(self.argv, env=self.env, cwd=self.cwd, stdin=subprocess.DEVNULL,
                                         stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                         preexec_fn=die_with_parent)
        with _lock:
            _live[self.proc.pid] = self
        return self

    def log_tail(self, lines=25):
        try:
            text = self.log_path.read_text(errors='replace')
        except OSError:
            return ''
        return '\n'.join(text.splitlines()[-lines:])

    def check_alive(self):
        """ProcessError if the child has exited (quoting its log)."""
        if self.proc is not None and self.proc.poll() is not None:
            raise ProcessError(f'{self.name} (pid {self.proc.pid}) exited with status {self.proc.returncode}; '
                               f'log {self.log_path}:\n{self.log_tail()}')

    def _signal_group(self, sig):
        try:
            os.killpg(self.proc.pid, sig)   # pgid == pid: the child is a session leader
        except ProcessLookupError:
            pass
        except PermissionError:             # not ours (cannot happen for a group we created)
            pass

    def stop(self, waits=STOP_WAITS):
        """Stop the child and its group: SIGINT, then SIGTERM, then SIGKILL. Returns the exit status."""
        if self.proc is None:
            return None
        try:
            for sig, wait in zip((signal.SIGINT, signal.SIGTERM, signal.SIGKILL), waits):
                if self.proc.poll() is not None:
                    break
                self._signal_group(sig)
                self.stop_signal = sig
                try:
                    self.proc.wait(timeout=wait)
                except subprocess.TimeoutExpired:
                    continue
            if self.proc.poll() is None:
                self.proc.wait()
            # the leader is gone; make sure nothing it spawned outlives it
            self._signal_group(signal.SIGKILL)
        finally:
            with _lock:
                _live.pop(self.proc.pid, None)
        return self.proc.returncode


class ProcessSet:
    """The children of one run; `stop_all()` (or leaving the `with` block) stops each, newest first."""

    def __init__(self):
        self.procs = []

    def start(self, name, argv, env, log_path, cwd=None):
        p = ManagedProcess(name, argv, env, log_path, cwd)
        self.procs.append(p)
        return p.start()

    def check_alive(self):
        for p in self.procs:
            p.check_alive()

    def stop_all(self, waits=STOP_WAITS):
        """Stop every child (in parallel, newest first in signalling order); {name: exit status}."""
        out = {}
        threads = []
        for p in reversed(self.procs):
            t = threading.Thread(target=lambda p=p: out.__setitem__(p.name, p.stop(waits)), daemon=True)
            t.start()
            threads.append(t)
        for t in threads:
            t.join()
        return out

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop_all()
        return False


def stop_all_children():
    """Stop every child still alive (atexit and signal handlers call this)."""
    with _lock:
        procs = list(_live.values())
    for p in procs:
        p.stop(waits=(1.0, 1.0, 1.0))


atexit.register(stop_all_children)


def die_with_parent():
    """Child side of Popen (preexec_fn): SIGKILL this process when the thread that started it dies,
    even by SIGKILL, when no `finally` runs (Linux prctl PR_SET_PDEATHSIG)."""
    try:
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, signal.SIGKILL)
    except OSError:
        pass


def python_module(module, *args):
    """argv running `python -m module args...` with this interpreter."""
    return [sys.executable, '-m', module, *args]


class Interrupted(KeyboardInterrupt):
    """Raised in the main thread by SIGTERM/SIGHUP so that `finally` blocks stop the children."""


_received = []      # signals whose exception may have been swallowed (see check_interrupted)
_timers = []        # the force-exit timer the first signal started
#: s after a signal by which the process has stopped: past it the children are stopped and it exits with 130
FORCE_EXIT_S = 20.0


def _interruption(signum):
    if signum == signal.SIGINT:
        return KeyboardInterrupt()
    return Interrupted(f'signal {signal.Signals(signum).name}')


def install_signal_handlers(force_exit_after=FORCE_EXIT_S):
    """SIGTERM and SIGHUP raise Interrupted in the main thread, SIGINT raises KeyboardInterrupt.

    The exception is raised in whatever Python code runs when the signal comes; Python drops one
    raised inside a finalizer (an rclpy Future's __del__, say). The signal is also remembered, and
    check_interrupted() raises it again. Should the process still run `force_exit_after` s after the
    first signal (the exception landed where nothing polls, a wait that never returns), a timer prints
    every thread's stack, stops every child and exits with status 130. Returns the previous handlers,
    for restore_signal_handlers().
    """
    def handler(signum, _frame):
        _received.append(signum)
        if not _timers:
            timer = threading.Timer(force_exit_after, _force_exit, args=(signum, force_exit_after))
            timer.daemon = True
            timer.start()
            _timers.append(timer)
        raise _interruption(signum)

    _received.clear()
    return {sig: signal.signal(sig, handler) for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)}


def _force_exit(signum, after):
    print(f'[demo] still running {after:g} s after {signal.Signals(signum).name}: stopping every child and '
          'exiting; the threads were at:', file=sys.stderr, flush=True)
    faulthandler.dump_traceback(file=sys.stderr, all_threads=True)
    stop_all_children()
    os._exit(130)


def check_interrupted():
    """Raise the interruption of a signal received since install_signal_handlers(), if any: the
    polling loops call it, so that a signal whose exception was swallowed still stops the run."""
    if _received:
        raise _interruption(_received[0])


def restore_signal_handlers(old):
    """Put back the handlers install_signal_handlers() replaced; forget the signals, cancel the force exit."""
    for sig, h in old.items():
        signal.signal(sig, h)
    _received.clear()
    while _timers:
        _timers.pop().cancel()

