"""The demo's experiments: for each scenario a sensible one, and the lecture's experiments
(disturbance rejection, model error, computed torque vs independent joint, ...).

An Experiment is data: which scenario (config/<scenario>.yaml), parameter overrides for the two
nodes, the references the demo publishes, the run length and the windows the metrics use.
All times are simulation seconds after the run's origin (the first control tick in lockstep).

References reach the controller as ROS messages:
- `trajectory`: one trajectory_msgs/JointTrajectory on /controller/joint_trajectory whose
  header.stamp is origin + t_start (the controller starts it exactly then, so lockstep runs are
  repeatable). A step is a one-point trajectory reaching its goal in one control period: the
  controller samples it only at the ticks, so it sees the goal at rest one period later.
- `force`: the initial force reference, the controller parameter f_d with force_ramp_time.
- `force_events`: later force references, geometry_msgs/WrenchStamped on
  /controller/wrench_reference stamped with their time and sent ahead of it while the bridge
  stands still (the first before the run starts, a later one at a pause between the one before
  it and its time): the controller applies each at exactly that tick.
- `bridge_events`: changes of the bridge's run-time parameters (e.g. disturbance.cartesian_force,
  a push on the tip) at simulation times: the bridge pauses itself at t (its pause_at), the demo
  sets the parameters and resumes it. The change acts from the tick the bridge paused at, the
  first at or past t, which the run records (RunData.events, summary `bridge_events`).
"""
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robot_control import scenarios
from robot_control.models import CLOSED_FORM
from robot_control.models.base import TASK_SPACES

#: position unit of each joint of each scenario ('rad' revolute, 'm' prismatic)
JOINT_UNITS = {
    'mass_spring_cubic': ('m',),
    'single_link': ('rad',),
    'polar_two_link': ('rad', 'm'),
    'planar_two_link': ('rad', 'rad'),
    'force_1dof': ('m',),
    'hybrid_cartesian_xy': ('m', 'm'),
    'hybrid_cartesian_xyz': ('m', 'm', 'm'),
    'iiwa': ('rad',) * 7,
    'panda': ('rad',) * 7,
    'ur5': ('rad',) * 6,
}

CONTROL_PERIOD = 0.001   # s, the configs' control_period: a step reaches its goal in one period


class Integer(int):
    """The value of an integer parameter (e.g. delay.measurement_ticks): a plain number is given as a double."""


@dataclass(frozen=True)
class TrajectorySpec:
    """A JointTrajectory in the scenario's joint order: points at t_start + times (s)."""

    t_start: float
    times: tuple                      # time_from_start of each point, s, > 0, increasing
    positions: tuple                  # (k, n)
    velocities: tuple = None          # (k, n) or None
    accelerations: tuple = None       # (k, n) or None

    @property
    def t_end(self):
        return self.t_start + self.times[-1]


@dataclass(frozen=True)
class Experiment:
    name: str
    scenario: str
    title: str
    duration: float                           # s of simulation after the origin (default run length)
    law: str = 'computed_torque'
    controller: dict = field(default_factory=dict)   # controller parameter overrides
    bridge: dict = field(default_factory=dict)       # sim_bridge parameter overrides
    trajectory: TrajectorySpec = None
    force: tuple = None                       # initial f_d per force axis, N (controller parameter)
    force_events: tuple = ()                  # ((t, (f per force axis)), ...) wrench references
    bridge_events: tuple = ()                 # ((t, {bridge parameter: value}), ...) set at run time
    service_calls: tuple = ()                 # ((t, std_srvs/Trigger service, the controller's log text when
                                              # its work starts, (controller parameter, ...)), ...): called at
                                              # t, the bridge running from that text until it answers, then
                                              # those parameters of the controller read (demo.Schedule)
    settle_from: float = 0.0                  # s: start of the change the settling time refers to
    force_window: object = 0.0                # s: force metrics use t >= force_window ("after settling"),
                                              # or ((t0, t1), ...): the union of these intervals
    steady_window: float = 0.25               # s: the final window of the steady-state error
    response_axis: str = None                 # task axis of the response to a push (bridge_events: on, off)
    figures: tuple = ()                       # names of the experiment's own figures (demo_metrics.FIGURES)
    notes: str = ''

    @property
    def joints(self):
        return scenarios.get(self.scenario).joints

    @property
    def units(self):
        return JOINT_UNITS[self.scenario]

    @property
    def task_axes(self):
        """The task axes of the controller's model: a closed form's own; a URDF model's by its task_space."""
        sc = scenarios.get(self.scenario)
        if sc.model != 'urdf':
            return CLOSED_FORM[sc.model].task_axes
        return TASK_SPACES[self.controller.get('task_space', 'position')]

    def with_duration(self, duration):
        import dataclasses
        return dataclasses.replace(self, duration=float(duration))


# -- reference builders ------------------------------------------------------------------------
def step(q_goal, t_start, back_to=None, t_back=None):
    """A step to q_goal at t_start (reached one control period later), optionally back at t_back."""
    dt = CONTROL_PERIOD
    times, pos = [dt], [tuple(q_goal)]
    if back_to is not None:
        times += [t_back - t_start, t_back - t_start + dt]
        pos += [tuple(q_goal), tuple(back_to)]
    zeros = tuple(tuple(0.0 for _ in q_goal) for _ in times)
    return TrajectorySpec(t_start, tuple(times), tuple(pos), zeros, zeros)


def sampled(fn, t_start, t_end, dt=0.02):
    """Points every dt of fn(tau) -> (q, qd, qdd) for tau = t - t_start in (0, t_end - t_start]."""
    k = int(round((t_end - t_start) / dt))
    taus = [dt * (i + 1) for i in range(k)]
    pts = [fn(tau) for tau in taus]
    return TrajectorySpec(t_start, tuple(taus), tuple(tuple(map(float, p[0])) for p in pts),
                          tuple(tuple(map(float, p[1])) for p in pts),
                          tuple(tuple(map(float, p[2])) for p in pts))


def raised_cosine(q_start, amplitude, freq):
    """tau -> q_start + amplitude (1 - cos(2 pi freq tau)) / 2 ... starts at rest (zero velocity)."""
    q0, a = np.asarray(q_start, float), np.asarray(amplitude, float)
    w = 2.0 * math.pi * freq

    def fn(tau):
        return (q0 + 0.5 * a * (1.0 - math.cos(w * tau)), 0.5 * a * w * math.sin(w * tau),
                0.5 * a * w * w * math.cos(w * tau))
    return fn


# -- URDF arms: joint positions for Cartesian targets on the table ------------------------------------
def quintic(s):
    """The rest-to-rest timing 10 s^3 - 15 s^4 + 6 s^5 of s in [0, 1] (zero speed and acceleration at both ends)."""
    return 10 * s**3 - 15 * s**4 + 6 * s**5


@dataclass(frozen=True)
class TableLine:
    """A line an arm draws on its scenario's table: `length` m along +y from (x, y) = `start` at the table
    top (the scenario surface's x_e, m), the redundancy resolved toward `posture` (rad)."""

    scenario: str
    posture: tuple
    start: tuple
    length: float

    @property
    def z(self):
        return scenarios.get(self.scenario).surface.x_e

    def model(self, task_space='position'):
        """The controller's model of the arm, task space 'position' (x, y, z) or 'pose' (also rx, ry, rz)."""
        from robot_control import models
        return models.for_scenario(scenarios.get(self.scenario), task_space=task_space)

    def start_positions(self, model=None):
        """Joint positions with the tip at the start of the line."""
        model = model or self.model()
        return tuple(float(v) for v in arm_ik(model, (*self.start, self.z), self.posture))

    def trajectory(self, t_start, T, dt=0.05, model=None):
        """A JointTrajectory drawing the line in T s (quintic timing), every point an IK solution."""
        model = model or self.model()
        x0, y0 = self.start
        k = int(round(T / dt))
        taus = np.array([dt * (i + 1) for i in range(k)])
        s = taus / T
        y = y0 + self.length * quintic(s)
        q = arm_ik(model, (x0, y0, self.z), self.posture)
        pos = []
        for yi in y:
            q = arm_ik(model, (x0, yi, self.z), q, self.posture)
            pos.append(q.copy())
        return TrajectorySpec(t_start, tuple(float(t) for t in taus), tuple(tuple(map(float, p)) for p in pos))


def arm_ik(model, p, q_init, q_posture=None, tol=1e-12, iters=200):
    """Joint positions (n,) putting the tip at p, a task position of `model` ((3,) m, or with the pose task
    space (6,): m and the rotation vector, rad): damped least squares on the task difference with a
    null-space pull toward q_posture (default q_init; the redundancy resolution the task laws' posture term
    also uses)."""
    q = np.array(q_init, dtype=float)
    q_nom = np.array(q_init if q_posture is None else q_posture, dtype=float)
    p = np.asarray(p, dtype=float)
    eye = np.eye(model.n)
    for _ in range(iters):
        err = model.task_difference(p, model.fk(q))
        if np.linalg.norm(err) < tol:
            break
        J = model.J(q)
        Jp = J.T @ np.linalg.inv(J @ J.T + 1e-10 * np.eye(J.shape[0]))
        q = q + Jp @ err + (eye - Jp @ J) @ (0.5 * (q_nom - q))
    if np.linalg.norm(model.task_difference(p, model.fk(q))) > 1e-9:
        raise ValueError(f'p: no joint solution found for tip position {p.tolist()}')
    return q


#: the iiwa: tool (link 7) pointing straight down, a 10 cm line from (0.55, -0.05) m
IIWA_LINE = TableLine('iiwa', (0.0, 0.7, 0.0, -1.6, 0.0, 0.68, 0.0), (0.55, -0.05), 0.10)
#: the Panda: hand pointing straight down, a 10 cm line from (0.5, -0.05) m
PANDA_LINE = TableLine('panda', (0.0, 0.35, 0.0, -2.45, 0.0, 2.8, 0.785), (0.5, -0.05), 0.10)
#: rad, the iiwa's start posture of the free-space experiments (the line's posture)
IIWA_POSTURE = IIWA_LINE.posture


def iiwa_motion(path, t_start, T, dt, model, derivatives=True):
    """A JointTrajectory following the task path p(s), s in [0, 1] over T s (`path` maps s to a task position
    of `model`), a point every dt, each an IK solution from the one before (the first from IIWA_POSTURE).
    derivatives: velocities and accelerations by central differences of the joint positions (consistent
    with them); False: positions only."""
    k = int(round(T / dt))
    taus = np.array([dt * i for i in range(k + 1)])
    q = arm_ik(model, path(0.0), IIWA_POSTURE)
    pos = [q.copy()]
    for tau in taus[1:]:
        q = arm_ik(model, path(tau / T), q, IIWA_POSTURE)
        pos.append(q.copy())
    pos = np.array(pos)
    rows = (lambda a: tuple(tuple(map(float, r)) for r in a[1:]))
    if not derivatives:
        return TrajectorySpec(t_start, tuple(float(t) for t in taus[1:]), rows(pos))
    vel = np.gradient(pos, dt, axis=0, edge_order=2)
    acc = np.gradient(vel, dt, axis=0, edge_order=2)
    return TrajectorySpec(t_start, tuple(float(t) for t in taus[1:]), rows(pos), rows(vel), rows(acc))


#: the rotation vector of the tool (link 7) pointing straight down, its x axis along world -x: R = Ry(pi), rad
IIWA_DOWN = (0.0, math.pi, 0.0)


def iiwa_start_pose(z, orientation=IIWA_DOWN):
    """Joint positions with the tip at the start of the line, height z (m), the tool at `orientation` (rad)."""
    return tuple(float(v) for v in arm_ik(IIWA_LINE.model('pose'), (*IIWA_LINE.start, z, *orientation), IIWA_POSTURE))


def iiwa_vertical_line(t_start, T, z, dt=0.01):
    """IIWA_LINE at height z in the pose task space: the tool held at IIWA_DOWN (velocities and accelerations included)."""
    x0, y0 = IIWA_LINE.start
    return iiwa_motion(lambda s: (x0, y0 + IIWA_LINE.length * quintic(s), z, *IIWA_DOWN), t_start, T, dt,
                       IIWA_LINE.model('pose'))


IIWA_CIRCLE = 0.05                       # m, radius of the circle of pose_tracking (10 cm across)
IIWA_WRIST = math.radians(20.0)          # rad, largest wrist rotation of pose_tracking


def iiwa_circle(t_start, T, dt=0.01):
    """One turn of a horizontal circle of radius IIWA_CIRCLE from the tip's pose at IIWA_POSTURE (quintic
    timing over T s), the tool turning about world z by IIWA_WRIST (1 - cos phi) / 2 (out to 20 degrees
    and back), as a JointTrajectory of the pose task space."""
    import pinocchio as pin
    model = IIWA_LINE.model('pose')
    x0 = model.fk(np.array(IIWA_POSTURE))
    centre = x0[:3] - (IIWA_CIRCLE, 0.0, 0.0)
    R0 = pin.exp3(x0[3:])

    def path(s):
        phi = 2.0 * math.pi * quintic(s)
        wrist = 0.5 * IIWA_WRIST * (1.0 - math.cos(phi))
        p = centre + IIWA_CIRCLE * np.array([math.cos(phi), math.sin(phi), 0.0])
        return np.concatenate([p, pin.log3(pin.exp3(np.array([0.0, 0.0, wrist])) @ R0)])
    return iiwa_motion(path, t_start, T, dt, model)


# -- the experiments -------------------------------------------------------------------------------
def _polar_step():
    q0 = scenarios.get('polar_two_link').q0
    goal = (0.5, 0.7)
    return Experiment(
        'polar_step', 'polar_two_link',
        'lecture example: PD computed torque, m = 2 kg, kp = 36, kv = 12; step from rest',
        duration=4.0, trajectory=step(goal, 0.5, back_to=q0, t_back=2.5), settle_from=2.5,
        notes='error must follow e(t) = e0 (1 + 6 t) exp(-6 t)')


def _planar(name, law, what):
    q0 = np.array(scenarios.get('planar_two_link').q0)
    traj = sampled(raised_cosine(q0, (1.2, -1.0), 1.0), 0.2, 2.2)
    return Experiment(name, 'planar_two_link', f'fast path (1 Hz, 1.2 / 1.0 rad, up to 3.8 rad/s): {what}',
                      duration=2.5, law=law, controller={'law': law}, trajectory=traj, settle_from=2.2)


def _single_link_step():
    return Experiment('single_link_step', 'single_link', 'PD computed torque, step 0 -> 0.8 rad against gravity',
                      duration=3.0, trajectory=step((0.8,), 0.5), settle_from=0.5)


def _mass_spring_sine():
    fn = raised_cosine((0.0,), (0.4,), 0.5)
    return Experiment('mass_spring_sine', 'mass_spring_cubic',
                      'partitioned law alpha = m, beta = b xd + k x^3; x_d = 0.2 (1 - cos(pi t)) m',
                      duration=4.0, trajectory=sampled(fn, 0.2, 4.2), settle_from=None)


D_DISTURBANCE = 2.0   # N, the lecture's d (m xdd + b xd + k x^3 + d = u)


def _disturbance(integral):
    name = 'disturbance_pid' if integral else 'disturbance_pd'
    law = 'PID' if integral else 'PD'
    return Experiment(
        name, 'mass_spring_cubic',
        f'constant disturbance d = {D_DISTURBANCE:g} N, {law} partitioned law, holding x_d = 0',
        duration=3.0, controller={'integral': integral},
        bridge={'disturbance.joint_torque': [-D_DISTURBANCE]}, settle_from=0.0,
        notes='PD: e_ss = d / (m kp); PID: e_ss -> 0')


MODEL_ERROR = 1.2     # simulated mass / the controller's


def _model_error(integral):
    name = 'model_error_pid' if integral else 'model_error_pd'
    law = 'PID' if integral else 'PD'
    m = scenarios.get('polar_two_link').params['m']
    return Experiment(
        name, 'polar_two_link',
        f'model error: robot m = {m * MODEL_ERROR:g} kg, controller m = {m:g} kg; {law} computed torque, holding',
        duration=3.0, controller={'integral': integral},
        bridge={'sim_params.m': m * MODEL_ERROR, 'initial_positions': [0.5, 0.5]}, settle_from=0.0)


def _force_steps():
    return Experiment(
        'force_steps', 'force_1dof', 'force servo, k_e = 1000 N/m: steps 0 -> 10 -> 5 -> 15 N from contact at rest',
        duration=6.0, law='force', controller={'force_ramp_time': 0.0}, bridge={'initial_positions': [0.1]},
        force=(10.0,), force_events=((2.0, (5.0,)), (4.0, (15.0,))), settle_from=0.0,
        # the last 0.5 s before each next step; the steps are stamped, so they land exactly on their tick
        force_window=((1.5, 1.999), (3.5, 3.999), (5.5, 6.0)),
        notes='force error must follow e_f(t) = f_d (1 + 6 t) exp(-6 t)')


def _hybrid_xy():
    fn = raised_cosine((0.3, 0.0), (0.0, 0.1), 0.5)
    return Experiment(
        'hybrid_xy_wall', 'hybrid_cartesian_xy',
        'hybrid: 10 N on the wall along x (approach from 1 cm), y follows 0.05 (1 - cos(pi t)) m',
        duration=5.0, law='hybrid', controller={'law': 'hybrid'}, force=(10.0,),
        trajectory=sampled(fn, 0.5, 5.0), settle_from=None, force_window=2.0)


def _hybrid_xyz():
    r = 0.05
    w = 2.0 * math.pi * 0.5
    ramp = 0.5

    def fn(tau):
        # circle in the x-z plane; the angular rate ramps up 0 -> w over `ramp` s (quintic smoothstep)
        if tau < ramp:
            s = tau / ramp
            th = w * ramp * (2.5 * s**4 - 3.0 * s**5 + s**6)
            thd = w * quintic(s)
            thdd = w * (30 * s**2 - 60 * s**3 + 30 * s**4) / ramp
        else:
            th = w * ramp * 0.5 + w * (tau - ramp)
            thd, thdd = w, 0.0
        x, z = r * math.sin(th), r * (1.0 - math.cos(th))
        xd, zd = r * math.cos(th) * thd, r * math.sin(th) * thd
        xdd = -r * math.sin(th) * thd**2 + r * math.cos(th) * thdd
        zdd = r * math.cos(th) * thd**2 + r * math.sin(th) * thdd
        return (x, 0.3, z), (xd, 0.0, zd), (xdd, 0.0, zdd)
    return Experiment(
        'hybrid_xyz_circle', 'hybrid_cartesian_xyz',
        'hybrid: 10 N on the surface along y, x-z draw a 5 cm circle at 0.5 Hz',
        duration=5.0, law='hybrid', controller={'law': 'hybrid'}, force=(10.0,),
        trajectory=sampled(fn, 0.5, 5.0), settle_from=None, force_window=2.0)


def _ptp(name, scenario, title, q_start, offset, bridge=None, duration=3.0):
    """Joint-space PD computed torque from rest at q_start to q_start + offset (rad): a quintic in 2 s from 0.2 s,
    held until `duration` s."""
    goal = np.asarray(q_start, dtype=float) + np.asarray(offset, dtype=float)
    traj = TrajectorySpec(0.2, (2.0,), (tuple(map(float, goal)),))
    return Experiment(name, scenario, f'{title}, joint-space PD computed torque (Pinocchio model): quintic '
                                      'point-to-point in 2 s', duration=duration,
                      bridge={'initial_positions': [float(v) for v in q_start], **(bridge or {})},
                      trajectory=traj, settle_from=0.2)


def _hybrid_line(name, line, title):
    """Operational-space hybrid control: 10 N down on the table from rest at the line's start, drawing it in 2 s
    from 1.0 s."""
    model = line.model()
    return Experiment(
        name, line.scenario, f'{title}, operational-space hybrid control: 10 N down on the table, drawing a '
                             f'{line.length * 100:g} cm line in 2 s',
        duration=3.5, law='hybrid', controller={'law': 'hybrid'},
        bridge={'initial_positions': list(line.start_positions(model))}, force=(-10.0,),
        trajectory=line.trajectory(1.0, 2.0, model=model), settle_from=None, force_window=1.2)


PUSH = 10.0                                             # N, the push of impedance_push (along -z)
IMPEDANCE = {'law': 'impedance', 'task_space': 'pose', 'cartesian_stiffness': [1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0]}
FREE_IIWA = {'initial_positions': list(IIWA_POSTURE), 'surface.enable': False}
PAYLOAD = {'payload.mass': 2.0, 'payload.com': [0.0, 0.0, 0.05]}   # kg, m in the tip frame


def _impedance_push():
    push = {'disturbance.cartesian_force': [0.0, 0.0, -PUSH]}
    release = {'disturbance.cartesian_force': [0.0, 0.0, 0.0]}
    return Experiment(
        'impedance_push', 'iiwa',
        f'KUKA iiwa, Cartesian impedance K = 1000 N/m, 100 N m/rad holding its start pose: a {PUSH:g} N push along -z '
        'on the tip from 0.5 s to 2 s',
        duration=3.5, law='impedance', controller=dict(IMPEDANCE), bridge=dict(FREE_IIWA),
        bridge_events=((0.5, push), (2.0, release)), settle_from=None, response_axis='z', figures=('push',),
        notes='deflection K^-1 F = 10 mm along -z, the other axes still; back without overshoot')


def _pose_tracking():
    return Experiment(
        'pose_tracking', 'iiwa',
        'KUKA iiwa, Cartesian impedance (K = 1000 N/m, 100 N m/rad) tracking a 10 cm circle (radius 5 cm) in 3 s '
        'while the wrist turns 20 degrees and back',
        duration=3.8, law='impedance', controller=dict(IMPEDANCE), bridge=dict(FREE_IIWA),
        trajectory=iiwa_circle(0.3, 3.0), settle_from=None, figures=('pose',))


def _payload(known):
    name = 'payload_compensated' if known else 'payload_unmodelled'
    told = 'configured in the controller' if known else 'unknown to the controller'
    return Experiment(
        name, 'iiwa', f'KUKA iiwa, gravity compensation holding 2 kg 5 cm out on the tip, the payload {told}',
        duration=3.0, law='gravity_compensation',
        controller={'law': 'gravity_compensation', **(PAYLOAD if known else {})}, bridge={**FREE_IIWA, **PAYLOAD},
        settle_from=None, figures=('drift',))


def _iiwa_hybrid_vertical():
    return Experiment(
        'iiwa_hybrid_vertical', 'iiwa',
        'KUKA iiwa, hybrid control in the pose task space: 10 N down on the table, drawing a 10 cm line in 2 s '
        'with the tool held vertical',
        duration=3.5, law='hybrid', controller={'law': 'hybrid', 'task_space': 'pose'},
        bridge={'initial_positions': list(iiwa_start_pose(IIWA_LINE.z))}, force=(-10.0,),
        trajectory=iiwa_vertical_line(1.0, 2.0, IIWA_LINE.z), settle_from=None, force_window=1.2, figures=('orientation',))


GAP_MOVE = 0.5   # rad, every joint's move in the iiwa_gap experiments
#: the iiwa_gap experiments' effects, each alone: (what the true robot has that the model does not, bridge overrides)
GAP_EFFECTS = {
    'friction': ('joint friction: Coulomb 1.0 N m joints 1-4, 0.5 N m joints 5-7, viscous 0.5 N m s/rad',
                 {'friction.coulomb': [1.0] * 4 + [0.5] * 3, 'friction.viscous': [0.5] * 7}),
    'payload': ('an unmodelled 2 kg payload 5 cm out on the flange', dict(PAYLOAD)),
    'masses': ('every link 10 % heavier than the model', {'sim_params.mass_scale': [1.1] * 7}),
    'late': ('the state one tick late', {'delay.measurement_ticks': Integer(1)}),
    'noise': ('position noise 1e-4 rad, velocity noise 5e-3 rad/s',
              {'noise.position_std': [1e-4] * 7, 'noise.velocity_std': [5e-3] * 7, 'seed': Integer(1)}),
}
#: the iiwa_gap variants in the table's order: the twin, each effect alone, all together
GAP_VARIANTS = ('twin', *GAP_EFFECTS, 'all')


def _gap(variant):
    """The model-reality gap on the iiwa: a GAP_MOVE rad quintic move of every joint in 2 s, then a 1 s hold, with
    computed torque (the scenario's gains), the true robot having `variant`'s effect (none: 'twin'; 'all': every
    one)."""
    if variant == 'twin':
        what, bridge = "nothing: the model's twin", {}
    elif variant == 'all':
        what, bridge = 'every effect together', {k: v for _, params in GAP_EFFECTS.values() for k, v in params.items()}
    else:
        what, bridge = GAP_EFFECTS[variant]
    return _ptp(f'iiwa_gap_{variant}', 'iiwa', f'KUKA iiwa, {GAP_MOVE:g} rad on every joint, the true robot with '
                                               f'{what}',
                IIWA_POSTURE, (GAP_MOVE,) * 7, bridge={'surface.enable': False, **bridge}, duration=3.2)


REAL_ARMS = ('iiwa', 'panda')
REAL_NAMES = {'iiwa': 'KUKA iiwa', 'panda': 'Franka Panda (fingers held)'}
REAL_MOVE = 0.5            # rad, every joint's move in the real-arm experiments, in REAL_MOVE_TIME s from 0.2 s
REAL_MOVE_TIME = 2.0
#: joint_impedance's stiffness on each real arm, N m/rad: Franka's joint impedance example on both (the iiwa's
#: proximal joints carry more: 1000 N m/rad, within KUKA FRI's joint impedance range of up to 5000)
REAL_STIFFNESS = {'iiwa': (1000.0, 1000.0, 600.0, 600.0, 250.0, 150.0, 50.0),
                  'panda': (600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0)}
REAL_FRICTION_ERROR = 0.7  # the friction estimate 30 % off: the profile's values times this
REAL_HOLD = 30.0           # s of the hold experiment
REAL_REPETITIONS = 3       # out-and-back moves of the adaptive experiment
IDENTIFY_AT = 2.7          # s: the identify experiment calls ~/identify_payload, holding the move's goal since 2.2 s
IDENTIFY_MOVE_TIME = 1.0   # s: payload_identification.move_time of the identify experiment (7 poses, 8 moves)
IDENTIFY_DURATION = 21.0   # s: the identify experiment's run: the identification ends at 15-18.5 s
#: rad/s: payload_identification.settle_velocity of the identify experiment: above one encoder count per tick (the
#: typical profiles' 1.8e-4 and 1.2e-4 rad in 1 ms: 0.18 and 0.12 rad/s), which the measured velocity shows at
#: rest and which the default 0.05 rad/s takes for motion (the Panda's sampling then restarts for 20 s)
IDENTIFY_SETTLE_VELOCITY = 0.3
IDENTIFY = {'payload_identification.move_time': IDENTIFY_MOVE_TIME,
            'payload_identification.settle_velocity': IDENTIFY_SETTLE_VELOCITY}
#: the real-arm experiments' variants: (title, law, controller overrides but the friction's, friction scale or None)
REAL_VARIANTS = {
    'move': ("joint impedance and its integral with friction compensation at the profile's values",
             'joint_impedance', {'integral': True}, 1.0),
    'move_friction_off': ('joint impedance and its integral with the friction estimate 30 % low', 'joint_impedance',
                          {'integral': True}, REAL_FRICTION_ERROR),
    'move_ct': ("computed torque (the scenario's gains), no friction compensation", 'computed_torque', {}, None),
    'hold': (f'joint impedance with friction compensation and the integral at rest, held to {REAL_HOLD:g} s',
             'joint_impedance', {'integral': True, 'integral_rest_velocity': 0.01}, 1.0),
    'adaptive': (f'adaptive computed torque with friction compensation, an unknown 2 kg payload 5 cm out, the move '
                 f'out and back {REAL_REPETITIONS} times', 'adaptive_computed_torque', {}, 1.0),
    'identify': ('joint impedance with friction compensation holding an unknown 2 kg payload 5 cm out, which '
                 f'~/identify_payload identifies at {IDENTIFY_AT:g} s (moves of {IDENTIFY_MOVE_TIME:g} s) and the '
                 'law then uses', 'joint_impedance', IDENTIFY, 1.0),
    'identify_exact_masses': ("the same on the typical robot with the model's link masses and inertias (the profile's "
                              '+10 % removed)', 'joint_impedance',
                              IDENTIFY, 1.0),
}


def real_friction(scenario, scale=1.0):
    """friction_compensation.coulomb and .viscous at `scale` times config/realism/<scenario>_typical.yaml's friction."""
    import yaml

    with open(realism_profile(scenario, 'typical'), encoding='utf-8') as f:
        friction = yaml.safe_load(f)['/**/sim_bridge']['ros__parameters']['friction']
    return {f'friction_compensation.{k}': [scale * v for v in friction[k]] for k in ('coulomb', 'viscous')}


def _real_arm(scenario, variant):
    """A real-arm experiment, for the typical robot (`--realism typical`): every joint REAL_MOVE rad in
    REAL_MOVE_TIME s from the scenario's start (the iiwa: IIWA_POSTURE), then held; `variant` of REAL_VARIANTS
    (the adaptive one moves out and back REAL_REPETITIONS times carrying PAYLOAD, which its model lacks)."""
    title, law, overrides, friction = REAL_VARIANTS[variant]
    q0 = tuple(float(v) for v in (IIWA_POSTURE if scenario == 'iiwa' else scenarios.get(scenario).q0))
    goal = tuple(v + REAL_MOVE for v in q0)
    controller = {'law': law, **overrides, **({} if friction is None else real_friction(scenario, friction))}
    if law == 'joint_impedance':
        controller['joint_stiffness'] = list(REAL_STIFFNESS[scenario])
    bridge = {'initial_positions': list(q0), 'surface.enable': False}
    t0, duration, figures, calls = 0.2, 3.2, (), ()
    traj = TrajectorySpec(t0, (REAL_MOVE_TIME,), (goal,))
    if variant == 'hold':
        duration, figures = REAL_HOLD, ('hold',)
    elif variant == 'adaptive':
        bridge.update(PAYLOAD)
        times = tuple(REAL_MOVE_TIME * (k + 1) for k in range(2 * REAL_REPETITIONS))
        rest = tuple((0.0,) * len(q0) for _ in times)
        traj = TrajectorySpec(t0, times, tuple((goal, q0)[k % 2] for k in range(len(times))), rest, rest)
        duration, figures = t0 + times[-1] + 0.5, ('repetitions',)
    elif variant.startswith('identify'):
        bridge.update(PAYLOAD)
        if variant == 'identify_exact_masses':
            bridge.update({f'sim_params.{k}': [1.0] * len(q0) for k in ('mass_scale', 'inertia_scale')})
        calls = ((IDENTIFY_AT, '/controller/identify_payload', 'identifying the payload', ('payload.mass', 'payload.com')),)
        duration, figures = IDENTIFY_DURATION, ('identify',)
    return Experiment(f'{scenario}_real_{variant}', scenario,
                      f'{REAL_NAMES[scenario]}, typical robot: {REAL_MOVE:g} rad on every joint in '
                      f'{REAL_MOVE_TIME:g} s, {title}', duration=duration, law=law, controller=controller,
                      bridge=bridge, trajectory=traj, settle_from=t0, figures=figures, service_calls=calls)


_BUILDERS = {
    'polar_step': _polar_step,
    'planar_fast_path': lambda: _planar('planar_fast_path', 'computed_torque', 'PD computed torque'),
    'planar_independent_joint': lambda: _planar('planar_independent_joint', 'independent_joint',
                                                'independent-joint PD, same design (kp = w_n^2 M_ii(q0))'),
    'single_link_step': _single_link_step,
    'mass_spring_sine': _mass_spring_sine,
    'disturbance_pd': lambda: _disturbance(False),
    'disturbance_pid': lambda: _disturbance(True),
    'model_error_pd': lambda: _model_error(False),
    'model_error_pid': lambda: _model_error(True),
    'force_steps': _force_steps,
    'hybrid_xy_wall': _hybrid_xy,
    'hybrid_xyz_circle': _hybrid_xyz,
    'iiwa_ptp': lambda: _ptp('iiwa_ptp', 'iiwa', 'KUKA iiwa', IIWA_LINE.posture, (0.6, -0.3, 0.4, 0.3, -0.5, 0.4, 0.8),
                             bridge={'surface.enable': False}),
    'iiwa_hybrid_line': lambda: _hybrid_line('iiwa_hybrid_line', IIWA_LINE, 'KUKA iiwa'),
    'panda_ptp': lambda: _ptp('panda_ptp', 'panda', 'Franka Panda (fingers held)', scenarios.get('panda').q0,
                              (0.6, 0.4, -0.4, 0.5, 0.5, -0.4, 0.8), bridge={'surface.enable': False}),
    'panda_hybrid_line': lambda: _hybrid_line('panda_hybrid_line', PANDA_LINE, 'Franka Panda (fingers held)'),
    'ur5_ptp': lambda: _ptp('ur5_ptp', 'ur5', 'UR5 (6 DOF, example-robot-data)', scenarios.get('ur5').q0,
                            (0.8, 0.5, -0.6, 0.5, 0.6, 1.0)),
    'iiwa_hybrid_vertical': _iiwa_hybrid_vertical,
    'impedance_push': _impedance_push,
    'pose_tracking': _pose_tracking,
    'payload_compensated': lambda: _payload(True),
    'payload_unmodelled': lambda: _payload(False),
    **{f'iiwa_gap_{variant}': (lambda v=variant: _gap(v)) for variant in GAP_VARIANTS},
    **{f'{arm}_real_{variant}': (lambda a=arm, v=variant: _real_arm(a, v)) for arm in REAL_ARMS for variant in REAL_VARIANTS},
}

#: the experiment `--scenario NAME` runs
DEFAULT_FOR_SCENARIO = {
    'polar_two_link': 'polar_step',
    'planar_two_link': 'planar_fast_path',
    'single_link': 'single_link_step',
    'mass_spring_cubic': 'mass_spring_sine',
    'force_1dof': 'force_steps',
    'hybrid_cartesian_xy': 'hybrid_xy_wall',
    'hybrid_cartesian_xyz': 'hybrid_xyz_circle',
    'iiwa': 'iiwa_hybrid_line',
    'panda': 'panda_hybrid_line',
    'ur5': 'ur5_ptp',
}

EXPERIMENTS = tuple(_BUILDERS)
#: the realism of a run: 'ideal' simulates the robot the controller models; 'typical' stacks the scenario's
#: realism profile (config/realism/<scenario>_typical.yaml) on the bridge's parameters
REALISM = ('ideal', 'typical')


#: the checkout's root (config/ beside robot_control/)
ROOT = Path(__file__).resolve().parents[2]


def config_file(relative):
    """config/<relative> of this checkout, else of the installed package; None when neither has it."""
    for base in (ROOT / 'config', Path(sys.prefix) / 'share' / 'robot_control' / 'config'):
        if (base / relative).is_file():
            return base / relative
    return None


def realism_profile(scenario, realism):
    """The parameter file the bridge stacks after the scenario's for `realism` (REALISM): None for 'ideal' and
    for a scenario without a profile, else config/realism/<scenario>_<realism>.yaml."""
    if realism not in REALISM:
        raise ValueError(f'realism: expected one of {REALISM}, got {realism!r}')
    return None if realism == 'ideal' else config_file(f'realism/{scenario}_{realism}.yaml')


def output_name(name, realism='ideal'):
    """Directory name of an experiment's outputs: the scenario's name for its default experiment
    (out/demo/polar_two_link), the experiment's own name otherwise (out/demo/disturbance_pid); a run other
    than 'ideal' adds its realism (out/demo/iiwa_ptp_typical)."""
    key = DEFAULT_FOR_SCENARIO.get(name, name)
    base = next((scenario for scenario, default in DEFAULT_FOR_SCENARIO.items() if default == key), key)
    return base if realism == 'ideal' else f'{base}_{realism}'


def get(name):
    """The Experiment called `name` (an experiment or a scenario name), or ValueError listing them."""
    key = DEFAULT_FOR_SCENARIO.get(name, name)
    try:
        build = _BUILDERS[key]
    except KeyError:
        raise ValueError(f'experiment: unknown {name!r}; expected a scenario {sorted(DEFAULT_FOR_SCENARIO)} '
                         f'or an experiment {list(EXPERIMENTS)}') from None
    return build()
