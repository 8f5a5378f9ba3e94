"""tracking_figure: the PNG is written, and the Figure holds the panels, labels and lines it should."""
import os
import subprocess
import sys

import numpy as np
import pytest
from matplotlib.image import imread

from support.figures import axes_by_row, check_no_offset
from robot_control.tools.plot import DPI, tracking_figure

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def polar_data(force=True, N=601):
    """A critically damped step on the polar robot (e = (1 + 6t) e^-6t e0), plus a force step."""
    t = np.linspace(0.0, 2.0, N)
    e0 = np.array([0.5, 0.1])
    e = np.outer((1.0 + 6.0 * t) * np.exp(-6.0 * t), e0)
    q_d = np.tile([1.0, 0.6], (N, 1))
    data = {
        'scenario': 'polar_two_link',
        'title': 'PD computed torque, kp=36, kv=12',
        't': t, 'joint_names': ['theta1', 'r'], 'units': ['rad', 'm'],
        'q': q_d - e, 'q_d': q_d,
        'tau': np.column_stack([20.0 + 30.0 * np.exp(-6.0 * t), 19.6 + 8.0 * np.exp(-5.0 * t)]),
        'effort_limit': np.array([60.0, 40.0]),
    }
    if force:
        f = 10.0 * (1.0 - np.exp(-8.0 * t))
        data.update(f=f[:, None], f_d=np.full((N, 1), 10.0), force_names=['x'])
    return data


def test_png_written_with_sane_size(tmp_path):
    path = tmp_path / 'out' / 'tracking.png'
    fig = tracking_figure(polar_data(), path)
    assert path.is_file() and path.stat().st_size > 20_000
    img = imread(path)
    w_in, h_in = fig.get_size_inches()
    assert img.shape[:2] == (round(h_in * DPI), round(w_in * DPI))
    assert 600 <= img.shape[1] <= 4000 and 600 <= img.shape[0] <= 4000
    assert img[..., :3].std() > 0.05  # not a blank canvas


def test_panels_labels_and_lines(tmp_path):
    data = polar_data()
    fig = tracking_figure(data, tmp_path / 'tracking.png')
    assert len(fig.axes) == 7  # position x2, error x2, effort x2, force x1
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [2, 2, 2, 1]
    pos, err, eff, frc = rows
    assert 'polar_two_link' in fig.get_suptitle() and 'kp=36' in fig.get_suptitle()
    assert [a.get_title() for a in pos] == ['theta1', 'r']
    assert [a.get_ylabel() for a in pos] == ['position [rad]', 'position [m]']
    assert [a.get_ylabel() for a in err] == ['error [rad]', 'error [m]']
    assert [a.get_ylabel() for a in eff] == ['torque [N m]', 'joint force [N]']
    assert frc[0].get_ylabel() == 'force [N]' and 'x' in frc[0].get_title()
    # Shared time axis, labelled at the bottom of each column.
    assert all(a.get_shared_x_axes().joined(a, pos[0]) for a in fig.axes)
    assert frc[0].get_xlabel() == 'time [s]' and eff[1].get_xlabel() == 'time [s]'
    assert pos[0].get_xlabel() == ''
    # Every panel has a legend and a grid.
    for a in fig.axes:
        assert a.get_legend() is not None
        assert any(line.get_visible() for line in a.get_xgridlines())
    # Lines carry the data: desired and actual positions, error = q_d - q, effort limits at +-limit.
    labels = [line.get_label() for line in pos[0].get_lines()]
    assert labels == ['desired $q_d$', 'actual $q$']
    np.testing.assert_array_equal(pos[1].get_lines()[1].get_ydata(), data['q'][:, 1])
    err_line = [line for line in err[0].get_lines() if line.get_label().startswith('$e')][0]
    np.testing.assert_allclose(err_line.get_ydata(), data['q_d'][:, 0] - data['q'][:, 0])
    levels = sorted(line.get_ydata()[0] for line in eff[0].get_lines() if line.get_linestyle() == '--')
    assert levels == [-60.0, 60.0]
    assert [line.get_label() for line in frc[0].get_lines()] == ['reference $f_d$', 'measured $f$']


def test_without_force_one_joint_and_1d_arrays(tmp_path):
    t = np.linspace(0.0, 1.0, 101)
    fig = tracking_figure({'scenario': 'single_link', 't': t, 'joint_names': ['shoulder'], 'units': ['rad'],
                           'q': np.sin(t), 'q_d': np.sin(t) + 0.01, 'tau': np.cos(t)}, tmp_path)
    assert (tmp_path / 'tracking.png').is_file()  # a directory gets tracking.png
    assert len(fig.axes) == 3
    assert [a.get_ylabel() for a in fig.axes] == ['position [rad]', 'error [rad]', 'torque [N m]']
    # no limit given: no dashed limit lines
    assert not [line for line in fig.axes[2].get_lines() if line.get_linestyle() == '--']


def test_task_axes_with_more_joints_than_axes():
    """iiwa hybrid control: 3 task axes (m), 7 joint torques, 1 force axis with a reference."""
    N = 200
    t = np.linspace(0.0, 1.0, N)
    x = np.zeros((N, 3))
    f_d = np.full((N, 3), np.nan)
    f_d[:, 2] = 10.0
    fig = tracking_figure({
        'scenario': 'iiwa', 't': t, 'joint_names': ['x', 'y', 'z'], 'units': ['m', 'm', 'm'],
        'q': x, 'q_d': x + 1e-3, 'tau': np.zeros((N, 7)), 'tau_names': [f'a{i}' for i in range(1, 8)],
        'tau_units': ['N m'] * 7, 'effort_limit': [320, 320, 176, 176, 110, 40, 40],
        'f': np.full((N, 3), 9.5), 'f_d': f_d, 'force_names': ['x', 'y', 'z']})
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [3, 3, 4, 3, 3]  # seven torques: a row of 4, a row of 3
    assert [a.get_title() for a in rows[2] + rows[3]] == [f'a{i}' for i in range(1, 8)]
    # the reference is drawn only where there is one
    assert [len(a.get_lines()) for a in rows[4]] == [1, 1, 2]
    # torques far below the limits keep their own scale; the legend says the limit is off scale
    a1 = rows[2][0]
    assert a1.get_legend().get_texts()[1].get_text() == 'limit \u00b1320 (off scale)'
    assert max(abs(v) for v in a1.get_ylim()) < 1.0


def iiwa_data(N=400):
    """Seven joints held near their start (1e-6 rad wobble) with small torques: what made offset labels."""
    t = np.linspace(0.0, 2.0, N)
    q0 = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.55])
    wobble = 1e-6 * np.sin(2 * np.pi * t)[:, None] * np.ones(7)
    names = [f'lbr_iiwa_joint_{i}' for i in range(1, 8)]
    return {'scenario': 'iiwa', 't': t, 'joint_names': names, 'units': ['rad'] * 7,
            'q': q0 + wobble, 'q_d': np.tile(q0, (N, 1)), 'tau': 30.0 + 1e-4 * wobble * 1e6,
            'effort_limit': [320, 320, 176, 176, 110, 40, 40]}


def test_seven_joints_in_rows_of_four_without_offset_labels(tmp_path):
    fig = tracking_figure(iiwa_data(), tmp_path / 'tracking.png')
    check_no_offset(fig)
    rows = axes_by_row(fig)
    assert [len(r) for r in rows] == [4, 3, 4, 3, 4, 3]  # position, error, effort: 4 + 3 each
    names = iiwa_data()['joint_names']
    for block, label in enumerate(['position [rad]', 'error [rad]', 'torque [N m]']):
        panels = rows[2 * block] + rows[2 * block + 1]
        assert [a.get_title() for a in panels] == names  # joint c in column c mod 4 of each block
        assert [a.get_subplotspec().colspan.start for a in panels] == [0, 1, 2, 3, 0, 1, 2]
        assert {a.get_ylabel() for a in panels} == {label}
    w, h = fig.get_size_inches()
    assert w < 16 and h < 16  # four columns, not seven
    assert all(tick.get_text() for ax in fig.axes for tick in ax.get_yticklabels())
    # joint 7 held at 0.55 rad: a flat line at its value, ticks printed as themselves
    q7 = rows[1][2]
    assert q7.get_title() == 'lbr_iiwa_joint_7'
    lo, hi = q7.get_ylim()
    assert lo < 0.55 < hi and hi - lo >= 2e-3 * 0.55 * 0.999
    labels = [float(t.get_text().replace('\u2212', '-')) for t in q7.get_yticklabels() if t.get_text()]
    assert labels and all(abs(v - 0.55) < 2e-3 for v in labels)
    # all panels on one time axis; the time label under the lowest panel of each column
    assert all(a.get_shared_x_axes().joined(a, fig.axes[0]) for a in fig.axes)
    assert [a.get_xlabel() for a in rows[-1]] == ['time [s]'] * 3 and rows[-2][3].get_xlabel() == 'time [s]'


@pytest.mark.parametrize('change, message', [
    ({'q': np.zeros((601, 3))}, r"^data\['q'\]: expected shape \(601, 2\)"),
    ({'units': ['rad', 'deg']}, r"^data\['units'\]"),
    ({'joint_names': ['a']}, r"^data\['units'\]: expected 1 names"),
    ({'effort_limit': [1.0]}, r"^data\['effort_limit'\]"),
    ({'f_d': np.zeros((601, 2))}, r"^data\['f_d'\]"),
    ({'t': [0.0]}, r"^data\['t'\]"),
])
def test_bad_input_names_the_key(change, message):
    data = polar_data()
    data.update(change)
    with pytest.raises(ValueError, match=message):
        tracking_figure(data)
    with pytest.raises(ValueError, match=r"^data\['scenario'\]: missing"):
        tracking_figure({k: v for k, v in polar_data().items() if k != 'scenario'})


def test_plot_module_needs_no_rclpy():
    code = ('import sys, robot_control.tools.plot; '
            'bad = [m for m in sys.modules if m.split(".")[0] in ("rclpy", "sensor_msgs", "std_msgs")]; '
            'print(bad); sys.exit(1 if bad else 0)')
    res = subprocess.run([sys.executable, '-c', code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                         env={**os.environ, 'PYTHONPATH': ROOT})
    assert res.returncode == 0, res.stdout + res.stderr
