"""The nodes' executables share one command line (robot_control.ros.entry): the same exit statuses and
the same message for a bad parameter, and a --help that lists every parameter of the node's table."""
import os
import re
import subprocess
import sys

import pytest

from robot_control.ros import controller_params
from sim_bridge import bridge_params

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
#: (module, program name, its parameter table)
NODES = [('robot_control.ros.controller_node', 'controller_node', controller_params.TABLE),
         ('sim_bridge.bridge_node', 'sim_bridge_node', bridge_params.TABLE)]
IDS = ['controller', 'sim_bridge']


def _run(module, *args):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1')
    return subprocess.run([sys.executable, '-m', module, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=60)


@pytest.mark.parametrize('module, prog, table', NODES, ids=IDS)
@pytest.mark.parametrize('param, name', [('omega_res:=-1.0', 'omega_res'), ('physics_step:=-0.001', 'physics_step'),
                                         ('no_such_parameter:=1.0', 'no_such_parameter')])
def test_a_bad_parameter_exits_2_with_the_same_message_format(module, prog, table, param, name):
    """Each node refuses what is not its parameter or what breaks its rules: status 2, and on stderr the
    line '<program>: bad parameter <name>: <reason>' (no traceback)."""
    run = _run(module, '--ros-args', '-p', param)
    assert run.returncode == 2, run.stderr
    lines = [line for line in run.stderr.splitlines() if re.match(rf'^{prog}: bad parameter {re.escape(name)}: \S',
                                                                  line)]
    assert len(lines) == 1, run.stderr
    assert 'Traceback' not in run.stderr


@pytest.mark.parametrize('module, prog, table', NODES, ids=IDS)
@pytest.mark.parametrize('flag, value, message', [('--executor', 'turbo', 'invalid choice'),
                                                  ('--cpu-wakeup-latency', '-1', 'expected a whole number of '
                                                   "microseconds >= 0, got '-1'")])
def test_a_usage_error_exits_2_as_a_bad_parameter_does(module, prog, table, flag, value, message):
    run = _run(module, flag, value)
    assert run.returncode == 2
    assert f'{prog}: error: argument {flag}: {message}' in run.stderr


@pytest.mark.parametrize('module, prog, table', NODES, ids=IDS)
def test_help_exits_0_and_lists_every_parameter_with_its_default(module, prog, table):
    """--help shows each row of the node's table (the README's rows): name, type, default with no
    parameter set, settable or read-only, then its meaning with units."""
    run = _run(module, '--help')
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(f'usage: {prog} ') and '--executor' in run.stdout
    rows = table.markdown_rows()
    assert len(rows) > 20
    lines = run.stdout.splitlines()
    for name, kind, default, meaning, _, setting in rows:
        setting = 'read-only' if setting.startswith('no') else 'settable at run time'
        head = f'  {name} ({kind}, default {default}, {setting}'
        at = [i for i, line in enumerate(lines) if line.startswith(head)]
        assert len(at) == 1, head
        body = []
        for line in lines[at[0] + 1:]:
            if not line.startswith(' ' * 6):
                break
            body.append(line.strip())
        assert ' '.join(body).startswith(' '.join(meaning.split())), name


def test_help_shows_the_controllers_gain_rule_overrides_as_settable():
    run = _run('robot_control.ros.controller_node', '--help')
    assert '  allow_underdamped (bool, default false, settable at run time)' in run.stdout
    assert '  allow_resonance (bool, default false, settable at run time)' in run.stdout
    assert '  gains.kp (double_array, default [], read-only, reported by the node)' in run.stdout
