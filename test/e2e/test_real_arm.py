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
Six runs, two at a time: 62 s of wall time measured on the loaded 2-core machine. The 30 s hold and the adaptive
move (demo experiments <arm>_real_hold, <arm>_real_adaptive) are measured in docs/results.md.
"""
import pytest

from support.e2e import Runs

MIN_TICKS = 0.98                   # the share of ticks the collector must see (test_experiments.MIN_TICKS)
RMS_TARGET, FINAL_TARGET = 5e-3, 2e-3    # rad, every joint
ARMS = ('iiwa', 'panda')
VARIANTS = ('move', 'move_friction_off', 'move_ct')


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
