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
    assert a1.get_ylim() == (-1.0, 1.0)  # zero torque: a flat line at 0 in +-1 N m (flat_limits)


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


def one_joint(t, q, tau, **extra):
    data = {'scenario': 'single_link', 't': t, 'joint_names': ['shoulder'], 'units': ['rad'], 'q': q,
            'q_d': np.full_like(t, np.nan), 'tau': tau}
    data.update(extra)
    return data


def y_ticks(ax):
    """The y tick values as printed, and the axis' offset/multiplier text, after a draw."""
    ax.figure.canvas.draw()
    lo, hi = ax.get_ylim()
    printed = [float(t.get_text().replace('\u2212', '-')) for t in ax.get_yticklabels()
               if t.get_text() and lo <= t.get_position()[1] <= hi]
    return printed, ax.yaxis.get_offset_text().get_text()


@pytest.mark.parametrize('tau', [np.full(201, 1e-15), 1e-15 * np.sign(np.sin(np.arange(201.0)))],
                         ids=['constant', 'sign flipping'])
def test_a_round_off_torque_reads_as_zero(tau):
    """A 1e-15 N m torque is 0 N m: y-limits around 0 at least +-1 N m wide, ticks without a
    multiplier or offset (not a 1e-15 band that looks like chatter)."""
    t = np.linspace(0.0, 2.0, 201)
    fig = tracking_figure(one_joint(t, np.full_like(t, 0.3) + 0.1 * t, tau))
    check_no_offset(fig)
    torque = [a for a in fig.axes if a.get_ylabel() == 'torque [N m]'][0]
    lo, hi = torque.get_ylim()
    assert lo <= -1.0 + 1e-12 and hi >= 1.0 - 1e-12 and abs(lo + hi) < 1e-12
    printed, offset = y_ticks(torque)
    assert offset == '' and 0.0 in printed and max(abs(v) for v in printed) <= 1.0


@pytest.mark.parametrize('value, unit, step', [(0.55, 'rad', 0.1), (-2.5, 'rad', 1.0), (40.0, 'N m', 10.0),
                                               (0.0, 'rad', 1.0)])
def test_a_constant_signal_is_a_flat_line_at_its_value(value, unit, step):
    """An exactly constant signal, and the same with round-off jitter, is drawn flat at its value in
    the middle of limits +- one step of its leading decade, printed without offset."""
    t = np.linspace(0.0, 2.0, 201)
    jitter = 1e-12 * max(1.0, abs(value)) * np.sin(np.arange(t.size))
    for signal in (np.full_like(t, value), value + jitter):
        q, tau = (signal, np.cos(t)) if unit == 'rad' else (np.sin(t), signal)
        fig = tracking_figure(one_joint(t, q, tau))
        ax = [a for a in fig.axes if a.get_ylabel() == ('position [rad]' if unit == 'rad' else 'torque [N m]')][0]
        line = ax.get_lines()[0]
        np.testing.assert_array_equal(line.get_ydata(), signal)
        lo, hi = ax.get_ylim()
        assert lo < value < hi
        np.testing.assert_allclose([lo, hi], [value - step, value + step], rtol=1e-9, atol=1e-12)
        printed, offset = y_ticks(ax)
        assert offset == '' and min(abs(v - value) for v in printed) < 1e-9
        check_no_offset(fig)


def test_only_the_signals_given_are_drawn():
    """No reference: no q_d line or legend entry and no error block; force all NaN: no force block;
    a legend entry names the source of its signal; a commanded effort says so."""
    t = np.linspace(0.0, 1.0, 101)
    data = one_joint(t, np.sin(t), np.cos(t), tau_kind='commanded', f=np.full((101, 1), np.nan),
                     sources={'q': '/joint_states', 'tau': '/robot_joint_commands'})
    fig = tracking_figure(data)
    assert [a.get_ylabel() for a in fig.axes] == ['position [rad]', 'torque [N m]']
    pos, eff = fig.axes
    assert [text.get_text() for text in pos.get_legend().get_texts()] == ['actual $q$ (/joint_states)']
    assert [line.get_label() for line in pos.get_lines()] == ['actual $q$ (/joint_states)']
    assert [text.get_text() for text in eff.get_legend().get_texts()] \
        == ['$\\tau$ commanded (/robot_joint_commands)']
    # an error without a reference (the controller's ~/error alone) keeps the error block
    data.update(e=0.01 * np.cos(t)[:, None], sources={'e': '/controller/error'})
    fig = tracking_figure(data)
    assert [a.get_ylabel() for a in fig.axes] == ['position [rad]', 'error [rad]', 'torque [N m]']
    assert [line.get_label() for line in fig.axes[1].get_lines()][-1] == '$e = q_d - q$ (/controller/error)'


@pytest.mark.parametrize('change, message', [
    ({'q': np.zeros((601, 3))}, r"^data\['q'\]: expected shape \(601, 2\)"),
    ({'units': ['rad', 'deg']}, r"^data\['units'\]"),
    ({'joint_names': ['a']}, r"^data\['units'\]: expected 1 names"),
    ({'effort_limit': [1.0]}, r"^data\['effort_limit'\]"),
    ({'f_d': np.zeros((601, 2))}, r"^data\['f_d'\]"),
    ({'t': [0.0]}, r"^data\['t'\]"),
    ({'tau_kind': 'measured'}, r"^data\['tau_kind'\]"),
    ({'sources': {'x_d': '/ref'}}, r"^data\['sources'\]"),
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
