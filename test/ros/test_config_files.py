"""config/*.yaml: one per scenario, each loads into the controller node and validates.

A file's sections are keyed `/**/<node name>` (rcl's wildcard: the node of that name in any
namespace), so the same file configures a robot at the root and one under `/arm`.
"""
import glob
import os

import numpy as np
import pytest
import yaml
from rclpy.parameter import Parameter

from support.param_files import flatten
from robot_control import scenarios
from robot_control.ros.controller_node import ControllerNode
from robot_control.ros.controller_params import ParameterError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIG = os.path.join(ROOT, 'config')
FILES = sorted(glob.glob(os.path.join(CONFIG, '*.yaml')))
NODE_SECTIONS = {'/**/controller', '/**/sim_bridge'}    # one file configures both nodes of a scenario
CONTROLLER = '/**/controller'


def _controller_params(path):
    with open(path) as f:
        doc = yaml.safe_load(f)
    return flatten(doc[CONTROLLER]['ros__parameters'])


def _node_from_file(context, path):
    return ControllerNode(context=context, cli_args=['--ros-args', '--params-file', path])


def test_every_scenario_has_a_config_file():
    names = {os.path.splitext(os.path.basename(p))[0] for p in FILES}
    assert names == set(scenarios.SCENARIOS)


@pytest.mark.parametrize('path', FILES, ids=os.path.basename)
def test_file_layout_is_ros_parameters_per_node(path):
    with open(path) as f:
        doc = yaml.safe_load(f)
    assert set(doc) <= NODE_SECTIONS and CONTROLLER in doc
    for section in doc.values():
        assert set(section) == {'ros__parameters'}
    params = _controller_params(path)
    assert params['scenario'] == os.path.splitext(os.path.basename(path))[0]


@pytest.mark.parametrize('path', FILES, ids=os.path.basename)
def test_file_loads_into_the_node_and_every_key_is_a_declared_parameter(ros_context, path):
    node = _node_from_file(ros_context, path)
    try:
        for name, value in _controller_params(path).items():
            assert node.has_parameter(name), f'{name} in {os.path.basename(path)} is not a controller parameter'
            param = node.get_parameter(name)
            if param.type_ in (Parameter.Type.DOUBLE, Parameter.Type.DOUBLE_ARRAY):
                assert all(isinstance(v, float) for v in np.atleast_1d(value)), f'{name}: write doubles with .0'
            got = list(param.value) if isinstance(value, list) else param.value
            assert got == value, name
        cfg = node.core.config
        assert cfg.law == node.get_parameter('law').value
        assert list(cfg.joints) == list(node.get_parameter('joints').value)
        assert np.all(cfg.effort_limit > 0.0)
    finally:
        node.destroy_node()


def test_polar_file_is_the_lecture_example(ros_context):
    path = os.path.join(CONFIG, 'polar_two_link.yaml')
    params = _controller_params(path)
    assert (params['model_params.m'], params['omega_res'], params['zeta']) == (2.0, 12.0, 1.0)
    node = _node_from_file(ros_context, path)
    try:
        cfg = node.core.config
        assert cfg.law == 'computed_torque' and not cfg.integral
        np.testing.assert_array_equal(cfg.control_law.motion_gains.kp, [36.0, 36.0])
        np.testing.assert_array_equal(cfg.control_law.motion_gains.kv, [12.0, 12.0])
        assert cfg.model.m == 2.0
        q = np.array([0.3, 0.8])
        np.testing.assert_allclose(cfg.model.g(q), [19.6 * 0.8 * np.cos(0.3), 19.6 * np.sin(0.3)], rtol=0,
                                   atol=1e-12)
    finally:
        node.destroy_node()


@pytest.mark.parametrize('key, value, match', [
    ('zeta', 0.5, '^zeta: 0.5 breaks the rule'),
    ('omega_n', 7.0, '^omega_n:'),
    ('law', 'pid', "^law: unknown 'pid'"),
    ('effort_limits', [1.0], '^effort_limits:'),
    ('zeta', 1, '^zeta: expected type DOUBLE'),
])
def test_an_invalid_file_fails_naming_the_parameter(ros_context, tmp_path, key, value, match):
    with open(os.path.join(CONFIG, 'polar_two_link.yaml')) as f:
        doc = yaml.safe_load(f)
    doc[CONTROLLER]['ros__parameters'][key] = value
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ParameterError, match=match):
        _node_from_file(ros_context, str(path))


def test_empty_lists_in_a_file_are_empty(ros_context, tmp_path):
    """`force_axes: []` turns off iiwa's force axis (with its k_e, x_e); `kp: []` keeps the designed gains,
    as a `ros2 param dump` of the running node writes them."""
    with open(os.path.join(CONFIG, 'iiwa.yaml')) as f:
        doc = yaml.safe_load(f)
    doc[CONTROLLER]['ros__parameters'].update(force_axes=[], k_e=[], x_e=[], f_d=[], kp=[])
    path = tmp_path / 'no_force.yaml'
    path.write_text(yaml.safe_dump(doc))
    node = _node_from_file(ros_context, str(path))
    try:
        cfg = node.core.config
        task = cfg.control_law.force_task
        assert task.force_axes == () and task.k_e.shape == (0,)
        assert node.get_parameter('kp').type_ == Parameter.Type.DOUBLE_ARRAY
        np.testing.assert_array_equal(cfg.control_law.motion_gains.kp, [36.0] * 7)
    finally:
        node.destroy_node()


@pytest.mark.parametrize('namespace', ['/', '/arm', '/robots/left'])
def test_file_applies_to_the_controller_in_any_namespace(ros_context, namespace):
    """`/**/controller` matches the node named controller whatever its namespace (as ros2 launch
    starts it: `-r __ns:=<namespace> --params-file <file>`)."""
    path = os.path.join(CONFIG, 'iiwa.yaml')
    node = ControllerNode(context=ros_context,
                          cli_args=['--ros-args', '-r', f'__ns:={namespace}', '--params-file', path])
    try:
        assert node.get_namespace() == namespace
        assert node.get_parameter('scenario').value == 'iiwa'     # the node's default is ''
        assert list(node.get_parameter('joints').value) == _controller_params(path)['joints']
    finally:
        node.destroy_node()


def test_a_key_the_controller_does_not_have_is_refused(ros_context, tmp_path):
    with open(os.path.join(CONFIG, 'polar_two_link.yaml')) as f:
        doc = yaml.safe_load(f)
    doc[CONTROLLER]['ros__parameters']['model_params']['mass'] = 2.0
    path = tmp_path / 'typo.yaml'
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ParameterError, match=r'^model_params.mass: unknown parameter of controller; did you mean '
                                             r'model_params.m\?'):
        _node_from_file(ros_context, str(path))


def test_file_applies_to_the_bridge_in_a_namespace(ros_context):
    from sim_bridge.bridge_node import SimBridge
    path = os.path.join(CONFIG, 'iiwa.yaml')
    with open(path) as f:
        want = yaml.safe_load(f)['/**/sim_bridge']['ros__parameters']
    node = SimBridge(context=ros_context, cli_args=['--ros-args', '-r', '__ns:=/arm', '--params-file', path])
    try:
        assert node.get_namespace() == '/arm'
        assert node.get_parameter('scenario').value == 'iiwa'     # the node's default is polar_two_link
        assert list(node.get_parameter('initial_positions').value) == want['initial_positions']
    finally:
        node.destroy_node()


# -- config/templates/your_robot.yaml: your own arm ---------------------------------------------------------------
TEMPLATE = os.path.join(CONFIG, 'templates', 'your_robot.yaml')
ROS_OWN = {'use_sim_time'}       # rclpy's own parameter, in no table


def _template_sections():
    with open(TEMPLATE, encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    assert set(doc) == NODE_SECTIONS and all(set(s) == {'ros__parameters'} for s in doc.values())
    return {name: flatten(doc[f'/**/{name}']['ros__parameters']) for name in ('controller', 'sim_bridge')}


def _through_table(table, params):
    """The checked values of `params` through `table` (ParameterError naming a bad one), after checking that
    every key is one of the table's rows, as the node refuses an unknown one."""
    rows, _ = table.resolve(lambda row: params.get(row.name, row.default), check=False)
    unknown = set(params) - set(rows.names()) - ROS_OWN
    assert not unknown, f'{sorted(unknown)} in {TEMPLATE} are no parameters of {table.node}'
    return table.validate(params)


def test_the_template_is_an_arm_the_package_does_not_ship_and_loads_through_both_tables():
    """config/templates/your_robot.yaml (the xArm7 of example-robot-data): valid for the controller's and the
    bridge's parameter tables and their builds (no rclpy), the same robot and joints in both sections."""
    from robot_control import urdf as urdf_files
    from robot_control.ros import controller_params
    from robot_control.ros.config_builder import ConfigBuilder
    from sim_bridge import bridge_params
    sections = _template_sections()
    ctrl, bridge = sections['controller'], sections['sim_bridge']
    assert ctrl['scenario'] == bridge['scenario'] == '' and ctrl['model'] == 'urdf'
    assert ctrl['urdf'] == bridge['urdf'] and ctrl['joints'] == bridge['joints']
    shipped = {os.path.basename(p) for p in glob.glob(os.path.join(urdf_files.DIR, '*.urdf'))}
    assert os.path.basename(ctrl['urdf']) not in shipped
    assert all(sc.urdf != ctrl['urdf'] for sc in scenarios.SCENARIOS.values())
    values = _through_table(controller_params.TABLE, ctrl)
    config = ConfigBuilder()(values)
    assert list(config.joints) == ctrl['joints'] == [f'joint{i}' for i in range(1, 8)]
    assert config.model.task_axes == ('x', 'y', 'z', 'rx', 'ry', 'rz') and np.all(config.effort_limit > 0.0)
    np.testing.assert_array_equal(config.control_law.motion_gains.kp, [36.0] * 7)   # omega_n = omega_res / 2 = 6 rad/s
    cfg = bridge_params.build(_through_table(bridge_params.TABLE, bridge))
    assert cfg.joints == tuple(ctrl['joints']) and cfg.urdf == urdf_files.resolve(ctrl['urdf'])
    assert len(cfg.initial_positions) == 7 and not cfg.surface_enable


def test_every_line_of_the_template_that_sets_a_value_explains_it():
    """A comment on each line that sets a parameter (or on the list it continues), units where the value has
    them: the template is the documentation a new user edits."""
    with open(TEMPLATE, encoding='utf-8') as f:
        lines = f.read().splitlines()
    for i, line in enumerate(lines):
        body = line.split('#')[0].rstrip()
        if body.endswith(':') or not body.strip() or ':' not in body:      # a section, a comment, a blank
            continue
        assert '#' in line, f'line {i + 1} of {TEMPLATE} sets a value without a comment: {line.strip()}'

