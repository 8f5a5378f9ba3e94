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
- sweep_local_s: the wall time of plan.sweep_episodes episodes (1,000 in the full run) on the local workers;
  sweep_local_1000_s scaled to 1,000.
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


def bracketed(p, run, singles):
    """(the sweep's ticks/s from run(), one episode's ticks/s in process: the median of `singles` episodes just
    before and `singles` just after it), so that both see the same load."""
    single = episode_rate(p, singles, 0)
    ticks = run()
    single += episode_rate(p, singles, singles)
    return ticks, statistics.median(single)


def bench_sweep(plan, log):
    """B5's figures (module docstring): plan.sweep_ratio_episodes episodes for each ratio, plan.sweep_episodes
    for the wall time."""
    cores = os.cpu_count() or 1
    spec = sweep_spec.load(SPEC)
    p = sweep_episode.plan(spec)
    episode_rate(p, 1, 0)                                           # warm-up: imports, first World
    out = {}
    with tempfile.TemporaryDirectory(prefix='bench_sweep_') as tmp:
        log(f'  {plan.sweep_ratio_episodes} episodes on {cores} local workers, between episodes in process ...')
        local, rate = bracketed(p, lambda: local_sweep(spec.with_episodes(plan.sweep_ratio_episodes), cores,
                                                       os.path.join(tmp, 'ratio'))[1], plan.sweep_single)
        out.update(sweep_episode_ticks_per_s=rate, sweep_local_vs_episode_ratio=local / (rate * cores))
        one, rate = bracketed(p, lambda: local_sweep(spec.with_episodes(plan.sweep_ratio_episodes // cores), 1,
                                                     os.path.join(tmp, 'one'))[1], plan.sweep_single)
        out['sweep_local_1_worker_vs_episode_ratio'] = one / rate
        log(f'  {plan.sweep_ratio_episodes} episodes on a two-host Ray cluster, between episodes in process ...')
        ray, rate = bracketed(p, lambda: ray_sweep(plan.sweep_ratio_episodes, os.path.join(tmp, 'ray'), log),
                              plan.sweep_single)
        if ray is not None:
            out['sweep_ray_vs_episode_ratio'] = ray / (rate * 2)
        log(f'  {plan.sweep_episodes} episodes on {cores} local workers, timed ...')
        wall, _ = local_sweep(spec.with_episodes(plan.sweep_episodes), cores, os.path.join(tmp, 'local'))
    out.update(sweep_local_s=wall, sweep_local_1000_s=wall * 1000 / plan.sweep_episodes)
    return out
