"""ament_python setup for robot_control (works with colcon and with pip)."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'robot_control'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(include=['robot_control', 'robot_control.*', 'sim_bridge', 'sim_bridge.*']),
    package_data={PACKAGE: ['urdf/*.urdf', 'ros/fastdds_profile.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml', 'LICENSE', 'CHANGELOG.rst']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
        ('share/' + PACKAGE + '/config/templates', glob('config/templates/*.yaml')),
        ('share/' + PACKAGE + '/config/realism', glob('config/realism/*.yaml')),
        ('share/' + PACKAGE + '/config/sweeps', glob('config/sweeps/*.yaml')),
        ('share/' + PACKAGE + '/launch', glob('launch/*.launch.py')),
        ('share/' + PACKAGE + '/urdf', glob(PACKAGE + '/urdf/*.urdf')),
        ('share/' + PACKAGE + '/dds', [PACKAGE + '/ros/fastdds_profile.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='robot_control developers',
    maintainer_email='robot_control@example.com',
    description='Computed-torque, force and hybrid control of manipulators, with a PyBullet bridge.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'controller_node = robot_control.ros.controller_node:main',
            'sim_bridge_node = sim_bridge.bridge_node:main',
            'record = robot_control.tools.record:main',
            'plot = robot_control.tools.plot:main',
            'sweep = robot_control.tools.sweep:main',
        ],
    },
)
