"""launch/scenario.launch.py, checked without `launch` (not on PyPI): its source is read as Python.

What is checked here: the arguments it declares (names, defaults, choices) and what it refers to
(the node executables, their names and the config sections, the /clock remapping rule, applied by
rclpy's own remapping). That `ros2 launch` brings the loop up is checked by `make check-ros2`.
"""
import ast
import importlib.metadata
import os
import xml.etree.ElementTree as ET

import pytest
import yaml

from robot_control import scenarios
from sim_bridge.bridge_params import MODES

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LAUNCH_FILE = os.path.join(ROOT, 'launch', 'scenario.launch.py')


def _tree():
    with open(LAUNCH_FILE, encoding='utf-8') as f:
        return ast.parse(f.read(), LAUNCH_FILE)


def _calls(name):
    """Every call of `name(...)` in the launch file."""
    return [n for n in ast.walk(_tree())
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == name]


def _keywords(call):
    return {k.arg: k.value for k in call.keywords}


def _constant(name):
    """The literal assigned to module-level `name`."""
    for node in _tree().body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError(f'{name} is not assigned in {LAUNCH_FILE}')


def _arguments():
    """{name: {'default_value': ..., 'choices': ...}} of the DeclareLaunchArgument calls (literals only)."""
    out = {}
    for call in _calls('DeclareLaunchArgument'):
        name = ast.literal_eval(call.args[0])
        kw = _keywords(call)
        out[name] = {k: ast.literal_eval(v) for k, v in kw.items()
                     if k in ('default_value', 'choices') and not isinstance(v, ast.Name)}
        if isinstance(kw.get('choices'), ast.Name):
            out[name]['choices'] = kw['choices'].id
    return out


def _nodes():
    """[(executable, name)] of the Node actions."""
    return [(ast.literal_eval(_keywords(c)['executable']), ast.literal_eval(_keywords(c)['name']))
            for c in _calls('Node')]


def test_it_declares_the_documented_arguments_with_their_defaults():
    args = _arguments()
    assert set(args) == {'scenario', 'mode', 'namespace', 'gui', 'use_sim_time'}
    assert {k: v['default_value'] for k, v in args.items()} == {
        'scenario': 'polar_two_link', 'mode': 'realtime', 'namespace': '', 'gui': 'false', 'use_sim_time': 'true'}


def test_mode_choices_are_the_bridge_modes_and_booleans_are_true_or_false():
    args = _arguments()
    assert tuple(args['mode']['choices']) == MODES
    assert _constant('BOOLEAN') == ['true', 'false']
    assert args['gui']['choices'] == args['use_sim_time']['choices'] == 'BOOLEAN'
    assert args['scenario']['choices'] == 'SCENARIOS'    # the installed config/*.yaml, read at launch


def test_default_scenario_and_every_shipped_one_has_a_file_for_both_nodes():
    assert _arguments()['scenario']['default_value'] in scenarios.SCENARIOS
    names = [name for _, name in _nodes()]
    assert sorted(names) == ['controller', 'sim_bridge']
    for scenario in scenarios.SCENARIOS:
        with open(os.path.join(ROOT, 'config', f'{scenario}.yaml'), encoding='utf-8') as f:
            doc = yaml.safe_load(f)
        for name in names:   # /**/<name>: the section applies whatever namespace the launch gives
            assert 'ros__parameters' in doc[f'/**/{name}'], (scenario, name)


def test_node_executables_are_the_package_console_scripts():
    scripts = {ep.name: ep.value for ep in importlib.metadata.distribution('robot_control').entry_points
               if ep.group == 'console_scripts'}
    assert dict(_nodes()) == {'sim_bridge_node': 'sim_bridge', 'controller_node': 'controller'}
    assert scripts['sim_bridge_node'] == 'sim_bridge.bridge_node:main'
    assert scripts['controller_node'] == 'robot_control.ros.controller_node:main'


def test_both_nodes_get_the_clock_remapping():
    for call in _calls('Node'):
        remap = _keywords(call)['remappings']
        assert isinstance(remap, ast.Name) and remap.id == 'CLOCK_REMAP'


@pytest.mark.parametrize('namespace, clock', [('/', '/clock'), ('/arm', '/arm/clock'),
                                              ('/robots/left', '/robots/left/clock')])
def test_clock_remapping_puts_clock_in_the_node_namespace(ros_context, namespace, clock):
    """The launch file's rule, as rcl applies it: a relative replacement is expanded in the node's
    namespace, so one rule serves every namespace (and none)."""
    from rclpy.node import Node
    rules = [a for src, dst in _constant('CLOCK_REMAP') for a in ('-r', f'{src}:={dst}')]
    node = Node('controller', context=ros_context, cli_args=['--ros-args', '-r', f'__ns:={namespace}', *rules])
    try:
        assert node.resolve_topic_name('/clock') == clock
        assert node.resolve_topic_name('joint_states') == f'{namespace.rstrip("/")}/joint_states'
    finally:
        node.destroy_node()


def test_package_xml_declares_the_launch_dependencies():
    root = ET.parse(os.path.join(ROOT, 'package.xml')).getroot()
    exec_depends = {e.text for e in root.iter('exec_depend')}
    imported = {n.names[0].name.split('.')[0] if isinstance(n, ast.Import) else n.module.split('.')[0]
                for n in ast.walk(_tree()) if isinstance(n, (ast.Import, ast.ImportFrom))}
    assert {'launch', 'launch_ros', 'ament_index_python'} <= imported
    assert imported - {'os'} <= exec_depends
