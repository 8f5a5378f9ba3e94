"""Tracking plots of a run (matplotlib, Agg canvas; no rclpy, no pyplot global state).

`tracking_figure(data, path)` draws one block of panels per quantity, top to bottom, each block one
panel per joint (or task axis, effort channel, force axis) in rows of at most MAX_COLUMNS panels, so
a 7-joint arm reads as two rows of 4 + 3 per quantity instead of one row seven panels wide:

    block 1  position: desired q_d (dashed) and actual q          [rad or m, per joint]
    block 2  error e = q_d - q                                     [rad or m]
    block 3  effort tau applied, with +-effort limit if given      [N m for revolute, N for prismatic]
    block 4  contact force f and its reference f_d                 [N]

Only what the data holds is drawn: a line (and its legend entry) only for a signal with a finite
sample in that panel, a panel only when one of its lines is drawn, a block only when one of its
panels is (no reference: no q_d line and no error block unless 'e' is given; no force block
without 'f'). A legend entry names the signal's source when 'sources' gives it (a bag's topic).

Every panel is titled with its coordinate's name; joint c sits in column c mod MAX_COLUMNS of each
block. All panels share the time axis (labelled under the lowest panel of each column). Tick labels
never use an offset ("1e-6+5.5e-1"), and a constant, round-off or nearly constant signal gets the
y-limits of `flat_limits`: a held joint reads as a flat line at its value, a 1e-15 N m torque as 0.

The input is a plain dict of numpy arrays (N samples, n coordinates, m effort channels, k force axes):

    key            shape / type      meaning
    'scenario'     str               scenario name, used in the title (required)
    't'            (N,)              time [s], increasing
    'joint_names'  n str             names of the plotted coordinates (joints, or task axes 'x', 'y')
    'units'        n str             'rad' or 'm' per coordinate
    'q', 'q_d'     (N, n)            actual and desired position [units]; all NaN where there is none
    'tau'          (N, m)            effort applied [N m or N]
    optional:
    'e'            (N, n)            tracking error; default q_d - q
    'tau_names'    m str             effort channel names; default joint_names (then m == n)
    'tau_units'    m str             'N m' or 'N' each; default from 'units' ('rad' -> 'N m', 'm' -> 'N')
    'tau_kind'     str               'applied' (default) or 'commanded': what 'tau' is
    'effort_limit' (m,)              |tau| limit per channel, drawn as dashed red lines (the axis keeps
                                     the effort's own scale when it stays below 40 % of the limit)
    'f'            (N, k)            measured contact force [N] (force exerted by the robot)
    'f_d'          (N, k)            force reference [N]; NaN where an axis has no reference
    'force_names'  k str             default 'f0', 'f1', ... ; e.g. ['x'] for the wall normal
    'sources'      {key: str}        where 'q', 'q_d', 'e', 'tau', 'f' or 'f_d' came from (a topic),
                                     appended to that signal's legend entry
    'title'        str               extra text after the scenario name (law, gains, ...)

NaN samples are allowed anywhere (not drawn). Shapes are checked; a bad entry is a ValueError whose
message starts with the key, e.g. "data['q']: expected shape (500, 2), got (500, 3)".
"""
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from robot_control.units import EFFORT_UNIT

__all__ = ['tracking_figure', 'check_tracking_data', 'MAX_COLUMNS']

POSITION_UNITS = ('rad', 'm')
COL_WIDTH_IN = 3.6
ROW_HEIGHT_IN = 2.3
DPI = 110
MAX_COLUMNS = 4
RELATIVE_SPAN = 2e-3   # smallest y span of a varying panel, relative to its largest |value|
ROUND_OFF = 1e-9       # a span below this (SI units, or relative to the largest |value|) is round-off
SIGNALS = {'q_d': 'desired $q_d$', 'q': 'actual $q$', 'e': '$e = q_d - q$', 'f_d': 'reference $f_d$',
           'f': 'measured $f$'}  # legend entry of each signal ('tau' is r'$\tau$ ' + its kind)
TAU_KINDS = ('applied', 'commanded')


def _names(key, value, n=None):
    got = [str(s) for s in value]
    if n is not None and len(got) != n:
        raise ValueError(f"data['{key}']: expected {n} names, got {len(got)}")
    return got


def _array(key, value, shape):
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"data['{key}']: expected numbers, got {type(value).__name__}") from exc
    if a.ndim == 1 and len(shape) == 2 and shape[1] == 1:
        a = a.reshape(-1, 1)
    if a.shape != tuple(shape):
        raise ValueError(f"data['{key}']: expected shape {tuple(shape)}, got {a.shape}")
    return a


def check_tracking_data(data):
    """Validate the plot input and return a normalised copy (arrays float64, defaults filled in)."""
    if not isinstance(data, dict):
        raise ValueError(f'data: expected a dict, got {type(data).__name__}')
    for key in ('scenario', 't', 'joint_names', 'units', 'q', 'q_d', 'tau'):
        if key not in data:
            raise ValueError(f"data['{key}']: missing")
    t = np.asarray(data['t'], dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"data['t']: expected a 1-D array of at least 2 samples, got shape {t.shape}")
    N = t.size
    names = _names('joint_names', data['joint_names'])
    n = len(names)
    if n == 0:
        raise ValueError("data['joint_names']: expected at least one name")
    units = _names('units', data['units'], n)
    bad = [u for u in units if u not in POSITION_UNITS]
    if bad:
        raise ValueError(f"data['units']: expected 'rad' or 'm' each, got {bad}")
    out = {'scenario': str(data['scenario']), 'title': str(data.get('title', '') or ''),
           't': t, 'joint_names': names, 'units': units,
           'q': _array('q', data['q'], (N, n)), 'q_d': _array('q_d', data['q_d'], (N, n))}
    out['e'] = _array('e', data['e'], (N, n)) if data.get('e') is not None else out['q_d'] - out['q']
    if data.get('tau_names') is not None:
        tau_names = _names('tau_names', data['tau_names'])
        m = len(tau_names)
    else:
        tau_names = names
        m = n
    out['tau'] = _array('tau', data['tau'], (N, m))
    out['tau_names'] = tau_names
    if data.get('tau_units') is not None:
        out['tau_units'] = _names('tau_units', data['tau_units'], m)
    elif data.get('tau_names') is None:
        out['tau_units'] = [EFFORT_UNIT[u] for u in units]
    else:
        raise ValueError("data['tau_units']: required when 'tau_names' is given")
    lim = data.get('effort_limit')
    if lim is not None:
        lim = np.abs(np.asarray(lim, dtype=float).reshape(-1))
        if lim.shape != (m,):
            raise ValueError(f"data['effort_limit']: expected shape ({m},), got {lim.shape}")
    out['effort_limit'] = lim
    if data.get('f') is not None:
        f = np.asarray(data['f'], dtype=float)
        k = 1 if f.ndim == 1 else (f.shape[1] if f.ndim == 2 else -1)
        if k <= 0:
            raise ValueError(f"data['f']: expected shape (N, k), got {f.shape}")
        out['f'] = _array('f', f, (N, k))
        out['f_d'] = _array('f_d', data['f_d'], (N, k)) if data.get('f_d') is not None else None
        out['force_names'] = (_names('force_names', data['force_names'], k)
                              if data.get('force_names') is not None else [f'f{i}' for i in range(k)])
    else:
        if data.get('f_d') is not None:
            raise ValueError("data['f_d']: given without data['f']")
        out['f'] = out['f_d'] = None
        out['force_names'] = []
    out['tau_kind'] = str(data.get('tau_kind') or 'applied')
    if out['tau_kind'] not in TAU_KINDS:
        raise ValueError(f"data['tau_kind']: expected one of {TAU_KINDS}, got {out['tau_kind']!r}")
    sources = data.get('sources') or {}
    bad = sorted(set(sources) - set(SIGNALS) - {'tau'}) if isinstance(sources, dict) else sources
    if bad:
        raise ValueError(f"data['sources']: expected a dict with keys of {sorted(SIGNALS) + ['tau']}, got {bad!r}")
    out['sources'] = {k: str(v) for k, v in sources.items() if v}
    return out


def _limit_lines(ax, limit, tau):
    """Dashed +-limit lines. When the effort stays far below the limit (< 40 %), the axis keeps the
    effort's own scale so its shape stays readable, and the legend says the limit is off scale."""
    finite = tau[np.isfinite(tau)]
    peak = float(np.max(np.abs(finite))) if finite.size else 0.0
    off_scale = limit > 2.5 * peak
    label = f'limit \u00b1{limit:g}' + (' (off scale)' if off_scale else '')
    ax.axhline(limit, color='tab:red', linestyle='--', linewidth=0.9, label=label)
    ax.axhline(-limit, color='tab:red', linestyle='--', linewidth=0.9)
    if off_scale and finite.size:
        lo, hi = float(np.min(finite)), float(np.max(finite))
        ax.set_ylim(flat_limits(finite) or (lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)))


def flat_limits(values):
    """The y-limits (lo, hi) of a panel whose values are constant, round-off or nearly constant;
    None for a varying signal (matplotlib's autoscale stands) or no finite value.

    Of the finite values v (SI units: rad, m, N m, N): size = max|v|, span = max v - min v,
    mid = (max v + min v) / 2.

        constant         span <= ROUND_OFF * max(1, size): the signal is one value c = mid, read
                         as c = 0 when |mid| <= ROUND_OFF (round-off of zero: a 1e-15 N m torque is
                         0 N m); limits c +- s with s = 10^floor(log10 |c|), one step of c's leading
                         decade (0.55 rad -> 0.45 .. 0.65), s = 1 unit for c = 0 (-1 .. 1 N m)
        nearly constant  span < RELATIVE_SPAN * size: mid +- RELATIVE_SPAN * size / 2 (a joint held
                         at 0.55 rad with a 1e-6 rad wobble: a flat line at 0.55 +- 5.5e-4)

    Either way the limits lie many decades above the round-off, so ticks need no offset and no
    power-of-ten multiplier beyond the value's own magnitude.
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return None
    lo, hi = float(np.min(v)), float(np.max(v))
    size, span, mid = max(abs(lo), abs(hi)), hi - lo, 0.5 * (lo + hi)
    if span <= ROUND_OFF * max(1.0, size):
        c = mid if abs(mid) > ROUND_OFF else 0.0
        s = 10.0 ** np.floor(np.log10(abs(c))) if c else 1.0
        return c - s, c + s
    if span < RELATIVE_SPAN * size:
        return mid - 0.5 * RELATIVE_SPAN * size, mid + 0.5 * RELATIVE_SPAN * size
    return None


def _scale_axis(ax, values):
    """Plain tick labels without offset; the limits of `flat_limits(values)` when they are wider than
    the view (lines such as +-effort limits keep a wider view)."""
    ax.ticklabel_format(axis='both', useOffset=False)
    lims = flat_limits(np.concatenate([np.ravel(v) for v in values])) if values else None
    lo, hi = ax.get_ylim()
    if lims is not None and lims[1] - lims[0] > hi - lo:
        ax.set_ylim(*lims)


def _has(a):
    return a is not None and bool(np.any(np.isfinite(a)))


def _line(ax, d, key, y, style, color, label=None):
    """Plot signal `key` (column y) if it holds a finite sample; legend entry with its source."""
    if not _has(y):
        return []
    label = label or SIGNALS[key]
    if key in d['sources']:
        label += f' ({d["sources"][key]})'
    ax.plot(d['t'], y, style, color=color, linewidth=1.3 if style == '--' else 1.1, label=label)
    return [y]


def panel_signals(d, block, c):
    """The arrays panel c of `block` would draw; an empty list: the panel has no data."""
    column = {'position': ('q_d', 'q'), 'error': ('e',), 'effort': ('tau',), 'force': ('f_d', 'f')}[block]
    return [d[k][:, c] for k in column if d[k] is not None and _has(d[k][:, c])]


def _draw_panel(ax, block, c, d):
    """Panel c of `block` ('position', 'error', 'effort', 'force'); returns the arrays drawn."""
    if block == 'position':
        drawn = _line(ax, d, 'q_d', d['q_d'][:, c], '--', 'tab:gray') + \
            _line(ax, d, 'q', d['q'][:, c], '-', 'tab:blue')
        ax.set_title(d['joint_names'][c])
        ax.set_ylabel(f'position [{d["units"][c]}]')
        return drawn
    if block == 'error':
        ax.axhline(0.0, color='black', linewidth=0.6)
        ax.set_title(d['joint_names'][c])
        ax.set_ylabel(f'error [{d["units"][c]}]')
        return _line(ax, d, 'e', d['e'][:, c], '-', 'tab:orange')
    if block == 'effort':
        unit = d['tau_units'][c]
        drawn = _line(ax, d, 'tau', d['tau'][:, c], '-', 'tab:green', f'$\\tau$ {d["tau_kind"]}')
        if d['effort_limit'] is not None and np.isfinite(d['effort_limit'][c]):
            _limit_lines(ax, d['effort_limit'][c], d['tau'][:, c])
        ax.set_title(d['tau_names'][c])
        ax.set_ylabel(f'{"torque" if unit.replace(" ", "") == "Nm" else "joint force"} [{unit}]')
        return drawn
    drawn = _line(ax, d, 'f_d', d['f_d'][:, c] if d['f_d'] is not None else None, '--', 'tab:gray') + \
        _line(ax, d, 'f', d['f'][:, c], '-', 'tab:purple')
    ax.set_title(f'contact force {d["force_names"][c]}')
    ax.set_ylabel('force [N]')
    return drawn


def panel_grid(counts):
    """[(block, index, row, column)] of the panels of blocks {block: panel count} (in that order), each
    block in rows of at most MAX_COLUMNS; and the grid's (rows, columns)."""
    ncols = min(MAX_COLUMNS, max(counts.values()))
    cells, row = [], 0
    for block, count in counts.items():
        for c in range(count):
            cells.append((block, c, row + c // ncols, c % ncols))
        row += -(-count // ncols)
    return cells, (row, ncols)


def tracking_figure(data, path=None):
    """Draw the tracking figure of `data` (see the module docstring) and save it as PNG.

    path: file to write (e.g. 'out/demo/polar_two_link/tracking.png'), or an existing directory
    (writes '<dir>/tracking.png'), or None (draw only). Returns the matplotlib Figure.
    """
    d = check_tracking_data(data)
    sizes = {'position': len(d['joint_names']), 'error': len(d['joint_names']), 'effort': len(d['tau_names']),
             'force': len(d['force_names'])}
    filled = {(block, c) for block, n in sizes.items() for c in range(n) if panel_signals(d, block, c)}
    counts = {block: n for block, n in sizes.items() if any((block, c) in filled for c in range(n))}
    if not counts:
        raise ValueError("data['q']: no finite sample to plot (nor in 'q_d', 'e', 'tau', 'f')")
    cells, (nrows, ncols) = panel_grid(counts)
    fig = Figure(figsize=(COL_WIDTH_IN * ncols + 0.8, ROW_HEIGHT_IN * nrows + 0.9), dpi=DPI,
                 layout='constrained')
    FigureCanvasAgg(fig)
    grid = fig.subplots(nrows, ncols, sharex=True, squeeze=False)
    used = {(r, c) for block, index, r, c in cells if (block, index) in filled}
    bottom = {}  # column -> lowest used axes (gets the time label)
    for block, index, r, c in cells:
        if (r, c) not in used:
            continue
        ax = grid[r, c]
        bottom[c] = ax
        ax.grid(True, alpha=0.35)
        _scale_axis(ax, _draw_panel(ax, block, index, d))
        ax.legend(loc='best', fontsize='small')
    for r in range(nrows):
        for c in range(ncols):
            if (r, c) not in used:
                fig.delaxes(grid[r, c])
    for ax in bottom.values():
        ax.set_xlabel('time [s]')
        ax.xaxis.set_tick_params(labelbottom=True)
    title = f'{d["scenario"]}: tracking'
    if d['title']:
        title += f' ({d["title"]})'
    fig.suptitle(title, fontsize='large', fontweight='bold')
    if path is not None:
        path = Path(path)
        if path.is_dir():
            path = path / 'tracking.png'
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=DPI)
    return fig


def main(args=None):
    """`python -m robot_control.plot BAG [-o PNG] [--namespace NS]` / the `plot` console script: the
    tracking figure of a rosbag2 directory (robot_control.tools.bag_tracking). Exit 0 and the PNG's
    path on stdout; exit 2 and the reason on stderr for a path that is no bag or a bag without a
    plottable joint_states."""
    import argparse
    import sys
    from robot_control.tools.bag_tracking import BagError, bag_directory, tracking_data
    p = argparse.ArgumentParser(prog='python -m robot_control.plot',
                                description='Draw the tracking figure (position, error, effort, force) from a '
                                            'rosbag2 directory written by ros2 bag record or robot_control.record.')
    p.add_argument('bag', help='rosbag2 directory (holding metadata.yaml)')
    p.add_argument('-o', '--output', default=None, help='PNG to write (default: <bag>_tracking.png beside the bag)')
    p.add_argument('-n', '--namespace', default=None, help='the robot\'s namespace, for a bag of several')
    opts = p.parse_args(args)
    try:
        bag = bag_directory(opts.bag).resolve()
        data = tracking_data(bag, opts.namespace)
    except BagError as exc:
        print(f'plot: {exc}', file=sys.stderr)
        return 2
    out = Path(opts.output) if opts.output else bag.parent / f'{bag.name}_tracking.png'
    tracking_figure(data, out)
    print(out)
    return 0
