"""Helpers of the end-to-end tests: demo runs on private DDS domains, shared between tests.

Every run is `robot_control.tools.demo.run` in lockstep: sim_bridge_node and controller_node as OS
processes (stopped by pid in the run's `finally`), the reference publisher and the collector
in this process. Each run claims a free ROS_DOMAIN_ID in E2E_DOMAINS with a lock file, so runs
of this suite, of a concurrent suite, or of two workers never share a domain; discovery is
limited to this machine (conftest.py and demo_procs.ros_env).

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
from robot_control.tools.demo_procs import DomainClaim

E2E_DOMAINS = range(71, 81)
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

