"""Tracking plots of a run (matplotlib, Agg canvas; no rclpy, no pyplot global state).

`tracking_figure(data, path)` draws one block of panels per quantity, top to bottom, each block one
panel per joint (or task axis, effort channel, force axis) in rows of at most MAX_COLUMNS panels, so
a 7-joint arm reads as two rows of 4 + 3 per quantity instead of one row seven panels wide:

    block 1  position: desired q_d (dashed) and actual q          [rad or m, per joint]
    block 2  error e = q_d - q                                     [rad or m]
    block 3  effort tau applied, with +-effort limit if given      [N m for revolute, N for prismatic]
    block 4  contact force f and its reference f_d (only if 'f')   [N]

Every panel is titled with its coordinate's name; joint c sits in column c mod MAX_COLUMNS of each
block. All panels share the time axis (labelled under the lowest panel of each column). Tick labels
never use an offset ("1e-6+5.5e-1"): values print as themselves (tiny ones with a power-of-ten
multiplier such as 1e-6 over the axis), and a panel whose values vary by less than RELATIVE_SPAN of
their size is widened to that span (a held joint reads as a flat line at its value; the error block
shows the small variation).

The input is a plain dict of numpy arrays (N samples, n coordinates, m effort channels, k force axes):

    key            shape / type      meaning
    'scenario'     str               scenario name, used in the title (required)
    't'            (N,)              time [s], increasing
    'joint_names'  n str             names of the plotted coordinates (joints, or task axes 'x', 'y')
    'units'        n str             'rad' or 'm' per coordinate
    'q', 'q_d'     (N, n)            actual and desired position [units]
    'tau'          (N, m)            effort applied [N m or N]
    optional:
    'e'            (N, n)            tracking error; default q_d - q
    'tau_names'    m str             effort channel names; default joint_names (then m == n)
    'tau_units'    m str             'N m' or 'N' each; default from 'units' ('rad' -> 'N m', 'm' -> 'N')
    'effort_limit' (m,)              |tau| limit per channel, drawn as dashed red lines (the axis keeps
                                     the effort's own scale when it stays below 40 % of the limit)
    'f'            (N, k)            measured contact force [N] (force exerted by the robot)
    'f_d'          (N, k)            force reference [N]; NaN where an axis has no reference
    'force_names'  k str             default 'f0', 'f1', ... ; e.g. ['x'] for the wall normal
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
RELATIVE_SPAN = 2e-3   # smallest y span of a panel, relative to its largest |value|


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
    if off_scale:
        lo, hi = (float(np.min(finite)), float(np.max(finite))) if finite.size else (0.0, 0.0)
        pad = 0.1 * (hi - lo) if hi > lo else max(0.1 * peak, 1e-3 * limit, 1e-9)
        ax.set_ylim(lo - pad, hi + pad)


def _no_offset(ax, values):
    """Plain tick labels without offset; widen a nearly constant panel to RELATIVE_SPAN of its size."""
    ax.ticklabel_format(axis='both', useOffset=False)
    finite = np.concatenate([np.asarray(v, dtype=float).ravel() for v in values])
    finite = finite[np.isfinite(finite)]
    if not finite.size:
        return
    lo, hi = ax.get_ylim()
    size = float(np.max(np.abs(finite)))
    if hi - lo < RELATIVE_SPAN * size:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - 0.5 * RELATIVE_SPAN * size, mid + 0.5 * RELATIVE_SPAN * size)


def _draw_panel(ax, block, c, d):
    """Panel c of `block` ('position', 'error', 'effort', 'force'); returns the arrays drawn."""
    t = d['t']
    if block == 'position':
        ax.plot(t, d['q_d'][:, c], '--', color='tab:gray', linewidth=1.3, label='desired $q_d$')
        ax.plot(t, d['q'][:, c], color='tab:blue', linewidth=1.1, label='actual $q$')
        ax.set_title(d['joint_names'][c])
        ax.set_ylabel(f'position [{d["units"][c]}]')
        return [d['q_d'][:, c], d['q'][:, c]]
    if block == 'error':
        ax.axhline(0.0, color='black', linewidth=0.6)
        ax.plot(t, d['e'][:, c], color='tab:orange', linewidth=1.1, label='$e = q_d - q$')
        ax.set_title(d['joint_names'][c])
        ax.set_ylabel(f'error [{d["units"][c]}]')
        return [d['e'][:, c]]
    if block == 'effort':
        unit = d['tau_units'][c]
        ax.plot(t, d['tau'][:, c], color='tab:green', linewidth=1.1, label=r'$\tau$ applied')
        if d['effort_limit'] is not None and np.isfinite(d['effort_limit'][c]):
            _limit_lines(ax, d['effort_limit'][c], d['tau'][:, c])
        ax.set_title(d['tau_names'][c])
        ax.set_ylabel(f'{"torque" if unit.replace(" ", "") == "Nm" else "joint force"} [{unit}]')
        return [d['tau'][:, c]]
    drawn = [d['f'][:, c]]
    if d['f_d'] is not None and np.any(np.isfinite(d['f_d'][:, c])):
        ax.plot(t, d['f_d'][:, c], '--', color='tab:gray', linewidth=1.3, label='reference $f_d$')
        drawn.append(d['f_d'][:, c])
    ax.plot(t, d['f'][:, c], color='tab:purple', linewidth=1.1, label='measured $f$')
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
    counts = {'position': len(d['joint_names']), 'error': len(d['joint_names']), 'effort': len(d['tau_names'])}
    if d['force_names']:
        counts['force'] = len(d['force_names'])
    cells, (nrows, ncols) = panel_grid(counts)
    fig = Figure(figsize=(COL_WIDTH_IN * ncols + 0.8, ROW_HEIGHT_IN * nrows + 0.9), dpi=DPI,
                 layout='constrained')
    FigureCanvasAgg(fig)
    grid = fig.subplots(nrows, ncols, sharex=True, squeeze=False)
    used = {(r, c) for _, _, r, c in cells}
    bottom = {}  # column -> lowest used axes (gets the time label)
    for block, index, r, c in cells:
        ax = grid[r, c]
        bottom[c] = ax
        ax.grid(True, alpha=0.35)
        _no_offset(ax, _draw_panel(ax, block, index, d))
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
