"""B5 sweep throughput (benchmarks.bench): config/sweeps/iiwa_typical.yaml, the iiwa under PD computed torque
on the typical realism profile, 3 s (3001 ticks) per episode.

- sweep_episode_ticks_per_s: one episode's tick rate in process (sweep_episode.run, no pool), the median
  of episodes run just before and just after the sweeps.
- sweep_local_s: the wall time of `episodes` episodes (1,000 in the full run) on `cores` local worker
  processes (sweep_engine.run_local, the pool's start included); sweep_local_1000_s scales it to 1,000.
- sweep_local_vs_episode_ratio: that run's ticks/s over (one episode's ticks/s x cores).
- sweep_ray_vs_episode_ratio: the same over a Ray cluster of two hosts (support.ray_cluster: two network
  namespaces joined by veth, one CPU each; the driver, `sweep run --ray`, in the head's namespace); only
  where network namespaces can be made (root), else absent.
"""
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

from robot_control.tools import sweep_engine, sweep_episode, sweep_spec

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEC = os.path.join(ROOT, 'config', 'sweeps', 'iiwa_typical.yaml')
RATE = re.compile(r'episodes run here: ([\d.]+) episodes/s, ([\d,]+) ticks/s')


def episode_rate(p, episodes, first):
    """ticks/s of each of `episodes` episodes run one by one in this process (episodes first, first + 1, ...)."""
    rates = []
    for k in range(first, first + episodes):
        t0 = time.perf_counter()
        row = sweep_episode.run(p, k)
        rates.append(row['ticks'] / (time.perf_counter() - t0))
    return rates


def local_sweep(spec, cores, out):
    """(wall s, ticks/s) of the spec's episodes on `cores` local worker processes."""
    t0 = time.perf_counter()
    _, progress = sweep_engine.run_local(spec, out, cores, say=lambda text: None, stream=open(os.devnull, 'w'))
    return time.perf_counter() - t0, progress.rates[1]


def ray_sweep(episodes, out, log):
    """ticks/s of `episodes` episodes of SPEC on a two-host Ray cluster (None where namespaces cannot be made)."""
    sys.path.insert(0, os.path.join(ROOT, 'test'))
    from support import two_hosts
    if two_hosts.unavailable() is not None:
        log(f'  Ray: skipped ({two_hosts.unavailable()})')
        return None
    from support.ray_cluster import RayCluster
    with RayCluster() as cluster:
        argv = [sys.executable, '-m', 'robot_control.sweep', 'run', SPEC, '--ray', cluster.address,
                '--episodes', str(episodes), '--out', out]
        done = cluster.run(argv, timeout=3600, cwd=ROOT)
    found = RATE.search(done.stdout)
    if done.returncode != 0 or found is None:
        raise RuntimeError(f'the sweep on the Ray cluster failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}')
    return float(found.group(2).replace(',', ''))


def bench_sweep(plan, log):
    """B5's figures (module docstring), with plan.sweep_episodes local episodes and plan.sweep_ray_episodes
    on the Ray cluster."""
    cores = os.cpu_count() or 1
    spec = sweep_spec.load(SPEC).with_episodes(plan.sweep_episodes)
    p = sweep_episode.plan(spec)
    episode_rate(p, 1, 0)                                           # warm-up: imports, first World
    single = episode_rate(p, plan.sweep_single, 0)
    with tempfile.TemporaryDirectory(prefix='bench_sweep_') as tmp:
        log(f'  {plan.sweep_episodes} episodes on {cores} local workers ...')
        wall, local_ticks = local_sweep(spec, cores, os.path.join(tmp, 'local'))
        log(f'  {plan.sweep_ray_episodes} episodes on a two-host Ray cluster ...')
        ray_ticks = ray_sweep(plan.sweep_ray_episodes, os.path.join(tmp, 'ray'), log)
    single += episode_rate(p, plan.sweep_single, plan.sweep_single)
    rate = statistics.median(single)
    out = {'sweep_episode_ticks_per_s': rate, 'sweep_local_s': wall,
           'sweep_local_1000_s': wall * 1000 / plan.sweep_episodes,
           'sweep_local_vs_episode_ratio': local_ticks / (rate * cores)}
    if ray_ticks is not None:
        out['sweep_ray_vs_episode_ratio'] = ray_ticks / (rate * 2)
    return out
