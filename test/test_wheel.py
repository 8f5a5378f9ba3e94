"""The wheel of the package holds the library, the core, both nodes and the user tools, and nothing of
the workshop: no benchmarks/, dev/ or test/ file and no module of theirs (bench*, check_ros2, ros2_cli ...).

The wheel is built by pip with the venv's setuptools from a copy of the checkout in tmp_path, so a
stale build/ of the checkout cannot leak into it and the checkout gains nothing.
"""
import os
import shutil
import subprocess
import sys
import zipfile

from support.packaging import PACKAGES, ROOT, python_lines, workshop_files, workshop_modules


def build_wheel(tmp_path):
    """{path: bytes} of the files of the wheel built from a copy of the checkout."""
    src = tmp_path / 'src'
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns('.*', '__pycache__', 'build', 'install', 'log', 'out',
                                                             '*.egg-info'))
    proc = subprocess.run([sys.executable, '-m', 'pip', 'wheel', str(src), '--no-deps', '--no-build-isolation',
                           '--disable-pip-version-check', '-q', '-w', str(tmp_path / 'wheel')],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (wheel,) = os.listdir(tmp_path / 'wheel')
    with zipfile.ZipFile(tmp_path / 'wheel' / wheel) as z:
        return {name: z.read(name) for name in z.namelist()}


def test_the_workshop_check_names_what_it_must_keep_out():
    assert {'bench', 'bench_mr', 'bench_pingpong', 'bench_ros', 'check_ros2', 'ros2_cli', 'ros2_checks'} \
        <= workshop_modules()
    assert workshop_files(['benchmarks/bench.py', 'dev/x.txt', 'test/conftest.py', 'robot_control/tools/bench.py',
                           'robot_control/tools/record.py', 'sim_bridge/bridge_node.py']) == \
        ['benchmarks/bench.py', 'dev/x.txt', 'robot_control/tools/bench.py', 'test/conftest.py']


def test_the_wheel_holds_the_package_and_nothing_of_the_workshop(tmp_path):
    files = build_wheel(tmp_path)
    modules = {p for p in files if p.endswith('.py') and '.data/' not in p}
    assert {'robot_control/laws/computed_torque.py', 'robot_control/core/controller.py',
            'robot_control/ros/controller_node.py', 'sim_bridge/bridge_node.py', 'robot_control/tools/demo.py',
            'robot_control/tools/record.py', 'robot_control/tools/plot.py'} <= modules
    assert {p.split('/')[0] for p in modules} == set(PACKAGES)
    assert workshop_files(files) == []
    print(f'wheel: {len(modules)} modules, {python_lines({p: files[p] for p in modules})} lines of Python')
