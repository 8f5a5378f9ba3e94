"""Bad run-time values for the rows of a parameter table (robot_control.param_table): what each row's type and
rules refuse, set through the node's parameter service as `ros2 param set` does.

bad_values(row, values) -> [(what, value)]: a value of another type (rclpy refuses it against the declared
type, before any callback), a non-finite number for a double (the table refuses NaN, and -inf), and per rule a
value that breaks it (a bound crossed, one entry too many, an unknown option, a repeated entry, an empty value).
A Custom rule's check is the build's (it may need the model): its cases come from the test (`extra`).
"""
import math

from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from robot_control import param_table as pt

#: a value of another type than the row's (never an int for a double, never an empty list: the engine coerces those)
WRONG_TYPE = {'bool': 'yes', 'integer': 'one', 'double': 'one', 'string': 2.5, 'bool_array': [1.5],
              'integer_array': ['one'], 'double_array': ['one'], 'string_array': [2.5]}
#: rclpy's reason for a value of the wrong type (its descriptor check, before the node's callbacks)
WRONG_TYPE_REASON = 'Wrong parameter type'


def _crossing(rule, values):
    """A number that breaks the Bound `rule`."""
    limit = values[rule.limit] if isinstance(rule.limit, str) else rule.limit
    return limit - 1.0 if rule.op in ('>', '>=') else limit + 1.0


def _rule_values(row, rule, current, values):
    n = max(1, len(current)) if row.is_array else 1
    if isinstance(rule, pt.Bound):
        x = _crossing(rule, values)
        return [('out of bounds', [x] * n if row.is_array else x)]
    if isinstance(rule, pt.Size):
        size = len(values[rule.of]) if isinstance(rule.of, str) else rule.of
        return [('wrong size', [1.0] * (size + 1))]
    if isinstance(rule, pt.OneOf):
        return [('unknown option', 'no_such_option')]
    if isinstance(rule, pt.SubsetOf):
        return [('unknown entry', ['no_such_option'])]
    if isinstance(rule, pt.Unique) and current:
        return [('repeated entry', [current[0], current[0]])]
    if isinstance(rule, pt.NotEmpty):
        return [('empty', [] if row.is_array else '')]
    return []


def bad_values(row, values, extra=()):
    """[(what, value)] that `row` refuses given the node's current `values` ({name: value}); `extra` adds cases."""
    current = values[row.name]
    out = [('wrong type', WRONG_TYPE[row.type])]
    if row.type == 'double':
        out += [('not a number', math.nan), ('-inf', -math.inf)]
    elif row.type == 'double_array':
        out.append(('not a number', [math.nan] * max(1, len(current))))
    for rule in row.rules:
        out += _rule_values(row, rule, current, values)
    return out + list(extra)


def rows_and_values(table, node):
    """(rows a run-time set may change: not read-only, not reported by the node; {name: value} of every row) of
    `table` as declared on `node`, its values read back from the node."""
    rows, values = table.resolve(lambda row: node.get_parameter(row.name).value)
    return [row for row in rows if not row.read_only and not row.reported], values


def setter(node, target, spin_until):
    """set(name, value) -> SetParametersResult: a set on the node named `target` through its parameter service,
    from `node`, as `ros2 param set` does (an answer proves the node lived through it). spin_until(predicate)
    spins the executor, bounded."""
    client = AsyncParameterClient(node, target)
    assert spin_until(client.services_are_ready), f'{target} has no parameter service'

    def set_(name, value):
        future = client.set_parameters([Parameter(name, value=value)])
        assert spin_until(future.done), f'{target} did not answer the set of {name} = {value!r}'
        return future.result().results[0]
    return set_


def check_refused(result, name, what):
    """A refused set: rclpy's reason for a wrong type, else the node's, naming the parameter."""
    assert not result.successful, f'{name} = {what} was accepted'
    if what == 'wrong type':
        assert result.reason.startswith(WRONG_TYPE_REASON), (name, result.reason)
    else:
        assert result.reason.startswith(f'{name}: '), (name, what, result.reason)
