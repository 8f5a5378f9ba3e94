"""config/realism/<scenario>_typical.yaml: bridge parameters stacked after a scenario file.

`--params-file config/iiwa.yaml --params-file config/realism/iiwa_typical.yaml`: each profile configures the
bridge alone, sets only the realism parameters (REALISM below, the contract with the bridge's parameter
table) and gives every per-joint list one entry per joint of its scenario.
"""
import glob
import os

import pytest
import yaml
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import parameter_dict_from_yaml_file

from support.param_files import flatten

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIG = os.path.join(ROOT, 'config')
PROFILES = sorted(glob.glob(os.path.join(CONFIG, 'realism', '*.yaml')))
BRIDGE = '/**/sim_bridge'
SUFFIX = '_typical.yaml'

JOINT, SIX, INT, SCALE = 'per joint', 'six', 'int', 'one per link or one for all'
#: the ROS parameter types of each shape
ROS_TYPES = {JOINT: {ParameterType.PARAMETER_DOUBLE_ARRAY}, SIX: {ParameterType.PARAMETER_DOUBLE_ARRAY},
             INT: {ParameterType.PARAMETER_INTEGER},
             SCALE: {ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_DOUBLE_ARRAY}}
#: every name a realism profile may set -> its shape
REALISM = {
    'friction.coulomb': JOINT,            # N m or N
    'friction.viscous': JOINT,            # N m s/rad
    'armature': JOINT,                    # kg m^2
    'sim_params.mass_scale': JOINT,       # 1
    'sim_params.inertia_scale': JOINT,    # 1
    'noise.position_std': JOINT,          # rad
    'noise.velocity_std': JOINT,          # rad/s
    'encoder_resolution': JOINT,          # rad per count
    'noise.wrench_std': SIX,              # N, N, N, N m, N m, N m
    'wrench_bias': SIX,                   # N, N, N, N m, N m, N m
    'noise.effort_std': JOINT,            # N m
    'delay.measurement_ticks': INT,
    'delay.actuation_ticks': INT,
    'seed': INT,
}


def _load(path):
    with open(path) as f:
        return yaml.safe_load(f)


def _scenario(path):
    return os.path.basename(path)[:-len(SUFFIX)]


def _joint_count(scenario):
    return len(_load(os.path.join(CONFIG, f'{scenario}.yaml'))[BRIDGE]['ros__parameters']['joints'])


def _is_float(v):
    return isinstance(v, float)


def test_there_is_a_typical_profile_for_each_arm():
    assert [os.path.basename(p) for p in PROFILES] == ['iiwa_typical.yaml', 'panda_typical.yaml',
                                                       'ur5_typical.yaml']


@pytest.mark.parametrize('path', PROFILES, ids=os.path.basename)
def test_profile_is_ros_parameter_yaml_of_the_bridge_alone(path):
    doc = _load(path)
    assert set(doc) == {BRIDGE} and set(doc[BRIDGE]) == {'ros__parameters'}
    params = parameter_dict_from_yaml_file(path, target_nodes=[BRIDGE])
    assert set(params) == set(flatten(doc[BRIDGE]['ros__parameters']))
    for name, param in params.items():
        assert name in REALISM and param.value.type in ROS_TYPES[REALISM[name]], name


@pytest.mark.parametrize('path', PROFILES, ids=os.path.basename)
def test_profile_sets_only_realism_parameters_shaped_for_its_scenario(path):
    n = _joint_count(_scenario(path))
    params = flatten(_load(path)[BRIDGE]['ros__parameters'])
    unknown = sorted(set(params) - set(REALISM))
    assert not unknown, f'not realism parameters: {unknown}'
    for name, value in params.items():
        shape = REALISM[name]
        if shape == INT:
            assert isinstance(value, int) and not isinstance(value, bool) and value >= 0, name
        elif shape == SCALE:
            scales = value if isinstance(value, list) else [value]
            assert scales and all(_is_float(v) and v > 0.0 for v in scales), \
                f'{name}: positive doubles (write 1.0, not 1)'
        else:
            want = n if shape == JOINT else 6
            assert isinstance(value, list) and len(value) == want, f'{name}: {want} values for {_scenario(path)}'
            assert all(_is_float(v) for v in value), f'{name}: write doubles with .0'


@pytest.mark.parametrize('path', PROFILES, ids=os.path.basename)
def test_profile_values_are_physical(path):
    """Friction, inertia, noise and resolution are not negative; the encoder resolves something."""
    params = flatten(_load(path)[BRIDGE]['ros__parameters'])
    for name in ('friction.coulomb', 'friction.viscous', 'armature', 'noise.position_std', 'noise.velocity_std',
                 'noise.effort_std', 'noise.wrench_std'):
        assert all(v >= 0.0 for v in params[name]), name
    assert all(0.0 < v < 0.01 for v in params['encoder_resolution'])


@pytest.mark.parametrize('path', PROFILES, ids=os.path.basename)
def test_profile_stacks_after_its_scenario_file(path):
    """Stacked, the profile adds its names to the scenario's bridge parameters and overrides none of them
    but the sim_params it refines; the scenario's own parameters survive."""
    scenario = flatten(_load(os.path.join(CONFIG, f'{_scenario(path)}.yaml'))[BRIDGE]['ros__parameters'])
    profile = flatten(_load(path)[BRIDGE]['ros__parameters'])
    assert not set(scenario) & set(profile)
    assert 'sim_params.gravity' in scenario


@pytest.mark.parametrize('path', PROFILES, ids=os.path.basename)
def test_profile_names_are_bridge_parameters_and_the_stack_builds(path):
    """The contract above is the bridge's own table: every name is one of its rows for the scenario, and the
    scenario's bridge parameters with the profile stacked on them build a configuration whose friction,
    sensors and link scaling are the profile's."""
    from sim_bridge import bridge_params
    scenario = _scenario(path)
    stacked = {**flatten(_load(os.path.join(CONFIG, f'{scenario}.yaml'))[BRIDGE]['ros__parameters']),
               **flatten(_load(path)[BRIDGE]['ros__parameters'])}
    values = bridge_params.defaults(scenario, **{k: tuple(v) if isinstance(v, list) else v
                                                 for k, v in stacked.items()})
    rows = {row.name for row in bridge_params.TABLE.resolve(lambda row: values.get(row.name, row.default))[0]}
    profile = flatten(_load(path)[BRIDGE]['ros__parameters'])
    assert set(profile) <= rows, sorted(set(profile) - rows)
    cfg = bridge_params.validate(values)
    assert cfg.friction.coulomb.tolist() == profile['friction.coulomb']
    assert cfg.friction.armature.tolist() == profile['armature']
    assert cfg.sensors.measurement_ticks == profile['delay.measurement_ticks']
    assert list(cfg.sim_params['mass_scale']) == profile['sim_params.mass_scale']
