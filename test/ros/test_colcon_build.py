"""`colcon build` of the repo gives a correct ament_python install (no ROS install needed).

colcon-ros (from PyPI, in .venv) recognizes package.xml's <build_type>ament_python</build_type>
and builds with plain setuptools (`setup.py egg_info build install --single-version-externally-managed`
run by .venv's python): no ament_package or sourced /opt/ros is needed. Everything colcon writes
(build, install, log) goes to pytest's tmp_path; the repo must not gain build/ install/ log/.
"""
import configparser
import glob
import os
import re
import shutil
import subprocess
import sys

import pytest

from support.packaging import PACKAGES, workshop_files

ROOT = os.path.realpath(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
VENV_BIN = os.path.dirname(os.path.abspath(sys.executable))
PKG = 'robot_control'
NODES = {'controller_node': 'robot_control.ros.controller_node:main',
         'sim_bridge_node': 'sim_bridge.bridge_node:main'}
TOOLS = {'record': 'robot_control.tools.record:main', 'plot': 'robot_control.tools.plot:main',
         'sweep': 'robot_control.tools.sweep:main'}
ARTIFACTS = ('build', 'install', 'log')


def repo_artifacts():
    """Top-level build outputs present in the repo (colcon's and setuptools')."""
    return {a for a in ARTIFACTS if os.path.exists(os.path.join(ROOT, a))} | \
        {os.path.basename(p) for p in glob.glob(os.path.join(ROOT, '*.egg-info'))}


def colcon_env(tmp):
    env = {k: v for k, v in os.environ.items()
           if k not in ('AMENT_PREFIX_PATH', 'COLCON_PREFIX_PATH', 'CMAKE_PREFIX_PATH', 'PYTHONPATH')}
    env.update(PATH=VENV_BIN + os.pathsep + env.get('PATH', ''),
               COLCON_HOME=str(tmp / 'colcon_home'),     # no user defaults (e.g. symlink-install)
               COLCON_LOG_PATH=str(tmp / 'log'),
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID='21',
               PYTHONDONTWRITEBYTECODE='1')
    return env


def colcon_build(base, tmp):
    """Run colcon build on `base` with every output under `tmp`; returns the package's install prefix."""
    colcon = shutil.which('colcon', path=VENV_BIN)
    assert colcon, f'colcon not found in {VENV_BIN} (pip install colcon-common-extensions)'
    cmd = [colcon, '--log-base', str(tmp / 'log'), 'build', '--base-paths', str(base),
           '--build-base', str(tmp / 'build'), '--install-base', str(tmp / 'install'),
           '--event-handlers', 'console_direct-']
    proc = subprocess.run(cmd, cwd=tmp, env=colcon_env(tmp), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, f'colcon build failed:\n{proc.stdout}\n{proc.stderr}'
    assert 'Summary: 1 package finished' in proc.stdout, proc.stdout
    return tmp / 'install' / PKG


def entry_points(prefix):
    """console_scripts of the installed distribution, from its egg-info."""
    found = glob.glob(str(prefix / 'lib' / 'python3*' / 'site-packages' / f'{PKG}-*.egg-info' / 'entry_points.txt'))
    assert len(found) == 1, found
    parser = configparser.ConfigParser()
    parser.read(found[0])
    return dict(parser['console_scripts'])


def text(path):
    with open(path, encoding='utf-8') as f:
        return f.read()


def names(pattern):
    return sorted(os.path.basename(p) for p in glob.glob(pattern))


@pytest.fixture(scope='module')
def installed(tmp_path_factory):
    """One colcon build of the repo itself (shared by the layout checks)."""
    tmp = tmp_path_factory.mktemp('colcon')
    before = repo_artifacts()
    prefix = colcon_build(ROOT, tmp)
    return prefix, before


def test_build_writes_nothing_into_the_repo(installed):
    _, before = installed
    after = repo_artifacts()
    assert after <= before, f'colcon wrote {sorted(after - before)} into {ROOT}'


def test_nodes_are_installed_where_ros2_run_looks(installed):
    prefix, _ = installed
    scripts = {**NODES, **TOOLS}  # ros2 run robot_control record / plot / sweep, too
    for node, target in scripts.items():
        path = prefix / 'lib' / PKG / node
        assert path.is_file() and os.access(path, os.X_OK), path
        with open(path, encoding='utf-8') as f:
            assert f.readline().startswith('#!'), f'{path} has no shebang'
    assert {k: v for k, v in entry_points(prefix).items() if k in scripts} == scripts


def test_package_is_registered_in_the_ament_index(installed):
    prefix, _ = installed
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / PKG).is_file()
    assert text(prefix / 'share' / PKG / 'package.xml') == text(os.path.join(ROOT, 'package.xml'))


def test_license_and_changelog_are_installed_and_match_package_xml(installed):
    """A released package carries the license package.xml declares (Apache-2.0) and its changelog."""
    prefix, _ = installed
    share = prefix / 'share' / PKG
    license_text = text(os.path.join(ROOT, 'LICENSE'))
    assert '<license>Apache-2.0</license>' in text(os.path.join(ROOT, 'package.xml'))
    assert 'Apache License' in license_text and 'Version 2.0, January 2004' in license_text
    assert 'END OF TERMS AND CONDITIONS' in license_text
    assert text(share / 'LICENSE') == license_text
    changelog = text(share / 'CHANGELOG.rst')
    version = re.search(r'<version>([^<]+)</version>', text(os.path.join(ROOT, 'package.xml'))).group(1)
    assert changelog.startswith('^^^') and f'\n{version} (' in changelog   # catkin_generate_changelog's form


def test_config_and_urdf_files_are_installed(installed):
    prefix, _ = installed
    share = prefix / 'share' / PKG
    assert names(str(share / 'config' / '*.yaml')) == names(os.path.join(ROOT, 'config', '*.yaml'))
    templates = names(os.path.join(ROOT, 'config', 'templates', '*.yaml'))
    assert templates and names(str(share / 'config' / 'templates' / '*.yaml')) == templates
    profiles = names(os.path.join(ROOT, 'config', 'realism', '*.yaml'))
    assert profiles and names(str(share / 'config' / 'realism' / '*.yaml')) == profiles
    urdfs = names(os.path.join(ROOT, PKG, 'urdf', '*.urdf'))
    assert urdfs, 'no shipped URDFs'
    assert names(str(share / 'urdf' / '*.urdf')) == urdfs
    site = glob.glob(str(prefix / 'lib' / 'python3*' / 'site-packages' / PKG / 'urdf'))
    assert len(site) == 1 and names(os.path.join(site[0], '*.urdf')) == urdfs   # package_data


def run_installed(prefix, code, cwd):
    """(site-packages of the install, stdout) of `code` run against the installed package alone."""
    site = glob.glob(str(prefix / 'lib' / 'python3*' / 'site-packages'))[0]
    env = dict(os.environ, PYTHONPATH=site, PYTHONDONTWRITEBYTECODE='1')
    proc = subprocess.run([sys.executable, '-P', '-c', code], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return site, proc.stdout


def test_the_install_holds_the_package_and_nothing_of_the_workshop(installed):
    """site-packages holds robot_control and sim_bridge (and their egg-info), no benchmarks/, dev/ or test/
    file and no module of theirs; lib/robot_control only the nodes and the user tools."""
    prefix, _ = installed
    (site,) = glob.glob(str(prefix / 'lib' / 'python3*' / 'site-packages'))
    files = [os.path.relpath(os.path.join(d, f), site).replace(os.sep, '/') for d, _, fs in os.walk(site) for f in fs]
    assert 'robot_control/tools/record.py' in files and 'sim_bridge/bridge_node.py' in files
    assert {f.split('/')[0] for f in files if not f.split('/')[0].endswith('.egg-info')} == set(PACKAGES)
    assert workshop_files(files) == []
    assert set(names(str(prefix / 'lib' / PKG / '*'))) == {*NODES, *TOOLS}


def test_launch_file_is_installed_where_ros2_launch_looks(installed):
    """`ros2 launch robot_control scenario.launch.py` finds share/robot_control/launch/*.launch.py."""
    prefix, _ = installed
    sources = names(os.path.join(ROOT, 'launch', '*.launch.py'))
    assert 'scenario.launch.py' in sources
    assert names(str(prefix / 'share' / PKG / 'launch' / '*.launch.py')) == sources
    assert text(prefix / 'share' / PKG / 'launch' / 'scenario.launch.py') == \
        text(os.path.join(ROOT, 'launch', 'scenario.launch.py'))


def test_installed_package_resolves_its_own_urdfs(installed, tmp_path):
    """The installed library (not the source tree) finds its shipped URDFs and builds a model."""
    prefix, _ = installed
    site, out = run_installed(prefix, 'import robot_control.models as m; '
                              "print(m.resolve_urdf('polar_two_link')); print(m.for_scenario('polar_two_link').n)",
                              tmp_path)
    path, n = out.split()
    assert path.startswith(site) and n == '2', out


def test_the_fast_dds_profile_is_installed_where_the_nodes_find_it(installed, tmp_path):
    """robot_control.ros.dds.PROFILE of the installed package (package_data) exists; share/ has a copy."""
    prefix, _ = installed
    assert (prefix / 'share' / PKG / 'dds' / 'fastdds_profile.xml').is_file()
    site, out = run_installed(prefix, 'import os; from robot_control.ros import dds; '
                              'print(dds.PROFILE, os.path.isfile(dds.PROFILE))', tmp_path)
    path, exists = out.split()
    assert path.startswith(site) and exists == 'True', out


def test_every_config_yaml_is_installed(tmp_path):
    """setup.py's config glob installs each YAML: build a copy of the package with one more YAML."""
    src = tmp_path / 'src' / PKG
    ignore = shutil.ignore_patterns('.*', '__pycache__', *ARTIFACTS, 'out', '*.egg-info', 'test')
    shutil.copytree(ROOT, src, ignore=ignore)
    os.makedirs(src / 'config', exist_ok=True)
    (src / 'config' / 'zz_probe.yaml').write_text('/**/controller:\n  ros__parameters:\n    rate: 1000.0\n')
    prefix = colcon_build(tmp_path / 'src', tmp_path)
    installed_yaml = names(str(prefix / 'share' / PKG / 'config' / '*.yaml'))
    assert installed_yaml == names(str(src / 'config' / '*.yaml'))
    assert 'zz_probe.yaml' in installed_yaml


#: rosdep key of each third-party module the package imports (ROS packages: their own name)
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'pinocchio': 'pinocchio', 'pybullet': 'python3-pybullet-pip',
               'pybullet_data': 'python3-pybullet-pip', 'matplotlib': 'python3-matplotlib', 'yaml': 'python3-yaml',
               'rosbags': 'python3-rosbags-pip', 'modern_robotics': 'python3-modern-robotics-pip',
               'mujoco': 'python3-mujoco-pip', 'pyarrow': 'python3-pyarrow-pip', 'optuna': 'python3-optuna-pip',
               'ray': 'python3-ray-pip'}


def imported_modules():
    """Top-level modules imported anywhere in the package's code (tests excluded), but its own and the stdlib's."""
    import ast
    found = set()
    for path in glob.glob(os.path.join(ROOT, 'robot_control', '**', '*.py'), recursive=True) + \
            glob.glob(os.path.join(ROOT, 'sim_bridge', '**', '*.py'), recursive=True):
        with open(path, encoding='utf-8') as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found.update(a.name.split('.')[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                found.add(node.module.split('.')[0])
    return found - set(sys.stdlib_module_names) - {PKG, 'sim_bridge'}


def test_package_xml_declares_every_module_the_package_imports():
    """After a colcon build on a ROS install, `rosdep install` must bring what the nodes and tools import."""
    import xml.etree.ElementTree as ET
    root = ET.parse(os.path.join(ROOT, 'package.xml')).getroot()
    declared = {e.text.strip() for tag in ('exec_depend', 'depend') for e in root.iter(tag)}
    modules = imported_modules()
    assert {'matplotlib', 'rosbags', 'rclpy', 'sensor_msgs'} <= modules     # the scan sees the tools and nodes
    missing = {m: ROSDEP_KEYS.get(m, m) for m in modules if ROSDEP_KEYS.get(m, m) not in declared}
    assert not missing, f'package.xml lacks <exec_depend> for {missing}'
