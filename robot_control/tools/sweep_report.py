"""A sweep's results: the summary (pass rate, percentiles, the worst episodes) and its plots (no rclpy).

summary.json:
    episodes, passed, pass_rate          episodes run, those that passed (stable and every criterion met)
    stable                               episodes whose error stayed bounded and finite
    criteria                             {metric: upper limit} of the spec
    percentiles                          {metric: {p0, p5, p50, p95, p99, p100}} over the episodes that ran
    worst                                the WORST episodes: the largest criterion ratio metric / limit
                                         (unstable first; without criteria: the largest rms_error), each with
                                         its episode index, seed, sampled values and metrics
Plots: histograms.png (each metric over the episodes) and metrics_vs_parameters.png (each metric against
each sampled parameter, failed episodes in red).
"""
import json
import math

import numpy as np

from robot_control.tools.sweep_episode import METRICS

WORST = 5
PERCENTILES = (0, 5, 50, 95, 99, 100)
PLOTTED = ('rms_error', 'max_error', 'final_error', 'peak_torque', 'saturated_ticks', 'force_rms_error')


def _finite(rows, key):
    values = np.array([r[key] for r in rows if isinstance(r.get(key), (int, float))], dtype=float)
    return values[np.isfinite(values)]


def badness(row, criteria):
    """How far an episode is from passing: inf when unstable or it did not run; else the largest
    metric / limit over the criteria (> 1 fails), or its rms_error without criteria."""
    if not row['stable']:
        return math.inf
    if not criteria:
        return row['rms_error']
    return max(row[k] / limit if limit else (math.inf if row[k] > 0 else 0.0) for k, limit in criteria.items())


def summary(rows, spec, sampled):
    """The summary dict of a run's rows (every episode once); `sampled`: the sampled columns."""
    n = len(rows)
    passed = sum(bool(r['passed']) for r in rows)
    pct = {}
    for key in METRICS[:-2]:
        values = _finite(rows, key)
        if values.size:
            pct[key] = {f'p{q}': float(np.percentile(values, q)) for q in PERCENTILES}
    worst = sorted(rows, key=lambda r: (-badness(r, spec.criteria), r['episode']))[:WORST]
    keep = ['episode', 'seed', *sampled, *METRICS, 'error']
    return {'episodes': n, 'passed': passed, 'pass_rate': passed / n if n else math.nan,
            'stable': sum(bool(r['stable']) for r in rows), 'criteria': dict(spec.criteria),
            'seed': spec.seed, 'percentiles': pct,
            'worst': [{k: r[k] for k in keep} | {'badness': badness(r, spec.criteria)} for r in worst]}


def format_summary(s, sampled):
    """The summary as text (`sweep run` prints it)."""
    crit = ', '.join(f'{k} <= {v:g}' for k, v in s['criteria'].items()) or 'none (stability only)'
    lines = [f'episodes {s["episodes"]}, passed {s["passed"]} ({100 * s["pass_rate"]:.1f} %), '
             f'stable {s["stable"]}; criteria: {crit}',
             f'  {"metric":<16} ' + ' '.join(f'{"p" + str(q):>10}' for q in PERCENTILES)]
    for key, p in s['percentiles'].items():
        lines.append(f'  {key:<16} ' + ' '.join(f'{p["p" + str(q)]:>10.4g}' for q in PERCENTILES))
    lines.append(f'worst {len(s["worst"])} episodes (episode, seed, sampled values, verdict):')
    for w in s['worst']:
        values = ', '.join(f'{c} {w[c]}' if isinstance(w[c], str) else f'{c} {w[c]:.4g}' for c in sampled)
        verdict = 'passed' if w['passed'] else ('unstable' if not w['stable'] else 'failed')
        lines.append(f'  #{w["episode"]} seed {w["seed"]}: {values}; rms_error {w["rms_error"]:.4g}, '
                     f'max_error {w["max_error"]:.4g}, peak_torque {w["peak_torque"]:.4g}: {verdict}'
                     + (f' ({w["error"]})' if w['error'] else ''))
    return '\n'.join(lines)


def _json(value):
    """A summary value as strict JSON takes it: NaN -> null (a metric the episode has not), inf -> "inf"."""
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else str(value)
    return value


def ticks_per_s_by(rows, column):
    """{value of `column`: control ticks per second of wall time of the episodes run with it (sum of ticks / sum
    of wall_s, each episode in its own process's time)}, e.g. per engine."""
    out = {}
    for value in sorted({r[column] for r in rows}):
        runs = [r for r in rows if r[column] == value and r['wall_s'] > 0]
        out[value] = sum(r['ticks'] for r in runs) / sum(r['wall_s'] for r in runs) if runs else math.nan
    return out


def _axis(rows, col):
    """(x (n,) float, labels or None) of a sampled column: numbers as they are, strings (e.g. engine) as the index
    of the value among `labels`, its sorted values."""
    values = [r[col] for r in rows]
    if not any(isinstance(v, str) for v in values):
        return np.array(values, dtype=float), None
    labels = sorted(set(values))
    return np.array([labels.index(v) for v in values], dtype=float), labels


def write(out, rows, spec, sampled):
    """summary.json and the plots in directory `out`; returns the summary."""
    s = summary(rows, spec, sampled)
    (out / 'summary.json').write_text(json.dumps(_json(s), indent=1, allow_nan=False))
    plots(out, rows, sampled)
    return s


def plots(out, rows, sampled):
    """histograms.png and metrics_vs_parameters.png in `out` (metrics with a finite value only)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    metrics = [k for k in PLOTTED if _finite(rows, k).size]
    if not metrics:
        return
    fig = Figure(figsize=(3.2 * len(metrics), 2.8), layout='constrained')
    FigureCanvasAgg(fig)
    for ax, key in zip(fig.subplots(1, len(metrics), squeeze=False)[0], metrics):
        ax.hist(_finite(rows, key), bins=min(30, max(5, len(rows) // 3)))
        ax.set_xlabel(key)
        ax.grid(True, alpha=0.35)
    fig.savefig(out / 'histograms.png', dpi=100)
    if not sampled:
        return
    fig = Figure(figsize=(3.0 * len(sampled) + 0.5, 2.4 * len(metrics) + 0.5), layout='constrained')
    FigureCanvasAgg(fig)
    grid = fig.subplots(len(metrics), len(sampled), squeeze=False)
    ok = np.array([bool(r['passed']) for r in rows])
    for i, key in enumerate(metrics):
        y = np.array([r[key] for r in rows], dtype=float)
        for j, col in enumerate(sampled):
            ax = grid[i, j]
            x, labels = _axis(rows, col)
            ax.scatter(x[ok], y[ok], s=8, color='tab:blue', label='passed')
            ax.scatter(x[~ok], y[~ok], s=8, color='tab:red', label='failed')
            ax.grid(True, alpha=0.35)
            if labels:
                ax.set_xticks(range(len(labels)), labels)
            elif np.all(x > 0) and x.max() > 100 * x.min():      # a log-uniform parameter, say
                ax.set_xscale('log')
            if i == len(metrics) - 1:
                ax.set_xlabel(col)
            if j == 0:
                ax.set_ylabel(key)
    grid[0, 0].legend(fontsize='small')
    fig.savefig(out / 'metrics_vs_parameters.png', dpi=100)
