"""The controller's parameter values -> ControllerConfig (free of rclpy).

ConfigBuilder()(values) builds the model (closed form or URDF; the latest one is kept, so a
change of gains does not rebuild a URDF model), sizes the servo gains the law needs (each of
kp, kv, ki explicit or designed from zeta, omega_res, omega_n by robot_control.gains; the force
servo's force_kp, force_kv, force_ki likewise; both written into the law's parameters) and makes
the ControllerConfig. The law (robot_control.laws.LAWS) says how its motion servo is sized.

Errors are ArgumentErrors named after a parameter, or after a config field or model argument
that the parameter table maps to its parameter (model_params.m answers to m).
"""
import numpy as np

from robot_control import gains as gain_design
from robot_control import scenarios
from robot_control.core.config import ControllerConfig
from robot_control.gains import ServoGains
from robot_control.laws import force_task, friction_compensation, law_class
from robot_control.laws.servo import gain_params as motion_params
from robot_control.models import make_model
from robot_control.models.base import POSE_JOINTS
from robot_control.param_table import ParameterError
from robot_control.validation import ArgumentError

MODEL_PARAMS = 'model_params.'


def as_parameter(override):
    """A gain rule's override in the node's terms: the parameter that allows it (allow_underdamped)."""
    return f'set the parameter {override}: true'


def servo_gains(values, prefix, n, design, scale=None):
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
    except ArgumentError as exc:
        raise ParameterError(prefix + exc.name, exc.reason) from None


def designed_gains(values):
    """The servo design (robot_control.gains.design) of zeta, omega_res, omega_n (0: the default) and integral."""
    return gain_design.design(values['zeta'], values['omega_res'], values['omega_n'] or None,
                              integral=values['integral'], allow_underdamped=values['allow_underdamped'],
                              allow_resonance=values['allow_resonance'], name_override=as_parameter)


def joint_inertia(model, q0):
    """diag M(q0) (q0 None: zeros): scales designed gains for independent_joint."""
    q = np.zeros(model.n) if q0 is None else np.array(q0, dtype=float)
    diag = np.diag(model.M(q)).copy()
    if not np.all(diag > 0.0):
        raise ParameterError('kp', f'independent_joint designs kp = omega_n^2 M_ii(q0) but M_ii(q0) = '
                                   f'{diag.tolist()} at q0 = {q.tolist()}; set the parameters kp and kv')
    return diag


def motion_gains(values, model, design, q0):
    """The motion servo's ServoGains for the law in values (None when it has none): as many as the law
    accepts (Law.servo_sizes: explicit kp may give any of them, designed gains the first), scaled by
    the joint inertia M_ii(q0) when the law takes torque gains."""
    law = law_class(values['law'])
    sizes = law.servo_sizes(model, values['force_axes'])
    if not sizes:
        return None
    size = len(values['kp']) if len(values['kp']) in sizes else sizes[0]
    scale = (lambda: joint_inertia(model, q0)) if law.torque_gains else None
    return servo_gains(values, '', size, design, scale)


def tolerances(values, model, kind):
    """constraints.<joint>.<kind> of every joint, in model order (rad or m; 0 = not checked)."""
    return [values.get(f'constraints.{joint}.{kind}', 0.0) for joint in (values['joints'] or model.joint_names)]


class ConfigBuilder:
    """values -> ControllerConfig; keeps the latest model. `description`: URDF XML text received on the
    robot_description topic, the model's source when model is 'urdf' and neither urdf nor
    robot_description is set."""

    def __init__(self):
        self._model_key = None
        self._model = None
        self.description = None

    def __call__(self, values):
        model = self.model(values)
        design = designed_gains(values)
        law = law_class(values['law'])
        scenario = values['scenario']
        q0 = scenarios.get(scenario).q0 if scenario else None
        motion = motion_gains(values, model, design, q0)
        law_params = {row.name: values[row.name] for row in law.all_param_rows()}
        law_params.update(motion_params(motion))
        if law.uses_force:
            law_params.update(force_task.gain_params(servo_gains(values, 'force_', len(values['force_axes']), design)))
        config = ControllerConfig(
            model=model, law=values['law'], integral=values['integral'],
            integral_limit=values['integral_limit'], integral_rest_velocity=values['integral_rest_velocity'],
            effort_limit=values['effort_limits'] or None,
            joints=values['joints'] or None, move_time=values['move_time'],
            trajectory_tolerance=tolerances(values, model, 'trajectory'), goal_tolerance=tolerances(values, model, 'goal'),
            goal_time=values['constraints.goal_time'],
            stopped_velocity_tolerance=values['constraints.stopped_velocity_tolerance'],
            law_params=law_params,
            friction_compensation=friction_compensation.values_of(values),
            velocity_cutoff_hz=values['velocity_filter.cutoff_hz'])
        q_d = values['q_d']
        if q_d and len(q_d) != model.n:
            raise ParameterError('q_d', f'expected empty or {model.n} values (one per joint), got {len(q_d)}')
        return config

    def model(self, values):
        """The model of `values` (the last one when its parameters did not change)."""
        params = {k[len(MODEL_PARAMS):]: v for k, v in values.items() if k.startswith(MODEL_PARAMS)}
        key = (values['model'], tuple(sorted(params.items())), values['urdf'], values['robot_description'],
               values['tip'], values['joints'], values['task_space'], values['payload.mass'],
               tuple(values['payload.com']), self.description)
        if key != self._model_key:
            self._model = self._make_model(values, params)
            self._model_key = key
        model = self._model
        if values['model'] == 'urdf' and values['task_space'] == 'pose' and len(model.tip_joints) < POSE_JOINTS:
            raise ParameterError('task_space', f'pose has {POSE_JOINTS} task axes: {len(model.tip_joints)} of the '
                                               f'joints {list(model.joint_names)} move the tip {model.tip} '
                                               f'({list(model.tip_joints)}), too few to hold a pose; set position, '
                                               'or auto (pose where 6 or more joints move the tip)')
        return model

    def _make_model(self, values, params):
        name = values['model']
        if name != 'urdf':
            try:
                return make_model(name, **params)
            except ArgumentError:
                raise
            except ValueError as exc:       # arguments that do not fit the class
                raise ParameterError('model', exc) from None
        source = values['robot_description'] or values['urdf'] or self.description
        if not source:
            raise ParameterError('urdf', "model 'urdf' needs urdf (file or shipped name), robot_description "
                                         '(XML text) or a URDF on the robot_description topic')
        try:
            payload = (values['payload.mass'], values['payload.com']) if values['payload.mass'] else None
            return make_model('urdf', urdf=source, joints=values['joints'] or None, tip=values['tip'] or None,
                              gravity=(0.0, 0.0, -params['gravity']), task_space=values['task_space'],
                              payload=payload)
        except ArgumentError as exc:
            if exc.name == 'urdf' and values['robot_description']:
                raise ParameterError('robot_description', exc.reason) from None
            raise
