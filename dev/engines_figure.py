"""PyBullet and MuJoCo overlaid, in process: the figure of docs/results.md's side-by-side section.

    python -m dev.engines_figure [--out docs/figures/engines/engines.png]      # from the repository root

Two demo experiments run as the sweep runs an episode (robot_control.tools.sweep_episode: the bridge's loop in
lockstep with the controller, no DDS; the demo's figures to the last digit) on each engine (`bridge: {engine:
...}`): force_steps (the force on the wall) and payload_unmodelled (joint 2 against its URDF limit), where the
engines part. Prints where the runs first differ by 1e-9 and 1e-3 and the largest force of each.
"""
import argparse
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from robot_control import urdf as urdf_files
from robot_control.tools import sweep_episode, sweep_spec
from dev.docs_results import save_figure

ENGINES = ('pybullet', 'mujoco')
OUT = Path('docs/figures/engines/engines.png')


def runs(experiment):
    """{engine: RunData} of `experiment` on each engine."""
    out = {}
    for engine in ENGINES:
        plan = sweep_episode.plan(sweep_spec.load({'experiment': experiment, 'episodes': 1, 'bridge': {'engine': engine}}))
        out[engine] = sweep_episode.run(plan, 0, keep=True)[1]
    return out


def first_difference(data, threshold):
    """The time (s) at which the engines' positions first differ by more than `threshold`, or None."""
    a, b = (data[e] for e in ENGINES)
    apart = np.flatnonzero(np.abs(a.q - b.q).max(axis=1) > threshold)
    return float(a.t[apart[0]]) if apart.size else None


def joint_limit(urdf, joint, upper):
    """The URDF limit (rad or m) of `joint` in the shipped `urdf`: upper or lower."""
    xml, _ = urdf_files.read(urdf_files.resolve(urdf))
    [limit] = [j.find('limit') for j in ET.fromstring(xml.lstrip()).findall('joint') if j.get('name') == joint]
    return float(limit.get('upper' if upper else 'lower'))


def figure(force, payload, limit, out):
    """Two panels: the contact force of force_steps, joint 2 of payload_unmodelled."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(8, 3), dpi=80)
    panels = ((force, lambda d: d.force_measured()[:, 0], 'force_steps: force on the wall', 'f_x (N)'),
              (payload, lambda d: d.q[:, 1], 'payload_unmodelled: joint 2', 'q_2 (rad)'))
    for ax, (data, signal, title, label) in zip(axes, panels):
        for engine, style in zip(ENGINES, ('-', '--')):
            ax.plot(data[engine].t, signal(data[engine]), style, label=engine)
        ax.set(xlabel='t (s)', ylabel=label, title=title)
    axes[1].axhline(limit, color='k', ls=':', lw=0.8, label='URDF limit')
    axes[1].legend(fontsize=7)
    save_figure(fig, out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', type=Path, default=OUT)
    opts = parser.parse_args(argv)
    data = {name: runs(name) for name in ('force_steps', 'payload_unmodelled')}
    for name, d in data.items():
        print(f'{name}: positions first differ by 1e-9 at t = {first_difference(d, 1e-9)} s, by 1e-3 at '
              f't = {first_difference(d, 1e-3)} s')
    for engine, d in data['force_steps'].items():
        f = d.force_measured()[:, 0]
        print(f'force_steps on {engine}: largest force {f.max():.3f} N at t = {d.t[np.argmax(f)]:.3f} s')
    q = data['payload_unmodelled']['pybullet'].q[:, 1]
    limit = joint_limit('kuka_iiwa/model.urdf', 'lbr_iiwa_joint_2', upper=q[np.argmax(np.abs(q))] > 0)
    figure(data['force_steps'], data['payload_unmodelled'], limit, opts.out)
    print(f'wrote {opts.out}')


if __name__ == '__main__':
    main()
