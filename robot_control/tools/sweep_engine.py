"""Running a sweep's episodes: local worker processes (forks of a forkserver, or spawned; or this process),
results appended as they finish, resumed without redoing finished episodes, and a worker that dies costs
only the episodes it had.

The run directory holds spec.yaml (the spec as read), run.json (its digest and the table's columns) and
episodes.csv (one row per finished episode, appended by this process only, in the order they finish; sorted
by episode when the run completes). On a restart the episodes in episodes.csv are skipped; a last line cut
short by an interruption is dropped. A worker process that dies (killed, crashed) breaks the pool: the
episodes that finished are kept, the pool is rebuilt and the unfinished ones run again, so every episode is
in the table exactly once. Episodes are deterministic (robot_control.tools.sweep_spec), so a rerun gives the
same row as a clean run, whichever worker runs it.

The engines are `run_local` (processes of this machine) and robot_control.tools.sweep_ray (a Ray cluster);
both go through `run_with`, which keeps the one writer (`RunDirectory.append`, then `finish`), skips the
episodes already in the table and takes each episode's row once. A worker runs `_init(spec text)` once
per process, then `episode(k)` -> the row.
"""
import concurrent.futures as cf
import csv
import io
import json
import math
import multiprocessing
import os
import sys
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import yaml

from robot_control.tools import sweep_episode, sweep_spec
from robot_control.validation import ArgumentError

MAX_POOL_RESTARTS = 10       # rebuilds of a pool whose worker died, in all
MAX_IDLE_RESTARTS = 2        # ... in a row without a finished episode (a worker that cannot start)
PROGRESS_PERIOD = 0.5         # s of wall time between progress lines on a terminal (rewritten in place)
LOG_PERIOD = 10.0             # ... into a file or pipe (one line each)


def parse(text):
    """A CSV cell back to the value written: int, float (repr round-trips bit for bit), bool or str."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return {'True': True, 'False': False}.get(text, text)


class RunDirectory:
    """A run's directory (see the module docstring) for a Spec and its Plan."""

    def __init__(self, path, spec, columns):
        self.path = Path(path)
        self.spec, self.columns = spec, list(columns)
        self.table = self.path / 'episodes.csv'
        self.path.mkdir(parents=True, exist_ok=True)
        meta = self.path / 'run.json'
        if meta.exists():
            old = json.loads(meta.read_text())
            if old['digest'] != spec.digest:
                raise ArgumentError('out', f'{self.path} holds a run of another spec (digest {old["digest"]}, '
                                           f'this one {spec.digest}): choose another --out')
        # the same spec but perhaps its episode count: written again
        (self.path / 'spec.yaml').write_text(yaml.safe_dump(spec.text, sort_keys=False))
        meta.write_text(json.dumps({'digest': spec.digest, 'episodes': spec.episodes, 'seed': spec.seed,
                                    'columns': self.columns}, indent=1))

    def rows(self):
        """The finished episodes' rows (a last line cut short is dropped from the file)."""
        if not self.table.exists():
            return []
        text = self.table.read_text()
        if text and not text.endswith('\n'):
            text = text[:text.rfind('\n') + 1]
            self.table.write_text(text)
        reader = csv.reader(io.StringIO(text))
        header = next(reader, None)
        if header is None:
            return []
        if header != self.columns:
            raise ArgumentError('out', f'{self.table}: columns differ from this spec\'s')
        return [{c: parse(v) for c, v in zip(header, line)} for line in reader if len(line) == len(header)]

    def append(self, row):
        """Append one finished episode's row (the header first on a new file)."""
        new = not self.table.exists() or self.table.stat().st_size == 0
        with open(self.table, 'a', newline='') as f:
            w = csv.writer(f)
            if new:
                w.writerow(self.columns)
            w.writerow([row[c] for c in self.columns])

    def parquet(self):
        """episodes.parquet beside episodes.csv when pyarrow is installed (it is optional): its path, or None."""
        try:
            from pyarrow import csv as pa_csv
            from pyarrow import parquet
        except ImportError:
            return None
        path = self.table.with_suffix('.parquet')
        parquet.write_table(pa_csv.read_csv(self.table), path)
        return path

    def finish(self, rows):
        """Rewrite the table sorted by episode (atomic), and its Parquet copy where pyarrow is installed."""
        tmp = self.table.with_suffix('.tmp')
        with open(tmp, 'w', newline='') as f:
            w = csv.writer(f)
            w.writerow(self.columns)
            for row in sorted(rows, key=lambda r: r['episode']):
                w.writerow([row[c] for c in self.columns])
        os.replace(tmp, self.table)
        self.parquet()


class Progress:
    """The progress line on stderr: episodes done, episodes/s, ticks/s, ETA (throttled)."""

    def __init__(self, total, done, stream=sys.stderr):
        self.total, self.done, self.stream = total, done, stream
        tty = getattr(stream, 'isatty', lambda: False)()
        self._period, self._start, self._end = (PROGRESS_PERIOD, '\r', '   ') if tty else (LOG_PERIOD, '', '\n')
        self.new = self.ticks = 0
        self.t0 = time.perf_counter()
        self._last = -math.inf

    def add(self, row, force=False):
        if row is not None:
            self.done += 1
            self.new += 1
            self.ticks += row.get('ticks') or 0
        now = time.perf_counter()
        if not force and now - self._last < self._period and self.done < self.total:
            return
        self._last = now
        span = max(now - self.t0, 1e-9)
        rate = self.new / span
        eta = (self.total - self.done) / rate if rate else math.inf
        self.stream.write(f'{self._start}[sweep] {self.done}/{self.total} episodes, {rate:.2f} episodes/s, '
                          f'{self.ticks / span:,.0f} ticks/s, ETA {eta:.0f} s{self._end}')
        if self.done >= self.total and self._start:
            self.stream.write('\n')
        self.stream.flush()

    @property
    def rates(self):
        """(episodes/s, ticks/s) of the episodes run here."""
        span = max(time.perf_counter() - self.t0, 1e-9)
        return self.new / span, self.ticks / span


# -- the worker's side -------------------------------------------------------------------------------------------
_PLAN = None


def _init(text):
    """A worker's start: the Plan of the spec's text, once per process."""
    global _PLAN
    _PLAN = sweep_episode.plan(sweep_spec.load(text))


def episode(k):
    """Episode k's row, in a worker started by _init."""
    return sweep_episode.run(_PLAN, k)


# -- the engine --------------------------------------------------------------------------------------------------
def run_local(spec, out, workers=1, say=lambda text: print(text, file=sys.stderr), stream=sys.stderr):
    """Run (or resume) every episode of Spec `spec` into directory `out` with `workers` processes (0: in this
    process); returns (rows sorted by episode, Progress)."""
    def execute(p, todo, rows, finished):
        if workers == 0:
            for k in todo:
                finished(sweep_episode.run(p, k))
        else:
            _pool(spec, workers, todo, rows, finished, say)
    return run_with(spec, out, execute, say, stream)


def run_with(spec, out, execute, say=lambda text: print(text, file=sys.stderr), stream=sys.stderr):
    """Run (or resume) every episode of Spec `spec` into directory `out` on an engine: `execute(plan, todo,
    rows, finished)` runs episodes `todo` (indices; `rows` {episode: row} holds those finished) and hands each
    finished episode's row to `finished` once. Returns (rows sorted by episode, Progress)."""
    p = sweep_episode.plan(spec)
    run_dir = RunDirectory(out, spec, sweep_episode.columns(p))
    rows = {r['episode']: r for r in run_dir.rows() if r['episode'] < spec.episodes}
    todo = [k for k in range(spec.episodes) if k not in rows]
    if rows:
        say(f'[sweep] resuming {out}: {len(rows)} episodes done, {len(todo)} to run')
    progress = Progress(spec.episodes, len(rows), stream)

    def finished(row):
        if row['episode'] in rows:          # an engine that ran an episode twice: the first row stands
            return
        run_dir.append(row)
        rows[row['episode']] = row
        progress.add(row)
    execute(p, todo, rows, finished)
    if not progress.new:
        progress.add(None, force=True)
    missing = [k for k in range(spec.episodes) if k not in rows]
    if missing:
        raise RuntimeError(f'the engine returned without episodes {missing[:10]} ({len(missing)} in all)')
    ordered = [rows[k] for k in range(spec.episodes)]
    run_dir.finish(ordered)
    return ordered, progress


#: what a forkserver imports once, before it forks the workers
PRELOAD = ['robot_control.tools.sweep_engine', 'sim_bridge.bridge_node', 'pybullet']


def context(method=None):
    """The multiprocessing context of the workers: forkserver where the platform has it (the server imports
    PRELOAD once; each worker, and a pool rebuilt after one died, is a fork of it), else spawn."""
    method = method or ('forkserver' if 'forkserver' in multiprocessing.get_all_start_methods() else 'spawn')
    ctx = multiprocessing.get_context(method)
    if method == 'forkserver':
        ctx.set_forkserver_preload(PRELOAD)
    return ctx


def _pool(spec, workers, todo, rows, finished, say):
    """Run episodes `todo` on a pool of `workers` processes, rebuilding it when a worker dies."""
    ctx = context()
    idle = 0
    for attempt in range(MAX_POOL_RESTARTS + 1):
        left = [k for k in todo if k not in rows]
        if not left:
            return
        if attempt:
            say(f'\n[sweep] a worker process died: rerunning the {len(left)} unfinished episodes')
        with cf.ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init, initargs=(spec.text,)) as pool:
            futures = [pool.submit(episode, k) for k in left]
            try:
                for fut in cf.as_completed(futures):
                    finished(fut.result())
                return
            except BrokenProcessPool:
                for fut in futures:        # finished before the pool broke: keep them
                    if fut.done() and not fut.cancelled() and fut.exception() is None:
                        finished(fut.result())
        idle = idle + 1 if len([k for k in todo if k not in rows]) == len(left) else 0
        if idle > MAX_IDLE_RESTARTS:
            break
    raise RuntimeError(f'worker processes died and no episode finished since ({len(todo)} to run); '
                       'run with --workers 0 to see why')
