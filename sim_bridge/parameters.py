"""The bridge node's parameters: one table (name, type, units, description, default) and one
validation function, free of rclpy so both can be tested and documented without DDS.

Defaults that depend on the scenario (joints, initial positions, surface, physical parameters)
are the scenario's own values, so `ros2 param get` shows what the simulator really uses.
Every failure is a ValueError whose message starts with the parameter name.

| name | type | units | default | runtime |
|---|---|---|---|---|
| scenario | string | - | polar_two_link ('' = custom URDF robot) | read-only |
| urdf | string | path | '' (the scenario's robot) | read-only |
| joints | string[] | - | the scenario's joints | read-only |
| initial_positions | double[] | rad or m | the scenario's q0 | read-only (used by reset) |
| mode | string | - | realtime (realtime or lockstep) | read-only |
| physics_step | double | s | 0.001 | read-only |
| control_period | double | s | 0.001 (integer multiple of physics_step) | read-only |
| clock_period | double | s (sim time) | 0.01 (0 = every control period) | read-only |
| real_time_factor | double | - | 1.0 | dynamic |
| command_timeout | double | s (sim time) | 0.05 | dynamic |
| lockstep_timeout | double | s (wall time) | 0.1 | dynamic |
| surface.enable | bool | - | true when the scenario has a surface | read-only |
| surface.k_e | double | N/m | the scenario's k_e | read-only |
| surface.x_e | double | m | the scenario's x_e | read-only |
| disturbance.joint_torque | double[] | N m or N per joint | zeros(n) | dynamic |
| disturbance.cartesian_force | double[] | N, world frame, at the tip | [0, 0, 0] | dynamic |
| sim_params.<p> | double | SI | the scenario's physical parameter p | read-only |
| sim_params.gravity | double | m/s^2 | 9.81 (URDF robots; closed forms list it when their model has it) | read-only |
| wrench_frame_id | string | - | world | read-only |
| diagnostics_period | double | s (wall time) | 1.0 | dynamic |
| gui | bool | - | false | read-only |

`sim_params.*` are the simulated robot's true physical parameters (one per parameter of the
scenario's closed-form model, e.g. m and gravity for polar_two_link): set them differently from
the controller's model to create a model-error payload (e.g. `sim_params.m: 2.5` on
polar_two_link while the controller keeps m = 2.0; the World regenerates the robot's URDF).
For URDF robots (iiwa) only gravity can be overridden; a payload is a modified URDF (`urdf`).
`disturbance.joint_torque` is added to the actuator torque: the lecture's load d (m xdd + ... + d = u)
is its negative.
"""
from dataclasses import dataclass

import numpy as np

from robot_control.validation import ArgumentError
from robot_control import scenarios, units, validation

MODES = ('realtime', 'lockstep')

#: parameters that may change while the node runs (all others are read-only)
DYNAMIC = ('real_time_factor', 'command_timeout', 'lockstep_timeout', 'disturbance.joint_torque',
           'disturbance.cartesian_force', 'diagnostics_period')


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: `kind` is bool, double, string, double_array or string_array."""

    name: str
    kind: str
    default: object
    description: str
    read_only: bool = True


def _scenario_or_none(name):
    return scenarios.SCENARIOS.get(name) if name else None


def robot_specs():
    """Phase 1: the parameters that choose the robot (everything else depends on them)."""
    return [
        ParamSpec('scenario', 'string', 'polar_two_link',
                  f'Lecture system to simulate, one of {sorted(scenarios.SCENARIOS)}; '
                  "'' for a custom URDF robot (then urdf and joints are required)."),
        ParamSpec('urdf', 'string', '',
                  "URDF of the simulated robot: a file path, a shipped name or a pybullet_data relative "
                  "path; '' = the scenario's robot."),
    ]


def joints_spec(scenario_name):
    sc = _scenario_or_none(scenario_name)
    return ParamSpec('joints', 'string_array', list(sc.joints) if sc else None,
                     'Joint names, in the order of every array parameter and of effort_controller/commands.')


def specs(scenario_name, n):
    """Phase 2: the remaining parameters, with defaults of scenario `scenario_name` (n joints)."""
    sc = _scenario_or_none(scenario_name)
    surf = sc.surface if sc else None
    out = [
        ParamSpec('initial_positions', 'double_array', [float(x) for x in sc.q0] if sc else [0.0] * n,
                  'Initial joint positions, rad or m, in joints order (also the state reset returns to).'),
        ParamSpec('mode', 'string', 'realtime',
                  'Pacing: realtime (physics follows the wall clock, latest command held, stale command '
                  '-> brakes) or lockstep (state at t_k, wait for the command stamped t_k, step).'),
        ParamSpec('physics_step', 'double', 0.001, 'Physics time step, s (whole nanoseconds).'),
        ParamSpec('control_period', 'double', 0.001,
                  'Control period, s: state published and command held for this long; an integer '
                  'multiple of physics_step.'),
        ParamSpec('clock_period', 'double', 0.01,
                  'Period of /clock, s of simulation time (0 = every control period); like gazebo_ros\'s '
                  'publish_rate, a 1 kHz /clock would wake every use_sim_time node 1000 times a second.'),
        ParamSpec('real_time_factor', 'double', 1.0,
                  'Realtime mode: simulated seconds per wall-clock second (> 0).', read_only=False),
        ParamSpec('command_timeout', 'double', 0.05,
                  'Realtime mode: a command older than this (s, simulation time) is stale and the brakes '
                  'engage; must exceed control_period.', read_only=False),
        ParamSpec('lockstep_timeout', 'double', 0.1,
                  'Lockstep mode: wall-clock time, s, after which the state is re-published when its '
                  'command has not come.', read_only=False),
        ParamSpec('surface.enable', 'bool', surf is not None,
                  "Build the scenario's elastic surface (wall or table)."),
        ParamSpec('surface.k_e', 'double', float(surf.k_e) if surf else 0.0,
                  'Surface stiffness k_e, N/m (f = k_e (x - x_e)).'),
        ParamSpec('surface.x_e', 'double', float(surf.x_e) if surf else 0.0,
                  'Surface location x_e along its normal task axis, m.'),
        ParamSpec('disturbance.joint_torque', 'double_array', [0.0] * n,
                  'Constant disturbance torque added at each joint, N m or N, in joints order.',
                  read_only=False),
        ParamSpec('disturbance.cartesian_force', 'double_array', [0.0, 0.0, 0.0],
                  'Constant disturbance force at the tip, N, world frame (x, y, z).', read_only=False),
    ]
    for key, value in sorted((sc.params if sc else {}).items()):
        out.append(ParamSpec(f'sim_params.{key}', 'double', float(value),
                             f'Simulated robot physical parameter {key!r} (SI); differ from the '
                             "controller's model for a model-error payload."))
    if sc is None or sc.model == 'urdf':
        out.append(ParamSpec('sim_params.gravity', 'double', units.GRAVITY,
                             'Gravitational acceleration of the simulated URDF robot, m/s^2 along world -z '
                             '(a heavier or lighter robot: point `urdf` at a modified URDF file).'))
    out += [
        ParamSpec('wrench_frame_id', 'string', 'world',
                  'frame_id of ft_sensor/wrench; the wrench is expressed in the world frame.'),
        ParamSpec('diagnostics_period', 'double', 1.0, 'Period of /diagnostics, s (wall time).',
                  read_only=False),
        ParamSpec('gui', 'bool', False, 'Open the PyBullet GUI (needs a display).'),
    ]
    return out


@dataclass(frozen=True)
class BridgeConfig:
    """A validated snapshot of the parameters: what the node's loop reads (never get_parameter)."""

    scenario: str
    urdf: str
    joints: tuple
    initial_positions: np.ndarray
    mode: str
    physics_step: float
    control_period: float
    physics_step_ns: int
    control_period_ns: int
    substeps: int
    clock_period_ns: int
    real_time_factor: float
    command_timeout: float
    command_timeout_ns: int
    lockstep_timeout: float
    surface_enable: bool
    k_e: float
    x_e: float
    disturbance_joint_torque: np.ndarray
    disturbance_cartesian_force: np.ndarray
    sim_params: dict
    wrench_frame_id: str
    diagnostics_period: float
    gui: bool

    @property
    def n(self):
        return len(self.joints)

    @property
    def lockstep(self):
        return self.mode == 'lockstep'


def _finite(name, value, *, positive=False, nonnegative=False):
    """validation.scalar for a parameter value, which must be a number (not a bool or a string)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentError(name, f'expected a number, got {value!r}')
    return validation.scalar(name, value, positive=positive, nonnegative=nonnegative)


def _array(name, value, n):
    try:
        a = np.array(list(value), dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(name, f'expected a list of numbers, got {value!r}') from None
    if a.size == 0:
        return np.zeros(n)
    if a.shape != (n,):
        raise ArgumentError(name, f'expected {n} values, got {a.size}')
    if not np.all(np.isfinite(a)):
        raise ArgumentError(name, f'expected finite values, got {a.tolist()}')
    return a


def _whole_ns(name, seconds):
    ns = units.to_ns(seconds)
    if ns < 1 or abs(seconds * units.NS_PER_S - ns) > 1e-3:
        raise ArgumentError(name, f'expected whole nanoseconds, got {seconds!r} s')
    return int(ns)


def check_scenario(value):
    """Phase-1 check of `scenario` (so an unknown one is reported before anything else)."""
    if not isinstance(value, str):
        raise ArgumentError('scenario', f'expected a string, got {value!r}')
    if value and value not in scenarios.SCENARIOS:
        raise ArgumentError('scenario', f'unknown {value!r}; expected one of {sorted(scenarios.SCENARIOS)} '
                         "or '' with urdf and joints")
    return value


def check_urdf(value, scenario):
    if not isinstance(value, str):
        raise ArgumentError('urdf', f'expected a string, got {value!r}')
    if not value:
        if not scenario:
            raise ArgumentError("urdf", "required when scenario is '' (a custom robot)")
        return ''
    from robot_control import urdf as urdf_files
    try:
        return urdf_files.resolve(value)
    except ValueError:
        raise ArgumentError('urdf', f'no such file {value!r} (nor shipped nor in pybullet_data)') from None


def check_joints(value):
    if value is None:
        raise ArgumentError("joints", "required when scenario is '' (a custom robot)")
    got = list(value)
    if not got:
        raise ArgumentError('joints', 'expected at least one joint name')
    if not all(isinstance(s, str) and s for s in got):
        raise ArgumentError('joints', f'expected non-empty strings, got {got}')
    if len(set(got)) != len(got):
        raise ArgumentError('joints', f'duplicate names in {got}')
    return tuple(got)


def validate(values):
    """BridgeConfig from a {name: value} mapping of every parameter, or ValueError naming one."""
    v = values
    scenario = check_scenario(v['scenario'])
    urdf = check_urdf(v['urdf'], scenario)
    joints = check_joints(v['joints'])
    sc = _scenario_or_none(scenario)
    if sc is not None and not urdf and set(joints) != set(sc.joints):
        raise ArgumentError('joints', f'scenario {scenario!r} has joints {list(sc.joints)}, got {list(joints)}')
    n = len(joints)
    if not len(v['initial_positions']):
        raise ArgumentError('initial_positions', f'expected {n} values, got 0')
    q0 = _array('initial_positions', v['initial_positions'], n)
    mode = v['mode']
    if mode not in MODES:
        raise ArgumentError('mode', f'expected one of {list(MODES)}, got {mode!r}')
    physics_step = _finite('physics_step', v['physics_step'], positive=True)
    if physics_step > 0.1:
        raise ArgumentError('physics_step', f'expected at most 0.1 s, got {physics_step}')
    physics_ns = _whole_ns('physics_step', physics_step)
    control_period = _finite('control_period', v['control_period'], positive=True)
    control_ns = _whole_ns('control_period', control_period)
    if control_ns % physics_ns:
        raise ArgumentError('control_period', f'expected an integer multiple of physics_step {physics_step} s, '
                         f'got {control_period} s')
    clock_period = _finite('clock_period', v['clock_period'], nonnegative=True)
    clock_ns = _whole_ns('clock_period', clock_period) if clock_period else 0
    rtf = _finite('real_time_factor', v['real_time_factor'], positive=True)
    timeout = _finite('command_timeout', v['command_timeout'], positive=True)
    if timeout <= control_period:
        raise ArgumentError('command_timeout', f'expected more than control_period {control_period} s, '
                         f'got {timeout} s')
    lockstep_timeout = _finite('lockstep_timeout', v['lockstep_timeout'], positive=True)
    surface_enable = v['surface.enable']
    if not isinstance(surface_enable, bool):
        raise ArgumentError('surface.enable', f'expected a bool, got {surface_enable!r}')
    k_e = _finite('surface.k_e', v['surface.k_e'], nonnegative=True)
    x_e = _finite('surface.x_e', v['surface.x_e'])
    if surface_enable:
        if sc is None or sc.surface is None:
            raise ArgumentError('surface.enable', f'scenario {scenario!r} has no surface')
        if not k_e > 0.0:
            raise ArgumentError('surface.k_e', f'expected a positive stiffness (N/m), got {k_e}')
    dist_tau = _array('disturbance.joint_torque', v['disturbance.joint_torque'], n)
    dist_f = _array('disturbance.cartesian_force', v['disturbance.cartesian_force'], 3)
    sim_params = {}
    for key, value in v.items():
        if key.startswith('sim_params.'):
            name = key[len('sim_params.'):]
            nonneg = name in ('gravity', 'b', 'k')
            sim_params[name] = _finite(key, value, positive=not nonneg, nonnegative=nonneg)
    frame = v['wrench_frame_id']
    if not isinstance(frame, str) or not frame:
        raise ArgumentError('wrench_frame_id', f'expected a non-empty frame name, got {frame!r}')
    diag = _finite('diagnostics_period', v['diagnostics_period'], positive=True)
    gui = v['gui']
    if not isinstance(gui, bool):
        raise ArgumentError('gui', f'expected a bool, got {gui!r}')
    return BridgeConfig(
        scenario=scenario, urdf=urdf, joints=joints, initial_positions=q0, mode=mode,
        physics_step=physics_step, control_period=control_period, physics_step_ns=physics_ns,
        control_period_ns=control_ns, substeps=control_ns // physics_ns, clock_period_ns=clock_ns, real_time_factor=rtf,
        command_timeout=timeout, command_timeout_ns=units.to_ns(timeout), lockstep_timeout=lockstep_timeout,
        surface_enable=surface_enable, k_e=k_e, x_e=x_e, disturbance_joint_torque=dist_tau,
        disturbance_cartesian_force=dist_f, sim_params=sim_params, wrench_frame_id=frame,
        diagnostics_period=diag, gui=gui)


def defaults(scenario_name='polar_two_link', **changes):
    """{name: value} of every parameter's default for a scenario, with `changes` applied
    (keys with dots written as in ROS, e.g. defaults(**{'surface.enable': False}))."""
    values = {s.name: s.default for s in robot_specs()}
    values['scenario'] = scenario_name
    values.update({k: v for k, v in changes.items() if k in ('urdf',)})
    values['joints'] = changes.get('joints', joints_spec(scenario_name).default)
    n = len(values['joints'] or ())
    values.update({s.name: s.default for s in specs(scenario_name, n)})
    values.update(changes)
    return values
