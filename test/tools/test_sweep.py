"""sweep: episodes equal the lockstep loop run by hand, replays are bit-identical, distributions stay in
bounds and repeat for a seed, resumed runs skip finished episodes, a killed worker loses nothing, and the
polar robot's lecture gains pass a +-20 % mass error where an under-designed gain fails some episodes."""
import csv
import io
import json
import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml
from matplotlib.image import imread

from robot_control.core.controller import Controller
from robot_control.param_table import Row
from robot_control.ros import controller_params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.tools import demo_metrics, sweep, sweep_engine, sweep_episode, sweep_report, sweep_spec
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params
from sim_bridge.bridge_loop import make_loop
from sim_bridge.engines import world_of_config

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MASS_ERROR = {'sim_params.m': {'uniform': [1.6, 2.4]}}          # kg: +-20 % of the controller's 2 kg


def polar(episodes=3, seed=7, controller=None, sample=None, criteria=None, duration=0.6):
    """A polar_two_link spec: a quintic move to (0.5 rad, 0.7 m) in 0.4 s from 0.1 s."""
    return sweep_spec.load({
        'scenario': 'polar_two_link', 'law': 'computed_torque', 'duration': duration, 'episodes': episodes,
        'seed': seed, 'trajectory': {'goal': [0.5, 0.7], 'duration': 0.4, 'start': 0.1},
        'controller': controller or {}, 'criteria': criteria or {},
        'sample': MASS_ERROR if sample is None else sample})


def without_wall(row):
    return {k: v for k, v in row.items() if k not in sweep_episode.RUN_COLUMNS}


def equal_rows(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], float) and math.isnan(a[k]):
            assert isinstance(b[k], float) and math.isnan(b[k]), k
        else:
            assert a[k] == b[k], k


# -- an episode is the loop run by hand ----------------------------------------------------------------
def by_hand(p, k):
    """Episode k of Plan p through the public pieces, written out: RunData."""
    seed, values, _ = sweep_episode.episode_values(p, k)
    cvals = controller_params.TABLE.validate(values['controller'])
    bvals = bridge_params.TABLE.validate(values['sim_bridge'])
    ccfg, bcfg = ConfigBuilder()(cvals), bridge_params.build(bvals)
    controller = Controller(ccfg, cvals['state_timeout'])
    world = world_of_config(bcfg)
    loop = make_loop(world, bcfg, publish_state=lambda *a: 0, count_publishers=lambda: (1, 0),
                     publish_diagnostics=lambda: None, log=lambda *a: None, clock=lambda: 0)
    loop.start()
    cols = {key: [] for key in ('t', 'q', 'qd', 'ta', 'tc', 'rp', 'rv', 'ra', 'ep', 'ev', 'f')}
    tr = p.experiment.trajectory
    for i in range(p.ticks):
        m = loop.measured
        q, qd, effort = m.state_values()
        cmd = controller.step(m.t_ns, list(bcfg.joints), q, qd)
        if i == 0:
            controller.core.set_trajectory(tr.times, tr.positions, t_start=tr.t_start)
        ref, err = controller.core.reference, controller.core.error
        for key, v in zip(cols, (m.t_ns / 1e9, q, qd, effort, cmd.tau, *ref, *err, m.contact_wrench()[0])):
            cols[key].append(np.array(v, dtype=float))
        loop.on_joint_command(m.t_ns, list(bcfg.joints), cmd.values)
    world.close()
    return demo_metrics.RunData(
        t=cols['t'], joints=bcfg.joints, joint_units=('rad', 'm'), q=cols['q'], qd=cols['qd'],
        tau_applied=cols['ta'], tau_cmd=cols['tc'], ref_names=bcfg.joints, ref_pos=cols['rp'], ref_vel=cols['rv'],
        ref_acc=cols['ra'], err_pos=cols['ep'], err_vel=cols['ev'], force_xyz=cols['f'], force_axes=(),
        force_axis_index=(), law='computed_torque', effort_limit=ccfg.effort_limit)


def test_an_episode_equals_the_lockstep_loop_run_by_hand_bit_for_bit():
    sample = {**MASS_ERROR, 'noise.position_std': {'loguniform': [1e-5, 1e-3]},
              'delay.measurement_ticks': {'integers': [1, 2]}}
    p = sweep_episode.plan(polar(sample=sample))
    row, data = sweep_episode.run(p, 1, keep=True)
    hand = by_hand(p, 1)
    assert data.samples == hand.samples == p.ticks == 601
    for key in ('t', 'q', 'qd', 'tau_cmd', 'tau_applied', 'err_pos', 'ref_pos'):
        assert np.array_equal(getattr(data, key), getattr(hand, key)), key
    equal_rows(without_wall(row), without_wall({**row, **sweep_episode.metrics_of(hand, p)}))
    assert row['delay.measurement_ticks'] in (1, 2) and row['noise.position_std[1]'] > 0
    assert row['stable'] and row['ticks'] == 601


# -- replay ------------------------------------------------------------------------------------------------
def test_replay_of_episode_k_is_bit_identical_to_its_row_and_a_changed_row_is_reported(tmp_path, capsys):
    spec = tmp_path / 'polar.yaml'
    spec.write_text('scenario: polar_two_link\nduration: 0.5\nepisodes: 3\nseed: 4\n'
                    'trajectory: {goal: [0.5, 0.7], duration: 0.4}\n'
                    'sample: {sim_params.m: {uniform: [1.6, 2.4]}, noise.velocity_std: {uniform: [0.0, 0.01]}}\n')
    run = tmp_path / 'run'
    assert sweep.main(['run', str(spec), '--workers', '0', '--out', str(run)]) == 0
    summary = json.loads((run / 'summary.json').read_text())        # strict JSON: no NaN
    assert summary['episodes'] == 3 and summary['passed'] == summary['stable'] == 3 and len(summary['worst']) == 3
    assert set(summary['percentiles']) >= {'rms_error', 'max_error', 'final_error', 'peak_torque'}
    assert summary['worst'][0]['force_rms_error'] is None
    for png in ('histograms.png', 'metrics_vs_parameters.png'):
        assert imread(run / png).shape[0] > 100
    assert 'passed 3 (100.0 %)' in capsys.readouterr().out
    assert sweep.main(['replay', str(run), '2']) == 0
    assert 'bit for bit' in capsys.readouterr().out
    trace = np.load(run / 'replay' / 'episode_2.npz')
    assert trace['q'].shape == (501, 2) and (run / 'replay' / 'episode_2_tracking.png').stat().st_size > 0
    assert sweep.main(['replay', str(run), '1', '--format', 'csv']) == 0
    assert (run / 'replay' / 'episode_1.csv').read_text().startswith('t,q[0],q[1]')
    lines = (run / 'episodes.csv').read_text().splitlines()
    header = lines[0].split(',')
    cells = lines[3].split(',')
    cells[header.index('rms_error')] = repr(float(cells[header.index('rms_error')]) * (1 + 1e-15))
    lines[3] = ','.join(cells)
    (run / 'episodes.csv').write_text('\n'.join(lines) + '\n')
    assert sweep.main(['replay', str(run), '2']) == 1
    assert 'rms_error' in capsys.readouterr().err
    assert sweep.main(['replay', str(run), '3']) == 2                  # not run yet
    assert 'K: episode 3 is not in' in capsys.readouterr().err
    assert sweep.main(['run', str(spec), '--workers', '0', '--out', str(run), '--episodes', '4']) == 0
    assert sweep.main(['replay', str(run), '3']) == 0                  # the run grew by one episode
    assert len((run / 'episodes.csv').read_text().splitlines()) == 5


# -- distributions ------------------------------------------------------------------------------------------
DOUBLE = Row('x', 'double', 1.0, '')
ARRAY = Row('v', 'double_array', (1.0, 2.0, 3.0), '')
INTEGER = Row('d', 'integer', 0, '')


@pytest.mark.parametrize('text, row, base, lo, hi', [
    ({'uniform': [1.6, 2.4]}, DOUBLE, 2.0, 1.6, 2.4),
    ({'loguniform': [1e-5, 1e-3]}, DOUBLE, 0.0, 1e-5, 1e-3),
    ({'normal': [0.0, 1.0], 'clip': [-0.5, 0.5]}, DOUBLE, 0.0, -0.5, 0.5),
    ({'integers': [0, 3]}, INTEGER, 0, 0, 3),
    ({'choice': [0.25, 0.5]}, DOUBLE, 0.0, 0.25, 0.5),
    ({'uniform': [0.8, 1.2], 'relative': True}, DOUBLE, 2.0, 1.6, 2.4),
    ({'uniform': [[0.0, 1.0, 2.0], [0.5, 1.5, 2.5]]}, ARRAY, (1.0, 2.0, 3.0), [0.0, 1.0, 2.0], [0.5, 1.5, 2.5]),
    ({'uniform': [0.9, 1.1], 'relative': True}, ARRAY, (1.0, 2.0, 3.0), [0.9, 1.8, 2.7], [1.1, 2.2, 3.3]),
])
def test_distributions_sample_within_their_bounds_and_repeat_for_a_seed(text, row, base, lo, hi):
    dist = sweep_spec.distribution('x', text)
    draws = [dist.draw(np.random.default_rng(s), base, row) for s in range(300)]
    a = np.array(draws, dtype=float)
    assert np.all(a >= np.array(lo) - 1e-12) and np.all(a <= np.array(hi) + 1e-12)
    assert len({repr(d) for d in draws}) > 1                       # not a constant
    assert draws == [dist.draw(np.random.default_rng(s), base, row) for s in range(300)]
    if row is INTEGER:
        assert all(isinstance(d, int) for d in draws) and set(draws) == {0, 1, 2, 3}     # both ends included
    if 'loguniform' in text:
        assert 0.3 < np.mean(np.log10(a) < -4.0) < 0.7               # half the draws in each decade


def test_episode_seeds_come_from_seed_sequence_spawn_and_the_draws_repeat():
    children = np.random.SeedSequence(11).spawn(4)
    assert [sweep_spec.episode_seed(11, k) for k in range(4)] == [int(c.generate_state(1)[0]) for c in children]
    p = sweep_episode.plan(polar(episodes=5, seed=11))
    first = [sweep_episode.episode_values(p, k)[2] for k in range(5)]
    assert first == [sweep_episode.episode_values(p, k)[2] for k in range(5)]
    assert len({d['sim_params.m'] for d in first}) == 5
    assert sweep_episode.episode_values(p, 2)[1]['sim_bridge']['seed'] == sweep_spec.episode_seed(11, 2)


@pytest.mark.parametrize('sample, name', [
    ({'payload.mass': {'uniform': [0.0, 1.0]}}, 'sample.payload.mass'),          # in both tables
    ({'no.such': {'uniform': [0.0, 1.0]}}, 'sample.no.such'),
    ({'sim_params.m': {'uniform': [2.0, 1.0]}}, 'sample.sim_params.m'),
    ({'sim_params.m': {'loguniform': [0.0, 1.0]}}, 'sample.sim_params.m'),
    ({'sim_params.m': {'uniform': [1.0, 2.0], 'normal': [1, 1]}}, 'sample.sim_params.m'),
    ({'controller/sim_params.m': {'uniform': [1.0, 2.0]}}, 'sample.controller/sim_params.m'),
    ({'sim_params.m': {'choice': ['heavy', 'light']}}, 'sample.sim_params.m'),
    ({'sim_params.m': {'uniform': [[1.0, 2.0], [2.0, 3.0]]}}, 'sample.sim_params.m'),     # a scalar parameter
    ({'noise.position_std': {'uniform': [[0, 0, 0], [1, 1, 1]]}}, 'sample.noise.position_std'),   # 2 joints
])
def test_a_bad_sample_is_refused_naming_it(sample, name):
    with pytest.raises(ArgumentError) as exc:
        sweep_episode.plan(polar(sample=sample))
    assert exc.value.name == name


def test_a_parameter_of_both_nodes_is_sampled_on_the_node_named():
    p = sweep_episode.plan(polar(sample={'sim_bridge/payload.mass': {'uniform': [0.1, 0.5]}}))
    _, values, columns = sweep_episode.episode_values(p, 0)
    assert 0.1 <= values['sim_bridge']['payload.mass'] == columns['payload.mass'] < 0.5
    assert values['controller'].get('payload.mass', 0.0) == 0.0


# -- resume, killed worker --------------------------------------------------------------------------------
def test_a_resumed_run_skips_finished_episodes_and_completes_the_same_table(tmp_path):
    spec = polar(episodes=4)
    clean, _ = sweep_engine.run_local(spec, tmp_path / 'clean', workers=0, say=lambda t: None)
    out = tmp_path / 'cut'
    sweep_engine.run_local(spec.with_episodes(2), out, workers=0, say=lambda t: None)
    with open(out / 'episodes.csv', 'a') as f:
        f.write('2,12345,1.9')                      # a row cut short by an interruption
    said, stream = [], io.StringIO()
    rows, progress = sweep_engine.run_local(spec, out, workers=0, say=said.append, stream=stream)
    line = r'\[sweep\] \d/4 episodes, [\d.]+ episodes/s, [\d,]+ ticks/s, ETA \d+ s\n'
    assert re.fullmatch(f'({line})+', stream.getvalue())
    assert stream.getvalue().splitlines()[-1].startswith('[sweep] 4/4 episodes')
    assert progress.new == 2 and said == [f'[sweep] resuming {out}: 2 episodes done, 2 to run']
    assert [r['episode'] for r in rows] == [0, 1, 2, 3]
    for a, b in zip(rows, clean):
        equal_rows(without_wall(a), without_wall(b))
    with pytest.raises(ArgumentError) as exc:
        sweep_engine.run_local(polar(episodes=4, seed=8), out, workers=0)
    assert exc.value.name == 'out'


def children(pid):
    try:
        return [int(c) for c in open(f'/proc/{pid}/task/{pid}/children').read().split()]
    except OSError:
        return []


def cmdline(pid):
    try:
        return open(f'/proc/{pid}/cmdline').read()
    except OSError:
        return ''


def workers_of(pid):
    """The pids of the pool's workers under process pid: the forks of its forkserver, or its spawned children
    (not the resource tracker)."""
    out = []
    for c in children(pid):
        cmd = cmdline(c)
        if 'forkserver' in cmd:
            out += children(c)
        elif 'spawn_main' in cmd and 'resource_tracker' not in cmd:
            out.append(c)
    return out


def wait_for(condition, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(0.01)
    raise AssertionError(f'timed out after {timeout} s waiting for {what}')


def test_a_killed_worker_costs_nothing_every_episode_once_as_in_a_clean_run(tmp_path):
    n = 16
    text = ('scenario: polar_two_link\nduration: 1.5\nepisodes: %d\nseed: 3\n'
            'trajectory: {goal: [0.5, 0.7], duration: 0.5}\nsample: {sim_params.m: {uniform: [1.6, 2.4]}}\n' % n)
    (tmp_path / 'spec.yaml').write_text(text)
    out = tmp_path / 'killed'
    proc = subprocess.Popen([sys.executable, '-m', 'robot_control.sweep', 'run', str(tmp_path / 'spec.yaml'),
                             '--workers', '2', '--out', str(out)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        table = out / 'episodes.csv'
        wait_for(lambda: table.exists() and len(table.read_text().splitlines()) >= 2, 120, 'a finished episode')
        victim = wait_for(lambda: workers_of(proc.pid), 30, 'a worker process')[0]
        done_at_kill = len(table.read_text().splitlines()) - 1
        os.kill(victim, signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr
    assert done_at_kill < n and 'a worker process died' in stderr
    rows = read_table(table)
    assert sorted(r['episode'] for r in rows) == list(range(n))
    clean, _ = sweep_engine.run_local(sweep_spec.load(str(tmp_path / 'spec.yaml')), tmp_path / 'clean', workers=0,
                                      say=lambda t: None)
    for a, b in zip(rows, clean):
        equal_rows(without_wall(a), without_wall(b))


def read_table(path):
    with open(path, newline='') as f:
        return [{k: sweep_engine.parse(v) for k, v in r.items()} for r in csv.DictReader(f)]


# -- a real pass/fail split -------------------------------------------------------------------------------------
CRITERIA = {'max_error': 0.12, 'final_error': 0.1}      # rad or m


def test_lecture_gains_pass_a_20_percent_mass_error_where_an_under_designed_gain_fails_some():
    lecture = [sweep_episode.run(sweep_episode.plan(polar(episodes=8, criteria=CRITERIA, duration=1.5)), k)
               for k in range(8)]
    assert all(r['passed'] for r in lecture), [(r['sim_params.m'], r['max_error']) for r in lecture]
    weak_plan = sweep_episode.plan(polar(episodes=8, criteria=CRITERIA, duration=1.5,
                                         controller={'omega_res': 6.0}))
    weak = [sweep_episode.run(weak_plan, k) for k in range(8)]
    verdicts = [r['passed'] for r in weak]
    assert any(verdicts) and not all(verdicts), [(r['sim_params.m'], r['final_error']) for r in weak]
    assert all(r['stable'] for r in weak)
    # the failures are the episodes furthest from the controller's 2 kg
    worst_passing = max(abs(r['sim_params.m'] - 2.0) for r in weak if r['passed'])
    assert all(abs(r['sim_params.m'] - 2.0) > worst_passing for r in weak if not r['passed'])


def test_stiff_gains_with_a_long_measurement_delay_are_unstable_and_lead_the_worst_episodes():
    spec = polar(episodes=4, seed=5, duration=1.5, controller={'omega_res': 300.0}, criteria={'max_error': 0.5},
                 sample={'delay.measurement_ticks': {'choice': [0, 20]}})
    p = sweep_episode.plan(spec)
    rows = [sweep_episode.run(p, k) for k in range(4)]
    delays = [r['delay.measurement_ticks'] for r in rows]
    assert sorted(set(delays)) == [0, 20] and all(isinstance(d, int) for d in delays)
    for r in rows:       # 20 ms of delay against w_n = 150 rad/s: the error leaves the 1 rad bound
        assert r['stable'] == r['passed'] == (r['delay.measurement_ticks'] == 0), r
    s = sweep_report.summary(rows, spec, ['delay.measurement_ticks'])
    assert s['passed'] == s['stable'] == delays.count(0) and s['pass_rate'] == delays.count(0) / 4
    assert [w['delay.measurement_ticks'] for w in s['worst']][:delays.count(20)] == [20] * delays.count(20)
    assert s['worst'][0]['badness'] == math.inf


def test_a_bad_spec_exits_2_naming_the_key(tmp_path, capsys):
    spec = tmp_path / 'bad.yaml'
    spec.write_text('scenario: polar_two_link\nduration: 0.5\nepisodes: 2\ncontroller: {no_such: 1}\n')
    assert sweep.main(['run', str(spec), '--workers', '0', '--out', str(tmp_path / 'r')]) == 2
    assert 'controller.no_such' in capsys.readouterr().err
    spec.write_text('scenario: polar_two_link\nduration: 0.5\ncriteria: {rms: 1}\n')
    assert sweep.main(['run', str(spec), '--out', str(tmp_path / 'r')]) == 2
    assert 'criteria.rms' in capsys.readouterr().err


def test_the_table_gets_a_parquet_copy(tmp_path):
    from pyarrow import parquet
    rows, _ = sweep_engine.run_local(polar(episodes=2), tmp_path, workers=0, say=lambda t: None)
    table = parquet.read_table(tmp_path / 'episodes.parquet').to_pylist()
    assert [r['episode'] for r in table] == [0, 1] and table[1]['rms_error'] == rows[1]['rms_error']


def test_a_draw_the_parameter_refuses_is_an_episode_that_did_not_run_naming_it():
    p = sweep_episode.plan(polar(episodes=6, sample={'sim_params.m': {'normal': [0.2, 1.0]}}))
    rows = [sweep_episode.run(p, k) for k in range(6)]
    refused = [r for r in rows if r['sim_params.m'] <= 0]
    ran = [r for r in rows if r['sim_params.m'] > 0]
    assert refused and ran
    for r in refused:
        assert r['error'].startswith('sim_params.m: ') and not r['stable'] and not r['passed'] and r['ticks'] == 0
        assert math.isnan(r['rms_error'])
    assert all(r['error'] == '' and r['ticks'] == 601 for r in ran)


def test_a_sampled_control_period_sets_the_episode_s_ticks():
    p = sweep_episode.plan(polar(episodes=4, seed=2, sample={'sim_bridge/control_period': {'choice': [0.001, 0.002]}}))
    rows = [sweep_episode.run(p, k) for k in range(4)]
    assert {r['control_period'] for r in rows} == {0.001, 0.002}
    for r in rows:
        assert r['ticks'] == round(0.6 / r['control_period']) + 1 and r['stable'], r


def test_an_iiwa_episode_does_not_depend_on_the_episodes_its_worker_ran_before():
    text = {'experiment': 'iiwa_ptp', 'episodes': 3, 'duration': 0.3, 'seed': 3,
            'sample': {'controller/payload.mass': {'uniform': [0.0, 1.0]},
                       'sim_bridge/payload.mass': {'uniform': [0.0, 1.0]},
                       'noise.velocity_std': {'uniform': [0.0, 0.01]}}}
    p = sweep_episode.plan(sweep_spec.load(text))
    after = [sweep_episode.run(p, k) for k in range(3)][2]
    fresh = sweep_episode.run(sweep_episode.plan(sweep_spec.load(text)), 2)
    equal_rows(without_wall(after), without_wall(fresh))
    assert after['ticks'] == 301 and after['rms_error.lbr_iiwa_joint_7'] > 0


def test_sampled_controller_gains_reach_the_controller_s_design():
    p = sweep_episode.plan(polar(episodes=3, sample={'zeta': {'uniform': [1.0, 1.5]},
                                                     'omega_res': {'loguniform': [6.0, 24.0]}}))
    for k in range(3):
        _, values, drawn = sweep_episode.episode_values(p, k)
        gains = ConfigBuilder()(controller_params.TABLE.validate(values['controller'])).control_law.motion_gains
        w_n = 0.5 * drawn['omega_res']                             # omega_n: 0 = 0.5 omega_res
        assert np.allclose(gains.kp, w_n ** 2) and np.allclose(gains.kv, 2.0 * drawn['zeta'] * w_n)
    assert sweep_episode.run(p, 0)['stable']


def test_the_docs_distributions_parse_and_the_shipped_spec_plans():
    text = open(os.path.join(ROOT, 'docs', 'sweep.md'), encoding='utf-8').read()
    block = re.search(r'```yaml\n(sample:.*?)```', text, re.S).group(1)
    sample = yaml.safe_load(block)['sample']
    assert len([sweep_spec.distribution(k, v) for k, v in sample.items()]) == 9
    spec = sweep_spec.load(os.path.join(ROOT, 'config', 'sweeps', 'polar_mass_error.yaml'))
    p = sweep_episode.plan(spec)
    assert spec.episodes == 200 and p.experiment.scenario == 'polar_two_link' and p.coordinates == ('theta1', 'r')
    bench = sweep_spec.load(os.path.join(ROOT, 'config', 'sweeps', 'iiwa_typical.yaml'))     # make bench's B5
    p = sweep_episode.plan(bench)
    assert bench.episodes == 1000 and p.ticks == 3001 and p.values['sim_bridge']['armature'][0] == 0.1


def test_the_engine_is_a_sweep_parameter_and_both_engines_track_alike():
    """engine: {choice: [pybullet, mujoco]} (a string parameter's choice): each episode runs on the engine drawn,
    the table names it, and the same robot tracks alike on both (RMS within 1e-9 rad: the same semi-implicit Euler
    step of the same dynamics); the report gives ticks/s per engine; mixed choices are refused naming the key."""
    p = sweep_episode.plan(polar(episodes=4, seed=2, sample={'engine': {'choice': ['pybullet', 'mujoco']}}))
    rows = [sweep_episode.run(p, k) for k in range(4)]
    assert {r['engine'] for r in rows} == {'pybullet', 'mujoco'} and all(r['stable'] for r in rows)
    rms = [r['rms_error'] for r in rows]
    assert max(rms) - min(rms) < 1e-9 and min(rms) > 0
    assert set(sweep_report.ticks_per_s_by(rows, 'engine')) == {'pybullet', 'mujoco'}
    with pytest.raises(ArgumentError) as err:
        sweep_spec.load({'scenario': 'polar_two_link', 'sample': {'engine': {'choice': ['mujoco', 1.0]}}})
    assert err.value.name == 'sample.engine'
