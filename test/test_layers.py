"""The rclpy-free layers import no rclpy, no message package and (but each world) no physics engine, and
no module of a layer above their own (library < core < ros, tools; the bridge's world and loop beside the core).

Each module is imported alone in a fresh interpreter, so a forbidden import anywhere in its
import graph shows up in sys.modules. The module list is discovered at collection time: every
module of the library's and the core's subpackages, plus the named modules that exist in this
checkout (none is skipped: absent ones are simply not collected).
"""
import json
import os
import pkgutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the rclpy-free layers: the library, the control core, the simulated world and the bridge's loop
#: (whole subpackages), plus the named modules beside them (the parameter tables among them)
PACKAGES = ['robot_control.models', 'robot_control.laws', 'robot_control.core', 'robot_control.urdf']
NAMED = ['robot_control', 'robot_control.validation', 'robot_control.gains', 'robot_control.trajectory',
         'robot_control.scenarios', 'robot_control.ros.cdr', 'robot_control.core.throttle',
         'robot_control.param_table', 'robot_control.ros.controller_params', 'robot_control.ros.config_builder',
         'sim_bridge.world', 'sim_bridge.surfaces', 'sim_bridge.disturbance', 'sim_bridge.pacing',
         'sim_bridge.bridge_loop', 'sim_bridge.bridge_params', 'sim_bridge.physics_check',
         'sim_bridge.joint_friction', 'sim_bridge.joint_physics', 'sim_bridge.sensors',
         'sim_bridge.mujoco_world', 'sim_bridge.mujoco_model', 'sim_bridge.engines', 'sim_bridge.world_base',
         'sim_bridge.pybullet_surface', 'sim_bridge.mujoco_surface']
#: the worlds and what they build on may import their own physics engine; nothing else may import one
ENGINE_ALLOWED = {'sim_bridge.world': 'pybullet', 'sim_bridge.pybullet_surface': 'pybullet',
                  'sim_bridge.physics_check': 'pybullet', 'sim_bridge.joint_physics': 'pybullet',
                  'sim_bridge.mujoco_world': 'mujoco', 'sim_bridge.mujoco_model': 'mujoco',
                  'sim_bridge.mujoco_surface': 'mujoco'}


def _exists(name):
    path = os.path.join(ROOT, *name.split('.'))
    return os.path.isfile(path + '.py') or os.path.isfile(os.path.join(path, '__init__.py'))


def _subpackage_modules(package):
    path = os.path.join(ROOT, *package.split('.'))
    return [package] + [f'{package}.{m.name}' for m in pkgutil.iter_modules([path])]


LIBRARY = sorted({n for n in NAMED + [m for p in PACKAGES for m in _subpackage_modules(p)] if _exists(n)})

PROBE = r'''
import importlib, json, sys
importlib.import_module(sys.argv[1])
print(json.dumps(sorted(sys.modules)))
'''


def _forbidden(module, engine=None):
    """True when `module` is a ROS module, or a physics engine's other than `engine` ('pybullet', 'mujoco', None)."""
    top = module.split('.')[0]
    ros = top == 'rclpy' or top.endswith('_msgs') or top == 'builtin_interfaces' or top.startswith('rosidl')
    own = {'pybullet': ('pybullet', 'pybullet_utils', 'pybullet_envs'), 'mujoco': ('mujoco',)}  # pybullet_data: data
    return ros or any(top in tops for name, tops in own.items() if name != engine)


def test_the_layer_list_holds_the_laws_and_models():
    assert {'robot_control.laws.hybrid', 'robot_control.laws.servo', 'robot_control.models.closed_form',
            'robot_control.core.controller', 'sim_bridge.pacing'} <= set(LIBRARY)


def _loaded(name):
    """sys.modules (names) after importing `name` alone in a fresh interpreter."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get('PYTHONPATH', ''))
    out = subprocess.run([sys.executable, '-c', PROBE, name], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize('name', LIBRARY)
def test_library_module_imports_no_ros_and_no_other_engine(name):
    loaded = _loaded(name)
    assert name in loaded
    bad = [m for m in loaded if _forbidden(m, ENGINE_ALLOWED.get(name))]
    assert not bad, f'{name} pulls in {bad}'


def test_the_probe_detects_a_forbidden_import():
    """The check itself can fail: importing pybullet (a module that does) is caught."""
    bad = [m for m in _loaded('pybullet') if _forbidden(m)]
    assert bad == ['pybullet']
    assert _forbidden('sensor_msgs.msg', 'pybullet') and _forbidden('rclpy.node', 'mujoco')
    assert not _forbidden('pybullet', 'pybullet') and not _forbidden('pybullet_data')
    assert _forbidden('mujoco') and not _forbidden('mujoco', 'mujoco')
    assert _forbidden('pybullet', 'mujoco') and _forbidden('mujoco', 'pybullet')


#: a module of a layer may import its own layer and the ones below it, never one above
ABOVE = {
    'library': ('robot_control.core', 'robot_control.ros', 'robot_control.tools', 'sim_bridge'),
    'core': ('robot_control.ros', 'robot_control.tools', 'sim_bridge'),
    'sim': ('robot_control.ros', 'robot_control.tools', 'sim_bridge.bridge_node'),   # beside the core
}


def _layer(name):
    if name.startswith('robot_control.ros') or name == 'sim_bridge.bridge_params':
        return None            # parameter tables: the ROS layer's, rclpy-free but above the core
    if name.startswith('sim_bridge'):
        return 'sim'
    if name.startswith('robot_control.core'):
        return 'core'
    return 'library'


def _upward(name, loaded):
    layer = _layer(name)
    if layer is None:
        return []
    return [m for m in loaded if m != name and m.startswith(ABOVE[layer])
            and not (m == 'sim_bridge' and layer == 'sim')]


@pytest.mark.parametrize('name', [n for n in LIBRARY if _layer(n)])
def test_library_module_imports_no_layer_above_its_own(name):
    up = _upward(name, _loaded(name))
    assert not up, f'{name} ({_layer(name)}) imports {up} from a layer above'


def test_the_layer_check_detects_an_upward_import():
    assert _upward('robot_control.laws.hybrid', ['robot_control.laws.hybrid', 'robot_control.core.config'])
    assert _upward('robot_control.core.controller', ['robot_control.ros.qos'])
    assert _upward('sim_bridge.pacing', ['sim_bridge.bridge_node'])
    assert not _upward('sim_bridge.pacing', ['sim_bridge', 'sim_bridge.world', 'robot_control.models'])
