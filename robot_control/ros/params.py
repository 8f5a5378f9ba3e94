"""Controller parameters: declarations (type, description with units, bounds) and validation.

Node layer (uses rclpy). `ControllerParameters(node)` declares every parameter once, reads the
start-up values (YAML/--ros-args overrides), and builds the controller's `ControllerConfig`;
`validate(changes)` builds the would-be configuration for a set of changes without touching
anything (the node's on-set callback), `commit()` makes it current (the post-set callback).
Every failure is a ParameterError whose message starts with the parameter's name, e.g.
"zeta: 0.5 breaks the rule zeta >= 1 (...)".

Model parameters use a flat dotted scheme that YAML nests naturally:
    model_params.m: 2.0          ->   model_params: {m: 2.0}
one double per argument of the closed-form model class (robot_control.models.closed_form),
e.g. polar_two_link: m (kg), gravity (m/s^2); for model 'urdf': gravity (m/s^2, along -z).

`scenario` (read-only) fills the defaults of model, model_params.*, joints, urdf, tip, force_axes,
k_e and x_e from robot_control.scenarios; anything set explicitly wins.

Typing: parameters are statically typed (YAML doubles carry .0). For convenience at run time a
pre-set callback (`coerce`) turns integers into doubles and any empty list into the parameter's
empty array type, so `ros2 param set /controller kp "[]"` (back to designed gains) and
`ros2 param set /controller omega_res 10` work.
"""
import dataclasses
import inspect
import math

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.parameter import Parameter

from robot_control import gains as gain_design
from robot_control import scenarios, units, validation
from robot_control.core.config import FORCE_FEEDBACK, ControllerConfig
from robot_control.laws import LAWS, law_class
from robot_control.gains import ServoGains
from robot_control.validation import ArgumentError
from robot_control.models import CLOSED_FORM, make_model

T = Parameter.Type


class ParameterError(ArgumentError):
    """An invalid parameter value: `name` is the parameter; str() is '<name>: <reason>'."""

    def __init__(self, name, reason):
        if isinstance(reason, ArgumentError):
            reason = reason.reason if reason.name == name else str(reason)
        super().__init__(name, reason)


@dataclasses.dataclass(frozen=True)
class Spec:
    """One parameter: name, type, default, description (with units), bounds text, read-only."""

    name: str
    type: T
    default: object
    description: str
    bounds: str = ''
    read_only: bool = False

    def descriptor(self):
        return ParameterDescriptor(name=self.name, type=self.type.value, description=self.description,
                                   additional_constraints=self.bounds, read_only=self.read_only)


def scenario_spec():
    """The `scenario` parameter: a name that fills the defaults of everything else."""
    return Spec('scenario', T.STRING, '',
                'scenario name filling the defaults of the model, joints and surface '
                '(robot_control.scenarios); empty = none',
                ' | '.join(["''"] + sorted(scenarios.SCENARIOS)), True)


def model_spec(default):
    """The `model` parameter: closed-form model name or 'urdf'."""
    return Spec('model', T.STRING, default, "closed-form model name or 'urdf'",
                ' | '.join(sorted(CLOSED_FORM) + ['urdf']), True)


def _scenario_defaults(name):
    """Defaults implied by scenario `name` ('' = none)."""
    if not name:
        return {}
    sc = scenarios.get(name)
    task_axes = ('x', 'y', 'z') if sc.model == 'urdf' else CLOSED_FORM[sc.model].task_axes
    force_axes = tuple(task_axes[i] for i in sc.force_axes)
    out = {'model': sc.model, 'joints': tuple(sc.joints), 'urdf': sc.urdf, 'tip': sc.tip,
           'force_axes': force_axes, 'model_params': dict(sc.params), 'q_nominal': tuple(sc.q0)}
    if sc.surface is not None and force_axes:
        k = len(force_axes)
        out['k_e'] = (sc.surface.k_e,) * k
        out['x_e'] = (sc.surface.x_e,) * k
    return out


def model_param_specs(model, defaults=None):
    """Specs of model_params.* for `model` (closed-form name or 'urdf'), defaults overridden by `defaults`."""
    defaults = defaults or {}
    if model == 'urdf':
        g = float(defaults.get('gravity', units.GRAVITY))
        return [Spec('model_params.gravity', T.DOUBLE, g, 'gravitational acceleration along world -z, m/s^2',
                     '>= 0')]
    try:
        cls = CLOSED_FORM[model]
    except KeyError:
        raise ParameterError('model', f"unknown {model!r}; expected 'urdf' or one of {sorted(CLOSED_FORM)}") from None
    specs = []
    unit_of = {'m': 'kg', 'm1': 'kg', 'm2': 'kg', 'm3': 'kg', 'l': 'm', 'l1': 'm', 'l2': 'm',
               'b': 'N s/m (viscous friction)', 'k': 'N/m^3 (cubic spring)', 'gravity': 'm/s^2'}
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.name == 'self':
            continue
        value = float(defaults.get(p.name, p.default))
        specs.append(Spec(f'model_params.{p.name}', T.DOUBLE, value,
                          f'{model} model parameter {p.name}, {unit_of.get(p.name, "SI")}',
                          '>= 0' if p.name in ('b', 'k', 'gravity') else '> 0'))
    return specs


def specs(defaults):
    """Every parameter except scenario, model and model_params.*, with `defaults` applied."""
    d = defaults.get
    return [
        Spec('joints', T.STRING_ARRAY, tuple(d('joints', ())),
             'controlled joint names in model order, matched by name in joint_states; empty = the model\'s '
             '(a URDF model: all movable joints)', 'unique names; closed form: one per model joint', True),
        Spec('urdf', T.STRING, d('urdf', ''),
             "model 'urdf': URDF file path, shipped name (robot_control/urdf) or pybullet_data path", '',
             True),
        Spec('robot_description', T.STRING, '',
             "model 'urdf': URDF XML text (wins over urdf when non-empty)", '', True),
        Spec('tip', T.STRING, d('tip', ''),
             "model 'urdf': task frame (link) for fk/J, needed by the force and hybrid laws", '', True),
        Spec('law', T.STRING, 'computed_torque', 'control law',
             ' | '.join(LAWS)),
        Spec('integral', T.BOOL, False, 'integral action (PID): ki used, integral state kept'),
        Spec('zeta', T.DOUBLE, 1.0, 'designed damping ratio, dimensionless', '>= 1 (no underdamping)'),
        Spec('omega_res', T.DOUBLE, 12.0, 'lowest structural resonance, rad/s', '> 0'),
        Spec('omega_n', T.DOUBLE, 0.0, 'designed natural frequency, rad/s; 0 = 0.5 omega_res',
             '0 or 0 < omega_n <= 0.5 omega_res'),
        Spec('kp', T.DOUBLE_ARRAY, (),
             'explicit Kp diagonal (empty = designed): 1/s^2 (computed torque, hybrid motion axes) or '
             'N m/rad, N/m (independent_joint)', 'empty, or one per joint (hybrid: per task or motion axis); >= 0'),
        Spec('kv', T.DOUBLE_ARRAY, (), 'explicit Kv diagonal (empty = designed): 1/s or N m s/rad, N s/m',
             'empty, or as many as kp needs; >= 0'),
        Spec('ki', T.DOUBLE_ARRAY, (), 'explicit Ki diagonal (empty = designed), used when integral: '
             '1/s^3 or N m/(rad s), N/(m s)', 'empty, or as many as kp needs; >= 0'),
        Spec('force_kp', T.DOUBLE_ARRAY, (), 'explicit force servo kp per force axis (empty = designed), 1/s^2',
             'empty or one per force axis; >= 0'),
        Spec('force_kv', T.DOUBLE_ARRAY, (), 'explicit force servo kv per force axis (empty = designed), 1/s',
             'empty or one per force axis; >= 0'),
        Spec('force_ki', T.DOUBLE_ARRAY, (), 'explicit force servo ki per force axis (empty = designed), 1/s^3',
             'empty or one per force axis; >= 0'),
        Spec('integral_limit', T.DOUBLE, math.inf,
             'clamp of |integral of the error| per entry: rad s, m s (joints/motion) or N s (force)',
             '> 0, .inf = no clamp'),
        Spec('effort_limits', T.DOUBLE_ARRAY, (), 'effort limit per joint, N m or N; empty = the model\'s '
             '(URDF <limit effort>, none for closed forms)', 'empty or one per joint; > 0'),
        Spec('state_timeout', T.DOUBLE, 0.5, 'watchdog: no joint_states for this long stops commanding, s '
             '(node clock: sim time when use_sim_time)', '> 0'),
        Spec('force_axes', T.STRING_ARRAY, tuple(d('force_axes', ())),
             'force-controlled task axes (names of the model\'s task axes, e.g. x)', 'subset of the task axes'),
        Spec('k_e', T.DOUBLE_ARRAY, tuple(d('k_e', ())), 'environment stiffness per force axis, N/m',
             'one per force axis; > 0'),
        Spec('x_e', T.DOUBLE_ARRAY, tuple(d('x_e', ())), 'environment location per force axis, m',
             'one per force axis'),
        Spec('force_feedback', T.STRING, 'sensor',
             "contact force: 'sensor' (ft_sensor/wrench) or 'model' (f = k_e (x - x_e))", ' | '.join(FORCE_FEEDBACK)),
        Spec('force_lead_time', T.DOUBLE, 0.0, 'force laws use the force predicted this far ahead, f + fdot T, '
             's; the control period compensates the command hold (0 = the lecture\'s law)', '>= 0'),
        Spec('f_d', T.DOUBLE_ARRAY, (), 'desired force per force axis (robot on environment), N; '
             'empty = 0; changes ramp over force_ramp_time', 'empty or one per force axis'),
        Spec('force_ramp_time', T.DOUBLE, 0.5, 'duration of a force reference change (quintic), s; 0 = step',
             '>= 0'),
        Spec('q_d', T.DOUBLE_ARRAY, (), 'joint set-point, rad or m; empty = hold the start position; '
             'a change starts a quintic move from the current reference over move_time', 'empty or one per joint'),
        Spec('move_time', T.DOUBLE, 2.0, 'duration of a q_d move, s', '> 0'),
        Spec('posture_kp', T.DOUBLE, 25.0, 'null-space posture stiffness (hybrid, redundant arms), 1/s^2', '>= 0'),
        Spec('posture_kv', T.DOUBLE, 10.0, 'null-space posture damping (hybrid, redundant arms), 1/s', '>= 0'),
        Spec('contact_max_travel', T.DOUBLE, 0.05,
             'lost-contact guard (force, hybrid): largest travel past the surface that the measured force '
             'does not explain before the force axis is held in position, m; .inf = off', '> 0'),
        Spec('contact_max_speed', T.DOUBLE, 0.5,
             'lost-contact guard (force, hybrid): largest speed along a force axis before it is held in '
             'position, m/s; .inf = off', '> 0'),
        Spec('publish_effort_array', T.BOOL, False,
             'also publish effort_controller/commands (std_msgs/Float64MultiArray, joints order)'),
        Spec('diagnostics_period', T.DOUBLE, 0.5, 'period of /diagnostics, s (wall clock)', '> 0'),
    ]


ARRAY_TYPES = (T.BYTE_ARRAY, T.BOOL_ARRAY, T.INTEGER_ARRAY, T.DOUBLE_ARRAY, T.STRING_ARRAY)


def _python(spec_type, value):
    """Parameter value -> the snapshot's Python value (tuples for arrays)."""
    if spec_type in (T.DOUBLE_ARRAY, T.STRING_ARRAY):
        return tuple(value or ())
    return value


class Snapshot:
    """Parameter values (name -> value) and the ControllerConfig built from them."""

    __slots__ = ('values', 'config')

    def __init__(self, values, config):
        self.values = values
        self.config = config


class ControllerParameters:
    """Declares the controller's parameters on `node` and turns their values into a ControllerConfig.

    Raises ParameterError (naming the parameter) when the start-up values are invalid.
    """

    def __init__(self, node):
        self._node = node
        self._model_cache = {}
        self.specs = {}
        values = {}
        scenario = self._declare(scenario_spec())
        values['scenario'] = scenario
        try:
            defaults = _scenario_defaults(scenario)
        except ValueError as exc:
            raise ParameterError('scenario', exc) from None
        self.q_nominal = defaults.get('q_nominal')
        values['model'] = self._declare(model_spec(defaults.get('model', 'polar_two_link')))
        if 'joints' not in defaults and values['model'] in CLOSED_FORM:
            defaults['joints'] = CLOSED_FORM[values['model']].joint_names
        for spec in model_param_specs(values['model'], defaults.get('model_params')) + specs(defaults):
            values[spec.name] = self._declare(spec)
        self.current = self.build(values)

    def _declare(self, spec):
        """Declare `spec`; returns its value (start-up override or default) as a Python value.

        Non-empty defaults are declared as values (their type is the spec's). Empty arrays are
        declared by type and then set to a typed empty list; a read-only one cannot be set after
        declaration and stays 'not set', which reads as empty.
        """
        node = self._node
        self.specs[spec.name] = spec
        empty = isinstance(spec.default, tuple) and not spec.default
        default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
        try:
            param = node.declare_parameter(spec.name, spec.type if empty else default, spec.descriptor())
        except InvalidParameterTypeException as exc:
            raise ParameterError(spec.name, f'expected type {spec.type.name} ({exc})') from None
        except InvalidParameterValueException as exc:
            raise ParameterError(spec.name, exc) from None
        if param.type_ == T.NOT_SET and not spec.read_only:  # no override, or an empty YAML list
            node.set_parameters([Parameter(spec.name, spec.type, default)])
            param = node.get_parameter(spec.name)
        return _python(spec.type, param.value)

    # -- run-time changes ------------------------------------------------------------------------
    def coerce(self, parameters):
        """Pre-set callback: int -> double, int array -> double array, any empty list -> the declared array type."""
        out = []
        for p in parameters:
            spec = self.specs.get(p.name)
            if spec is not None and p.type_ != spec.type:
                if spec.type == T.DOUBLE and p.type_ == T.INTEGER:
                    p = Parameter(p.name, T.DOUBLE, float(p.value))
                elif spec.type == T.DOUBLE_ARRAY and p.type_ == T.INTEGER_ARRAY:
                    p = Parameter(p.name, T.DOUBLE_ARRAY, [float(v) for v in p.value])
                elif spec.type in ARRAY_TYPES and p.type_ in ARRAY_TYPES and len(p.value) == 0:
                    p = Parameter(p.name, spec.type, [])
            out.append(p)
        return out

    def validate(self, parameters):
        """Snapshot the current values would become with `parameters` applied; ParameterError if invalid."""
        values = dict(self.current.values)
        for p in parameters:
            spec = self.specs.get(p.name)
            if spec is None:
                continue  # use_sim_time and other parameters the node does not own
            values[p.name] = _python(spec.type, p.value)
        return self.build(values)

    def commit(self, snapshot):
        """Make `snapshot` (from validate()) current."""
        self.current = snapshot

    # -- values -> ControllerConfig ----------------------------------------------------------------
    def build(self, values):
        """Snapshot(values, ControllerConfig) or ParameterError naming the first invalid parameter."""
        model = self._model(values)
        n = model.n
        try:
            config = self._config(values, model)
        except ParameterError:
            raise
        except ValueError as exc:
            name = str(exc).split(':', 1)[0]
            raise ParameterError(name if name in self.specs else 'law', exc) from None
        k = len(config.force_axes)
        for name, length, what in (('q_d', n, 'joint'), ('f_d', k, 'force axis')):
            arr = values[name]
            if arr and len(arr) != length:
                raise ParameterError(name, f'expected empty or {length} values (one per {what}), got {len(arr)}')
            if arr:
                validation.vector(name, arr, length)
        for name in ('state_timeout', 'diagnostics_period'):
            try:
                validation.scalar(name, values[name], positive=True)
            except ValueError as exc:
                raise ParameterError(name, exc) from None
        return Snapshot(values, config)

    def _model(self, values):
        name = values['model']
        mp = {k.split('.', 1)[1]: v for k, v in values.items() if k.startswith('model_params.')}
        key = (name, tuple(sorted(mp.items())), values['urdf'], values['robot_description'], values['tip'],
               values['joints'])
        if key in self._model_cache:
            return self._model_cache[key]
        try:
            if name == 'urdf':
                source = values['robot_description'] or values['urdf']
                if not source:
                    raise ParameterError('urdf', "model 'urdf' needs urdf (file or shipped name) or "
                                                 'robot_description (XML text)')
                if not source.lstrip().startswith('<'):
                    from robot_control.models.urdf_model import resolve_urdf
                    try:
                        source = resolve_urdf(source)
                    except ValueError as exc:
                        raise ParameterError('urdf', str(exc).split(': ', 1)[-1]) from None
                gravity = validation.scalar('gravity', mp['gravity'], nonnegative=True)
                model = make_model('urdf', urdf=source, joints=values['joints'] or None,
                                   tip=values['tip'] or None, gravity=(0.0, 0.0, -gravity))
            else:
                model = make_model(name, **mp)
        except ParameterError:
            raise
        except ValueError as exc:
            first = str(exc).split(':', 1)[0]
            if first in mp:
                raise ParameterError(f'model_params.{first}', str(exc).split(': ', 1)[-1]) from None
            if first in ('joints', 'tip'):
                raise ParameterError(first, str(exc).split(': ', 1)[-1]) from None
            raise ParameterError('model', exc) from None
        self._model_cache = {key: model}  # keep the latest only
        return model

    def _gains(self, values, prefix, n, design, scale=None):
        """ServoGains (n,): each of {prefix}kp, kv, ki explicit (n values) or, when empty, designed.

        Designed gains are design.kp, kv, ki times `scale` per entry (a callable giving the (n,)
        scale, evaluated only when needed); ki is used only with integral action.
        """
        integral = values['integral']
        out = []
        for g in ('kp', 'kv', 'ki'):
            name, arr = f'{prefix}{g}', values[f'{prefix}{g}']
            if g == 'ki' and not integral:
                out.append(np.zeros(n))
            elif arr:
                if len(arr) != n:
                    raise ParameterError(name, f'expected {n} values, got {len(arr)} (or none for designed gains)')
                out.append(np.array(arr, dtype=float))
            else:
                out.append(getattr(design, g) * (np.ones(n) if scale is None else scale()))
        try:
            return ServoGains(*out)
        except ValueError as exc:
            text = str(exc)
            raise ParameterError(f'{prefix}{text.split(":", 1)[0]}', text.split(': ', 1)[-1]) from None

    def _config(self, values, model):
        law = values['law']
        try:
            design = gain_design.design(values['zeta'], values['omega_res'], values['omega_n'] or None,
                                        integral=values['integral'])
        except ValueError as exc:
            name = str(exc).split(':', 1)[0]
            raise ParameterError(name if name in self.specs else 'zeta', exc) from None
        force_axes = values['force_axes']
        k = len(force_axes)
        law_cls = law_class(law)
        sizes = law_cls.servo_sizes(model, force_axes)
        motion = None
        if sizes:
            explicit = len(values['kp'])
            size = explicit if explicit in sizes else sizes[0]
            scale = (lambda: self._joint_inertia(model)) if law_cls.torque_gains else None
            motion = self._gains(values, '', size, design, scale)
        force = self._gains(values, 'force_', k, design) if k else None
        return ControllerConfig(
            model=model, law=law, gains=motion, force_gains=force, integral=values['integral'],
            integral_limit=values['integral_limit'],
            effort_limit=values['effort_limits'] or None,
            joints=values['joints'] or None, force_axes=force_axes,
            k_e=values['k_e'], x_e=values['x_e'], force_feedback=values['force_feedback'],
            force_lead_time=values['force_lead_time'],
            posture_gains=(values['posture_kp'], values['posture_kv']),
            move_time=values['move_time'], force_ramp_time=values['force_ramp_time'],
            contact_max_travel=values['contact_max_travel'], contact_max_speed=values['contact_max_speed'])

    def _joint_inertia(self, model):
        """diag M(q_nominal) (scenario start, else zeros): scales designed gains for independent_joint."""
        q = np.zeros(model.n) if self.q_nominal is None else np.array(self.q_nominal, dtype=float)
        diag = np.diag(model.M(q)).copy()
        if not np.all(diag > 0.0):
            raise ParameterError('kp', f'independent_joint designs kp = omega_n^2 M_ii(q0) but M_ii(q0) = '
                                       f'{diag.tolist()} at q0 = {q.tolist()}; give kp and kv explicitly')
        return diag

