"""The demo's real-arm experiments (robot_control.tools.demo_experiments: <arm>_real_<variant>), their figures
(demo_metrics: hold, repetitions) and their table in docs/results.md (dev.docs_results), without DDS.
test/e2e/test_real_arm.py runs the moves through the nodes."""
import json

import numpy as np
import pytest
import yaml

from dev import docs_results
from robot_control.tools import demo, demo_experiments as exps, demo_metrics


def _run(t, q, err):
    n = q.shape[1]
    z = np.zeros_like(q)
    return demo_metrics.RunData(
        t=t, joints=tuple(f'j_{i + 1}' for i in range(n)), joint_units=('rad',) * n, q=q, qd=z, tau_applied=z,
        tau_cmd=z, ref_names=tuple(f'j_{i + 1}' for i in range(n)), ref_pos=z, ref_vel=z, ref_acc=z, err_pos=err,
        err_vel=z, force_xyz=np.zeros((t.size, 3)), force_axes=(), force_axis_index=(), law='joint_impedance')


@pytest.mark.parametrize('arm', exps.REAL_ARMS)
def test_each_variant_is_the_move_on_its_arm_with_the_profile_s_friction(arm):
    with open(demo.realism_profile(arm, 'typical'), encoding='utf-8') as f:
        friction = yaml.safe_load(f)['/**/sim_bridge']['ros__parameters']['friction']
    for variant, (_, law, overrides, scale) in exps.REAL_VARIANTS.items():
        exp = exps.get(f'{arm}_real_{variant}')
        assert exp.law == law == exp.controller['law'] and exp.scenario == arm
        q0 = np.array(exp.bridge['initial_positions'])
        np.testing.assert_allclose(exp.trajectory.positions[0], q0 + exps.REAL_MOVE, rtol=0, atol=1e-12)
        assert exp.trajectory.times[0] == exps.REAL_MOVE_TIME
        if scale is None:
            assert not any(k.startswith('friction_compensation.') for k in exp.controller)
        else:
            for key in ('coulomb', 'viscous'):
                np.testing.assert_allclose(exp.controller[f'friction_compensation.{key}'],
                                           scale * np.array(friction[key]), rtol=1e-12)
        assert all(exp.controller[k] == v for k, v in overrides.items())
    assert exps.REAL_VARIANTS['move_friction_off'][3] == 0.7
    adaptive = exps.get(f'{arm}_real_adaptive')
    assert adaptive.bridge['payload.mass'] == 2.0 and 'payload.mass' not in adaptive.controller
    assert len(adaptive.trajectory.times) == 2 * exps.REAL_REPETITIONS
    np.testing.assert_allclose(adaptive.trajectory.positions[1], adaptive.bridge['initial_positions'])
    assert exps.get(f'{arm}_real_hold').duration == exps.REAL_HOLD


def test_hold_and_repetition_figures_on_a_synthetic_run():
    """Joint 2 moves 1 mrad between 20 and 25 s of a 30 s run: the travel of the last 10 s is 1 mrad; the
    repetitions' RMS are those of the error in each out-and-back pair of segments."""
    t = np.arange(0, 30001) * 0.001
    q = np.zeros((t.size, 2))
    q[(t > 22.0) & (t < 25.0), 1] = 1e-3
    q[t < 5.0, 0] = 0.5                            # before the window: not counted
    fig = demo_metrics.hold_figures(_run(t, q, q), exps.get('iiwa_real_hold'))
    assert fig == {'last_10_s_travel_rad': pytest.approx(1e-3)}
    exp = exps.get('iiwa_real_adaptive')
    t = np.arange(0, int(exp.duration * 1000) + 1) * 0.001
    err = np.zeros((t.size, 7))
    start = exp.trajectory.t_start
    err[(t >= start) & (t < start + 4.0)] = 2e-3
    err[(t >= start + 4.0) & (t < start + 8.0)] = 1e-3
    fig = demo_metrics.repetition_figures(_run(t, err, err), exp)
    assert fig == pytest.approx({'repetition_1_rms_rad': 2e-3, 'repetition_2_rms_rad': 1e-3,
                                 'repetition_3_rms_rad': 0.0})


def _summary(experiment, rms, final, figures=None):
    joints = [f'lbr_iiwa_joint_{i}' for i in range(1, 8)]
    return {'experiment': experiment, 'scenario': 'iiwa', 'law': 'joint_impedance', 'mode': 'lockstep',
            'duration_s': 3.2, 'samples': 3201, 'rms_error': dict(zip(joints, rms)),
            'max_error': dict(zip(joints, rms)), 'final_error': dict(zip(joints, final)),
            'steady_state_error': dict(zip(joints, final)), 'settling_time_s': 2.0, 'force_rms_error': None,
            'saturated_ticks': 0, 'loop_rate_hz': 300.0, 'latency_p50_ms': 0.2, 'latency_p99_ms': 9.0,
            'realism': 'typical', 'realism_profile': 'config/realism/iiwa_typical.yaml', 'figures': figures or {}}


def test_the_real_arm_runs_have_their_own_table_and_stay_out_of_the_typical_one(tmp_path):
    results = tmp_path / 'out'
    for name, s in (('iiwa_real_move_typical', _summary('iiwa_real_move', [1e-3] * 6 + [1.5e-3], [2e-4] * 7)),
                    ('iiwa_real_hold_typical', _summary('iiwa_real_hold', [1e-4] * 7, [5e-5] * 7,
                                                        {'last_10_s_travel_rad': 3.6e-4})),
                    ('iiwa_ptp_typical', _summary('iiwa_ptp', [0.5] * 7, [0.5] * 7))):
        (results / name).mkdir(parents=True)
        (results / name / 'summary.json').write_text(json.dumps(s))
    summaries = docs_results.load_summaries(results)
    _, typical, _, real = docs_results.split(summaries)
    assert [s['experiment'] for _, s in real] == ['iiwa_real_move', 'iiwa_real_hold']
    assert [s['experiment'] for _, s in typical] == ['iiwa_ptp']
    table = docs_results.real_arm_table(summaries)
    rows = [line for line in table.splitlines() if line.startswith('| iiwa_real')]
    assert rows[0].startswith('| iiwa_real_move | iiwa | joint_impedance |')
    assert '1.50e-03 rad (j7)' in rows[0] and rows[0].endswith('| 0 |')
    assert '3.60e-04 rad' in rows[1]
    assert 'iiwa_real' not in docs_results.typical_table(summaries)


@pytest.mark.parametrize('arm', exps.REAL_ARMS)
def test_the_identify_experiments_carry_an_unknown_payload_and_call_the_identification_at_rest(arm):
    for variant in ('identify', 'identify_exact_masses'):
        exp = exps.get(f'{arm}_real_{variant}')
        assert exp.bridge['payload.mass'] == 2.0 and not any(k.startswith('payload.') for k in exp.controller)
        (t, service, started, names), = exp.service_calls
        assert started == 'identifying the payload'
        assert service == '/controller/identify_payload' and names == ('payload.mass', 'payload.com')
        assert exp.trajectory.t_end < t < exp.duration
    exact = exps.get(f'{arm}_real_identify_exact_masses').bridge
    assert exact['sim_params.mass_scale'] == [1.0] * 7 and 'sim_params.mass_scale' not in exps.get(f'{arm}_real_identify').bridge


def test_identify_figures_compare_the_payload_and_the_hold_before_the_call_and_at_the_end():
    exp = exps.get('iiwa_real_identify')
    t = np.arange(0, int(exp.duration * 1000) + 1) * 0.001
    err = np.zeros((t.size, 7))
    err[t < 2.7, 1] = 0.02                         # the hold before the call
    err[t > exp.duration - 1.0, 6] = 0.003         # the end
    data = _run(t, err, err)
    data.calls = [{'t': 2.7, 't_called': 2.7, 't_answered': 15.5, 'parameters': {
        'payload.mass': 2.1, 'payload.com': [0.0, 0.003, 0.054]}}]
    fig = demo_metrics.identify_figures(data, exp)
    assert fig == pytest.approx({'payload_mass_kg': 2.1, 'payload_mass_error': 0.05, 'payload_com_error_m': 0.005,
                                 'hold_error_before_rad': 0.02, 'hold_error_after_rad': 0.003})
    data.calls[0]['t_answered'] = exp.duration - 0.1   # answered within the end's window: no after figure
    assert demo_metrics.identify_figures(data, exp)['hold_error_after_rad'] is None
