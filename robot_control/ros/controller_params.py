"""The controller node's parameter table (robot_control.param_table), free of rclpy.

Three stages: `scenario` (read-only) fills the defaults of everything else from
robot_control.scenarios (model, model_params.*, joints, urdf, tip, force_axes, k_e, x_e);
`model` (read-only) chooses the model_params.* rows; then every other parameter, among them each
registered law's rows (robot_control.laws.LAWS: Law.all_param_rows, the rows of the groups a law
shares with others, such as the force setup, listed once). Anything set explicitly wins over a
scenario default.

Model parameters use a flat dotted scheme that YAML nests naturally:
    model_params.m: 2.0          ->   model_params: {m: 2.0}
one double per argument of the closed-form model class (robot_control.models.closed_form),
e.g. polar_two_link: m (kg), gravity (m/s^2); for model 'urdf': gravity (m/s^2, along -z).
The values become a ControllerConfig in robot_control.ros.config_builder.
"""
import dataclasses
import functools
import inspect
import math

from robot_control import scenarios, units
from robot_control import urdf as urdf_files
from robot_control.core import velocity
from robot_control.laws import LAWS
from robot_control.laws import friction_compensation
from robot_control.models import CLOSED_FORM
from robot_control.models.closed_form import MAY_BE_ZERO, PARAMETER_UNITS
from robot_control.param_table import (ParameterError, Row, Table, custom, gt, gt_eq, one_of, size,  # noqa: F401
                                           subset_of, unique)

DEFAULT_MODEL = 'polar_two_link'


@functools.lru_cache(maxsize=None)
def scenario_defaults(name):
    """Defaults implied by scenario `name` ('' = none): {parameter or 'model_params': value}."""
    if not name:
        return {}
    sc = scenarios.get(name)
    task_axes = ('x', 'y', 'z') if sc.model == 'urdf' else CLOSED_FORM[sc.model].task_axes
    force_axes = tuple(task_axes[i] for i in sc.force_axes)
    out = {'model': sc.model, 'joints': tuple(sc.joints), 'urdf': sc.urdf, 'tip': sc.tip,
           'force_axes': force_axes, 'model_params': dict(sc.params)}
    if sc.model == 'urdf':      # the lecture's URDF scenarios are written in the tip's position
        out['task_space'] = 'position'

    if sc.surface is not None and force_axes:
        out['k_e'] = (sc.surface.k_e,) * len(force_axes)
        out['x_e'] = (sc.surface.x_e,) * len(force_axes)
    return out


def scenario_row():
    return Row('scenario', 'string', '',
               'scenario name filling the defaults of the model, joints and surface (robot_control.scenarios); '
               'empty = none', [one_of([''] + sorted(scenarios.SCENARIOS))], read_only=True)


def model_row(values):
    return Row('model', 'string', scenario_defaults(values['scenario']).get('model', DEFAULT_MODEL),
               "closed-form model name or 'urdf'", [one_of(sorted(CLOSED_FORM) + ['urdf'])], read_only=True)


def model_param_rows(model, defaults):
    """model_params.* of `model` (closed-form name or 'urdf'), defaults overridden by `defaults`;
    each row answers to its argument's name (the model's errors name the argument)."""
    if model == 'urdf':
        return [Row('model_params.gravity', 'double', float(defaults.get('gravity', units.GRAVITY)),
                    'gravitational acceleration along world -z, m/s^2', [gt_eq(0)], aliases=('gravity',))]
    rows = []
    for p in inspect.signature(CLOSED_FORM[model].__init__).parameters.values():
        if p.name == 'self':
            continue
        rows.append(Row(f'model_params.{p.name}', 'double', float(defaults.get(p.name, p.default)),
                        f'{model} model parameter {p.name}, {PARAMETER_UNITS[p.name]}',
                        [gt_eq(0) if p.name in MAY_BE_ZERO else gt(0)], aliases=(p.name,)))
    return rows


def _controller_urdf(value, values):
    """model 'urdf' reads urdf (unless robot_description holds the XML): it must exist."""
    if values['model'] == 'urdf' and value and not values['robot_description']:
        urdf_files.resolve(value)


def task_axes_rule(model):
    """force_axes among the model's task axes: known for a closed form; a URDF model with a tip has x, y, z
    (task_space position) or x, y, z, rx, ry, rz (pose)."""
    if model in CLOSED_FORM:
        return subset_of(CLOSED_FORM[model].task_axes, "the model's task axes")
    return custom('subset of the task axes (with a tip: x, y, z; task_space pose also rx, ry, rz)')


def rows(values):
    """Every parameter after scenario and model, with the scenario's (or the model's) defaults."""
    d = dict(scenario_defaults(values['scenario']))
    model = values['model']
    if 'joints' not in d and model in CLOSED_FORM:
        d['joints'] = CLOSED_FORM[model].joint_names
    get = d.get
    return (model_param_rows(model, d.get('model_params', {})) + robot_rows(get) + servo_rows() + law_rows(d, model)
            + motion_rows() + list(friction_compensation.PARAM_ROWS) + payload_id_rows() + node_rows())


def robot_rows(get):
    """The robot: joints, the URDF and its tip, the task space, a payload (defaults `get` from the scenario)."""
    return [
        Row('joints', 'string_array', get('joints', ()),
            "controlled joint names in model order, matched by name in joint_states; empty = the model's "
            '(a URDF model: all movable joints)', [unique(), custom('closed form: one per model joint')],
            read_only=True),
        Row('urdf', 'string', get('urdf', ''),
            "model 'urdf': URDF file path, shipped name (robot_control/urdf) or pybullet_data path",
            [custom("model 'urdf': an existing URDF", _controller_urdf)], read_only=True),
        Row('robot_description', 'string', '', "model 'urdf': URDF XML text (wins over urdf when non-empty)",
            read_only=True),
        Row('tip', 'string', get('tip', ''),
            "model 'urdf': task frame (link) for fk/J, needed by the task-space laws (force, hybrid, impedance)",
            read_only=True),
        Row('task_space', 'string', get('task_space', 'auto'),
            "model 'urdf': the tip's task space: position (x, y, z, m), pose (also rx, ry, rz: its orientation "
            'as a rotation vector, rad; errors on SO(3); needs 6 or more joints moving the tip) or auto (pose '
            'where 6 or more of the joints move the tip, else position)',
            [one_of(('auto', 'position', 'pose')), custom('pose: 6 or more joints moving the tip')],
            read_only=True),
        Row('payload.mass', 'double', 0.0, "model 'urdf': mass carried by the tip, kg; 0 = none (set by "
            '~/identify_payload)', [gt_eq(0)], aliases=('payload',)),
        Row('payload.com', 'double_array', (0.0, 0.0, 0.0), "model 'urdf': the payload's centre of mass in the "
            'tip frame, m (set by ~/identify_payload)', [size(3, 'coordinate')]),
    ]


def payload_id_rows():
    """~/identify_payload: the poses it visits and how it measures at each (robot_control.core.payload_id)."""
    prefix = 'payload_identification.'
    return [
        Row(prefix + 'poses', 'double_array', (), 'joint offsets from the pose at the call, rad, one per joint for '
            'each pose, flat; empty = that pose and +-0.6 rad on each of the last three joints'),
        Row(prefix + 'move_time', 'double', 1.5, 'duration of each move between poses, s', [gt(0)]),
        Row(prefix + 'settle_time', 'double', 0.3, 'wait after each move before sampling, s', [gt_eq(0)]),
        Row(prefix + 'settle_velocity', 'double', 0.05, 'at rest: every |qd| below this, rad/s', [gt(0)]),
        Row(prefix + 'sample_time', 'double', 0.3, 'time at rest over which the joint torques are averaged at '
            'each pose, s', [gt(0)]),
    ]


def servo_rows():
    """The law and the design of the servo gains from zeta, omega_res, omega_n (the motion servo's kp, kv, ki
    and the force servo's, when not explicit); the integral; limits."""
    return [
        Row('law', 'string', 'computed_torque', 'control law', [one_of(LAWS)]),
        Row('integral', 'bool', False, 'integral action (PID): ki used, integral state kept'),
        Row('zeta', 'double', 1.0, 'designed damping ratio, dimensionless',
            [gt(0), custom('>= 1 (no underdamping) unless allow_underdamped')]),
        Row('allow_underdamped', 'bool', False, 'allow a designed zeta < 1 (an underdamped, oscillating '
            'response, which the lecture rules out for safety)'),
        Row('omega_res', 'double', 12.0, 'lowest structural resonance, rad/s', [gt(0)]),
        Row('omega_n', 'double', 0.0, 'designed natural frequency, rad/s; 0 = 0.5 omega_res',
            [gt_eq(0), custom('<= 0.5 omega_res unless allow_resonance')]),
        Row('allow_resonance', 'bool', False, 'allow a designed omega_n > 0.5 omega_res (a servo fast enough '
            'to excite the structural resonance)'),
        Row('integral_limit', 'double', math.inf,
            'clamp of |integral of the error| per entry: rad s, m s (joints/motion) or N s (force); .inf = no clamp',
            [gt(0)], inf=True),
        Row('integral_rest_velocity', 'double', math.inf,
            'integrate an entry only while its error is at rest, |Ed| <= this: rad/s, m/s (joints/motion) or N/s '
            '(force); stops the integral hunting under friction (the integral only breaks a stuck joint free); '
            '.inf = always integrate', [gt(0)], inf=True),
        Row('velocity_filter.cutoff_hz', 'double', 0.0, 'cutoff f_c of the joint velocities estimated from the '
            'positions (first-order low-pass differentiator, Tustin), Hz; 0 = the joint_states velocities (a state '
            f'without velocities: estimated with f_c = {velocity.DEFAULT_CUTOFF_HZ:g} Hz)', [gt_eq(0)]),
        Row('effort_limits', 'double_array', (), "effort limit per joint, N m or N; empty = the model's "
            '(URDF <limit effort>, none for closed forms)', [custom('empty or one per joint'), gt(0)], inf=True),
    ]


def motion_rows():
    """The references: set-point moves, the force reference, trajectory goals and tolerances."""
    return [
        Row('q_d', 'double_array', (), 'joint set-point, rad or m; empty = hold the start position; '
            'a change starts a quintic move from the current reference over move_time',
            [custom('empty or one per joint')]),
        Row('move_time', 'double', 2.0, 'duration of a q_d move, s', [gt(0)]),
        Row('f_d', 'double_array', (), 'desired force per force axis (robot on environment), N; '
            'empty = 0; changes ramp over force_ramp_time', [size('force_axes', 'force axis', empty_ok=True)]),
        Row('allow_partial_joints_goal', 'bool', False,
            'a trajectory may name some of the joints; the others hold (joint_trajectory_controller)'),
        Row('constraints.goal_time', 'double', 0.0,
            'time a trajectory may take past its end to reach its goal tolerances, s; 0 = no limit', [gt_eq(0)]),
        Row('constraints.stopped_velocity_tolerance', 'double', 0.01,
            'largest joint speed of a reached goal, rad/s or m/s', [gt_eq(0)]),

    ]


#: rules of the laws' rows that depend on the model: parameter name -> rule of the model's name
MODEL_RULES = {'force_axes': task_axes_rule}


def law_rows(defaults, model):
    """Each registered law's parameters (Law.all_param_rows), each once, in the registry's order, with the
    scenario's `defaults` ({name: value}) and the rules that depend on the `model` (MODEL_RULES)."""
    rows = {}
    for law in LAWS.values():
        for row in law.all_param_rows():
            if row.name in rows:
                continue
            rule = MODEL_RULES.get(row.name)
            rows[row.name] = dataclasses.replace(row, default=defaults.get(row.name, row.default),
                                                 rules=row.rules + ((rule(model),) if rule else ()))
    return list(rows.values())


def node_rows():
    """The node: watchdog, outputs, lifecycle, and the gains in force it reports."""
    return [
        Row('state_timeout', 'double', 0.5, 'watchdog: no joint_states for this long stops commanding, s '
            '(node clock: sim time when use_sim_time)', [gt(0)]),
        Row('publish_effort_array', 'bool', False,
            'also publish effort_controller/commands (std_msgs/Float64MultiArray, joints order)'),
        Row('diagnostics_period', 'double', 0.5, 'period of /diagnostics, s (wall clock)', [gt(0)]),
        Row('wrench_wait', 'double', 0.005, 'longest wait of a state for the ft_sensor/wrench stamped like it '
            '(force laws, once the two streams are paired), s (wall clock); 0 = until it comes (lockstep: the '
            'simulator publishes a tick\'s wrench before its state and waits for the command)', [gt_eq(0)],
            read_only=True),
        Row('autostart', 'bool', True,
            'configure and activate at start-up (false: wait for lifecycle transitions, e.g. ros2 lifecycle set)',
            read_only=True),
        *gains_rows(),
    ]


#: the gains in force, reported by the node (designed or explicit), per servo
GAINS = (('kp', '1/s^2 (N m/rad for independent_joint)'), ('kv', '1/s (N m s/rad)'), ('ki', '1/s^3 (N m/(rad s))'))


def gains_rows():
    """gains.kp, kv, ki (the motion servo: per joint, or per task / motion axis for hybrid) and gains.force_kp,
    kv, ki (per force axis): what the controller computes with, written by it after every change."""
    rows = []
    for gain, unit in GAINS:
        rows.append(Row(f'gains.{gain}', 'double_array', (), f'in force: the motion servo\'s {gain} per joint (hybrid: '
                        f'per task or motion axis), {unit}; follows every change of {gain}, zeta, omega_res, omega_n',
                        reported=True))
    for gain, unit in GAINS:
        rows.append(Row(f'gains.force_{gain}', 'double_array', (), f'in force: the force servo\'s {gain} per force '
                        f'axis, {unit.split(" ")[0]}; follows every change of force_{gain}, zeta, omega_res, omega_n',
                        reported=True))
    return rows


def gains_in_force(config):
    """{gains.*: tuple} of a ControllerConfig, for the reported rows."""
    out = {}
    law = config.control_law
    for prefix, gains in (('gains.', law.motion_gains), ('gains.force_', law.force_task.gains)):
        for gain, _ in GAINS:
            out[f'{prefix}{gain}'] = () if gains is None else tuple(getattr(gains, gain).tolist())
    return out


def constraint_rows(values):
    """constraints.<joint>.trajectory and .goal per controlled joint (joint_trajectory_controller's names);
    a URDF model without an explicit joints list has none (its joints are known only once it is built)."""
    joints = values['joints'] or (CLOSED_FORM[values['model']].joint_names if values['model'] in CLOSED_FORM else ())
    out = []
    for joint in joints:
        out += [Row(f'constraints.{joint}.trajectory', 'double', 0.0,
                    f'path tolerance of {joint}: largest |q_d - q| while a trajectory runs, rad or m; 0 = not '
                    'checked (a violation holds the position and reports ERROR)', [gt_eq(0)]),
                Row(f'constraints.{joint}.goal', 'double', 0.0,
                    f'goal tolerance of {joint}: largest |q_d - q| at the end of a trajectory, rad or m; '
                    '0 = not checked', [gt_eq(0)])]
    return out


TABLE = Table('controller', lambda values: [scenario_row()], lambda values: [model_row(values)], rows,
              constraint_rows)
