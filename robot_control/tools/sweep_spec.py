"""A sweep's specification (the YAML `sweep run` reads) and its sampling, free of rclpy.

A spec names the experiment (a demo experiment by name, or one described in the YAML), the parameter
values both nodes start from, the distributions of the sampled parameters, the episode count, the run
seed and the pass criteria. Episode k of a run is fully determined by (spec, run seed, k):

    ss_k  = SeedSequence(seed, spawn_key=(k,))        (= SeedSequence(seed).spawn(k + 1)[k])
    s_k   = ss_k.generate_state(1)[0]                 the episode's seed, uint32 (the table's `seed`)
    draws = default_rng(s_k)                          the sampled parameters, in the spec's order
    sim_bridge `seed` = s_k                           the sensor noise streams (unless the spec sets it)

Parameter values of a node, later ones winning: config/<scenario>.yaml, the spec's `config` files
(e.g. config/realism/iiwa_typical.yaml), the demo experiment's overrides, the spec's `controller:` and
`bridge:` overrides, then the sampled values. Every name is checked against the node's parameter table
for the scenario (robot_control.ros.controller_params.TABLE, sim_bridge.bridge_params.TABLE), so any
row of either table can be set or sampled, and a row added to a table later works without a change here.
A name that is in both tables (payload.mass, ...) is written with its node: `sim_bridge/payload.mass`,
`controller/payload.mass`.

Distributions (per parameter; for an array parameter the bounds are scalars, drawn for every entry
independently, or lists of one bound per entry):
    {uniform: [lo, hi]}          lo <= x < hi
    {normal: [mean, std]}        optional clip: [lo, hi]
    {loguniform: [lo, hi]}       log x uniform in [log lo, log hi), 0 < lo < hi
    {integers: [lo, hi]}         whole numbers lo..hi, both included
    {choice: [a, b, ...]}        one of the values, equally likely; numbers, or strings for a string
                                 parameter (e.g. engine: {choice: [pybullet, mujoco]}: each episode on one)
    relative: true               (any of them) the draw multiplies the parameter's base value
Integer parameters take the draw rounded to the nearest whole number.
"""
import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import yaml

from robot_control.validation import ArgumentError

NODES = ('controller', 'sim_bridge')
KINDS = ('uniform', 'normal', 'loguniform', 'integers', 'choice')
#: the spec's keys and what they hold
KEYS = ('name', 'experiment', 'scenario', 'law', 'config', 'controller', 'bridge', 'trajectory', 'duration',
        'episodes', 'seed', 'sample', 'criteria', 'settle_from', 'steady_window', 'force', 'stability_limit',
        'tune', 'grid')
#: metrics a criterion may bound (upper limits), see robot_control.tools.sweep_episode.METRICS
CRITERIA = ('rms_error', 'max_error', 'final_error', 'peak_torque', 'saturated_ticks', 'force_rms_error',
            'force_max_error')


@dataclasses.dataclass(frozen=True)
class Distribution:
    """One sampled parameter: `node` ('controller' | 'sim_bridge'), `name` (its row), `kind` (KINDS),
    `args` (the bounds or values as given), `clip` ((lo, hi) or None, normal only), `relative`."""

    node: str
    name: str
    kind: str
    args: tuple
    clip: tuple = None
    relative: bool = False

    def draw(self, rng, base, row):
        """A value of parameter `row` (param_table.Row) drawn with numpy Generator `rng`: a float, an int
        or a list of them (array rows: one per entry of `base`, the parameter's value before sampling)."""
        size = _entries(self, base, row)
        if self.kind == 'choice' and row.type == 'string':
            return self.args[int(rng.integers(len(self.args)))]
        if self.kind == 'choice':
            value = np.asarray(self.args, dtype=float)[rng.integers(len(self.args), size=size)]
        else:
            a, b = (np.broadcast_to(np.asarray(x, dtype=float), size or ()) for x in self.args)
            if self.kind == 'uniform':
                value = rng.uniform(a, b)
            elif self.kind == 'loguniform':
                value = np.exp(rng.uniform(np.log(a), np.log(b)))
            elif self.kind == 'integers':
                value = rng.integers(a.astype(np.int64), b.astype(np.int64), endpoint=True).astype(float)
            else:
                value = rng.normal(a, b)
                if self.clip is not None:
                    value = np.clip(value, *self.clip)
        value = np.asarray(value, dtype=float)
        if self.relative:
            value = value * (np.asarray(base, dtype=float) if size else float(base))
        if row.type in ('integer', 'integer_array'):
            value = np.rint(value).astype(np.int64)
        return value.tolist() if size else value.item()


def _entries(dist, base, row):
    """The number of entries to draw: None for a scalar row, else the array's length. A choice of strings is for a
    string row only, a choice of numbers for the others."""
    if dist.kind == 'choice' and isinstance(dist.args[0], str) != (row.type == 'string'):
        raise ArgumentError(f'sample.{dist.name}', f'choice: expected {"strings" if row.type == "string" else "numbers"}'
                                                   f' for a {row.type} parameter, got {list(dist.args)}')
    if not row.is_array:
        if any(np.ndim(a) for a in dist.args if dist.kind != 'choice'):
            raise ArgumentError(f'sample.{dist.name}', 'a scalar parameter takes scalar bounds')
        return None
    lengths = {len(a) for a in dist.args if dist.kind != 'choice' and np.ndim(a)}
    if len(lengths) > 1:
        raise ArgumentError(f'sample.{dist.name}', f'per-entry bounds of different lengths {sorted(lengths)}')
    n = lengths.pop() if lengths else len(base or ())
    if base and len(base) != n:
        raise ArgumentError(f'sample.{dist.name}', f'{n} per-entry bounds for {len(base)} entries')
    if not n:
        raise ArgumentError(f'sample.{dist.name}', 'an empty array parameter: give per-entry bounds')
    return n


def distribution(key, text):
    """A Distribution from the spec's `sample` entry key: {kind: args, clip: ..., relative: ...}."""
    node, _, name = key.rpartition('/')
    where = f'sample.{key}'
    if node and node not in NODES:
        raise ArgumentError(where, f'node {node!r}: expected one of {list(NODES)}')
    if not isinstance(text, dict):
        raise ArgumentError(where, f'expected {{one of {list(KINDS)}: [...]}}, got {text!r}')
    kinds = [k for k in text if k in KINDS]
    extra = sorted(set(text) - set(KINDS) - {'clip', 'relative'})
    if len(kinds) != 1 or extra:
        raise ArgumentError(where, f'expected exactly one of {list(KINDS)} (and optionally clip, relative), '
                                   f'got {sorted(text)}')
    kind, args = kinds[0], text[kinds[0]]
    if not isinstance(args, (list, tuple)) or (kind != 'choice' and len(args) != 2) or not args:
        raise ArgumentError(where, f'{kind}: expected [lo, hi]' if kind != 'choice' else 'choice: expected a list')
    if kind == 'choice' and not (all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in args)
                                 or all(isinstance(v, str) for v in args)):
        raise ArgumentError(where, f'choice: expected numbers or strings, got {args}')
    if kind != 'choice':
        lo, hi = (np.asarray(a, dtype=float) for a in args)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ArgumentError(where, f'{kind}: bounds must be finite, got {args}')
        if kind == 'normal' and np.any(hi < 0):
            raise ArgumentError(where, f'normal: std must be >= 0, got {args[1]}')
        if kind != 'normal' and np.any(hi < lo) or kind in ('uniform', 'loguniform') and np.any(hi <= lo):
            raise ArgumentError(where, f'{kind}: expected lo < hi, got {args}')
        if kind == 'loguniform' and np.any(lo <= 0):
            raise ArgumentError(where, f'loguniform: bounds must be > 0, got {args}')
    clip = text.get('clip')
    if clip is not None and (kind != 'normal' or len(clip) != 2 or clip[0] > clip[1]):
        raise ArgumentError(where, f'clip: [lo, hi] with lo <= hi, for normal only, got {clip!r}')
    return Distribution(node, name, kind, tuple(args), tuple(clip) if clip else None, bool(text.get('relative')))


@dataclasses.dataclass(frozen=True)
class Spec:
    """A checked spec (see the module docstring and docs/sweep.md). `text`: the dict it was read from."""

    text: dict
    episodes: int
    seed: int
    samples: tuple                        # Distributions, in the spec's order
    criteria: dict                        # metric -> upper limit
    stability_limit: float                # rad or m: a larger |e| is unstable

    @property
    def digest(self):
        """A hash of the spec's text but its episode count: a run directory belongs to one spec, and may be
        extended by more episodes (episode k does not depend on the count)."""
        text = {k: v for k, v in self.text.items() if k != 'episodes'}
        return hashlib.sha256(json.dumps(text, sort_keys=True).encode()).hexdigest()[:16]

    def with_episodes(self, episodes):
        return dataclasses.replace(self, episodes=int(episodes), text={**self.text, 'episodes': int(episodes)})


def load(path_or_text):
    """Spec from a YAML file path or an already parsed dict; ArgumentError naming the bad key."""
    if isinstance(path_or_text, dict):
        text = path_or_text
    else:
        try:
            text = yaml.safe_load(Path(path_or_text).read_text())
        except (OSError, yaml.YAMLError) as exc:
            raise ArgumentError('spec', f'cannot read {path_or_text}: {exc}') from None
    if not isinstance(text, dict):
        raise ArgumentError('spec', 'expected a YAML mapping')
    unknown = sorted(set(text) - set(KEYS))
    if unknown:
        raise ArgumentError(unknown[0], f'unknown key; expected some of {list(KEYS)}')
    if not text.get('experiment') and not text.get('scenario'):
        raise ArgumentError('experiment', 'give a demo experiment by name or a scenario')
    episodes, seed = text.get('episodes', 100), text.get('seed', 0)
    if not isinstance(episodes, int) or episodes < 1:
        raise ArgumentError('episodes', f'expected a whole number >= 1, got {episodes!r}')
    if not isinstance(seed, int) or seed < 0:
        raise ArgumentError('seed', f'expected a whole number >= 0, got {seed!r}')
    criteria = dict(text.get('criteria') or {})
    for key, limit in criteria.items():
        if key not in CRITERIA or not isinstance(limit, (int, float)):
            raise ArgumentError(f'criteria.{key}', f'expected an upper limit (a number) on one of {list(CRITERIA)}')
    limit = text.get('stability_limit', 1.0)
    if not isinstance(limit, (int, float)) or isinstance(limit, bool) or not limit > 0:
        raise ArgumentError('stability_limit', f'expected a number > 0 (rad or m), got {limit!r}')
    samples = tuple(distribution(k, v) for k, v in (text.get('sample') or {}).items())
    return Spec(text, episodes, seed, samples, criteria, float(limit))


def episode_seed(run_seed, k):
    """The seed of episode k (uint32 as int): the first word of SeedSequence(run_seed).spawn(...)[k]."""
    return int(np.random.SeedSequence(run_seed, spawn_key=(k,)).generate_state(1)[0])


def node_of(name, node, tables):
    """The node whose table holds parameter `name` ('' node: the one table that does); tables:
    {node: param_table.Rows}. ArgumentError naming sample.<name> when none or both do."""
    holders = [n for n in NODES if name in tables[n]]
    if node:
        if node not in holders:
            raise ArgumentError(f'sample.{node}/{name}', f'not a parameter of {node} for this scenario')
        return node
    if not holders:
        raise ArgumentError(f'sample.{name}', 'not a parameter of the controller nor of sim_bridge for this scenario')
    if len(holders) > 1:
        raise ArgumentError(f'sample.{name}', 'a parameter of both nodes: write controller/' + name
                                              + ' or sim_bridge/' + name)
    return holders[0]


def sample(spec, k, values, tables):
    """Episode k's sampled values: {node: {name: value}} drawn in the spec's order from the episode's
    seed, each from its node's `values` (the base values) and `tables` ({node: Rows})."""
    rng = np.random.default_rng(episode_seed(spec.seed, k))
    out = {n: {} for n in NODES}
    for dist in spec.samples:
        node = node_of(dist.name, dist.node, tables)
        row = tables[node][dist.name]
        out[node][dist.name] = dist.draw(rng, values[node].get(dist.name, row.default), row)
    return out


def flat_columns(spec, drawn):
    """{column: value} of the sampled values, array entries as name[i]."""
    out = {}
    for dist in spec.samples:
        node = dist.node or next(n for n in NODES if dist.name in drawn[n])
        value = drawn[node][dist.name]
        if isinstance(value, list):
            out.update({f'{dist.name}[{i}]': v for i, v in enumerate(value)})
        else:
            out[dist.name] = value
    return out
