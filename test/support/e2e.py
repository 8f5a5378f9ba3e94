"""Helpers of the end-to-end tests: demo runs on private DDS domains, shared between tests.

Every run is `robot_control.tools.demo.run` in lockstep: sim_bridge_node and controller_node as OS
processes (stopped by pid in the run's `finally`), the reference publisher and the collector
in this process. Each run claims a free ROS_DOMAIN_ID in E2E_DOMAINS with a lock file, so runs
of this suite, of a concurrent suite, or of two workers never share a domain; discovery is
limited to this machine (conftest.py and processes.ros_env).

`Runs` starts a set of runs on a small thread pool (E2E_WORKERS, default 2: one run keeps about
one core busy, because the lockstep loop hands each tick from one process to the next) and
hands out results as the tests ask for them; all waits are bounded.
"""
import concurrent.futures
import itertools
import os
import threading

import numpy as np

from robot_control.tools import demo, demo_metrics
from robot_control.tools.processes import DomainClaim

#: the ids the runs claim: 71-80, or E2E_DOMAINS="first-last" (a range kept clear of concurrent suites)
E2E_DOMAINS = range(*(lambda a, b: (int(a), int(b) + 1))(*os.environ.get('E2E_DOMAINS', '71-80').split('-')))
#: the domain ids of test/e2e/test_own_arm.py (the user's own arm), claimed like the others; clear of the
#: end-to-end pool (71-80) and the robustness rigs (81-92)
OWN_ARM_DOMAINS = (98, 99)
WORKERS = int(os.environ.get('E2E_WORKERS', '2'))
RUN_TIMEOUT = 300.0          # s of wall time for one run, start-up included
_next = itertools.count()


def run_experiment(name, out_dir, duration=None, record=False, plot=False, **kwargs):
    """One lockstep demo run of experiment `name` on a claimed private domain; returns a RunResult."""
    with DomainClaim(E2E_DOMAINS, start=next(_next), timeout=RUN_TIMEOUT) as claim:
        return demo.run(name, mode='lockstep', duration=duration, out_dir=out_dir, record=record, plot=plot,
                        domain_id=claim.domain_id, write=None, **kwargs)


class Runs:
    """Runs submitted up front, results on demand: runs.get('polar') -> RunResult (or its exception)."""

    def __init__(self, base_dir, workers=WORKERS):
        self.base_dir = base_dir
        self.pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, workers), thread_name_prefix='e2e')
        self.futures = {}
        self.lock = threading.Lock()

    def submit(self, key, name, **kwargs):
        with self.lock:
            if key not in self.futures:
                self.futures[key] = self.pool.submit(run_experiment, name, self.base_dir / key, **kwargs)
        return self

    def get(self, key):
        return self.futures[key].result(timeout=RUN_TIMEOUT * (1 + len(self.futures) / max(1, WORKERS)))

    def close(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


def common_ticks(a, b):
    """Index arrays (ia, ib) of the ticks both runs recorded (same simulation time)."""
    ta = np.round(a.t * 1e9).astype(np.int64)
    tb = np.round(b.t * 1e9).astype(np.int64)
    common, ia, ib = np.intersect1d(ta, tb, return_indices=True)
    return ia, ib


def restrict(data, index):
    """A copy of RunData `data` keeping the ticks `index` only."""
    import copy
    out = copy.copy(data)
    for name in ('t', 'q', 'qd', 'tau_applied', 'tau_cmd', 'ref_pos', 'ref_vel', 'ref_acc', 'err_pos', 'err_vel',
                 'force_xyz', 'state_wall_ns', 'cmd_wall_ns'):
        value = getattr(data, name)
        if value is not None:
            setattr(out, name, value[index])
    return out


PHYSICS_KEYS = ('rms_error', 'max_error', 'final_error', 'steady_state_error', 'settling_time_s',
                'force_rms_error', 'force_max_error', 'force_steady_state_error', 'force_settling_time_s',
                'saturated_ticks')


def physics_summary(data, experiment_name, duration):
    """The run-independent part of the summary (no wall-clock figures) of `data`."""
    from robot_control.tools import demo_experiments
    s = demo_metrics.summarize(data, demo_experiments.get(experiment_name), 'lockstep', duration)
    return {k: s[k] for k in PHYSICS_KEYS}



class Lockstep:
    """One lockstep loop (bridge and controller processes with config/<scenario>.yaml, or a parameter file of
    one's own: `scenario` a path ending in .yaml) driven step by step
    from this process (robot_control.tools.demo.LiveRun): the bridge starts paused at t = 0; advance(t)
    runs the simulation until the command of the tick at t s has arrived and pauses it again, so
    references sent and parameters set between two advances take effect at a known tick.
    Use as a context manager on a claimed domain: every process is stopped on exit."""

    def __init__(self, domain_id, log_dir, scenario, bridge=None, controller=None):
        from robot_control.tools import processes
        self.live = demo.LiveRun(domain_id, processes.ros_env(domain_id), log_dir, lambda *a, **k: None)
        self.scenario, self.bridge_params, self.controller_params = scenario, bridge or {}, controller or {}
        self._clients = {}           # node name -> AsyncParameterClient

    def __enter__(self):
        try:
            self.live.start_nodes(self.scenario, {'mode': 'lockstep', **self.bridge_params}, self.controller_params)
            self.live.wait_for_first_tick('lockstep')
        except BaseException:
            self.live.close()
            raise
        return self

    def __exit__(self, *exc):
        self.live.close()
        return False

    @property
    def control(self):
        """The run's demo_ros.RunControl: trajectory publisher, /rosout log of the nodes."""
        return self.live.control

    def advance(self, t):
        """Resume, run until the command of the tick at t s (simulation time) has arrived, pause; returns the
        time (s) of the state the paused bridge holds: the first tick at or past t, where the bridge pauses
        itself (its pause_at), however slowly this process runs beside it."""
        self.live.control.set_bridge_parameters({'pause_at': float(t)}, poll=self.live.alive)
        self.live.resume()
        self.live.run_until(int(round(t * demo.NS)), (),
                            demo.Progress(self.live.collector, 0, {}, (), None))
        self.live.pause()
        return self.live.paused_at() / demo.NS

    def send_trajectory(self, joints, times, positions, velocities=None, accelerations=None, stamp_ns=0):
        """Publish a JointTrajectory on /controller/joint_trajectory; wait until the controller logs that it
        accepted it (or cancelled the motion, for an empty one); RuntimeError naming a rejection."""
        from robot_control.ros import conversions
        control = self.control
        mark = len(control.log)
        control.traj_pub.publish(conversions.joint_trajectory(joints, times, positions, velocities, accelerations,
                                                              stamp_ns=stamp_ns))
        said = ('empty trajectory', 'trajectory accepted')[bool(len(times))]
        control.spin_until(lambda: control.controller_said(said, mark) is not None
                           or control.controller_rejections(mark), demo.CONFIRM_TIMEOUT, self.live.alive,
                           f'the controller to log "{said}"')
        if control.controller_rejections(mark):
            raise RuntimeError(f'controller rejected the trajectory: {control.controller_rejections(mark)}')

    def set_bridge(self, **params):
        """Set parameters of the running bridge (names with '__' for '.') through its parameter service."""
        self._set('sim_bridge', params)

    def set_controller(self, **params):
        """Set parameters of the running controller (names with '__' for '.') through its parameter service."""
        self._set('controller', params)

    def _set(self, node, params):
        from rclpy.parameter import Parameter
        from rclpy.parameter_client import AsyncParameterClient
        if node not in self._clients:
            self._clients[node] = AsyncParameterClient(self.control.node, f'/{node}')
        client = self._clients[node]
        self.control.spin_until(client.services_are_ready, demo.STARTUP_TIMEOUT, self.live.alive,
                                f'the {node} parameter services')
        future = client.set_parameters([Parameter(k.replace('__', '.'), value=v) for k, v in params.items()])
        self.control.spin_until(future.done, demo.CONFIRM_TIMEOUT, self.live.alive, f'the {node} to set parameters')
        bad = [r.reason for r in future.result().results if not r.successful]
        if bad:
            raise RuntimeError(f'the {node} refused {params}: {bad}')

    def states(self):
        """(t (k,) s, q (k, n), qd (k, n)) of every joint_states tick so far, in the bridge's joint order
        (a state re-published while paused counted once)."""
        return self._by_stamp('/joint_states', lambda m: (m.position, m.velocity))

    def references(self):
        """(t (k,) s, q_d (k, n), qd_d (k, n)) the controller published on ~/reference, one per tick."""
        return self._by_stamp('/controller/reference', lambda m: (m.position, m.velocity))

    def _by_stamp(self, topic, fields):
        from robot_control.ros import conversions
        rows = {}
        for msg, _, _ in self.live.collector.messages(topic):
            rows.setdefault(conversions.stamp_to_ns(msg.header.stamp), fields(msg))
        stamps = sorted(rows)
        return (np.array(stamps) / demo.NS, np.array([rows[s][0] for s in stamps]),
                np.array([rows[s][1] for s in stamps]))

    def diagnostics(self, suffix):
        """[(level, message, {key: value})] of every /diagnostics status named ...`suffix`, in arrival order."""
        from robot_control.ros import conversions
        return [conversions.diagnostic_values(s) for msg, _, _ in self.live.collector.messages('/diagnostics')
                for s in msg.status if s.name.endswith(suffix)]

    def log(self, level=None):
        """The controller's /rosout lines (text), optionally of one level (rcl_interfaces Log: 20 INFO, 40 ERROR)."""
        return [text for name, lvl, text in self.control.log if name == 'controller' and level in (None, lvl)]
