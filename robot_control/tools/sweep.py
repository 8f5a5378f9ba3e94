"""`sweep`: Monte Carlo runs of an experiment over uncertain parameters, in process (docs/sweep.md).

    sweep run SPEC.yaml [--workers N | --ray auto|ADDRESS] [--out DIR] [--episodes N] [--seed S]
    sweep replay RUN K [--format npz|csv]
    sweep tune SPEC.yaml [--workers N] [--out DIR] [--trials N]     (robot_control.tools.sweep_tune)
    sweep grid SPEC.yaml [--workers N] [--out DIR]

`run` runs the spec's episodes (each the rclpy-free Controller and the bridge's World in lockstep,
robot_control.tools.sweep_episode) on N local worker processes (robot_control.tools.sweep_engine) or as
tasks on a Ray cluster (robot_control.tools.sweep_ray),
resuming a run directory that holds finished episodes, and writes episodes.csv, summary.json and the
plots (robot_control.tools.sweep_report); the summary is printed. `replay` reruns episode K of a run
directory, checks that its metrics equal its row bit for bit, and writes its trajectory and tracking
figure (RUN/replay/episode_K.npz or .csv, episode_K_tracking.png). Exit 0; 1 when a replay differs
from its row; 2 on a bad spec or argument (the reason on stderr).
"""
import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

from robot_control.tools import demo_metrics, sweep_engine, sweep_episode, sweep_report, sweep_spec, sweep_tune
from robot_control.validation import ArgumentError

TRACE = ('t', 'q', 'qd', 'tau_cmd', 'tau_applied', 'ref_pos', 'ref_vel', 'err_pos', 'err_vel', 'force_xyz')
NOT_REPLAYED = sweep_episode.RUN_COLUMNS       # the only columns a replay may change


def sampled_columns(columns):
    """The sampled-value columns among a table's columns (between seed and the metrics)."""
    return columns[2:columns.index(sweep_episode.METRICS[0])]


def cmd_run(opts):
    spec = sweep_spec.load(opts.spec)
    if opts.episodes is not None:
        spec = spec.with_episodes(opts.episodes)
    if opts.seed is not None:
        spec = sweep_spec.load({**spec.text, 'seed': opts.seed})
    out = Path(opts.out or Path('out') / 'sweep' / Path(opts.spec).stem)
    if opts.ray:
        from robot_control.tools import sweep_ray
        rows, progress = sweep_ray.run_ray(spec, out, opts.ray)
        engine = f'on the Ray cluster at {opts.ray}'
    else:
        rows, progress = sweep_engine.run_local(spec, out, opts.workers)
        engine = f'with {opts.workers} worker(s)'

    columns = sweep_episode.columns(sweep_episode.plan(spec))
    sampled = sampled_columns(columns)
    s = sweep_report.write(out, rows, spec, sampled)
    eps, ticks = progress.rates
    print(sweep_report.format_summary(s, sampled))
    if progress.new:
        print(f'{progress.new} episodes run here: {eps:.2f} episodes/s, {ticks:,.0f} ticks/s {engine}')
    if 'engine' in sampled:
        print('in the episodes, per engine: ' + ', '.join(f'{name} {rate:,.0f} ticks/s' for name, rate in
                                                          sweep_report.ticks_per_s_by(rows, 'engine').items()))
    print(f'results: {out}/episodes.csv, summary.json, histograms.png, metrics_vs_parameters.png')
    return 0


def read_row(run, k):
    """Row k of RUN/episodes.csv, or ArgumentError."""
    with open(Path(run) / 'episodes.csv', newline='') as f:
        for row in csv.DictReader(f):
            if int(row['episode']) == k:
                return {c: sweep_engine.parse(v) for c, v in row.items()}
    raise ArgumentError('K', f'episode {k} is not in {run}/episodes.csv')


def same(a, b):
    """Equal values, NaN equal to NaN (bit for bit for floats: repr round-trips)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def write_trace(data, path, fmt):
    """The episode's per-tick arrays as .npz, or as one .csv (one column per entry)."""
    arrays = {k: np.asarray(getattr(data, k)) for k in TRACE}
    if fmt == 'npz':
        np.savez(path.with_suffix('.npz'), **arrays)
        return path.with_suffix('.npz')
    cols, names = [], []
    for k, a in arrays.items():
        a = a.reshape(a.shape[0], -1)
        cols.append(a)
        names += [k] if a.shape[1] == 1 and k == 't' else [f'{k}[{i}]' for i in range(a.shape[1])]
    np.savetxt(path.with_suffix('.csv'), np.hstack(cols), delimiter=',', header=','.join(names), comments='')
    return path.with_suffix('.csv')


def cmd_replay(opts):
    from robot_control.tools.plot import tracking_figure
    run = Path(opts.run)
    spec = sweep_spec.load(str(run / 'spec.yaml'))
    p = sweep_episode.plan(spec)
    stored = read_row(run, opts.k)
    row, data = sweep_episode.run(p, opts.k, keep=True)
    differ = [c for c in stored if c not in NOT_REPLAYED and not same(stored[c], row[c])]
    out = run / 'replay'
    out.mkdir(exist_ok=True)
    if data is not None:
        path = write_trace(data, out / f'episode_{opts.k}', opts.format)
        png = out / f'episode_{opts.k}_tracking.png'
        tracking_figure(demo_metrics.plot_data(data, p.experiment, f'episode {opts.k}, seed {row["seed"]}'), png)
        print(f'trajectory: {path}\nfigure: {png}')
    if differ:
        print(f'episode {opts.k} differs from its row in {differ}', file=sys.stderr)
        return 1
    print(f'episode {opts.k} (seed {row["seed"]}) replayed: every metric equals its row bit for bit')
    return 0


def parser():
    p = argparse.ArgumentParser(prog='sweep', description='Monte Carlo runs of an experiment over uncertain '
                                                          'parameters, in process (docs/sweep.md).')
    sub = p.add_subparsers(dest='command', required=True)
    r = sub.add_parser('run', help='run (or resume) the episodes of a spec')
    r.add_argument('spec', help='the spec, YAML (docs/sweep.md)')
    r.add_argument('--workers', type=int, default=1, help='worker processes (0: in this process; default 1)')
    r.add_argument('--out', default=None, help='run directory (default out/sweep/<spec name>)')
    r.add_argument('--ray', metavar='ADDRESS', default=None,
                   help="run the episodes as tasks on a running Ray cluster: its head's HOST:PORT, or auto "
                        '(RAY_ADDRESS, or a cluster started on this machine); --workers is then ignored')
    r.add_argument('--episodes', type=int, default=None, help="override the spec's episode count")
    r.add_argument('--seed', type=int, default=None, help="override the spec's run seed")
    r.set_defaults(func=cmd_run)
    y = sub.add_parser('replay', help='rerun one episode of a run: its trajectory and figure')
    y.add_argument('run', help='the run directory')
    y.add_argument('k', type=int, metavar='K', help='the episode index')
    y.add_argument('--format', choices=('npz', 'csv'), default='npz')
    y.set_defaults(func=cmd_replay)
    sweep_tune.add_commands(sub)
    return p


def main(argv=None):
    opts = parser().parse_args(argv)
    if getattr(opts, 'workers', 1) < 0:
        print('sweep: --workers: expected >= 0', file=sys.stderr)
        return 2
    try:
        return opts.func(opts)
    except ArgumentError as exc:
        print(f'sweep: {exc.name}: {exc.reason}', file=sys.stderr)
        return 2
