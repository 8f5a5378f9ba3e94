"""sweep on a real Ray cluster of two hosts (support.ray_cluster: the head in one network namespace, a worker
node in another, joined by a veth pair; the driver in the head's namespace): the episodes run on both
nodes, every row equals the local run's bit for bit, and a Ray worker killed mid-sweep loses no episode
and counts none twice."""
import os
import signal
import sys
import time

import pytest
import yaml

from support import two_hosts
from robot_control.tools import sweep_engine, sweep_episode, sweep_spec

ray = pytest.importorskip('ray')
pytestmark = pytest.mark.skipif(two_hosts.unavailable() is not None, reason=str(two_hosts.unavailable()))

ROOT = two_hosts.ROOT
#: the polar robot, PD computed torque, +-20 % true mass and position noise: 1.5 s (1501 ticks) per episode
SPEC = {'scenario': 'polar_two_link', 'law': 'computed_torque', 'duration': 1.5, 'episodes': 48, 'seed': 3,
        'trajectory': {'goal': [0.5, 0.7], 'duration': 1.0, 'start': 0.1},
        'sample': {'sim_params.m': {'uniform': [1.6, 2.4]}, 'noise.position_std': {'loguniform': [1e-5, 1e-3]}}}


@pytest.fixture(scope='module')
def cluster():
    from support.ray_cluster import RayCluster
    with RayCluster() as c:
        yield c


@pytest.fixture(scope='module')
def local(tmp_path_factory):
    """The spec's rows run in this process, by episode."""
    rows, _ = sweep_engine.run_local(sweep_spec.load(SPEC), tmp_path_factory.mktemp('local'), workers=0,
                                     say=lambda t: None)
    return {r['episode']: r for r in rows}


def read_table(run):
    d = sweep_engine.RunDirectory(run, sweep_spec.load(str(run / 'spec.yaml')), sweep_episode.columns(
        sweep_episode.plan(sweep_spec.load(str(run / 'spec.yaml')))))
    return d.rows()


def assert_equal_to_local(rows, local):
    assert sorted(r['episode'] for r in rows) == list(range(SPEC['episodes']))      # each once
    for r in rows:
        mine = local[r['episode']]
        for c in mine:
            if c in sweep_episode.RUN_COLUMNS:
                continue
            a, b = r[c], mine[c]
            assert a == b or (isinstance(a, float) and a != a and b != b), (r['episode'], c, a, b)


def sweep_argv(spec, out, address):
    return [sys.executable, '-m', 'robot_control.sweep', 'run', str(spec), '--ray', address, '--out', str(out)]


def write_spec(tmp_path, **changes):
    path = tmp_path / 'spec.yaml'
    path.write_text(yaml.safe_dump({**SPEC, **changes}, sort_keys=False))      # the draws follow `sample`'s order
    return path


def test_a_sweep_on_a_two_host_ray_cluster_runs_on_both_nodes_and_equals_the_local_run(cluster, local, tmp_path):
    out = tmp_path / 'ray'
    done = cluster.run(sweep_argv(write_spec(tmp_path), out, cluster.address), timeout=600, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    assert 'Ray cluster: 2 node(s), 2 CPU(s)' in done.stderr
    assert f'on the Ray cluster at {cluster.address}' in done.stdout
    rows = read_table(out)
    assert_equal_to_local(rows, local)
    nodes = {r['worker'].split('/')[0] for r in rows}
    assert nodes == {cluster.addr['a'], cluster.addr['b']}, nodes


def test_an_address_where_no_cluster_answers_exits_2_naming_it(tmp_path, capsys):
    from robot_control.tools import sweep
    assert sweep.main(['run', str(write_spec(tmp_path)), '--ray', '127.0.0.1:1', '--out', str(tmp_path / 'r')]) == 2
    assert "sweep: ray: no Ray cluster answers at '127.0.0.1:1'" in capsys.readouterr().err


def test_a_ray_worker_killed_mid_sweep_loses_no_episode_and_counts_none_twice(cluster, local, tmp_path):
    out = tmp_path / 'killed'
    table = out / 'episodes.csv'
    far = cluster.addr['b']

    def far_rows():
        try:
            lines = table.read_text().splitlines()[1:]
        except OSError:
            return []
        return [line for line in lines if f',{far}/' in line]
    env = {'RAY_ADDRESS': cluster.address}                 # --ray auto finds the cluster through it
    proc = cluster.start(sweep_argv(write_spec(tmp_path), out, 'auto'), cwd=ROOT, extra_env=env)
    try:
        deadline = time.monotonic() + 300
        while not far_rows() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        victim = int(far_rows()[0].split(f',{far}/')[1].split(',')[0])     # the far node's worker process
        assert victim in cluster.workers('b')
        os.kill(victim, signal.SIGKILL)
        done_at_kill = len(table.read_text().splitlines()) - 1
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, stderr[-3000:]
    assert done_at_kill < SPEC['episodes']
    rows = read_table(out)
    assert_equal_to_local(rows, local)
    far_pids = {r['worker'] for r in rows if r['worker'].startswith(f'{far}/')}
    assert len(far_pids) >= 2, far_pids                    # the far node went on with a new worker process
