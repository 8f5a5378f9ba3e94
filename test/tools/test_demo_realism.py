"""The demo's realism option without running it: which parameter files the bridge is started with, where the
outputs go, and the iiwa_gap experiments' bridge overrides (no DDS, no processes)."""
import pytest

from robot_control.tools import demo, demo_experiments as exps


def _files(argv):
    return [argv[i + 1] for i, a in enumerate(argv) if a == '--params-file']


def test_typical_stacks_the_scenarios_profile_after_its_file_and_before_the_overrides():
    profile = demo.realism_profile('iiwa', 'typical')
    assert profile == demo.ROOT / 'config' / 'realism' / 'iiwa_typical.yaml'
    argv = demo.node_argv('sim_bridge.bridge_node', 'iiwa', {'delay.measurement_ticks': exps.Integer(1),
                                                             'payload.mass': 2}, profiles=[profile])
    assert _files(argv) == [str(demo.config_path('iiwa')), str(profile)]
    assert argv.index(str(profile)) < argv.index('delay.measurement_ticks:=1')   # -p wins over every file
    assert 'payload.mass:=2.0' in argv                                  # a number is a double, but an Integer


def test_ideal_and_a_scenario_without_a_profile_run_the_scenario_alone():
    assert demo.realism_profile('iiwa', 'ideal') is None
    assert demo.realism_profile('single_link', 'typical') is None
    assert demo.realism_profile('polar_two_link', 'typical').name == 'polar_two_link_typical.yaml'
    with pytest.raises(ValueError, match="realism: expected one of"):
        demo.realism_profile('iiwa', 'measured')
    assert _files(demo.node_argv('sim_bridge.bridge_node', 'iiwa', {})) == [str(demo.config_path('iiwa'))]


def test_typical_outputs_go_beside_the_ideal_ones():
    assert exps.output_name('iiwa_ptp', 'typical') == 'iiwa_ptp_typical'
    assert exps.output_name('polar_step', 'typical') == 'polar_two_link_typical'
    assert exps.output_name('polar_step') == 'polar_two_link'
    with pytest.raises(SystemExit):
        demo.main(['--experiment', 'iiwa_ptp', '--realism', 'measured'])


def test_the_gap_variants_each_add_their_effect_and_all_adds_every_one():
    twin = exps.get('iiwa_gap_twin')
    assert twin.bridge == {'initial_positions': list(exps.IIWA_POSTURE), 'surface.enable': False}
    assert twin.duration == 3.2 and twin.trajectory.t_end == pytest.approx(2.2)
    goal = twin.trajectory.positions[-1]
    assert goal == pytest.approx([q + exps.GAP_MOVE for q in exps.IIWA_POSTURE])
    every = {}
    for variant, (_, params) in exps.GAP_EFFECTS.items():
        assert exps.get(f'iiwa_gap_{variant}').bridge == {**twin.bridge, **params}
        every.update(params)
    assert exps.get('iiwa_gap_all').bridge == {**twin.bridge, **every}
    assert exps.get('iiwa_gap_late').bridge['delay.measurement_ticks'] == 1
