"""robot_control.urdf: the lookup of URDFs by name (shipped, pybullet_data, example-robot-data) and of their
mesh files as PyBullet finds them (mesh_path, with_absolute_meshes)."""
import os
import sys

import pytest

from robot_control import urdf
from robot_control.validation import ArgumentError

UR5 = 'ur_description/urdf/ur5_robot.urdf'


def _touch(path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as f:
        f.write('solid\nendsolid\n')
    return str(path)


def test_mesh_path_drops_the_scheme_and_takes_the_nearest_directory_that_holds_the_file(tmp_path):
    base = tmp_path / 'share' / 'robots' / 'arm' / 'urdf'
    base.mkdir(parents=True)
    far = _touch(tmp_path / 'share' / 'robots' / 'arm' / 'meshes' / 'a.stl')
    found = _touch(tmp_path / 'share' / 'robots' / 'arm' / 'meshes' / 'b.stl')
    # package://pkg/...: from urdf/ upwards, found below share/robots
    shared = _touch(tmp_path / 'share' / 'robots' / 'pkg' / 'meshes' / 'c.stl')
    assert urdf.mesh_path('package://pkg/meshes/c.stl', str(base)) == shared
    assert urdf.mesh_path('model://pkg/meshes/c.stl', str(base)) == shared
    assert urdf.mesh_path(f'file://{shared}', str(base)) == shared
    assert urdf.mesh_path('../meshes/a.stl', str(base)) == far
    assert urdf.mesh_path('meshes/b.stl', str(base)) == found        # found from arm/, one level up
    nearer = _touch(base / 'meshes' / 'b.stl')                       # now also next to the URDF: it wins
    assert urdf.mesh_path('package://meshes/b.stl', str(base)) == nearer
    assert urdf.mesh_path(far, str(base)) == far                     # absolute: as it is


@pytest.mark.parametrize('name', ['http://example.com/a.stl', 'package://nowhere/none.stl', 'none.stl', ''])
def test_mesh_path_is_none_for_other_uris_and_files_found_nowhere(tmp_path, name):
    assert urdf.mesh_path(name, str(tmp_path)) is None


def test_with_absolute_meshes_rewrites_what_it_finds(tmp_path):
    mesh = _touch(tmp_path / 'pkg' / 'meshes' / 'a.stl')
    xml = ('<robot name="r"><link name="l"><visual><geometry><mesh filename="package://pkg/meshes/a.stl"/>'
           '</geometry></visual></link></robot>')
    out = urdf.with_absolute_meshes(xml, str(tmp_path / 'pkg' / 'urdf'))
    assert f'filename="file://{mesh}"' in out
    assert urdf.with_absolute_meshes(out, '/elsewhere') == out          # already absolute: as it is


@pytest.mark.parametrize('name', ['package://gone/b.stl', 'http://example.com/b.stl', '/no/such/b.stl'])
def test_a_mesh_found_nowhere_is_an_error_naming_the_link_the_mesh_and_the_places(tmp_path, monkeypatch, name):
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path / 'ros'))
    monkeypatch.setenv('ROS_PACKAGE_PATH', str(tmp_path / 'src'))
    xml = (f'<robot name="r"><link name="l"><collision><geometry><mesh filename="{name}"/></geometry></collision>'
           '</link></robot>')
    with pytest.raises(ArgumentError) as info:
        urdf.with_absolute_meshes(xml, str(tmp_path / 'pkg' / 'urdf'))
    assert info.value.name == 'urdf'
    assert f"link 'l': mesh '{name}' not found; looked in" in str(info.value)
    if name.startswith('package://'):
        for place in (tmp_path / 'ros' / 'share' / 'gone' / 'b.stl', tmp_path / 'src' / 'gone' / 'b.stl',
                      tmp_path / 'pkg' / 'urdf'):
            assert str(place) in str(info.value)


def test_package_uris_resolve_through_the_ament_index_and_ros_package_path(tmp_path, monkeypatch):
    """package://<pkg>/<rest>: share/<pkg> of an AMENT_PREFIX_PATH prefix first, then a ROS_PACKAGE_PATH
    entry holding <pkg> (or named <pkg>), wherever the URDF is; the example-robot-data wheel's prefix too."""
    installed = _touch(tmp_path / 'install' / 'share' / 'arm' / 'meshes' / 'a.stl')
    source = _touch(tmp_path / 'src' / 'arm' / 'meshes' / 'a.stl')
    hand = _touch(tmp_path / 'ws' / 'hand' / 'meshes' / 'h.stl')
    elsewhere = str(tmp_path / 'copy')
    monkeypatch.setenv('ROS_PACKAGE_PATH', os.pathsep.join([str(tmp_path / 'src'), str(tmp_path / 'ws' / 'hand')]))
    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    assert urdf.mesh_path('package://arm/meshes/a.stl', elsewhere) == source
    assert urdf.mesh_path('package://hand/meshes/h.stl', elsewhere) == hand
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path / 'install'))
    assert urdf.mesh_path('package://arm/meshes/a.stl', elsewhere) == installed
    link7 = 'package://example-robot-data/robots/xarm_description/meshes/xarm7/visual/link7.stl'
    wheel = os.path.dirname(urdf.search_dirs()[-1])          # <prefix>/share/example-robot-data
    assert urdf.mesh_path(link7, elsewhere) == os.path.join(wheel, link7[len('package://example-robot-data/'):])


def test_example_robot_data_is_found_from_the_wheel():
    path = urdf.resolve(UR5)
    assert path.endswith(os.path.join('example-robot-data', 'robots', UR5)) and os.path.isfile(path)
    assert os.path.dirname(os.path.dirname(os.path.dirname(path))) in urdf.search_dirs()


def test_example_robot_data_is_found_in_a_ros_install(tmp_path, monkeypatch):
    """Without the wheel on sys.path, an AMENT_PREFIX_PATH prefix holding share/example-robot-data/robots."""
    monkeypatch.setattr(sys, 'path', [d for d in sys.path if not os.path.isdir(os.path.join(d, 'cmeel.prefix'))])
    assert not any('example-robot-data' in d for d in urdf.search_dirs())
    robots = tmp_path / 'opt' / 'share' / 'example-robot-data' / 'robots'
    target = _touch(robots / 'ur_description' / 'urdf' / 'ur5_robot.urdf')
    monkeypatch.setenv('AMENT_PREFIX_PATH', os.pathsep.join([str(tmp_path / 'empty'), str(tmp_path / 'opt')]))
    assert urdf.search_dirs()[-1] == str(robots)
    assert urdf.resolve(UR5) == target
