"""The bridge node's parameters: one table (robot_control.param_table: name, type, default,
description with units, rules, read-only) and build(), which turns checked values into the
BridgeConfig snapshot the node's loop reads; free of rclpy so both can be tested and documented
without DDS.

Stages: `scenario` and `urdf` choose the robot, `joints` defaults to the scenario's, and every
other default is the scenario's own value (joints, initial positions, surface, physical
parameters), so `ros2 param get` shows what the simulator really uses. Only real_time_factor,
command_timeout, lockstep_timeout, disturbance.*, friction.*, armature, pause_at and diagnostics_period may
change at run time. The sensor model's rows (noise.*, encoder_resolution, wrench_bias, delay.*, seed) are
sim_bridge.sensors', the joint friction's sim_bridge.joint_friction's.

`sim_params.*` are the simulated robot's true physical parameters (one per parameter of the
scenario's closed-form model, e.g. m and gravity for polar_two_link): set them differently from
the controller's model to create a model-error payload (e.g. `sim_params.m: 2.5` on
polar_two_link while the controller keeps m = 2.0; the World regenerates the robot's URDF).
For URDF robots (iiwa) gravity and the links (sim_params.mass_scale, inertia_scale, com_offset:
sim_bridge.true_robot) can be changed; `urdf` may also be another file than the controller's (e.g. with
a payload).
`disturbance.joint_torque` is added to the actuator torque: the lecture's load d (m xdd + ... + d = u)
is its negative.

Every failure is a ParameterError (an ArgumentError) whose .name is the parameter.
"""
from dataclasses import dataclass

import numpy as np

from robot_control import scenarios, units
from robot_control import urdf as urdf_files
from robot_control.models.closed_form import MAY_BE_ZERO, PARAMETER_UNITS
from robot_control.validation import ArgumentError
from sim_bridge.engines import ENGINES
from robot_control.param_table import (ParameterError, Row, Table, custom, gt, gt_eq, lt_eq, not_empty, one_of,
                                           size, unique)
from sim_bridge import joint_friction, sensors, true_robot

MODES = ('realtime', 'lockstep')
SIM_PARAMS = 'sim_params.'


def _scenario(name):
    return scenarios.SCENARIOS.get(name) if name else None


def _fixed(*args, **kwargs):
    """A row that cannot change at run time (most of the bridge's)."""
    return Row(*args, read_only=True, **kwargs)


def _check_urdf(value, values):
    if value:
        urdf_files.resolve(value)
    elif not values['scenario']:
        raise ArgumentError('urdf', "required when scenario is '' (a custom robot)")


def robot_rows(values):
    """Stage 1: the parameters that choose the robot (everything else depends on them)."""
    return [
        _fixed('scenario', 'string', 'polar_two_link',
               f'Lecture system to simulate, one of {sorted(scenarios.SCENARIOS)}; '
               "'' for a custom URDF robot (then urdf and joints are required).",
               [one_of([''] + sorted(scenarios.SCENARIOS))]),
        _fixed('urdf', 'string', '',
               'URDF of the simulated robot: a file path, a shipped name or a pybullet_data relative '
               "path; '' = the scenario's robot.",
               [custom("an existing URDF; required when scenario is ''", _check_urdf)]),
    ]


def joints_rows(values):
    """Stage 2: the joints (the scenario's by default, required for a custom robot)."""
    sc = _scenario(values['scenario'])
    return [_fixed('joints', 'string_array', sc.joints if sc else None,
                   'Joint names, in the order of every array parameter and of effort_controller/commands.',
                   [not_empty(), unique(), custom("the scenario's joints (any order) unless urdf is set")])]


def rows(values):
    """Stage 3: the remaining parameters, with the scenario's defaults."""
    sc = _scenario(values['scenario'])
    n = len(values['joints'] or ())
    surf = sc.surface if sc else None
    per_joint = size('joints', 'joint')
    out = [
        _fixed('initial_positions', 'double_array', sc.q0 if sc else (0.0,) * n,
               'Initial joint positions, rad or m, in joints order (also the state reset returns to).',
               [per_joint], aliases=('q0',)),
        _fixed('mode', 'string', 'realtime',
               'Pacing: realtime (physics follows the wall clock, latest command held, stale command '
               '-> brakes) or lockstep (state at t_k, wait for the command stamped t_k, step).', [one_of(MODES)]),
        _fixed('physics_step', 'double', 0.001, 'Physics time step, s (whole nanoseconds).',
               [gt(0), lt_eq(0.1), custom('whole nanoseconds')], aliases=('dt',)),
        _fixed('control_period', 'double', 0.001,
               'Control period, s: state published and command held for this long; an integer '
               'multiple of physics_step.', [gt(0), custom('an integer multiple of physics_step')]),
        _fixed('clock_period', 'double', 0.01,
               "Period of /clock, s of simulation time (0 = every control period); like gazebo_ros's "
               'publish_rate, a 1 kHz /clock would wake every use_sim_time node 1000 times a second.',
               [gt_eq(0), custom('whole nanoseconds')]),
        Row('real_time_factor', 'double', 1.0,
            'Realtime mode: simulated seconds per wall-clock second (> 0).', [gt(0)]),
        Row('command_timeout', 'double', 0.05,
            'Realtime mode: a command older than this (s, simulation time) is stale and the brakes '
            'engage; must exceed control_period.', [gt('control_period')]),
        Row('lockstep_timeout', 'double', 0.1,
            'Lockstep mode: wall-clock time, s, after which the state is re-published when its '
            'command has not come.', [gt(0)]),
        _fixed('surface.enable', 'bool', surf is not None, "Build the scenario's elastic surface (wall or table).",
               [custom('only where the scenario has a surface')], aliases=('surface',)),
        _fixed('surface.k_e', 'double', float(surf.k_e) if surf else 0.0,
               'Surface stiffness k_e, N/m (f = k_e (x - x_e)).', [gt_eq(0), custom('> 0 when enabled')]),
        _fixed('surface.x_e', 'double', float(surf.x_e) if surf else 0.0,
               'Surface location x_e along its normal task axis, m.'),
        Row('disturbance.joint_torque', 'double_array', (0.0,) * n,
            'Constant disturbance torque added at each joint, N m or N, in joints order.',
            [size('joints', 'joint', empty_ok=True)]),
        Row('disturbance.cartesian_force', 'double_array', (0.0, 0.0, 0.0),
            'Constant disturbance force at the tip, N, world frame (x, y, z).', [size(3, empty_ok=True)]),
        _fixed('payload.mass', 'double', 0.0, 'Mass carried by the tip of the simulated robot, kg (a solid sphere); '
               '0 = none. The controller may be told of it (its payload.mass) or not.', [gt_eq(0)]),
        _fixed('payload.com', 'double_array', (0.0, 0.0, 0.0), "The payload's centre of mass in the tip link's "
               'frame, m.', [size(3)]),
    ]
    out += joint_friction.rows(n)
    for key, value in sorted((sc.params if sc else {}).items()):
        out.append(_fixed(f'{SIM_PARAMS}{key}', 'double', float(value),
                          f'Simulated robot physical parameter {key!r}, {PARAMETER_UNITS[key]}; differ from the '
                          "controller's model for a model-error payload.",
                          [gt_eq(0) if key in MAY_BE_ZERO else gt(0)]))
    if sc is None or sc.model == 'urdf':
        out.append(_fixed(f'{SIM_PARAMS}gravity', 'double', units.GRAVITY,
                          'Gravitational acceleration of the simulated URDF robot, m/s^2 along world -z '
                          '(a heavier or lighter robot: sim_params.mass_scale, or `urdf` naming a modified URDF '
                          'file).', [gt_eq(0)]))
        out += true_robot.rows(n)
    out += [
        _fixed('wrench_frame_id', 'string', 'world',
               'frame_id of ft_sensor/wrench; the wrench is expressed in the world frame.', [not_empty()]),
        Row('diagnostics_period', 'double', 1.0, 'Period of /diagnostics, s (wall time).', [gt(0)]),
        Row('pause_at', 'double', -1.0,
            'Simulation time, s, at which the bridge pauses itself, as ~/pause true would: after the first tick '
            'at or past it (a time already past: the next tick). Negative: never. Each new value arms it once; '
            '~/pause false resumes. Run-time changes made while paused act from the tick it paused at.'),
        _fixed('gui', 'bool', False, 'Open the PyBullet GUI (needs a display).'),
        _fixed('engine', 'string', 'pybullet', f'Physics engine of the simulated robot, one of {list(ENGINES)}.',
               [one_of(list(ENGINES))]),
    ]
    return out


TABLE = Table('sim_bridge', robot_rows, joints_rows, rows, sensors.rows)


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
    friction: joint_friction.JointFriction
    payload: tuple
    wrench_frame_id: str
    diagnostics_period: float
    pause_at: float
    gui: bool
    sensors: sensors.SensorModel
    engine: str = 'pybullet'

    @property
    def n(self):
        return len(self.joints)

    @property
    def lockstep(self):
        return self.mode == 'lockstep'


def _whole_ns(name, seconds):
    ns = units.to_ns(seconds)
    if ns < 1 or abs(seconds * units.NS_PER_S - ns) > 1e-3:
        raise ParameterError(name, f'expected whole nanoseconds, got {seconds!r} s')
    return int(ns)


def _vector(value, n):
    """An array parameter as a float array; empty = zeros(n)."""
    return np.array(value, dtype=float) if value else np.zeros(n)


def build(values):
    """BridgeConfig from checked values (TABLE's rules hold), or ParameterError naming a parameter."""
    v = values
    scenario, joints = v['scenario'], v['joints']
    urdf = urdf_files.resolve(v['urdf']) if v['urdf'] else ''     # exists: the urdf row's rule
    sc = _scenario(scenario)
    if sc is not None and not urdf and set(joints) != set(sc.joints):
        raise ParameterError('joints', f'scenario {scenario!r} has joints {list(sc.joints)}, got {list(joints)}')
    n = len(joints)
    physics_ns = _whole_ns('physics_step', v['physics_step'])
    control_ns = _whole_ns('control_period', v['control_period'])
    if control_ns % physics_ns:
        raise ParameterError('control_period', f'expected an integer multiple of physics_step {v["physics_step"]} s, '
                                               f'got {v["control_period"]} s')
    clock_ns = _whole_ns('clock_period', v['clock_period']) if v['clock_period'] else 0
    if v['surface.enable']:
        if sc is None or sc.surface is None:
            raise ParameterError('surface.enable', f'scenario {scenario!r} has no surface')
        if not v['surface.k_e'] > 0.0:
            raise ParameterError('surface.k_e', f'expected a positive stiffness (N/m), got {v["surface.k_e"]}')
    for name in ('payload.mass', 'disturbance.cartesian_force'):
        if sc is None and np.any(v[name]):
            raise ParameterError(name, "needs a tip link to act at: a scenario's robot has one (parameter "
                                       "scenario); a custom URDF robot (scenario '') has none")
    friction = joint_friction.from_values(v, n)
    sim_params = {k[len(SIM_PARAMS):]: value for k, value in v.items() if k.startswith(SIM_PARAMS)}
    return BridgeConfig(
        scenario=scenario, urdf=urdf, joints=tuple(joints), initial_positions=np.array(v['initial_positions']),
        mode=v['mode'], physics_step=v['physics_step'], control_period=v['control_period'],
        physics_step_ns=physics_ns, control_period_ns=control_ns, substeps=control_ns // physics_ns,
        clock_period_ns=clock_ns, real_time_factor=v['real_time_factor'], command_timeout=v['command_timeout'],
        command_timeout_ns=units.to_ns(v['command_timeout']), lockstep_timeout=v['lockstep_timeout'],
        surface_enable=v['surface.enable'], k_e=v['surface.k_e'], x_e=v['surface.x_e'],
        disturbance_joint_torque=_vector(v['disturbance.joint_torque'], n),
        disturbance_cartesian_force=_vector(v['disturbance.cartesian_force'], 3), sim_params=sim_params,
        friction=friction,
        payload=(v['payload.mass'], tuple(v['payload.com'])) if v['payload.mass'] else None,
        wrench_frame_id=v['wrench_frame_id'], diagnostics_period=v['diagnostics_period'], pause_at=v['pause_at'],
        gui=v['gui'], sensors=sensors.model(v), engine=v['engine'])


def validate(values):
    """BridgeConfig from a {name: value} mapping (missing names: their defaults), or ParameterError."""
    return build(TABLE.validate(values))


def defaults(scenario_name='polar_two_link', **changes):
    """{name: value} of every parameter's default for a scenario, with `changes` applied
    (keys with dots written as in ROS, e.g. defaults(**{'surface.enable': False}))."""
    values = TABLE.defaults(**{**changes, 'scenario': scenario_name})
    values.update(changes)
    return values
