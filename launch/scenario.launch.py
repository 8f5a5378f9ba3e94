"""One robot_control loop: the simulator bridge and the controller of one scenario, or of your own robot.

    ros2 launch robot_control scenario.launch.py scenario:=iiwa namespace:=arm mode:=lockstep
    ros2 launch robot_control scenario.launch.py scenario:=iiwa engine:=mujoco
    ros2 launch robot_control scenario.launch.py params_file:=my_arm.yaml

Arguments (`ros2 launch robot_control scenario.launch.py --show-args` lists them):
  scenario      config/<scenario>.yaml of the package's share directory; '' (default) = polar_two_link,
                or none when params_file is given
  params_file   your YAML file for both nodes (sections `/**/controller` and `/**/sim_bridge`, e.g. a
                copy of config/templates/your_robot.yaml), read after the scenario's file, so its values
                win; '' (default) = none
  mode          the bridge's pacing: realtime (default) | lockstep
  namespace     namespace of both nodes; '' (default) = none
  gui           the bridge's PyBullet GUI, true | false (default; the GUI needs a display)
  engine        the bridge's physics engine, pybullet (default) | mujoco
  use_sim_time  the controller runs on the bridge's /clock, true (default) | false
  cpu_wakeup_latency
                both nodes hold a CPU wake-up latency request of this many microseconds while they run
                (their --cpu-wakeup-latency: 0 keeps idle CPUs from sleeping, for real time; needs root or
                a udev rule giving write access to /dev/cpu_dma_latency); '' (default) = none

Both nodes read the same files in the same order (the launch logs which), whose sections
`/**/controller` and `/**/sim_bridge` apply in any namespace; the arguments mode, gui, engine and
use_sim_time override the files. /clock is remapped to the relative name `clock` in both nodes: it stays /clock
without a namespace and becomes /<namespace>/clock with one, so several robots with their own
simulated time can run side by side.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, LogInfo, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = 'robot_control'
CONFIG_DIR = os.path.join(get_package_share_directory(PACKAGE), 'config')
SCENARIOS = sorted(os.path.splitext(f)[0] for f in os.listdir(CONFIG_DIR) if f.endswith('.yaml'))
SCENARIO_CHOICES = [''] + SCENARIOS
DEFAULT_SCENARIO = 'polar_two_link'
BOOLEAN = ['true', 'false']
#: the bridge's physics engines (its read-only parameter `engine`; sim_bridge.engines.ENGINES), the default first
ENGINES = ['pybullet', 'mujoco']
#: /clock follows the node's namespace (a relative replacement is expanded in the node's namespace)
CLOCK_REMAP = [('/clock', 'clock')]


def parameter_files(scenario, params_file):
    """The YAML files both nodes read, in order (a later file's values win): config/<scenario>.yaml of the
    share directory (DEFAULT_SCENARIO when scenario is '' and params_file too), then params_file (a path,
    ~ expanded, relative to the working directory). RuntimeError naming params_file when it is no file."""
    if not scenario and not params_file:
        scenario = DEFAULT_SCENARIO
    files = [os.path.join(CONFIG_DIR, scenario + '.yaml')] if scenario else []
    if params_file:
        path = os.path.abspath(os.path.expanduser(params_file))
        if not os.path.isfile(path):
            raise RuntimeError(f'params_file: no file {path}')
        files.append(path)
    return files


def node_flags(cpu_wakeup_latency):
    """The command-line flags of both nodes (before --ros-args): --cpu-wakeup-latency US when given (not '')."""
    return ['--cpu-wakeup-latency', cpu_wakeup_latency] if cpu_wakeup_latency else []


def _nodes(context):
    """The two nodes, their parameter files evaluated from the arguments, and a line saying which they read."""
    def arg(name):
        return LaunchConfiguration(name).perform(context)
    files = parameter_files(arg('scenario'), arg('params_file'))
    namespace = arg('namespace')
    flags = node_flags(arg('cpu_wakeup_latency'))
    return [
        LogInfo(msg=f'sim_bridge and controller read, in this order (a later file wins): {", ".join(files)}'),
        Node(package=PACKAGE, executable='sim_bridge_node', name='sim_bridge', namespace=namespace,
             parameters=[*files, {'mode': arg('mode'), 'gui': arg('gui') == 'true', 'engine': arg('engine')}],
             arguments=flags, remappings=CLOCK_REMAP, output='screen'),
        Node(package=PACKAGE, executable='controller_node', name='controller', namespace=namespace,
             parameters=[*files, {'use_sim_time': arg('use_sim_time') == 'true'}],
             arguments=flags, remappings=CLOCK_REMAP, output='screen'),
    ]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('scenario', default_value='', choices=SCENARIO_CHOICES,
                              description='scenario: config/<scenario>.yaml of the share directory; '
                                          f"'' = {DEFAULT_SCENARIO}, or none when params_file is given"),
        DeclareLaunchArgument('params_file', default_value='',
                              description='your YAML file for both nodes (/**/controller, /**/sim_bridge), read '
                                          "after the scenario's: its values win; '' = none"),
        DeclareLaunchArgument('mode', default_value='realtime', choices=['realtime', 'lockstep'],
                              description="the bridge's pacing: realtime (wall clock) or lockstep "
                                          '(deterministic: each state waits for its command)'),
        DeclareLaunchArgument('namespace', default_value='',
                              description="namespace of both nodes ('' = none); /clock moves into it"),
        DeclareLaunchArgument('gui', default_value='false', choices=BOOLEAN,
                              description='open the PyBullet GUI (needs a display)'),
        DeclareLaunchArgument('engine', default_value=ENGINES[0], choices=ENGINES,
                              description="the bridge's physics engine"),
        DeclareLaunchArgument('use_sim_time', default_value='true', choices=BOOLEAN,
                              description="the controller's clock is the bridge's simulated /clock"),
        DeclareLaunchArgument('cpu_wakeup_latency', default_value='',
                              description='both nodes hold a CPU wake-up latency request of this many us '
                                          "(--cpu-wakeup-latency; 0 for real time, needs root); '' = none"),
        OpaqueFunction(function=_nodes),
    ])
