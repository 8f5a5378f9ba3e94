"""One robot_control loop: the PyBullet bridge and the controller of one scenario.

    ros2 launch robot_control scenario.launch.py scenario:=iiwa namespace:=arm mode:=lockstep

Arguments (`ros2 launch robot_control scenario.launch.py --show-args` lists them):
  scenario      config/<scenario>.yaml of the package's share directory (default polar_two_link)
  mode          the bridge's pacing: realtime (default) | lockstep
  namespace     namespace of both nodes; '' (default) = none
  gui           the bridge's PyBullet GUI, true | false (default; the GUI needs a display)
  use_sim_time  the controller runs on the bridge's /clock, true (default) | false

Both nodes read the scenario's file, whose sections `/**/controller` and `/**/sim_bridge` apply
in any namespace; the arguments override the file. /clock is remapped to the relative name
`clock` in both nodes: it stays /clock without a namespace and becomes /<namespace>/clock with
one, so several robots with their own simulated time can run side by side.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterFile, ParameterValue

PACKAGE = 'robot_control'
CONFIG_DIR = os.path.join(get_package_share_directory(PACKAGE), 'config')
SCENARIOS = sorted(os.path.splitext(f)[0] for f in os.listdir(CONFIG_DIR) if f.endswith('.yaml'))
BOOLEAN = ['true', 'false']
#: /clock follows the node's namespace (a relative replacement is expanded in the node's namespace)
CLOCK_REMAP = [('/clock', 'clock')]


def generate_launch_description():
    scenario = LaunchConfiguration('scenario')
    namespace = LaunchConfiguration('namespace')
    config = ParameterFile([os.path.join(CONFIG_DIR, ''), scenario, '.yaml'])
    return LaunchDescription([
        DeclareLaunchArgument('scenario', default_value='polar_two_link', choices=SCENARIOS,
                              description='scenario: config/<scenario>.yaml of the share directory'),
        DeclareLaunchArgument('mode', default_value='realtime', choices=['realtime', 'lockstep'],
                              description="the bridge's pacing: realtime (wall clock) or lockstep "
                                          '(deterministic: each state waits for its command)'),
        DeclareLaunchArgument('namespace', default_value='',
                              description="namespace of both nodes ('' = none); /clock moves into it"),
        DeclareLaunchArgument('gui', default_value='false', choices=BOOLEAN,
                              description='open the PyBullet GUI (needs a display)'),
        DeclareLaunchArgument('use_sim_time', default_value='true', choices=BOOLEAN,
                              description="the controller's clock is the bridge's simulated /clock"),
        Node(package=PACKAGE, executable='sim_bridge_node', name='sim_bridge', namespace=namespace,
             parameters=[config, {'mode': LaunchConfiguration('mode'),
                                  'gui': ParameterValue(LaunchConfiguration('gui'), value_type=bool)}],
             remappings=CLOCK_REMAP, output='screen'),
        Node(package=PACKAGE, executable='controller_node', name='controller', namespace=namespace,
             parameters=[config, {'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'),
                                                                 value_type=bool)}],
             remappings=CLOCK_REMAP, output='screen'),
    ])
