"""`sweep tune` and `sweep grid`: gains scored on a seeded Monte Carlo batch (docs/sweep.md), no rclpy.

A gain choice g (controller parameter values) is scored on the spec's batch: episodes 0 .. B-1 of the
spec with `controller:` extended by g, run by the local engine (robot_control.tools.sweep_engine.run_local)
into RUN/batches/<spec digest>/. The batch's draws depend on the spec's seed and the episode index only, so
every choice meets the same B robots, and a batch cut short resumes where it stopped.

    objective_i(g) = P_p { m_i(episode) : episodes of the batch }     (m_i: rms_error, peak_torque, ...;
                                                                       P_p: the p-th percentile, the value
                                                                       of an episode (numpy's 'higher');
                                                                       one not finite counts as +inf)
    constraints(g) = (episodes not stable, saturated ticks summed)    feasible when both are 0

`tune`: Optuna (TPE, multi-objective, the constraints set per trial) minimises (objective_1, objective_2) over the
spec's `tune.parameters`; the study lives in RUN/study.db (SQLite), so a rerun continues it up to
`tune.trials` finished trials (a trial cut short by an interruption is run again, its finished episodes
kept). The chosen point of the Pareto front (the feasible trials no other feasible trial dominates):

    e* = min over the front of objective_1
    chosen = argmin objective_2 over the front's trials with objective_1 <= (1 + error_tolerance) e*

(ties: the smaller objective_1, then the earlier trial). It is written as RUN/gains.yaml, a `--params-file`
of the controller node (`/**/controller: ros__parameters:` the law, the spec's `controller:` overrides and
the chosen values), which is read back through the controller's parameter table and ConfigBuilder. With
`tune.evaluate: {episodes: N, seed: S}` that file (stacked after the spec's `config` files) is then scored on
N episodes of run seed S (robots the tune did not see) in RUN/evaluation/ (episodes.csv, summary.json, plots).

`grid`: every combination of the values of two controller parameters (`grid: {x_name: [...], y_name: [...]}`)
scored on the batch: its pass rate (robot_control.tools.sweep_report.summary), RUN/grid.csv, RUN/map.png.
"""
import csv
import fcntl
import hashlib
import itertools
import json
import math
import os
from pathlib import Path

import numpy as np
import yaml

from robot_control.tools import sweep_engine, sweep_episode, sweep_report
from robot_control.tools import sweep_spec as specs
from robot_control.validation import ArgumentError

TUNE_KEYS = ('parameters', 'trials', 'batch', 'percentile', 'objectives', 'start', 'error_tolerance', 'seed',
             'evaluate')
SEARCH_KINDS = ('uniform', 'loguniform', 'integers', 'choice')
CONSTRAINTS = ('unstable', 'saturated_ticks')      # Optuna's constraint names (trial.set_constraint)
OBJECTIVE_METRICS = ('rms_error', 'max_error', 'final_error', 'peak_torque', 'force_rms_error', 'force_max_error')


# -- the batch a gain choice is scored on ------------------------------------------------------------------------
def batch_spec(spec, gains, episodes):
    """The Spec of one gain choice: `spec` without tune/grid, `controller:` extended by `gains`, `episodes` long."""
    text = {k: v for k, v in spec.text.items() if k not in ('tune', 'grid')}
    text['controller'] = {**(text.get('controller') or {}), **gains}
    text['episodes'] = int(episodes)
    return specs.load(text)


def run_batch(spec, gains, episodes, out, workers):
    """The rows of the batch of gain choice `gains` ({controller parameter: value}), run or resumed in
    out/batches/<digest>."""
    one = batch_spec(spec, gains, episodes)
    with open(os.devnull, 'w') as quiet:
        rows, _ = sweep_engine.run_local(one, Path(out) / 'batches' / one.digest, workers,
                                         say=lambda text: None, stream=quiet)
    return one, rows


def percentile(rows, metric, p):
    """The p-th percentile of `metric` over the rows; a value that is not finite (unstable, not run) is +inf."""
    values = np.array([r[metric] for r in rows], dtype=float)
    values[~np.isfinite(values)] = np.inf
    return float(np.percentile(values, p, method='higher'))


def constraints(rows):
    """(episodes not stable, saturated ticks over the batch): the CONSTRAINTS, feasible when both are <= 0."""
    return (float(sum(not r['stable'] for r in rows)),
            float(sum(r['saturated_ticks'] for r in rows if isinstance(r['saturated_ticks'], int))))


# -- the tune section ------------------------------------------------------------------------------------------
def _number(where, value, kind=float, low=None):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind is int and not isinstance(value, int)) \
            or not math.isfinite(value) or (low is not None and value < low):
        raise ArgumentError(where, f'expected a {"whole " if kind is int else ""}number'
                                   f'{"" if low is None else f" >= {low}"}, got {value!r}')
    return kind(value)


def tune_settings(spec):
    """The spec's `tune` section, checked: {parameters: {name: Distribution}, trials, batch, percentile,
    objectives, start, error_tolerance, seed}."""
    t = spec.text.get('tune')
    if not isinstance(t, dict):
        raise ArgumentError('tune', 'expected a mapping with at least `parameters` (docs/sweep.md)')
    unknown = sorted(set(t) - set(TUNE_KEYS))
    if unknown:
        raise ArgumentError(f'tune.{unknown[0]}', f'unknown key; expected some of {list(TUNE_KEYS)}')
    params = t.get('parameters')
    if not isinstance(params, dict) or not params:
        raise ArgumentError('tune.parameters', 'expected {controller parameter: {uniform|loguniform|integers|'
                                               'choice: ...}}')
    search = {}
    for name, text in params.items():
        dist = specs.distribution(name, text)
        if dist.node or dist.kind not in SEARCH_KINDS or dist.clip:
            raise ArgumentError(f'tune.parameters.{name}', f'expected a controller parameter searched over one of '
                                                           f'{list(SEARCH_KINDS)}')
        if dist.kind != 'choice' and any(np.ndim(a) for a in dist.args):
            raise ArgumentError(f'tune.parameters.{name}', 'scalar bounds (relative: true scales an array)')
        search[name] = dist
    sampled = {d.name for d in spec.samples}
    if sampled & set(search):
        raise ArgumentError('tune.parameters', f'{sorted(sampled & set(search))} are also sampled')
    objectives = list(t.get('objectives', ['rms_error', 'peak_torque']))
    if len(objectives) != 2 or not set(objectives) <= set(OBJECTIVE_METRICS):
        raise ArgumentError('tune.objectives', f'expected [error metric, effort metric] of {list(OBJECTIVE_METRICS)}')
    start = t.get('start') or {}
    if not isinstance(start, dict) or set(start) - set(search):
        raise ArgumentError('tune.start', 'expected {searched parameter: value} (a factor when relative)')
    out = dict(parameters=search, objectives=objectives, start=start,
               trials=_number('tune.trials', t.get('trials', 30), int, 1),
               batch=_number('tune.batch', t.get('batch', spec.episodes), int, 1),
               percentile=_number('tune.percentile', t.get('percentile', 95), float, 0),
               error_tolerance=_number('tune.error_tolerance', t.get('error_tolerance', 0.1), float, 0),
               seed=_number('tune.seed', t.get('seed', spec.seed), int, 0))
    if out['percentile'] > 100:
        raise ArgumentError('tune.percentile', f'expected 0 .. 100, got {out["percentile"]}')
    ev = t.get('evaluate')
    if ev is not None:
        if not isinstance(ev, dict) or set(ev) - {'episodes', 'seed'}:
            raise ArgumentError('tune.evaluate', 'expected {episodes: N, seed: S}')
        out['evaluate'] = {'episodes': _number('tune.evaluate.episodes', ev.get('episodes', spec.episodes), int, 1),
                           'seed': _number('tune.evaluate.seed', ev.get('seed', spec.seed + 1), int, 0)}
    return out


def suggest(trial, name, dist):
    """Optuna's suggestion of searched parameter `name` (a factor when dist.relative)."""
    if dist.kind == 'choice':
        return trial.suggest_categorical(name, list(dist.args))
    lo, hi = (float(a) for a in dist.args)
    if dist.kind == 'integers':
        return trial.suggest_int(name, int(lo), int(hi))
    return trial.suggest_float(name, lo, hi, log=dist.kind == 'loguniform')


def gain_values(plan, search, suggested):
    """{controller parameter: value} of suggested values: a relative one times the parameter's base value
    (every entry of an array), an array one the same value in every entry of its base (as many as the
    motion coordinates when its base is empty, as kp's), an integer parameter rounded."""
    out = {}
    for name, dist in search.items():
        row = plan.tables['controller'][name]
        value = suggested[name]
        base = plan.values['controller'].get(name, row.default)
        if dist.relative:
            value = [float(value) * float(b) for b in base] if row.is_array else float(value) * float(base)
        elif row.is_array:
            value = [float(value)] * (len(base) or len(plan.coordinates))
        if row.type in ('integer', 'integer_array'):
            value = [int(round(v)) for v in value] if row.is_array else int(round(value))
        out[name] = value
    return out


#: tune keys that change no trial: a stored study goes on when only they change
NOT_IN_STUDY = ('trials', 'error_tolerance', 'evaluate')


def study_name(spec):
    """The stored study's name: a hash of the spec but its episode count and the tune keys NOT_IN_STUDY."""
    tune = {k: v for k, v in spec.text['tune'].items() if k not in NOT_IN_STUDY}
    text = {k: v for k, v in spec.text.items() if k not in ('episodes', 'tune')}
    return hashlib.sha256(json.dumps({**text, 'tune': tune}, sort_keys=True).encode()).hexdigest()[:16]


# -- the study ------------------------------------------------------------------------------------------------------
class Tuner:
    """One `sweep tune` run directory: the spec, its settings, the Optuna study in out/study.db."""

    def __init__(self, spec, out, workers=1, trials=None):
        import optuna
        self.optuna = optuna
        self.spec, self.out, self.workers = spec, Path(out), workers
        self.settings = tune_settings(spec)
        if trials is not None:
            self.settings['trials'] = _number('--trials', trials, int, 1)
        self.plan = sweep_episode.plan(batch_spec(spec, {}, self.settings['batch']))
        for name in self.settings['parameters']:
            if name not in self.plan.tables['controller']:
                raise ArgumentError(f'tune.parameters.{name}', 'not a parameter of the controller for this scenario')
        self.out.mkdir(parents=True, exist_ok=True)
        self._lock = open(self.out / 'tune.lock', 'w')
        try:
            try:
                fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise ArgumentError('out', f'{self.out} is being tuned by another process') from None
            self.study = self._study()
        except BaseException:
            self.close()
            raise

    def _study(self):
        """The stored study of this spec (created on the first run), its sampler seeded past its trials."""
        optuna = self.optuna
        optuna.logging.set_verbosity(optuna.logging.WARNING)
        storage, name = f'sqlite:///{self.out / "study.db"}', study_name(self.spec)
        others = [n for n in optuna.get_all_study_names(storage) if n != name]
        if others:
            raise ArgumentError('out', f'{self.out} holds a tune of another spec (study {others[0]}, this one '
                                       f'{name}): choose another --out')
        study = optuna.create_study(study_name=name, storage=storage, load_if_exists=True,
                                    directions=['minimize', 'minimize'])
        done = sum(t.state.name == 'COMPLETE' for t in study.get_trials(deepcopy=False))
        s = self.settings
        study.sampler = optuna.samplers.TPESampler(      # seeded past the trials stored: a resumed run draws anew
            seed=s['seed'] + done, multivariate=True, n_startup_trials=max(2, min(10, s['trials'] // 3)))
        return study

    def close(self):
        """Release the run directory (its lock)."""
        self._lock.close()

    def trials(self, states=('COMPLETE',)):
        return [t for t in self.study.get_trials(deepcopy=False) if t.state.name in states]

    def recover(self):
        """Trials an interrupted run left RUNNING: failed, and their values asked for again (first)."""
        stale = self.trials(('RUNNING',))
        for t in stale:
            self.study.tell(t.number, state=self.optuna.trial.TrialState.FAIL)
            self.study.enqueue_trial(t.params, user_attrs={'retry_of': t.number})
        if not self.study.trials and self.settings['start']:
            self.study.enqueue_trial(self.settings['start'], user_attrs={'start': True})
        return len(stale)

    def objective(self, trial):
        s = self.settings
        gains = gain_values(self.plan, s['parameters'],
                            {n: suggest(trial, n, d) for n, d in s['parameters'].items()})
        one, rows = run_batch(self.spec, gains, s['batch'], self.out, self.workers)
        trial.set_user_attr('gains', gains)
        for key, value in zip(CONSTRAINTS, constraints(rows)):
            trial.set_constraint(key, value)
        trial.set_user_attr('pass_rate', sweep_report.summary(rows, one, [])['pass_rate'])
        trial.set_user_attr('batch', one.digest)
        return tuple(percentile(rows, m, s['percentile']) for m in s['objectives'])

    def run(self, say=print):
        """Run trials until `trials` have finished (resuming the stored study); returns the number run here."""
        if self.recover():
            say(f'[tune] {self.out}: a trial cut short is run again')
        done = len(self.trials())
        if done:
            say(f'[tune] resuming {self.out}: {done} trials done, {max(0, self.settings["trials"] - done)} to run')
        ran = 0
        while len(self.trials()) < self.settings['trials']:
            self.study.optimize(self.objective, n_trials=1)
            ran += 1
            t = self.study.trials[-1]
            if t.state.name == 'COMPLETE':
                say(f'[tune] trial {t.number}: {describe(t, self.settings)}')
        return ran


def feasible(trial):
    return all(c <= 0 for c in trial.constraints.values())


def pareto_front(trials):
    """The feasible trials no other feasible trial dominates (<= in both objectives, < in one), by number."""
    ok = [t for t in trials if feasible(t)]
    return [t for t in ok if not any(all(a <= b for a, b in zip(o.values, t.values))
                                     and any(a < b for a, b in zip(o.values, t.values)) for o in ok)]


def choose(front, tolerance):
    """The chosen trial of a Pareto front (module docstring): the least objective_2 among the trials within
    (1 + tolerance) of the front's least objective_1; None for an empty front."""
    if not front:
        return None
    best = min(t.values[0] for t in front)
    near = [t for t in front if t.values[0] <= (1 + tolerance) * best]
    return min(near, key=lambda t: (t.values[1], t.values[0], t.number))


def describe(t, s):
    p = f'p{s["percentile"]:g}'
    gains = ', '.join(f'{k} {v:.4g}' for k, v in t.params.items())
    verdict = 'feasible' if feasible(t) else ', '.join(f'{k} {t.constraints[k]:.0f}' for k in CONSTRAINTS)
    return (f'{gains}: {p} {s["objectives"][0]} {t.values[0]:.4g}, {p} {s["objectives"][1]} {t.values[1]:.4g}, '
            f'pass rate {100 * t.user_attrs["pass_rate"]:.0f} %, {verdict}')


# -- what a tune writes ----------------------------------------------------------------------------------------
def nested(flat):
    """{'a.b': 1} -> {'a': {'b': 1}}: parameter names as the nested keys of a `ros__parameters` section."""
    out = {}
    for name, value in flat.items():
        *path, leaf = name.split('.')
        node = out
        for key in path:
            node = node.setdefault(key, {})
        node[leaf] = value
    return out


class _Dumper(yaml.SafeDumper):
    """YAML as config/*.yaml writes it: mappings as blocks, lists inline."""


_Dumper.add_representer(list, lambda d, v: d.represent_sequence('tag:yaml.org,2002:seq', v, flow_style=True))


def controller_files(spec, scenario):
    """The spec's `config` files that hold a controller section (a realism profile holds the bridge's only)."""
    out = []
    for name in spec.text.get('config') or ():
        path = sweep_episode.parameter_file(name, scenario)
        if sweep_episode.SECTIONS['controller'] in (yaml.safe_load(path.read_text()) or {}):
            out.append(name)
    return out


def gains_yaml(tuner, trial, path):
    """Write the chosen trial as a controller `--params-file` (module docstring) and read it back: the spec's
    files then it, through the controller's parameter table and ConfigBuilder; returns the file's parameters."""
    s, spec = tuner.settings, tuner.spec
    params = {'law': tuner.plan.values['controller']['law'], **(spec.text.get('controller') or {}),
              **trial.user_attrs['gains']}
    p = f'p{s["percentile"]:g}'
    scenario = tuner.plan.experiment.scenario
    files = ' '.join(f'--params-file {f}' for f in [f'config/{scenario}.yaml', *controller_files(spec, scenario)])
    head = [f'# sweep tune: trial {trial.number} of {len(tuner.trials())}, the least {s["objectives"][1]} among the '
            f'Pareto front within {100 * s["error_tolerance"]:g} % of its best {s["objectives"][0]}:',
            f'# {p} {s["objectives"][0]} {trial.values[0]:.6g}, {p} {s["objectives"][1]} {trial.values[1]:.6g}, '
            f'pass rate {100 * trial.user_attrs["pass_rate"]:.1f} % over {s["batch"]} episodes (seed {spec.seed}).',
            f'# ros2 run robot_control controller_node --ros-args {files} --params-file {path.name}']
    text = yaml.dump({'/**/controller': {'ros__parameters': nested(params)}}, Dumper=_Dumper, sort_keys=False)
    path.write_text('\n'.join(head) + '\n' + text)
    p_check = sweep_episode.plan(file_spec(spec, path, 1, spec.seed))   # the table validates, ConfigBuilder builds
    for name, value in params.items():
        if p_check.values['controller'].get(name) != value:
            raise RuntimeError(f'{path}: {name} reads back as {p_check.values["controller"].get(name)!r}, '
                               f'not {value!r}')
    return params


def file_spec(spec, path, episodes, seed):
    """The spec run with the gains file `path` stacked after its `config` files in place of its `controller:`
    overrides (the file holds them), `episodes` of run seed `seed`."""
    return batch_spec(specs.load({**spec.text, 'config': [*(spec.text.get('config') or ()), str(Path(path).resolve())],
                                  'controller': {}, 'seed': seed}), {}, episodes)


def evaluate(tuner, path, workers):
    """The gains file scored on tune.evaluate's episodes (another seed than the batch's: robots the tune did not
    see), run in out/evaluation/<hash of its parameters> with its summary and plots: (the summary, that directory)."""
    ev = tuner.settings['evaluate']
    one = file_spec(tuner.spec, path, ev['episodes'], ev['seed'])
    values = json.dumps(yaml.safe_load(Path(path).read_text()), sort_keys=True)      # not its comments
    where = tuner.out / 'evaluation' / hashlib.sha256(values.encode()).hexdigest()[:16]
    with open(os.devnull, 'w') as quiet:
        rows, _ = sweep_engine.run_local(one, where, workers, say=lambda text: None, stream=quiet)
    return sweep_report.write(where, rows, one, []), where


def trial_table(tuner, front, chosen, path):
    """trials.csv: every finished trial's number, searched values, objectives, constraints, pass rate, verdicts."""
    names = list(tuner.settings['parameters'])
    ids = {t.number for t in front}
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['trial', *names, *tuner.settings['objectives'], *CONSTRAINTS, 'pass_rate',
                    'feasible', 'pareto', 'chosen', 'start'])
        for t in tuner.trials():
            w.writerow([t.number, *(t.params[n] for n in names), *t.values, *(t.constraints[k] for k in CONSTRAINTS),
                        t.user_attrs['pass_rate'], feasible(t), t.number in ids,
                        chosen is not None and t.number == chosen.number, bool(t.user_attrs.get('start'))])


def pareto_plot(tuner, front, chosen, path):
    """pareto.png: objective_2 against objective_1 of every finished trial; the front joined, the chosen marked."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    s = tuner.settings
    trials = tuner.trials()
    fig = Figure(figsize=(6.4, 4.6), layout='constrained')
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ok = np.array([t.values for t in trials if feasible(t)], dtype=float).reshape(-1, 2)
    bad = np.array([t.values for t in trials if not feasible(t)], dtype=float).reshape(-1, 2)
    lo, hi = (ok.min(axis=0), ok.max(axis=0)) if len(ok) else (np.zeros(2), np.full(2, np.inf))
    span = np.maximum(hi - lo, 0.1 * np.abs(hi))
    lo, hi = lo - 0.15 * span, hi + 0.15 * span            # the axes: the feasible trials, 15 % around
    inside = np.all((bad >= lo) & (bad <= hi), axis=1) if len(ok) else np.all(np.isfinite(bad), axis=1)
    ax.scatter(ok[:, 0], ok[:, 1], s=18, color='tab:blue', marker='o', label='feasible')
    ax.scatter(bad[inside, 0], bad[inside, 1], s=18, color='tab:red', marker='x',
               label=f'unstable or saturated ({int(np.sum(~inside))} more off the axes)')
    if len(ok):
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    if front:
        pts = np.array(sorted(t.values for t in front))
        ax.step(pts[:, 0], pts[:, 1], where='post', color='k', lw=1.0, label=f'Pareto front ({len(front)})')
    starts = [t for t in trials if t.user_attrs.get('start')]
    for t in starts:
        ax.scatter(*t.values, s=90, facecolors='none', edgecolors='tab:orange', lw=1.5, label='start')
    if chosen is not None:
        ax.scatter(*chosen.values, s=160, marker='*', color='gold', edgecolors='k', zorder=5,
                   label=f'chosen (trial {chosen.number})')
    p = f'p{s["percentile"]:g}'
    ax.set_xlabel(f'{p} {s["objectives"][0]} over {s["batch"]} episodes (rad or m)')
    ax.set_ylabel(f'{p} {s["objectives"][1]} (N m or N)')
    ax.set_title(f'{len(trials)} trials: {", ".join(s["parameters"])}', fontsize='medium')
    ax.grid(True, alpha=0.35)
    ax.legend(fontsize='small')
    fig.savefig(path, dpi=100)


def finish(tuner):
    """trials.csv, pareto.png, tune.json and (when a trial is feasible) gains.yaml; returns tune.json's dict."""
    front = sorted(pareto_front(tuner.trials()), key=lambda t: t.values[0])
    chosen = choose(front, tuner.settings['error_tolerance'])
    trial_table(tuner, front, chosen, tuner.out / 'trials.csv')
    pareto_plot(tuner, front, chosen, tuner.out / 'pareto.png')
    result = {'trials': len(tuner.trials()), 'batch': tuner.settings['batch'], 'seed': tuner.spec.seed,
              'percentile': tuner.settings['percentile'], 'objectives': tuner.settings['objectives'],
              'front': [t.number for t in front], 'chosen': None}
    if chosen is not None:
        params = gains_yaml(tuner, chosen, tuner.out / 'gains.yaml')
        result['chosen'] = {'trial': chosen.number, 'values': list(chosen.values), 'searched': chosen.params,
                            'parameters': params, 'pass_rate': chosen.user_attrs['pass_rate']}
        if 'evaluate' in tuner.settings:
            s, where = evaluate(tuner, tuner.out / 'gains.yaml', tuner.workers)
            result['evaluation'] = {k: s[k] for k in ('episodes', 'seed', 'passed', 'pass_rate', 'stable')}
            result['evaluation']['directory'] = str(where)
    starts = [t for t in tuner.trials() if t.user_attrs.get('start')]
    if starts:
        result['start'] = {'trial': starts[0].number, 'values': list(starts[0].values),
                           'feasible': feasible(starts[0]), 'pass_rate': starts[0].user_attrs['pass_rate']}
    (tuner.out / 'tune.json').write_text(json.dumps(sweep_report._json(result), indent=1, allow_nan=False))
    return result


# -- the grid ---------------------------------------------------------------------------------------------------
def grid_settings(spec):
    """The spec's `grid`: two controller parameters and their values, {x_name: [...], y_name: [...]}."""
    g = spec.text.get('grid')
    if not isinstance(g, dict) or len(g) != 2 or not all(
            isinstance(v, list) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
            for v in g.values()):
        raise ArgumentError('grid', 'expected {x parameter: [values], y parameter: [values]} (two controller '
                                    'parameters)')
    return list(g.items())


def run_grid(spec, out, workers=1, say=print):
    """Every cell of the spec's grid scored on the spec's episodes; writes grid.csv and map.png in `out`,
    returns [(x, y, pass_rate, summary)]."""
    (xn, xs), (yn, ys) = grid_settings(spec)
    out = Path(out)
    cells = []
    for y, x in itertools.product(ys, xs):
        one, rows = run_batch(spec, {xn: x, yn: y}, spec.episodes, out, workers)
        s = sweep_report.summary(rows, one, [])
        cells.append((x, y, s['pass_rate'], s))
        say(f'[grid] {xn} {x:g}, {yn} {y:g}: pass rate {100 * s["pass_rate"]:.0f} % ({s["passed"]}/{s["episodes"]}), '
            f'stable {s["stable"]}')
    with open(out / 'grid.csv', 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow([xn, yn, 'episodes', 'passed', 'pass_rate', 'stable', 'p95_max_error', 'p95_final_error'])
        for x, y, rate, s in cells:
            pct = s['percentiles']
            w.writerow([x, y, s['episodes'], s['passed'], rate, s['stable'],
                        pct.get('max_error', {}).get('p95', math.nan), pct.get('final_error', {}).get('p95', math.nan)])
    grid_map(cells, (xn, xs), (yn, ys), spec, out / 'map.png')
    return cells


def grid_map(cells, x, y, spec, path):
    """map.png: the pass rate of every cell, a colour map annotated in %."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    (xn, xs), (yn, ys) = x, y
    rate = np.array([c[2] for c in cells], dtype=float).reshape(len(ys), len(xs))
    fig = Figure(figsize=(1.0 * len(xs) + 2.2, 0.6 * len(ys) + 1.8), layout='constrained')
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    im = ax.imshow(100 * rate, origin='lower', cmap='RdYlGn', vmin=0, vmax=100, aspect='auto')
    for (i, j), v in np.ndenumerate(rate):
        ax.text(j, i, f'{100 * v:.0f}', ha='center', va='center', fontsize='small')
    ax.set_xticks(range(len(xs)), [f'{v:g}' for v in xs])
    ax.set_yticks(range(len(ys)), [f'{v:g}' for v in ys])
    ax.set_xlabel(xn)
    ax.set_ylabel(yn)
    crit = ', '.join(f'{k} <= {v:g}' for k, v in spec.criteria.items())
    ax.set_title(f'pass rate (%) over {spec.episodes} episodes: stable, {crit}', fontsize='small')
    fig.colorbar(im, ax=ax, label='pass rate, %')
    fig.savefig(path, dpi=100)


# -- the commands ---------------------------------------------------------------------------------------------
def cmd_tune(opts):
    spec = specs.load(opts.spec)
    out = Path(opts.out or Path('out') / 'tune' / Path(opts.spec).stem)
    tuner = Tuner(spec, out, opts.workers, opts.trials)
    try:
        ran = tuner.run()
        result = finish(tuner)
    finally:
        tuner.close()
    print(f'{result["trials"]} trials ({ran} run here), Pareto front: trials {result["front"]}')
    if result['chosen'] is None:
        print('no trial is feasible (every one had an unstable episode or a saturated tick): no gains.yaml')
        return 1
    chosen = next(t for t in tuner.trials() if t.number == result['chosen']['trial'])
    print(f'chosen: trial {chosen.number}: {describe(chosen, tuner.settings)}')
    if 'evaluation' in result:
        e = result['evaluation']
        print(f'gains.yaml on {e["episodes"]} other episodes (seed {e["seed"]}): passed {e["passed"]} '
              f'({100 * e["pass_rate"]:.1f} %), stable {e["stable"]}: {e["directory"]}/summary.json')
    print(f'results: {out}/gains.yaml, pareto.png, trials.csv, tune.json, study.db')
    return 0


def cmd_grid(opts):
    spec = specs.load(opts.spec)
    out = Path(opts.out or Path('out') / 'grid' / Path(opts.spec).stem)
    run_grid(spec, out, opts.workers)
    print(f'results: {out}/grid.csv, map.png')
    return 0


def add_commands(sub):
    """The `tune` and `grid` subcommands of `sweep`'s parser."""
    t = sub.add_parser('tune', help="tune the controller's gains with Optuna on a Monte Carlo batch (resumes)")
    t.add_argument('spec', help='the spec, YAML, with a tune section (docs/sweep.md)')
    t.add_argument('--workers', type=int, default=1, help='worker processes per batch (0: in this process)')
    t.add_argument('--out', default=None, help='run directory (default out/tune/<spec name>)')
    t.add_argument('--trials', type=int, default=None, help="override tune.trials (finished trials in all)")
    t.set_defaults(func=cmd_tune)
    g = sub.add_parser('grid', help='the pass rate of every combination of two controller parameters: a map')
    g.add_argument('spec', help='the spec, YAML, with a grid section (docs/sweep.md)')
    g.add_argument('--workers', type=int, default=1, help='worker processes per cell (0: in this process)')
    g.add_argument('--out', default=None, help='run directory (default out/grid/<spec name>)')
    g.set_defaults(func=cmd_grid)
