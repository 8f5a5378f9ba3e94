"""The parameter engine on an rclpy node (robot_control.ros.param_engine), in-process, a fresh context per test.

A probe table stands for a node's: a read-only robot choice, a model argument answering to its own
name (m), a bounded double, arrays with fixed and relative sizes, a read-only array; build()
raises the library's ArgumentErrors by their own names.
"""
import dataclasses

import pytest
from rclpy.parameter import Parameter

from robot_control.ros.param_engine import ParameterEngine, ParameterNode
from robot_control.param_table import ParameterError, Row, Table, custom, gt, one_of, size
from robot_control.validation import ArgumentError

T = Parameter.Type


def _table():
    return Table(
        'probe',
        lambda v: [Row('robot', 'string', 'arm', 'which robot', [one_of(['arm', 'cart'])], read_only=True)],
        lambda v: [Row('model_params.m', 'double', 2.0 if v['robot'] == 'arm' else 5.0, 'mass, kg', [gt(0)],
                       aliases=('m',)),
                   Row('rate', 'double', 10.0, 'loop rate, Hz', [gt(0), custom('<= 1000 (checked by build)')]),
                   Row('gains', 'double_array', (), 'gains, 1/s^2; empty = designed',
                       [size('axes', 'axis', empty_ok=True)]),
                   Row('axes', 'string_array', ('x', 'y'), 'task axes', [], read_only=True),
                   Row('tags', 'string_array', ('a',), 'labels'),
                   Row('enabled', 'bool', True, 'on or off')])


@dataclasses.dataclass(frozen=True)
class Config:
    m: float
    rate: float


def _build(values):
    if values['model_params.m'] > 100.0:
        raise ArgumentError('m', f'expected at most 100 kg, got {values["model_params.m"]}')
    if values['rate'] > 1000.0:
        raise ArgumentError('rate', f'expected at most 1000 Hz, got {values["rate"]}')
    return Config(values['model_params.m'], values['rate'])


class Probe(ParameterNode):
    def __init__(self, context, **kwargs):
        super().__init__('probe', context=context, **kwargs)
        self.applied = []
        try:
            self.params = ParameterEngine(self, _table(), _build, apply=self._apply)
        except BaseException:
            self.destroy_node()
            raise

    def _apply(self, old, new, changed):
        self.applied.append((old, new, changed))


@pytest.fixture
def probe(ros_context):
    made = []

    def make(*cli, **overrides):
        node = Probe(ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()],
                     cli_args=['--ros-args', *cli] if cli else None)
        made.append(node)
        return node
    yield make
    for node in made:
        node.destroy_node()


def _yaml(tmp_path, body):
    path = tmp_path / 'params.yaml'
    path.write_text('probe:\n  ros__parameters:\n' + ''.join(f'    {line}\n' for line in body))
    return str(path)


# -- declaration ----------------------------------------------------------------------------------------------
def test_every_row_is_declared_with_its_descriptor(probe):
    node = probe()
    described = {d.name: d for d in node.describe_parameters(['robot', 'model_params.m', 'rate', 'gains', 'axes'])}
    assert described['robot'].read_only and described['robot'].type == T.STRING.value
    assert described['robot'].additional_constraints == 'arm | cart'
    assert described['rate'].description == 'loop rate, Hz' and not described['rate'].read_only
    assert described['rate'].additional_constraints == '> 0; <= 1000 (checked by build)'
    assert described['gains'].type == T.DOUBLE_ARRAY.value
    assert described['gains'].additional_constraints == 'empty or one per axis'
    assert node.get_parameter('gains').type_ == T.DOUBLE_ARRAY and list(node.get_parameter('gains').value) == []
    assert node.params.current.config == Config(2.0, 10.0)


def test_start_up_values_come_from_overrides_and_stages_from_earlier_values(probe):
    node = probe(robot='cart', rate=50.0)
    values = node.params.current.values
    assert (values['robot'], values['model_params.m'], values['rate']) == ('cart', 5.0, 50.0)
    assert values['axes'] == ('x', 'y') and values['gains'] == ()
    with pytest.raises(TypeError):
        values['rate'] = 1.0                                  # the snapshot is read-only


def test_a_yaml_file_loads_and_empty_lists_read_as_empty(probe, tmp_path):
    node = probe('--params-file', _yaml(tmp_path, ['rate: 20.0', 'gains: []', 'axes: []', 'tags: []',
                                                   'use_sim_time: true']))
    values = node.params.current.values
    assert (values['rate'], values['gains'], values['axes'], values['tags']) == (20.0, (), (), ())
    assert node.get_parameter('tags').type_ == T.STRING_ARRAY                 # typed: `ros2 param get` shows []
    assert node.get_parameter('use_sim_time').value is True


def test_the_node_records_its_overrides_and_declares_none_of_them_itself(ros_context, tmp_path):
    node = ParameterNode('probe', context=ros_context, parameter_overrides=[Parameter('rate', value=3.0)],
                         cli_args=['--ros-args', '-p', 'gains:=[]', '--params-file', _yaml(tmp_path, ['x: 1'])])
    try:
        assert dict(node.start_up_overrides) == {'rate': 3.0, 'gains': None, 'x': 1}
        assert sorted(node.list_parameters([], 0).names) == ['start_type_description_service', 'use_sim_time']
    finally:
        node.destroy_node()


# -- start-up errors ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize('overrides, name, match', [
    ({'robot': 'boat'}, 'robot', r"unknown 'boat'; expected one of \['arm', 'cart'\]"),
    ({'rate': 0.0}, 'rate', 'expected a positive number, got 0.0'),
    ({'rate': 10}, 'rate', r'expected type DOUBLE, got 10 \(INTEGER\); YAML doubles need a decimal point'),
    ({'gains': [1.0]}, 'gains', r'expected empty or 2 values \(one per axis\), got 1'),
    ({'model_params.m': 200.0}, 'model_params.m', 'expected at most 100 kg'),      # build's m, mapped
    ({'rate': 2000.0}, 'rate', 'expected at most 1000 Hz'),
    ({'rat': 1.0}, 'rat', 'unknown parameter of probe; did you mean rate?'),
    ({'zzz': 1.0, 'qqq': 2}, 'qqq', r"unknown parameter of probe \(known: .*\) \(also unknown: \['zzz'\]\)"),
])
def test_invalid_start_up_values_raise_naming_the_parameter(probe, overrides, name, match):
    with pytest.raises(ParameterError, match=f'^{name}: {match}') as err:
        probe(**overrides)
    assert err.value.name == name


def test_rules_come_before_unknown_parameters_and_unknown_parameters_before_build(probe):
    with pytest.raises(ParameterError, match='^rate: expected a positive number'):
        probe(rate=-1.0, rte=1.0)
    with pytest.raises(ParameterError, match='^rte: unknown parameter'):
        probe(rate=2000.0, rte=1.0)


def test_unknown_parameters_are_refused_from_the_command_line_and_files_but_rclpys_own_are_known(probe, tmp_path):
    with pytest.raises(ParameterError, match='^gainz: unknown parameter') as err:
        probe('-p', 'gainz:=[1.0]')
    assert err.value.name == 'gainz'
    with pytest.raises(ParameterError, match='^extra.deep: unknown parameter'):
        probe('--params-file', _yaml(tmp_path, ['extra:', '  deep: 1.0']))
    node = probe('-p', 'use_sim_time:=true', '-p', 'start_type_description_service:=false',
                 '-p', 'qos_overrides./parameter_events.publisher.depth:=10')
    assert node.params.current.config == Config(2.0, 10.0)


# -- run time ------------------------------------------------------------------------------------------------------
def test_a_valid_change_is_built_committed_and_applied(probe):
    node = probe()
    before = node.params.current
    assert node.set_parameters([Parameter('rate', value=20.0)])[0].successful
    after = node.params.current
    assert after.config == Config(2.0, 20.0) and after.values['rate'] == 20.0
    assert node.applied == [(before, after, frozenset({'rate'}))]


@pytest.mark.parametrize('name, value, reason', [
    ('rate', -1.0, 'rate: expected a positive number, got -1.0'),
    ('rate', 5000.0, 'rate: expected at most 1000 Hz, got 5000.0'),
    ('model_params.m', 500.0, 'model_params.m: expected at most 100 kg, got 500.0'),
    ('gains', [1.0, 2.0, 3.0], 'gains: expected empty or 2 values (one per axis), got 3'),
])
def test_an_invalid_change_is_refused_with_the_parameters_name_and_nothing_changes(probe, name, value, reason):
    node = probe()
    before = node.params.current
    old = node.get_parameter(name).value
    result = node.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and result.reason == reason
    assert node.get_parameter(name).value == old and node.params.current is before and node.applied == []


def test_integers_and_empty_lists_are_coerced_to_the_declared_type(probe):
    node = probe(gains=[1.0, 2.0])
    results = node.set_parameters([Parameter('rate', T.INTEGER, 30), Parameter('gains', T.INTEGER_ARRAY, [3, 4])])
    assert all(r.successful for r in results)
    assert node.get_parameter('rate').type_ == T.DOUBLE and node.params.current.values['gains'] == (3.0, 4.0)
    assert node.set_parameters([Parameter('gains', T.BOOL_ARRAY, [])])[0].successful
    assert node.get_parameter('gains').type_ == T.DOUBLE_ARRAY and node.params.current.values['gains'] == ()
    assert not node.set_parameters([Parameter('enabled', T.INTEGER, 1)])[0].successful     # not a double: no coercion


def test_read_only_parameters_are_refused(probe):
    node = probe()
    result = node.set_parameters([Parameter('robot', value='cart')])[0]
    assert not result.successful and 'read-only' in result.reason
    assert node.params.current.values['robot'] == 'arm' and node.applied == []


def test_rclpys_own_parameters_pass_without_a_rebuild(probe):
    node = probe()
    before = node.params.current
    assert node.set_parameters([Parameter('use_sim_time', value=True)])[0].successful
    assert node.params.current is before and node.applied == []


def test_an_atomic_change_is_checked_as_a_whole(probe):
    node = probe()
    assert not node.set_parameters_atomically([Parameter('gains', value=[1.0, 2.0, 3.0])]).successful
    result = node.set_parameters_atomically([Parameter('gains', value=[1.0, 2.0]), Parameter('rate', value=5.0)])
    assert result.successful and node.params.current.values['gains'] == (1.0, 2.0)
    assert node.applied[-1][2] == frozenset({'gains', 'rate'})
