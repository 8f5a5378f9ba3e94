"""The parameter table without rclpy: rows, rules, stages, error mapping, rendering, and the two
nodes' tables (robot_control.param_table, robot_control.ros.controller_params, sim_bridge.bridge_params)."""
import math

import pytest

from robot_control import scenarios
from robot_control.ros import controller_params as params
from robot_control.param_table import (ParameterError, Row, Table, custom, gt, gt_eq, lt, lt_eq, markdown,
                                           not_empty, one_of, plain_text, size, subset_of, unique)
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params


def _rejects(row, value, values, match):
    with pytest.raises(ParameterError, match=match) as err:
        row.check(value, values)
    assert err.value.name == row.name and isinstance(err.value, ArgumentError)


# -- rules -----------------------------------------------------------------------------------------------
def test_bounds_on_a_scalar_name_the_parameter_and_the_bound():
    row = Row('rate', 'double', 1.0, 'Hz', [gt(0), lt_eq(10.0)])
    row.check(10.0, {})
    _rejects(row, 0.0, {}, r'^rate: expected a positive number, got 0.0$')
    _rejects(row, 10.5, {}, r'^rate: expected a number <= 10.0, got 10.5$')
    _rejects(Row('x', 'double', 1.0, 'm', [gt_eq(0)]), -1.0, {}, 'non-negative number')
    _rejects(Row('x', 'integer', 1, '-', [lt(3)]), 3, {}, r'^x: expected a number < 3, got 3$')
    assert row.constraints == '> 0; <= 10.0'


def test_a_bound_may_be_another_parameter_and_applies_to_each_entry_of_an_array():
    row = Row('timeout', 'double', 1.0, 's', [gt('period')])
    row.check(0.2, {'period': 0.1})
    _rejects(row, 0.1, {'period': 0.1}, r'^timeout: expected a number > period = 0.1, got 0.1$')
    assert row.constraints == '> period'
    gains = Row('kp', 'double_array', (), '1/s^2', [gt_eq(0)])
    gains.check((1.0, 0.0), {})
    _rejects(gains, (1.0, -2.0), {}, r'^kp: expected non-negative values, got \[1.0, -2.0\]$')


def test_one_of_and_subset_of():
    law = Row('law', 'string', 'a', '-', [one_of(['a', 'b'])])
    law.check('b', {})
    _rejects(law, 'c', {}, r"^law: unknown 'c'; expected one of \['a', 'b'\]$")
    assert Row('s', 'string', '', '-', [one_of(['', 'x'])]).constraints == "'' | x"
    axes = Row('axes', 'string_array', (), '-', [subset_of(('x', 'y'), 'the task axes')])
    axes.check(('y',), {})
    _rejects(axes, ('x', 'q'), {}, r"^axes: \['q'\] not among the task axes \['x', 'y'\]$")
    assert axes.constraints == 'subset of x, y (the task axes)'


def test_size_fixed_or_one_per_entry_of_another_parameter():
    force = Row('force', 'double_array', (), 'N', [size(3, empty_ok=True)])
    force.check((), {})
    force.check((1.0, 2.0, 3.0), {})
    _rejects(force, (1.0,), {}, r'^force: expected empty or 3 values, got 1$')
    per = Row('k_e', 'double_array', (), 'N/m', [size('axes', 'force axis')])
    per.check((1.0, 2.0), {'axes': ('x', 'y')})
    _rejects(per, (), {'axes': ('x',)}, r'^k_e: expected 1 values \(one per force axis\), got 0$')
    assert (force.constraints, per.constraints) == ('empty or 3 values', 'one per force axis')


def test_unique_not_empty_and_custom():
    names = Row('joints', 'string_array', ('a',), '-', [not_empty(), unique()])
    _rejects(names, ('a', 'a'), {}, r"^joints: duplicate entries in \['a', 'a'\]$")
    _rejects(names, (), {}, '^joints: expected at least one entry$')
    _rejects(names, ('a', ''), {}, 'non-empty strings')
    _rejects(Row('frame', 'string', 'w', '-', [not_empty()]), '', {}, '^frame: expected a non-empty string$')
    def even_check(v, values):
        if v % 2:
            raise ArgumentError('count', f'{v} is odd')
    even = Row('n', 'integer', 2, '-', [custom('even', even_check)])
    even.check(4, {})
    _rejects(even, 3, {}, '^n: 3 is odd$')
    Row('zeta', 'double', 1.0, '-', [custom('>= 1 (checked by the design)')]).check(0.5, {})   # text only


# -- rows: types and values -------------------------------------------------------------------------------
def test_convert_gives_the_snapshot_values_and_names_a_wrong_type():
    assert Row('a', 'double', 1, '-').default == 1.0 and isinstance(Row('a', 'double', 1, '-').default, float)
    assert Row('v', 'double_array', [1, 2.5], '-').convert([3, 4]) == (3.0, 4.0)
    assert Row('s', 'string_array', (), '-').convert(['x']) == ('x',)
    with pytest.raises(ParameterError, match=r"^a: expected double, got 'x'$"):
        Row('a', 'double', 1.0, '-').convert('x')
    with pytest.raises(ParameterError, match='^b: expected bool'):
        Row('b', 'bool', False, '-').convert(1)
    with pytest.raises(ParameterError, match='^v: expected a list'):
        Row('v', 'double_array', (), '-').convert(1.0)
    with pytest.raises(ValueError, match='float64'):
        Row('c', 'float64', 1.0, '-')


def test_doubles_are_finite_unless_the_row_allows_inf():
    with pytest.raises(ParameterError, match='^t: expected a finite number, got inf$'):
        Row('t', 'double', 1.0, 's').convert(math.inf)
    with pytest.raises(ParameterError, match='^t: expected a finite number, got nan$'):
        Row('t', 'double', 1.0, 's', inf=True).convert(math.nan)
    with pytest.raises(ParameterError, match='expected finite values'):
        Row('v', 'double_array', (), '-').convert([0.0, math.nan])
    assert Row('limit', 'double', 1.0, '-', [gt(0)], inf=True).convert(math.inf) == math.inf
    with pytest.raises(ParameterError):
        Row('limit', 'double', 1.0, '-', inf=True).convert(-math.inf)
    assert Row('limit', 'double', 1.0, '-', [gt(0)], inf=True).constraints == '> 0; .inf allowed'


def test_not_set_reads_as_an_empty_array_or_is_required():
    assert Row('kp', 'double_array', (), '-').convert(None) == ()
    assert Row('axes', 'string_array', ('z',), '-').convert(None) == ()
    with pytest.raises(ParameterError, match='^joints: required'):
        Row('joints', 'string_array', None, '-').convert(None)
    with pytest.raises(ParameterError, match='^rate: required'):
        Row('rate', 'double', 1.0, '-').convert(None)


# -- tables ------------------------------------------------------------------------------------------------
def _table():
    return Table('probe',
                 lambda v: [Row('robot', 'string', 'small', '-', [one_of(['small', 'big'])], read_only=True)],
                 lambda v: [Row('mass', 'double', 1.0 if v['robot'] == 'small' else 9.0, 'kg', [gt(0)],
                                aliases=('m',)),
                            Row('gains', 'double_array', (), '-', [size('links', 'link', empty_ok=True)]),
                            Row('links', 'string_array', ('a', 'b'), '-', read_only=True)])


def test_later_stages_take_defaults_from_earlier_values():
    assert _table().defaults()['mass'] == 1.0
    assert _table().defaults(robot='big')['mass'] == 9.0
    rows, values = _table().resolve(lambda row: 'big' if row.name == 'robot' else row.default)
    assert rows.names() == ['robot', 'mass', 'gains', 'links'] and values['mass'] == 9.0


def test_each_stage_is_checked_before_the_next_is_made():
    made = []
    table = Table('probe', lambda v: [Row('robot', 'string', 'x', '-', [one_of(['x'])], read_only=True)],
                  lambda v: made.append(v['robot']) or [])
    with pytest.raises(ParameterError, match="^robot: unknown 'moon'"):
        table.validate({'robot': 'moon'})
    assert made == []


def test_relative_rules_see_every_value_of_the_stage():
    with pytest.raises(ParameterError, match=r'^gains: expected empty or 2 values \(one per link\), got 1$'):
        _table().validate({'gains': [1.0]})
    assert _table().validate({'gains': [1.0, 2.0]})['gains'] == (1.0, 2.0)


def test_a_stage_may_read_only_read_only_parameters_and_names_are_unique():
    reads_settable = Table('probe', lambda v: [Row('rate', 'double', 1.0, '-')],
                           lambda v: [Row('other', 'double', v['rate'], '-')])
    with pytest.raises(ValueError, match=r"reads \['rate'\], which may change at run time"):
        reads_settable.defaults()
    twice = Table('probe', lambda v: [Row('a', 'bool', True, '-')], lambda v: [Row('a', 'bool', True, '-')])
    with pytest.raises(ValueError, match='declared twice'):
        twice.defaults()


def test_library_errors_map_to_their_parameter_through_the_aliases():
    rows, _ = _table().resolve()
    assert rows.parameter_of('m') == 'mass' and rows.parameter_of('mass') == 'mass'
    assert rows.parameter_of('nothing') is None
    err = rows.error(ArgumentError('m', 'expected a positive number, got -1.0'))
    assert isinstance(err, ParameterError) and err.name == 'mass'
    assert str(err) == 'mass: expected a positive number, got -1.0'
    own = ParameterError('gains', 'bad')
    assert rows.error(own) is own


def test_markdown_rows_render_defaults_rules_and_run_time_setting():
    rows = _table().markdown_rows(robot='big')
    assert rows[0] == ('robot', 'string', "'small'", '-', 'small | big', 'no')      # a seeded row: its own default
    assert rows[1] == ('mass', 'double', '9.0', 'kg', '> 0', 'yes')
    assert rows[3][2] == "['a', 'b']"
    text = markdown(rows)
    assert text.splitlines()[0] == '| parameter | type | default | meaning, units | bounds | set at run time |'
    assert '| robot | string | \'small\' | - | small \\| big | no |' in text


def test_plain_text_lists_each_row_with_its_default_setting_and_wrapped_meaning():
    meaning = 'payload mass, kg; ' + ' '.join(['long words'] * 12)
    table = Table('probe', lambda v: [Row('robot', 'string', 'small', 'which robot', [one_of(['small', 'big'])],
                                          read_only=True),
                                      Row('mass', 'double', 1.0, meaning, [gt(0)]),
                                      Row('gains.kp', 'double_array', (), 'in force, 1/s^2', reported=True)])
    lines = plain_text(table.markdown_rows(), width=40).splitlines()
    assert lines[:2] == ["  robot (string, default 'small', read-only)", '      which robot [bounds: small | big]']
    assert lines[2] == '  mass (double, default 1.0, settable at run time)'
    assert all(len(line) <= 40 and line.startswith(' ' * 6) for line in lines[3:-2])
    assert ' '.join(line.strip() for line in lines[3:-2]) == meaning + ' [bounds: > 0]'
    assert lines[-2:] == ['  gains.kp (double_array, default [], read-only, reported by the node)',
                          '      in force, 1/s^2']
    assert table.markdown_rows()[2][5] == 'no (reported)'


# -- the nodes' tables -------------------------------------------------------------------------------------
@pytest.mark.parametrize('table', [params.TABLE, bridge_params.TABLE], ids=['controller', 'sim_bridge'])
@pytest.mark.parametrize('scenario', sorted(scenarios.SCENARIOS))
def test_every_row_is_described_and_every_scenario_default_passes_its_rules(table, scenario):
    rows, values = table.resolve(lambda row: scenario if row.name == 'scenario' else row.default)
    for row in rows:
        assert row.description, row.name
    assert values['scenario'] == scenario


def test_the_controller_scenario_fills_the_defaults():
    d = params.TABLE.defaults(scenario='iiwa')
    sc = scenarios.get('iiwa')
    assert (d['model'], d['joints'], d['urdf'], d['tip']) == ('urdf', sc.joints, sc.urdf, sc.tip)
    assert (d['force_axes'], d['k_e'], d['x_e']) == (('z',), (20000.0,), (0.25,))
    assert d['model_params.gravity'] == 9.81 and 'model_params.m' not in d
    polar = params.TABLE.defaults()
    assert (polar['scenario'], polar['model'], polar['joints']) == ('', 'polar_two_link', ('theta1', 'r'))
    assert (polar['model_params.m'], polar['model_params.gravity']) == (2.0, 9.81)


def test_the_controllers_model_arguments_answer_to_their_own_names():
    rows, _ = params.TABLE.resolve(lambda row: 'planar_two_link' if row.name == 'scenario' else row.default)
    assert rows.parameter_of('l1') == 'model_params.l1' and rows.parameter_of('m2') == 'model_params.m2'
    with pytest.raises(ParameterError, match='^model_params.l1: expected a positive number'):
        params.TABLE.validate({'scenario': 'planar_two_link', 'model_params.l1': 0.0})
    with pytest.raises(ParameterError, match="^force_axes: \\['q'\\] not among the model's task axes"):
        params.TABLE.validate({'force_axes': ['q']})
