"""A node's parameters as data: one declarative table, checked here without rclpy.

In the spirit of generate_parameter_library's YAML schema, each Row is a parameter: name, type,
default, description with units, validation rules, read-only or settable at run time. The same
table declares the parameters on a node (robot_control.ros.param_engine), checks every start-up
value and run-time change, and renders the parameter tables of docs/parameters.md (markdown()) and
the nodes' --help listings (plain_text()).

Rules (a row's `rules`, rendered in this order into the descriptor's additional_constraints):
    gt(x), gt_eq(x), lt(x), lt_eq(x)   bounds; x a number or another parameter's name (its value);
                                       on an array, each entry
    one_of(options)                    one of the options
    subset_of(options, what=None)      each entry of an array among the options (`what` names them)
    size(n), size('joints', 'joint')   n entries, or one per entry of another parameter;
                                       empty_ok=True also accepts an empty array
    unique(), not_empty()              no repeated entry; not an empty string or array
    custom(text, check=None)           check(value, values) raises an ArgumentError; without a check
                                       the rule is enforced by the node's build() (e.g. it needs the model)
Doubles are finite unless the row says inf=True (then +inf is allowed, e.g. "no clamp").

Stages: a Table is a sequence of stages, functions of the values of the stages before it that
return rows. That is how defaults depend on the scenario and rows on the model (model_params.*).
A parameter a stage reads must be read-only, so the rows never change at run time.

Every failure is a ParameterError, an ArgumentError whose .name is the parameter.
"""
import dataclasses
import math
import operator
import textwrap

from robot_control.validation import ArgumentError

SCALAR_TYPES = ('bool', 'integer', 'double', 'string')
ARRAY_TYPES = ('bool_array', 'integer_array', 'double_array', 'string_array')
TYPES = SCALAR_TYPES + ARRAY_TYPES


class ParameterError(ArgumentError):
    """An invalid parameter value: `name` is the parameter; str() is '<name>: <reason>'.

    `reason` may be an ArgumentError: its own reason when it names the same parameter, else its text.
    """

    def __init__(self, name, reason):
        if isinstance(reason, ArgumentError):
            reason = reason.reason if reason.name == name else str(reason)
        super().__init__(name, reason)


# -- rules ---------------------------------------------------------------------------------------------------
class Rule:
    """A validation rule: `text` for the docs, check(row, value, values) raises ParameterError."""

    text = ''

    def check(self, row, value, values):
        raise NotImplementedError


_OPS = {'>': operator.gt, '>=': operator.ge, '<': operator.lt, '<=': operator.le}
_ZERO_WORDS = {'>': 'positive', '>=': 'non-negative'}


class Bound(Rule):
    """value op limit (each entry of an array); limit a number or the name of another parameter."""

    def __init__(self, op, limit):
        self.op, self.limit = op, limit
        self.text = f'{op} {_number(limit)}'

    def check(self, row, value, values):
        limit = values[self.limit] if isinstance(self.limit, str) else self.limit
        entries = value if row.is_array else (value,)
        if all(_OPS[self.op](x, limit) for x in entries):
            return
        word = _ZERO_WORDS.get(self.op) if limit == 0 and not isinstance(self.limit, str) else None
        where = f'{self.limit} = {_number(limit)}' if isinstance(self.limit, str) else _number(limit)
        if row.is_array:
            wanted = f'{word} values' if word else f'values {self.op} {where}'
            raise ParameterError(row.name, f'expected {wanted}, got {list(value)}')
        wanted = f'a {word} number' if word else f'a number {self.op} {where}'
        raise ParameterError(row.name, f'expected {wanted}, got {_number(value)}')


class OneOf(Rule):
    def __init__(self, options):
        self.options = tuple(options)
        self.text = ' | '.join("''" if o == '' else str(o) for o in self.options)

    def check(self, row, value, values):
        if value not in self.options:
            raise ParameterError(row.name, f'unknown {value!r}; expected one of {list(self.options)}')


class SubsetOf(Rule):
    def __init__(self, options, what=None):
        self.options = tuple(options)
        self.what = what or f'{list(self.options)}'
        self.text = f'subset of {", ".join(self.options)}' + (f' ({what})' if what else '')

    def check(self, row, value, values):
        unknown = [v for v in value if v not in self.options]
        if unknown:
            raise ParameterError(row.name, f'{unknown} not among {self.what} {list(self.options)}')


class Size(Rule):
    """len(value) == n, or one per entry of parameter `of` (then `what` names an entry)."""

    def __init__(self, of, what=None, empty_ok=False):
        self.of, self.what, self.empty_ok = of, what or of, empty_ok
        count = f'one per {self.what}' if isinstance(of, str) else f'{of} values'
        self.text = f'empty or {count}' if empty_ok else count

    def check(self, row, value, values):
        n = len(values[self.of]) if isinstance(self.of, str) else self.of
        if len(value) == n or (self.empty_ok and not value):
            return
        per = f' (one per {self.what})' if isinstance(self.of, str) else ''
        raise ParameterError(row.name, f'expected {"empty or " if self.empty_ok else ""}{n} values{per}, '
                                       f'got {len(value)}')


class Unique(Rule):
    text = 'unique'

    def check(self, row, value, values):
        if len(set(value)) != len(value):
            raise ParameterError(row.name, f'duplicate entries in {list(value)}')


class NotEmpty(Rule):
    """A non-empty string; an array with at least one entry (and no empty string in it)."""

    text = 'not empty'

    def check(self, row, value, values):
        if not row.is_array:
            if not value:
                raise ParameterError(row.name, 'expected a non-empty string')
            return
        if not value:
            raise ParameterError(row.name, 'expected at least one entry')
        if row.type == 'string_array' and not all(value):
            raise ParameterError(row.name, f'expected non-empty strings, got {list(value)}')


class Custom(Rule):
    """`check(value, values)` raises an ArgumentError (its reason is the row's) when the value breaks
    the rule; without a check the rule is the node's build() to enforce and is here for the docs."""

    def __init__(self, text, check=None):
        self.text, self._check = text, check

    def check(self, row, value, values):
        if self._check is None:
            return
        try:
            self._check(value, values)
        except ArgumentError as exc:
            raise ParameterError(row.name, exc.reason) from None


def gt(limit):
    return Bound('>', limit)


def gt_eq(limit):
    return Bound('>=', limit)


def lt(limit):
    return Bound('<', limit)


def lt_eq(limit):
    return Bound('<=', limit)


def one_of(options):
    return OneOf(options)


def subset_of(options, what=None):
    return SubsetOf(options, what)


def size(of, what=None, *, empty_ok=False):
    return Size(of, what, empty_ok)


def unique():
    return Unique()


def not_empty():
    return NotEmpty()


def custom(text, check=None):
    return Custom(text, check)


# -- rows ----------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Row:
    """One parameter. `default` None = required (no default in this configuration); array defaults
    are tuples. `aliases`: the names the library gives this parameter in its errors (a config field,
    a model argument), so a build error maps back to the parameter. `inf`: a double may be +inf.
    `reported`: the node writes the value (what is in force, e.g. designed gains); a set from outside
    is refused as read-only."""

    name: str
    type: str
    default: object
    description: str
    rules: tuple = ()
    read_only: bool = False
    inf: bool = False
    aliases: tuple = ()
    reported: bool = False

    def __post_init__(self):
        if self.type not in TYPES:
            raise ValueError(f'{self.name}: type {self.type!r} is not one of {list(TYPES)}')
        if self.default is not None:
            object.__setattr__(self, 'default', self.convert(self.default))
        object.__setattr__(self, 'rules', tuple(self.rules))

    @property
    def is_array(self):
        return self.type in ARRAY_TYPES

    @property
    def constraints(self):
        """The rules as text (the descriptor's additional_constraints, the bounds column of docs/parameters.md)."""
        texts = [r.text for r in self.rules if r.text]
        if self.inf:
            texts.append('.inf allowed')
        return '; '.join(texts)

    def convert(self, value):
        """`value` as the snapshot holds it (float for a double, a tuple for an array), or
        ParameterError. None (not set, or an empty list at start-up): () for an array, else required."""
        if value is None:
            if self.default is None or not self.is_array:
                raise ParameterError(self.name, 'required: there is no default for this configuration')
            return ()
        if self.is_array:
            if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
                raise ParameterError(self.name, f'expected a list ({self.type}), got {value!r}')
            element = self.type[:-len('_array')]
            return tuple(self._scalar(element, v, value) for v in value)
        return self._scalar(self.type, value, value)

    def _scalar(self, kind, v, whole):
        ok = {'bool': isinstance(v, bool), 'string': isinstance(v, str),
              'integer': isinstance(v, int) and not isinstance(v, bool),
              'double': isinstance(v, (int, float)) and not isinstance(v, bool)}[kind]
        if not ok:
            raise ParameterError(self.name, f'expected {self.type}, got {whole!r}')
        if kind != 'double':
            return v
        x = float(v)
        if math.isnan(x) or (math.isinf(x) and not (self.inf and x > 0)):
            what = 'finite values' if self.is_array else 'a finite number'
            raise ParameterError(self.name, f'expected {what}, got {list(whole) if self.is_array else x}')
        return x

    def check(self, value, values):
        for rule in self.rules:
            rule.check(self, value, values)


def _number(x):
    if isinstance(x, str):
        return x
    if isinstance(x, float) and math.isinf(x):
        return '.inf' if x > 0 else '-.inf'
    return str(x)


# -- tables --------------------------------------------------------------------------------------------------
class Rows:
    """The rows of one configuration (a table's stages resolved), in declaration order."""

    def __init__(self, rows):
        self._rows = {r.name: r for r in rows}
        self._alias = {a: r.name for r in rows for a in r.aliases}

    def __iter__(self):
        return iter(self._rows.values())

    def __contains__(self, name):
        return name in self._rows

    def __getitem__(self, name):
        return self._rows[name]

    def names(self):
        return list(self._rows)

    def check(self, values):
        """Every row's rules on `values` (converted values of every row); ParameterError."""
        for row in self._rows.values():
            row.check(values[row.name], values)

    def parameter_of(self, name):
        """The parameter a library name stands for: a row's own name or one of its aliases; None."""
        return name if name in self._rows else self._alias.get(name)

    def error(self, exc):
        """ParameterError for an ArgumentError raised while building from these parameters: its
        name mapped to the parameter (the name itself when no row claims it)."""
        if isinstance(exc, ParameterError):
            return exc
        return ParameterError(self.parameter_of(exc.name) or exc.name, exc.reason)


class _Reads(dict):
    """The values a stage sees; remembers which it read (they must be read-only)."""

    def __init__(self, values):
        super().__init__(values)
        self.read = set()

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.read.add(key)
        return super().get(key, default)


class Table:
    """A node's parameter table: `stages` are functions (values so far) -> iterable of Row."""

    def __init__(self, node, *stages):
        self.node = node
        self.stages = stages

    def resolve(self, read=None, check=True):
        """(Rows, values): each stage's rows, their values read with read(row) (default: the row's
        default) and, with `check`, converted and checked stage by stage (ParameterError). Without
        `check` the values are returned as read."""
        read = read or (lambda row: row.default)
        rows, values = {}, {}
        for stage in self.stages:
            seen = _Reads(values)
            new = list(stage(seen))
            settable = sorted(name for name in seen.read if name in rows and not rows[name].read_only)
            if settable:
                raise ValueError(f'{self.node}: a stage reads {settable}, which may change at run time')
            for row in new:
                if row.name in values:
                    raise ValueError(f'{self.node}: parameter {row.name} declared twice')
                value = read(row)
                values[row.name] = row.convert(value) if check else value
                rows[row.name] = row
            if check:
                for row in new:
                    row.check(values[row.name], values)
        return Rows(rows.values()), values

    def validate(self, values):
        """Converted, checked values of every row for a {name: value} mapping (missing = default)."""
        return self.resolve(lambda row: values.get(row.name, row.default))[1]

    def defaults(self, **seed):
        """{name: value} of every row's default, where the stages see `seed` for the names it holds
        (e.g. scenario='iiwa'); unchecked."""
        return self.resolve(lambda row: seed.get(row.name, row.default), check=False)[1]

    def markdown_rows(self, **seed):
        """(name, type, default, description, bounds, set at run time) per row; defaults as the
        stages make them under `seed` (the seeded rows themselves show their own default). Set at
        run time: one of SETTING's keys."""
        rows, _ = self.resolve(lambda row: seed.get(row.name, row.default), check=False)
        return [(r.name, r.type, _yaml(r.default), r.description, r.constraints, _setting(r)) for r in rows]


#: the "set at run time" column of markdown_rows() -> its words in a plain-text listing
SETTING = {'yes': 'settable at run time', 'no': 'read-only', 'no (reported)': 'read-only, reported by the node'}


def _setting(row):
    if row.reported:
        return 'no (reported)'
    return 'no' if row.read_only else 'yes'


HEADER = '| parameter | type | default | meaning, units | bounds | set at run time |\n|---|---|---|---|---|---|\n'


def markdown(rows):
    """A markdown table of markdown_rows()."""
    def cell(text):
        return str(text).replace('|', '\\|').replace('\n', ' ')
    return HEADER + ''.join('| ' + ' | '.join(cell(c) for c in row) + ' |\n' for row in rows)


def plain_text(rows, width=100):
    """A plain-text listing of markdown_rows() (a node's --help): per parameter the line
    '  <name> (<type>, default <default>, settable at run time | read-only)' and under it its meaning
    with units and its bounds, indented and wrapped at `width` columns."""
    indent = ' ' * 6
    lines = []
    for name, kind, default, meaning, bounds, setting in rows:
        lines.append(f'  {name} ({kind}, default {default}, {SETTING[setting]})')
        text = meaning + (f' [bounds: {bounds}]' if bounds else '')
        lines += textwrap.wrap(text, width, initial_indent=indent, subsequent_indent=indent, break_on_hyphens=False)
    return '\n'.join(lines)


def flatten(d, prefix=''):
    """{'a': {'b': 1}} -> {'a.b': 1}: the nested keys of a `ros__parameters` section as parameter names."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flatten(v, f'{prefix}{k}.'))
        else:
            out[f'{prefix}{k}'] = v
    return out


def _yaml(v):
    """A default as YAML shows it ('' quoted, .inf, lists in brackets); '(required)' for None."""
    if v is None:
        return '(required)'
    if isinstance(v, float) and math.isinf(v):
        return '.inf' if v > 0 else '-.inf'
    if isinstance(v, (list, tuple)):
        return '[' + ', '.join(_yaml(x) for x in v) + ']'
    if isinstance(v, str):
        return f"'{v}'"
    return str(v).lower() if isinstance(v, bool) else str(v)
