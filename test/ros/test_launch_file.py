"""launch/scenario.launch.py, checked without `launch` (not on PyPI): its source is read as Python.

What is checked here: the arguments it declares (names, defaults, choices) and what it refers to
(the node executables, their names and the config sections, the /clock remapping rule, applied by
rclpy's own remapping); its parameter_files() (compiled alone from the file's source) and the nodes
started with the files it gives, as ros2 launch passes them (--params-file, in order). That `ros2
launch` brings the loop up is checked by `make check-ros2`.
"""
import ast
import importlib.metadata
import os
import xml.etree.ElementTree as ET

import pytest
import yaml

from robot_control import scenarios
from sim_bridge.bridge_params import MODES
from sim_bridge.engines import ENGINES

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
    """{name: {'default_value': ..., 'choices': ...}} of the DeclareLaunchArgument calls (literals; choices given as
    a name: the name)."""
    out = {}
    for call in _calls('DeclareLaunchArgument'):
        name = ast.literal_eval(call.args[0])
        kw = _keywords(call)
        out[name] = {k: ast.literal_eval(v) for k, v in kw.items()
                     if k in ('default_value', 'choices') and isinstance(v, (ast.Constant, ast.List))}
        if isinstance(kw.get('choices'), ast.Name):
            out[name]['choices'] = kw['choices'].id
    return out


def _nodes():
    """[(executable, name)] of the Node actions."""
    return [(ast.literal_eval(_keywords(c)['executable']), ast.literal_eval(_keywords(c)['name']))
            for c in _calls('Node')]


def test_it_declares_the_documented_arguments_with_their_defaults():
    args = _arguments()
    assert set(args) == {'scenario', 'params_file', 'mode', 'namespace', 'gui', 'engine', 'use_sim_time',
                         'cpu_wakeup_latency'}
    assert {k: v.get('default_value') for k, v in args.items() if k != 'engine'} == {
        'scenario': '', 'params_file': '', 'mode': 'realtime', 'namespace': '', 'gui': 'false',
        'use_sim_time': 'true', 'cpu_wakeup_latency': ''}


def test_engine_choices_are_the_bridges_engines_pybullet_the_default():
    """engine:= takes the bridge's engines (sim_bridge.engines.ENGINES); its default is ENGINES[0], pybullet, and the
    bridge node is given it (parameters=[*files, {..., 'engine': ...}])."""
    assert _constant('ENGINES') == list(ENGINES) and ENGINES[0] == 'pybullet'
    [engine] = [c for c in _calls('DeclareLaunchArgument') if ast.literal_eval(c.args[0]) == 'engine']
    kw = _keywords(engine)
    assert ast.unparse(kw['default_value']) == 'ENGINES[0]' and ast.unparse(kw['choices']) == 'ENGINES'
    [bridge] = [c for c in _calls('Node') if ast.literal_eval(_keywords(c)['executable']) == 'sim_bridge_node']
    assert 'engine' in [ast.literal_eval(k) for k in _keywords(bridge)['parameters'].elts[-1].keys]


def test_mode_choices_are_the_bridge_modes_and_booleans_are_true_or_false():
    args = _arguments()
    assert tuple(args['mode']['choices']) == MODES
    assert _constant('BOOLEAN') == ['true', 'false']
    assert args['gui']['choices'] == args['use_sim_time']['choices'] == 'BOOLEAN'
    assert args['scenario']['choices'] == 'SCENARIO_CHOICES'    # '' and the installed config/*.yaml
    assert 'choices' not in args['params_file']


def test_default_scenario_and_every_shipped_one_has_a_file_for_both_nodes():
    assert _constant('DEFAULT_SCENARIO') in scenarios.SCENARIOS
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


# -- params_file: your own robot -----------------------------------------------------------------------------
TEMPLATE = os.path.join(ROOT, 'config', 'templates', 'your_robot.yaml')


def _parameter_files():
    """parameter_files() of the launch file, compiled alone, CONFIG_DIR being the repository's config/."""
    [fn] = [n for n in _tree().body if isinstance(n, ast.FunctionDef) and n.name == 'parameter_files']
    namespace = {'os': os, 'CONFIG_DIR': os.path.join(ROOT, 'config'), 'DEFAULT_SCENARIO': _constant('DEFAULT_SCENARIO')}
    exec(compile(ast.Module(body=[fn], type_ignores=[]), LAUNCH_FILE, 'exec'), namespace)
    return namespace['parameter_files']


def _config(name):
    return os.path.join(ROOT, 'config', f'{name}.yaml')


def test_parameter_files_are_the_scenario_then_the_users(tmp_path, monkeypatch):
    files = _parameter_files()
    assert files('', '') == [_config('polar_two_link')]                 # nothing given: the lecture's example
    assert files('iiwa', '') == [_config('iiwa')]
    assert files('', TEMPLATE) == [TEMPLATE]                            # your robot alone
    assert files('iiwa', TEMPLATE) == [_config('iiwa'), TEMPLATE]       # yours after the scenario's: yours win
    monkeypatch.chdir(tmp_path)
    (tmp_path / 'my_arm.yaml').write_text('{}')
    assert files('', 'my_arm.yaml') == [str(tmp_path / 'my_arm.yaml')]  # relative to where ros2 launch runs
    with pytest.raises(RuntimeError, match=r'^params_file: no file .*/nope\.yaml$'):
        files('', 'nope.yaml')


def test_both_nodes_read_the_same_files_then_the_arguments_and_the_launch_says_which():
    """parameters=[*files, {arguments}] in both Node actions (the arguments override the files), and a LogInfo
    naming the files, in the function that makes the nodes from the evaluated arguments."""
    for call in _calls('Node'):
        params = _keywords(call)['parameters']
        assert isinstance(params, ast.List) and isinstance(params.elts[0], ast.Starred)
        assert params.elts[0].value.id == 'files' and isinstance(params.elts[-1], ast.Dict)
    [log] = _calls('LogInfo')
    assert any(isinstance(n, ast.Name) and n.id == 'files' for n in ast.walk(log))
    assert len(_calls('OpaqueFunction')) == 1


def _node_with_files(kind, context, files, namespace='/'):
    """A node started as ros2 launch starts it: -r __ns:=... --params-file <each file, in order>."""
    args = ['--ros-args', '-r', f'__ns:={namespace}'] + [a for f in files for a in ('--params-file', f)]
    return kind(context=context, cli_args=args)


def test_the_template_as_params_file_brings_up_the_xarm_in_both_nodes(ros_context):
    from robot_control.ros.controller_node import ControllerNode
    from sim_bridge.bridge_node import SimBridge
    files = _parameter_files()('', TEMPLATE)
    joints = [f'joint{i}' for i in range(1, 8)]
    bridge = _node_with_files(SimBridge, ros_context, files, '/arm')
    try:
        assert list(bridge.joint_names) == joints and bridge.world.n == 7
        assert bridge.cfg.urdf.endswith('xarm_description/urdf/xarm7.urdf')
    finally:
        bridge.destroy_node()
    ctrl = _node_with_files(ControllerNode, ros_context, files, '/arm')
    try:
        assert list(ctrl.core.config.joints) == joints and ctrl.core.config.law == 'computed_torque'
    finally:
        ctrl.destroy_node()


def test_a_params_file_after_a_scenario_wins(ros_context, tmp_path):
    """scenario:=iiwa params_file:=tweak.yaml: iiwa's values, with the tweak's where it has one."""
    from robot_control.ros.controller_node import ControllerNode
    tweak = tmp_path / 'tweak.yaml'
    tweak.write_text(yaml.safe_dump({'/**/controller': {'ros__parameters': {'omega_res': 20.0}}}))
    ctrl = _node_with_files(ControllerNode, ros_context, _parameter_files()('iiwa', str(tweak)))
    try:
        assert ctrl.get_parameter('scenario').value == 'iiwa'
        assert ctrl.get_parameter('omega_res').value == 20.0        # iiwa.yaml says 12.0
        assert list(ctrl.core.config.control_law.motion_gains.kp) == [100.0] * 7        # (20 / 2)^2
    finally:
        ctrl.destroy_node()


def test_cpu_wakeup_latency_becomes_both_nodes_flag(capsys):
    """cpu_wakeup_latency:=US gives both nodes --cpu-wakeup-latency US before --ros-args (arguments=flags, from
    node_flags() compiled alone); '' gives none. The flags as a node's executable reads them: a bad value is its
    usage error."""
    [fn] = [n for n in _tree().body if isinstance(n, ast.FunctionDef) and n.name == 'node_flags']
    namespace = {}
    exec(compile(ast.Module(body=[fn], type_ignores=[]), LAUNCH_FILE, 'exec'), namespace)
    flags = namespace['node_flags']
    assert flags('') == [] and flags('0') == ['--cpu-wakeup-latency', '0']
    for call in _calls('Node'):
        assert ast.unparse(_keywords(call)['arguments']) == 'flags'
    from robot_control.ros import controller_node
    assert controller_node.ENTRY.options(['controller_node', *flags('0'), '--ros-args']).cpu_wakeup_latency == 0
    with pytest.raises(SystemExit):
        controller_node.ENTRY.options(['controller_node', *flags('-5')])
    assert "argument --cpu-wakeup-latency: expected a whole number of microseconds >= 0, got '-5'" in \
        capsys.readouterr().err
