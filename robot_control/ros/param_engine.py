"""The parameter engine: a node's table (robot_control.param_table) declared on an rclpy node.

    class MyNode(ParameterNode):
        def __init__(self, **kwargs):
            super().__init__('my_node', **kwargs)
            self._params = ParameterEngine(self, TABLE, build, apply=self._apply_parameters)
            snapshot = self._params.current          # Snapshot(values, config), immutable

        def _apply_parameters(self, old, new, changed):   # after a run-time change was committed
            ...

ParameterEngine(node, table, build, apply):
- declares every row with a ParameterDescriptor (type, description, the rules as
  additional_constraints, read_only), stage by stage, reading the start-up values (YAML, -p,
  parameter_overrides=) and checking each stage's rules; an empty list given at start-up reads
  as an empty array;
- then refuses a start-up override that is no row of the table and not rclpy's own
  (use_sim_time, start_type_description_service, qos_overrides.*), naming it (a typo is named
  before the build error it may cause);
- then calls build(values) -> config (the node's own configuration object), or, for a managed
  (lifecycle) node created with deferred=True, leaves that to configure() (its on_configure);
  release() (on_cleanup) drops the configuration again;
- at run time: a pre-set callback coerces int -> double, int array -> double array and an empty
  list of any type -> the declared array type (`ros2 param set /controller omega_res 10`,
  `kp "[]"`); the on-set callback checks the rules and builds the would-be configuration, and
  refuses with the reason '<parameter>: <what is wrong>'; the post-set callback commits it and
  calls apply(old, new, changed names).
Every error is a ParameterError whose .name is the parameter; an ArgumentError from build()
(a config field, a model argument) is mapped to its parameter through the table's names and
aliases. Values in the snapshot are Python values (floats, str, bools, tuples for arrays).

ParameterNode is the rclpy Node the engine needs: one that knows which start-up overrides it was
given. rclpy has no public accessor for them; created with
automatically_declare_parameters_from_overrides=True, Node.__init__ hands them all to
declare_parameters(), which ParameterNode records on that first call instead of declaring them
(rclpy cannot declare an empty-list override automatically, and the engine declares each with
its own type and descriptor).
"""
import dataclasses
import difflib
from types import MappingProxyType

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.node import Node
from rclpy.parameter import Parameter

from robot_control.param_table import ParameterError
from robot_control.validation import ArgumentError

T = Parameter.Type
TYPES = {'bool': T.BOOL, 'integer': T.INTEGER, 'double': T.DOUBLE, 'string': T.STRING,
         'bool_array': T.BOOL_ARRAY, 'integer_array': T.INTEGER_ARRAY, 'double_array': T.DOUBLE_ARRAY,
         'string_array': T.STRING_ARRAY}
_ARRAYS = (T.BYTE_ARRAY, T.BOOL_ARRAY, T.INTEGER_ARRAY, T.DOUBLE_ARRAY, T.STRING_ARRAY)
#: parameters rclpy itself declares on every node (and their prefixes): never refused as unknown
ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')
ROS_PREFIXES = ('qos_overrides.',)


class ParameterNode(Node):
    """rclpy Node that records its start-up parameter overrides ({name: value}, start_up_overrides).

    kwargs go to rclpy.node.Node; automatically_declare_parameters_from_overrides is always True
    (that is how the overrides reach declare_parameters, which records them on its first call).
    """

    def __init__(self, node_name, **kwargs):
        self.__overrides = None
        kwargs['automatically_declare_parameters_from_overrides'] = True
        super().__init__(node_name, **kwargs)
        if self.__overrides is None:
            self.destroy_node()
            raise RuntimeError('rclpy did not pass the parameter overrides to declare_parameters(); '
                               'ParameterNode needs an rclpy that does (Jazzy\'s rclpy 7 does)')

    @property
    def start_up_overrides(self):
        """{name: value} of the overrides given at start-up (None for an empty list)."""
        return MappingProxyType(self.__overrides)

    def declare_parameters(self, namespace, parameters, ignore_override=False):
        if self.__overrides is None:     # Node.__init__ handing over the overrides: record, do not declare
            self.__overrides = {p[0]: p[1] for p in parameters}
            return []
        return super().declare_parameters(namespace, parameters, ignore_override)


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """The parameter values ({name: value}, read-only) and the configuration built from them."""

    values: MappingProxyType
    config: object


class ParameterEngine:
    """Declares `table` on `node` (a ParameterNode) and keeps the current Snapshot.

    build(values) -> config: the node's configuration from a read-only {name: value}; raises
    ParameterError or ArgumentError. apply(old, new, changed): called after a run-time change was
    committed, with the Snapshots before and after and the set of changed names. Raises
    ParameterError when the start-up values are invalid. deferred: the configuration is built by
    configure(), not at once (Snapshot.config is None until then, and after release()).
    """

    def __init__(self, node, table, build, apply=None, deferred=False):
        self._node, self._build, self._apply = node, build, apply
        self._pending = None
        self._reporting = False
        self._overrides = node.start_up_overrides
        self.rows, values = table.resolve(self._declare)
        self._refuse_unknown()
        self._current = Snapshot(MappingProxyType(values), None if deferred else self._built(values))
        node.add_pre_set_parameters_callback(self._coerce)
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._post_set)

    @property
    def current(self):
        """The committed Snapshot."""
        return self._current

    @property
    def configured(self):
        """True while a configuration is built (always, unless deferred and not configured)."""
        return self._current.config is not None

    def configure(self):
        """Build the configuration of the current values (ParameterError naming the parameter); the Snapshot."""
        values = self._current.values
        self._current = Snapshot(values, self._built(dict(values)))
        return self._current

    def release(self):
        """Drop the configuration (a managed node's cleanup); the values stay."""
        self._current = Snapshot(self._current.values, None)

    def validate(self, changes):
        """The Snapshot that {name: value} `changes` would make, without committing it; ParameterError.
        Without a configuration (not configured yet) only the table's rules are checked."""
        values = dict(self._current.values)
        for name, value in changes.items():
            values[name] = self.rows[name].convert(value)
        self.rows.check(values)
        return Snapshot(MappingProxyType(values), self._built(values) if self.configured else None)

    def error(self, exc):
        """ParameterError for an ArgumentError raised by code that uses the configuration (its name
        mapped to the parameter as for build())."""
        return self.rows.error(exc)

    # -- start-up ------------------------------------------------------------------------------------------
    def _declare(self, row):
        """Declare `row`; its start-up value (None when not set: an empty list, or no default)."""
        node, kind = self._node, TYPES[row.type]
        descriptor = ParameterDescriptor(name=row.name, type=kind.value, description=row.description,
                                         additional_constraints=row.constraints, read_only=row.read_only)
        if row.default is None or (row.is_array and not row.default):
            initial = kind            # declared by type: not set until a value comes
        else:
            initial = list(row.default) if row.is_array else row.default
        try:
            param = node.declare_parameter(row.name, initial, descriptor)
        except InvalidParameterTypeException:
            raise ParameterError(row.name, self._type_reason(row)) from None
        if param.type_ != T.NOT_SET or not row.is_array:
            return param.value
        given = row.name in self._overrides         # as an empty list: rclpy reads YAML [] as not set
        if not row.read_only and (given or row.default is not None):
            node.set_parameters([Parameter(row.name, kind, [])])    # typed, so that `ros2 param get` shows []
        return [] if given else None

    def _type_reason(self, row):
        got = self._overrides.get(row.name)
        got_type = T.from_parameter_value(got).name if got is not None else 'NOT_SET'
        hint = '; YAML doubles need a decimal point, e.g. 1.0' if row.type.startswith('double') else ''
        return f'expected type {TYPES[row.type].name}, got {got!r} ({got_type}){hint}'

    def _refuse_unknown(self):
        unknown = sorted(name for name in self._overrides
                         if name not in self.rows and name not in ROS_PARAMETERS and not name.startswith(ROS_PREFIXES))
        if not unknown:
            return
        name = unknown[0]
        close = difflib.get_close_matches(name, self.rows.names(), 1)
        hint = f'; did you mean {close[0]}?' if close else f' (known: {self.rows.names()})'
        others = f' (also unknown: {unknown[1:]})' if unknown[1:] else ''
        raise ParameterError(name, f'unknown parameter of {self._node.get_name()}{hint}{others}')

    def _built(self, values):
        try:
            return self._build(MappingProxyType(values))
        except ArgumentError as exc:
            raise self.rows.error(exc) from None

    # -- run time ------------------------------------------------------------------------------------------
    def _coerce(self, parameters):
        """Pre-set callback: int -> double, int array -> double array, an empty list -> the row's array type."""
        out = []
        for p in parameters:
            row = self.rows[p.name] if p.name in self.rows else None
            kind = TYPES[row.type] if row is not None else None
            if kind is not None and p.type_ != kind:
                if kind == T.DOUBLE and p.type_ == T.INTEGER:
                    p = Parameter(p.name, T.DOUBLE, float(p.value))
                elif kind == T.DOUBLE_ARRAY and p.type_ == T.INTEGER_ARRAY:
                    p = Parameter(p.name, T.DOUBLE_ARRAY, [float(v) for v in p.value])
                elif kind in _ARRAYS and p.type_ in _ARRAYS and len(p.value) == 0:
                    p = Parameter(p.name, kind, [])
            out.append(p)
        return out

    def report(self, values):
        """Write {name: value} to reported rows (what the node has in force), the one way they change."""
        self._reporting = True
        try:
            self._node.set_parameters([Parameter(name, TYPES[self.rows[name].type],
                                                 list(value) if self.rows[name].is_array else value)
                                       for name, value in values.items()])
        finally:
            self._reporting = False

    def _on_set(self, parameters):
        self._pending = None
        reported = [p.name for p in parameters if p.name in self.rows and self.rows[p.name].reported]
        if reported and not self._reporting:
            return SetParametersResult(successful=False, reason=f'{reported[0]}: read-only: '
                                                                f'{self.rows[reported[0]].description}')
        changes = {p.name: p.value for p in parameters if p.name in self.rows and not self.rows[p.name].reported}
        if not changes:         # use_sim_time and other parameters of rclpy's own
            return SetParametersResult(successful=True)
        try:
            self._pending = (parameters, self.validate(changes))
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _post_set(self, parameters):
        pending, self._pending = self._pending, None
        changed = frozenset(p.name for p in parameters if p.name in self.rows and not self.rows[p.name].reported)
        if not changed:
            return
        if pending is None or pending[0] is not parameters:     # not expected: _on_set validated this list
            pending = (parameters, self.validate({p.name: p.value for p in parameters if p.name in changed}))
        old, self._current = self._current, pending[1]
        if self._apply is not None:
            self._apply(old, self._current, changed)
