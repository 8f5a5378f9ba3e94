"""`make check-ros2`: build the package with colcon and drive it with the `ros2` command line, as
users do. Needs a `ros2` command on PATH (a sourced ROS 2 Jazzy install, or a stand-in built from
the same sources); `make test` never runs it.

    python -m dev.check_ros2 [--keep-logs]

What it does: `colcon build` of this checkout into a temporary directory; `source
install/setup.bash` for every child; ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID
of its own (DOMAIN_IDS, claimed with a lock file so that two runs never share one). Then:
  ros2 launch scenario.launch.py (iiwa, lockstep, namespace arm): the loop runs under /arm,
  ros2 node list, ros2 topic echo --once and ros2 topic hz of /arm/joint_states,
  ros2 service call /arm/sim_bridge/pause and /arm/sim_bridge/reset (their effect on the stamps),
  ros2 lifecycle nodes/get/set on /arm/controller, Ctrl-C ends the launch cleanly;
  ros2 run of each node (polar_two_link at the root), ros2 param get, an accepted ros2 param set
  and a rejected one (its reason printed).
Each check prints 'PASS <check>: <what it saw>' or 'FAIL <check>: <reason>'; the exit status is 1
when any failed, 2 without a `ros2` command. Every process it started is stopped by its process
group, also on failure and Ctrl-C, and `ros2 daemon stop` ends the CLI's daemon.
"""
import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

from dev.ros2_checks import LAUNCH_CHECKS, RUN_CHECKS, LaunchSession, RunSession
from dev.ros2_cli import CheckFailed, Ros2, colcon_command, run_to_end, sourced_env, tail
from robot_control.tools import processes

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = 'robot_control'
#: domain ids of this check: clear of the test suite's 1..92 and of the demo's 101..199
DOMAIN_IDS = tuple(range(93, 101))
EXIT_FAILED, EXIT_NO_ROS2 = 1, 2
#: s a colcon build of the package may take
BUILD_TIMEOUT = 300.0
NO_ROS2 = ('check-ros2: no `ros2` command on PATH. Source a ROS 2 Jazzy install '
           '(source /opt/ros/jazzy/setup.bash) or a stand-in built from the Jazzy sources '
           '(README: "Checking with the ros2 command line"), then run it again.')


class Report:
    """Runs checks in order and prints one line per check."""

    def __init__(self, out=None):
        self.out = out          # None: sys.stdout at the time of printing
        self.passed, self.failed = [], []

    def check(self, name, fn, *args):
        """fn(*args) returns what it saw (PASS) or raises CheckFailed (FAIL); True when it passed."""
        try:
            seen = fn(*args)
        except CheckFailed as exc:
            self.fail(name, str(exc))
            return False
        self.passed.append(name)
        print(f'PASS {name}' + (f': {seen}' if seen else ''), file=self.out or sys.stdout, flush=True)
        return True

    def fail(self, name, reason):
        self.failed.append(name)
        print(f'FAIL {name}: {reason}', file=self.out or sys.stdout, flush=True)

    def summary(self):
        n = len(self.passed) + len(self.failed)
        verdict = 'all passed' if not self.failed else f'{len(self.failed)} failed: {", ".join(self.failed)}'
        return f'check-ros2: {n} checks, {verdict}'


def build(tmp):
    """colcon build of ROOT with build, install and log under `tmp` (the checkout gains nothing)."""
    if not (ROOT / 'package.xml').is_file():
        raise CheckFailed(f'{ROOT} is not the package checkout (no package.xml): run it from the checkout\'s .venv')
    colcon = colcon_command()
    cmd = [colcon, '--log-base', str(tmp / 'log'), 'build', '--base-paths', str(ROOT),
           '--build-base', str(tmp / 'build'), '--install-base', str(tmp / 'install'),
           '--event-handlers', 'console_direct-']
    status, text = run_to_end('colcon build', cmd, dict(os.environ), tmp / 'colcon.log', BUILD_TIMEOUT, cwd=tmp)
    if status != 0 or 'Summary: 1 package finished' not in text:
        raise CheckFailed(f'{colcon} build exited with status {status}: {tail(text, 8)}')
    launch = tmp / 'install' / PACKAGE / 'share' / PACKAGE / 'launch' / 'scenario.launch.py'
    if not launch.is_file():
        raise CheckFailed(f'{launch} was not installed')
    return f'{colcon} -> {tmp / "install"}'


def run_session(report, make_session, checks, ros2, share):
    """The checks of one session in order; when the first (the start) fails, the others are not run.
    The session's processes are stopped before it returns."""
    session = make_session(ros2, share)
    try:
        (first, start), *rest = checks
        if not report.check(first, start, session):
            for name, _ in rest:
                report.fail(name, f'not run: {first} failed')
            return
        for name, fn in rest:
            report.check(name, fn, session)
    finally:
        session.close()


def run_all(report, domain_id, tmp):
    """Build, then both sessions with the install sourced; `ros2 daemon stop` at the end."""
    if not report.check('colcon build', build, tmp):
        return
    try:
        env = sourced_env(tmp / 'install' / 'setup.bash', processes.ros_env(domain_id))
    except CheckFailed as exc:
        report.fail('source install/setup.bash', str(exc))
        return
    share = tmp / 'install' / PACKAGE / 'share' / PACKAGE
    with processes.ProcessSet() as procs:
        ros2 = Ros2(env, tmp / 'logs', procs)
        try:
            if not report.check('ros2 daemon start', lambda: tail(ros2.start_daemon(), 1)):
                return
            run_session(report, LaunchSession, LAUNCH_CHECKS, ros2, share)
            run_session(report, RunSession, RUN_CHECKS, ros2, share)
        finally:
            procs.stop_all()
            report.check('ros2 daemon stop', stop_daemon, ros2)


def stop_daemon(ros2):
    """`ros2 daemon stop`: the daemon started by `ros2 daemon start` ends, with its process group."""
    return tail(ros2.stop_daemon(), 1)


def main(argv=None):
    parser = argparse.ArgumentParser(prog='check_ros2', description=__doc__.split('\n\n')[0])
    parser.add_argument('--keep-logs', action='store_true', help='keep the build and the logs (kept anyway on failure)')
    opts = parser.parse_args(argv)
    if shutil.which('ros2') is None:
        print(NO_ROS2, file=sys.stderr)
        return EXIT_NO_ROS2
    report = Report()
    tmp = Path(tempfile.mkdtemp(prefix='check-ros2-'))
    old = processes.install_signal_handlers()
    try:
        with processes.DomainClaim(DOMAIN_IDS, start=os.getpid()) as claim:
            print(f'check-ros2: ROS_DOMAIN_ID={claim.domain_id}, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST', flush=True)
            run_all(report, claim.domain_id, tmp)
    except KeyboardInterrupt:
        report.fail('interrupted', 'every process it started was stopped')
    finally:
        processes.stop_all_children()
        processes.restore_signal_handlers(old)
    print(report.summary(), flush=True)
    if report.failed or opts.keep_logs:
        print(f'check-ros2: build and logs kept in {tmp}', flush=True)
    else:
        shutil.rmtree(tmp, ignore_errors=True)
    return EXIT_FAILED if report.failed else 0


if __name__ == '__main__':
    sys.exit(main())
