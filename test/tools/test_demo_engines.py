"""The demo on either engine, and both side by side (robot_control.tools.demo: --engine, output_name,
side_by_side): the pieces that need no run. A run on MuJoCo end to end is the e2e suite's and `demo --engine`."""
from robot_control.tools import demo


def _summary(rms, force=None, reference=15.0):
    """A run's summary with these RMS errors {coordinate: value} and, given, a steady force on axis x, N."""
    out = {'rms_error': rms, 'force_axes': []}
    if force is not None:
        out.update(force_axes=['x'], force_reference={'x': reference}, force_steady_state_error={'x': reference - force})
    return out


def test_the_engine_option_takes_either_engine_or_both_pybullet_the_default():
    parse = demo._parser().parse_args
    assert parse([]).engine == 'pybullet' == demo.ENGINES[0]
    assert parse(['--engine', 'mujoco']).engine == 'mujoco' and parse(['--all', '--engine', 'both']).engine == 'both'


def test_a_mujoco_run_writes_beside_the_pybullet_one():
    assert demo.output_name('force_steps') == 'force_1dof'
    assert demo.output_name('force_steps', engine='mujoco') == 'force_1dof_mujoco'
    assert demo.output_name('iiwa_ptp', 'typical', 'mujoco') == 'iiwa_ptp_typical_mujoco'


def test_side_by_side_flags_what_differs_beyond_the_issue_s_bounds():
    """Tracking: < 1 mrad apart, or < 10 % of the larger; force: < 5 % of the larger."""
    summaries = {
        ('a', 'pybullet'): _summary({'q1': 4.0e-3, 'q2': 1.0e-3}), ('a', 'mujoco'): _summary({'q1': 4.9e-3}),
        ('b', 'pybullet'): _summary({'q1': 0.050}), ('b', 'mujoco'): _summary({'q1': 0.056}),
        ('c', 'pybullet'): _summary({'q1': 0.0}, force=15.0), ('c', 'mujoco'): _summary({'q1': 0.0}, force=14.4),
        ('d', 'pybullet'): _summary({'q1': 0.0}, force=15.0), ('d', 'mujoco'): _summary({'q1': 0.0}, force=14.0),
        ('e', 'pybullet'): _summary({'q1': 0.2}),
    }
    rows = {line.split(' | ')[0][2:]: line.split(' | ') for line in demo.side_by_side(summaries, 'abcde').splitlines()[2:]}
    assert rows['a'][1:4] == ['4.000e-03', '4.900e-03', '']                   # 0.9 mrad apart
    assert rows['b'][3] == 'differs'                                           # 6 mrad, 11 %
    assert rows['c'][4:] == ['15.000', '14.400', ' |']                         # 4 %
    assert rows['d'][6] == 'differs |'                                          # 6.7 %
    assert rows['e'][1:3] == ['2.000e-01', '-']                                # not run on mujoco: no verdict
