"""Controllers that work on a real arm, through the nodes: the typical robots (config/realism/iiwa_typical.yaml,
panda_typical.yaml: friction, rotor inertia, link masses 10 % over the model, velocity noise, encoder
quantization, one tick of actuation delay) in lockstep over DDS on claimed private domains (support.e2e),
the demo's real-arm experiments (robot_control.tools.demo_experiments.REAL_VARIANTS, `--realism typical`).

Every joint moves 0.5 rad in 2 s, then is held to 3.2 s:
  - joint_impedance and its integral (stiffness 1000/600 ... 50 N m/rad) with friction compensation at the
    profile's values: RMS <= 5 mrad and final error <= 2 mrad on every joint (measured: iiwa RMS <= 1.6 mrad,
    final <= 0.8 mrad; Panda RMS <= 1.0 mrad, final <= 0.7 mrad);
  - the same with the friction estimate 30 % low: measured iiwa RMS <= 1.4 mrad, final <= 0.8 mrad; Panda
    RMS <= 1.1 mrad, final <= 0.6 mrad (checked within the same targets);
  - computed torque with the scenario's gains on the same robot: the iiwa's wrist never leaves its start
    (final error 0.5 rad on joints 5-7), the Panda ends up to 0.09 rad short (checked: > 10x the targets).
And the payload identified (<arm>_real_identify, 21 s): joint impedance with friction compensation holding the
move's goal with a 2 kg payload 5 cm out on the flange that the controller is not told of; at 2.7 s the demo calls
/controller/identify_payload with the bridge running until it answers (7 poses; the answer names the joint state it
was reached at, which times it however late a busy machine delivers it). The links being 10 % heavier
than the model, part of their gravity torque is taken for payload (measured: iiwa 2.69 kg, com 42 mm off; Panda
2.34 kg, 37 mm off), but the hold error with the identified payload drops (measured: iiwa 16.6 -> 4.0 mrad, Panda
22.7 -> 4.1 mrad): checked, the answer within 40 % in mass and the hold error at the end below half of the one
before the call. Eight runs, two at a time: 76 s of wall time measured on the loaded 2-core machine (the same
figures as the demo's runs: lockstep repeats). The 30 s hold, the adaptive move and the identification with the model's link masses
(demo experiments <arm>_real_hold, <arm>_real_adaptive, <arm>_real_identify_exact_masses) are measured in
docs/results.md.
"""
import pytest

from support.e2e import Runs

#: the share of ticks the collector must see (it keeps a backlog of demo_ros.DEPTH ticks per topic; the figures
#: checked hold on the ticks it saw)
MIN_TICKS = 0.9
RMS_TARGET, FINAL_TARGET = 5e-3, 2e-3    # rad, every joint
ARMS = ('iiwa', 'panda')
VARIANTS = ('move', 'move_friction_off', 'move_ct', 'identify')


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    r = Runs(tmp_path_factory.mktemp('real_arm'))
    try:
        for arm in ARMS:
            for variant in VARIANTS:
                r.submit(f'{arm}_{variant}', f'{arm}_real_{variant}', realism='typical')
        yield r
    finally:
        r.close()


def _summary(runs, key):
    s = runs.get(key).summary
    assert s['samples'] >= MIN_TICKS * s['expected_ticks']
    assert s['realism'] == 'typical' and s['saturated_ticks'] == 0
    return s


@pytest.mark.parametrize('arm', ARMS)
@pytest.mark.parametrize('variant', ('move', 'move_friction_off'))
def test_joint_impedance_with_friction_compensation_tracks_every_joint_within_the_targets(runs, arm, variant):
    s = _summary(runs, f'{arm}_{variant}')
    assert s['law'] == 'joint_impedance'
    assert max(s['rms_error'].values()) <= RMS_TARGET, s['rms_error']
    assert max(s['final_error'].values()) <= FINAL_TARGET, s['final_error']


@pytest.mark.parametrize('arm', ARMS)
def test_computed_torque_on_the_same_robot_leaves_the_gap(runs, arm):
    s = _summary(runs, f'{arm}_move_ct')
    assert s['law'] == 'computed_torque'
    assert max(s['final_error'].values()) > 10 * FINAL_TARGET, s['final_error']
    assert max(s['rms_error'].values()) > 5 * RMS_TARGET, s['rms_error']


@pytest.mark.parametrize('arm', ARMS)
def test_the_payload_identified_during_the_run_lowers_the_hold_error(runs, arm):
    s = _summary(runs, f'{arm}_identify')
    call, = s['service_calls']
    assert call['success'] and call['service'] == '/controller/identify_payload', call
    assert call['t_called'] == 2.7 and call['t_answered'] < s['duration_s'] - 0.5, call
    fig = s['figures']
    assert abs(fig['payload_mass_error']) < 0.4, fig
    assert fig['payload_mass_kg'] == call['parameters']['payload.mass']
    assert fig['hold_error_after_rad'] < 0.5 * fig['hold_error_before_rad'], fig
