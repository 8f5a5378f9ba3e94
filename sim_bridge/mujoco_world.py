"""The MuJoCo world: the same robot, the same interface as sim_bridge.world.World, another engine.

    (M(q) + diag(I_a)) qdd + C(q, qd) qd + g(q) = tau + tau_env + tau_f,   tau = clip(command, effort limits)

tau_env: the mass-spring's -k x^3 - b xd, the surface's spring at the tip (sim_bridge.mujoco_surface) and the
configured disturbance (joint torque, and the Cartesian force at the tip frame origin as J(q)^T f via
mj_applyFT). tau_f and I_a: the joints' friction (viscous, Coulomb with stiction) and armature, the
equations of sim_bridge.joint_friction solved as on PyBullet (joint_friction.step_loss, with MuJoCo's M and
C qd + g of the step's state, every other load of the step known exactly), and sent as the joint torque
tau + f - I_a qdd - b qd (MuJoCo's own frictionloss, armature and damping stay zero: its implicit damping
and its friction-loss constraint would not be the same equations). Units SI; time kept as integer
nanoseconds. The robot is the PyBullet world's checked URDF copy (same resolution of scenario, params,
payload, joints, q0), compiled by sim_bridge.mujoco_model with the URDF's exact inertias; stepped by
MuJoCo's semi-implicit Euler (as PyBullet's) at dt, loads computed between mj_step1 and mj_step2 (at
the step's state).

Brakes: the joint torque that stops the joints in one step and pulls them back to the held
positions in BRAKE_STEPS steps, qdd_b = -(qd + (q - q_b) / (BRAKE_STEPS dt)) / dt, by inverse dynamics
(mj_rne) less the environment's loads, each clipped to the joint's effort limit (UNLIMITED_BRAKE
where the URDF sets none): at most the effort limit, as PyBullet's position motors.
"""
import tempfile

import mujoco
import numpy as np

from robot_control import validation
from robot_control.validation import ArgumentError
from sim_bridge import mujoco_model, surfaces
from sim_bridge.disturbance import Disturbance
from sim_bridge.joint_friction import JointFriction, inertia, step_loss
from sim_bridge.mujoco_surface import MujocoSurface
from sim_bridge.world_base import UNLIMITED_BRAKE, check_travel, clip_torque, resolve, scenario_of, whole_ns

#: the brake's position time constant in steps (PyBullet's position motor: positionGain 0.1)
BRAKE_STEPS = 10.0


def _effort_limits(xml, joints):
    """URDF <limit effort> of `joints` (n,), N m or N; inf where none is set (0 or absent)."""
    import xml.etree.ElementTree as ET
    limits = {}
    for joint in ET.fromstring(xml.lstrip()).findall('joint'):
        limit = joint.find('limit')
        effort = float(limit.get('effort', '0')) if limit is not None else 0.0
        limits[joint.get('name')] = effort if effort > 0.0 else np.inf
    return np.array([limits[name] for name in joints])


def _at(index):
    """`index` (an integer array) as a slice where it is a contiguous ascending run (numpy then indexes by a view,
    not a copy), else as it is."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


def _travel(model, ids):
    """(lower, upper) per joint id as World keeps them: lower > upper where the joint is unlimited."""
    return [tuple(model.jnt_range[j]) if model.jnt_limited[j] else (0.0, -1.0) for j in ids]


class MujocoWorld:
    """A MuJoCo world stepping one robot under a held joint torque: sim_bridge.world.World's
    arguments (gui must be False), properties and methods; `model` and `data` are MuJoCo's."""

    def __init__(self, scenario=None, gui=False, dt=0.001, params=None, urdf=None, joints=None, q0=None,
                 surface=True, disturbance=None, tip=None, surface_damping=0.0, payload=None, friction=None):
        if gui:
            raise ArgumentError('gui', 'the MuJoCo world has no viewer')
        self.scenario = scenario_of(scenario)
        self.dt_ns = whole_ns(dt)
        self.dt = self.dt_ns * 1e-9
        self._tmp = tempfile.TemporaryDirectory(prefix='sim_bridge_mujoco_')
        try:
            self._spec = resolve(self.scenario, params, urdf, joints, q0, surface, tip, surface_damping,
                                  payload, self._tmp.name)
            self._disturbance = Disturbance.from_config(self.n, disturbance, self._spec.tip is not None)
            self._load()
            self.set_friction(friction)
            self._build(self._spec.q0)
            self.report = self._spec.warnings + self._physics_report()
        except BaseException:
            self.close()
            raise

    def _load(self):
        spec = self._spec
        with open(spec.urdf, encoding='utf-8') as f:
            xml = f.read()
        try:
            self.model = mujoco_model.load(xml, spec.joints, spec.gravity, self.dt)
        except ValueError as exc:
            raise ArgumentError('urdf', f'MuJoCo cannot compile {spec.urdf}: {exc}') from None
        names = [self.model.joint(j).name for j in range(self.model.njnt)]
        unknown = [name for name in spec.joints if name not in names]
        if unknown:
            raise ArgumentError('joints', f'unknown {unknown}; the URDF\'s movable joints are {names}')
        if self.model.nv != len(spec.joints):
            raise ArgumentError('joints', f'expected single-dof joints (revolute, continuous, prismatic), got {names}')
        self._qadr, self._dadr = mujoco_model.dofs(self.model, spec.joints)
        self._q_at, self._v_at = _at(self._qadr), _at(self._dadr)      # the same, as slices where they can be
        self._travel = _travel(self.model, [self.model.joint(name).id for name in spec.joints])
        self._limit = _effort_limits(xml, spec.joints)
        self._limit_min = float(np.min(self._limit))
        self._brake_limit = np.where(np.isfinite(self._limit), self._limit, UNLIMITED_BRAKE)
        bodies = [self.model.body(b).name for b in range(self.model.nbody)]
        if spec.tip is not None and spec.tip not in bodies:
            raise ArgumentError('tip', f'unknown link {spec.tip!r}; the URDF\'s links are {bodies[1:]}')
        self._tip = self.model.body(spec.tip).id if spec.tip is not None else None
        self._radius = surfaces.probe_radius(xml, spec.tip) if spec.surface is not None else None
        self.data = mujoco.MjData(self.model)

    def _build(self, q0):
        """Start again from q0 at rest: t = 0, zero torque, brakes off."""
        check_travel(self._spec.joints, q0, self._travel)
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self._qadr] = q0
        mujoco.mj_forward(self.model, self.data)
        self.t_ns = 0
        self._tau = np.zeros(self.n)
        self._brake, self._brake_applied = None, np.zeros(self.n)
        self._loss = None
        self._sets = None       # the Coulomb solver's active sets of the last step (a start; the solution is unique)
        self._surface = None if self._spec.surface is None else self._make_surface()

    def _make_surface(self):
        spec = self._spec
        normal = surfaces.surface_normal(spec.task_axes, spec.surface.axis, spec.closed_form)
        half = surfaces.HALF_WIDTH_WALL if spec.closed_form else surfaces.HALF_WIDTH_TABLE
        return MujocoSurface(spec.surface, normal, self._radius, self.data.xpos[self._tip].copy(),
                             spec.surface_damping, half, self._tip)

    def _physics_report(self):
        """Lines naming the joints where MuJoCo's M(q0) or g(q0) differ from Pinocchio's on the URDF."""
        from robot_control.models.urdf_model import UrdfModel
        with open(self._spec.urdf, encoding='utf-8') as f:
            model = UrdfModel(f.read(), joints=list(self._spec.joints), gravity=(0.0, 0.0, -self.gravity))
        q = self._spec.q0
        m = mujoco_model.mass_matrix(self.model, self.data)[np.ix_(self._dadr, self._dadr)]
        g = mujoco_model.inverse_dynamics(self.model, self.data, np.zeros(self.model.nv))[self._dadr]
        lines = []
        for k, name in enumerate(self._spec.joints):
            dg, dm = abs(g[k] - model.g(q)[k]), np.abs(m[k] - model.M(q)[k]).max()
            if dg > 1e-9 or dm > 1e-9:
                lines.append(f'physics differs from the URDF: joint {name!r}: MuJoCo g differs by {dg:.3g} N m, '
                             f'M row by {dm:.3g} kg m^2 from the Pinocchio model\'s')
        return lines

    # -- properties ----------------------------------------------------------------------------
    n = property(lambda self: len(self._spec.joints), doc='Number of controlled joints.')
    joint_names = property(lambda self: self._spec.joints, doc='Controlled joint names, command order.')
    urdf = property(lambda self: self._spec.urdf, doc='Path of the checked URDF copy the model was compiled from.')
    gravity = property(lambda self: self._spec.gravity, doc='Gravitational acceleration along world -z, m/s^2.')
    surface = property(lambda self: self._spec.surface, doc='The surface in the world (scenarios.Surface), or None.')
    tip = property(lambda self: self._spec.tip, doc='Tip link name, or None.')
    t = property(lambda self: self.t_ns * 1e-9, doc='Simulation time, s (t_ns * 1e-9).')
    braked = property(lambda self: self._brake is not None, doc='True while the brakes hold the arm.')

    @property
    def effort_limit(self):
        """Per-joint effort limit from the URDF, N m or N, (n,); inf where the URDF sets none."""
        return self._limit.copy()

    @property
    def disturbance(self):
        """(joint_torque (n,), cartesian_force (3,)) in force, read-only arrays."""
        return self._disturbance.joint_torque, self._disturbance.cartesian_force

    # -- life ----------------------------------------------------------------------------------
    def reset(self, q0=None):
        """Start again exactly: t = 0, q = q0 (default: the start given at construction), qd = 0, zero
        torque, brakes off; the disturbance is kept. Same inputs -> bit-identical run."""
        self._build(self._spec.q0 if q0 is None else validation.vector('q0', q0, self.n))

    def close(self):
        """Delete the temporary URDFs (idempotent)."""
        self._tmp.cleanup()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- commands ------------------------------------------------------------------------------
    def set_torque(self, tau):
        """Hold joint torque `tau` (n,), N m or N, clipped to the effort limits; returns the clipped copy."""
        self.hold_torque(tau)
        return self._tau.copy()

    @property
    def held(self):
        """The actuator torque the next step holds (what hold_torque last held), (n,) N m or N."""
        return self._tau

    def hold_torque(self, tau):
        """set_torque without the returned array: the bridge's call, once per control period. A list of n finite
        numbers is checked by one sum (validation.float_list) and compared without numpy."""
        self._tau = np.array(clip_torque(tau, self.n, self._limit, self._limit_min))   # a copy: held until changed

    def set_friction(self, friction):
        """Replace the joints' friction and armature (World's `friction` argument), from the next step."""
        self.friction = JointFriction.of(self.n, friction)
        self._friction_active, self._loss, self._sets = self.friction.active, None, None

    def joint_friction_torque(self):
        """tau_loss = b qd - f + I_a qdd (n,), N m or N, of the last step (sim_bridge.joint_friction): zeros
        without friction and armature, before a step, or while braked."""
        return np.zeros(self.n) if self._loss is None or self._brake is not None else self._loss.copy()

    def set_disturbance(self, joint_torque=None, cartesian_force=None):
        """Replace the disturbance: joint_torque (n,) N m or N, cartesian_force (3,) N in world axes at
        the tip frame origin; None means zero; held until changed."""
        self._disturbance = Disturbance(self.n, joint_torque, cartesian_force, self._tip is not None)

    def brake(self, on):
        """Engage (True: hold the positions at engagement, at most the effort limit) or release (False)."""
        if bool(on) != self.braked:
            self._brake, self._brake_applied = (self.state()[0] if on else None), np.zeros(self.n)

    # -- stepping ------------------------------------------------------------------------------
    def prepare(self, tau=None):
        """Nothing to form ahead of a step (World.prepare's counterpart: MuJoCo's joint physics is its own)."""

    def step(self, k=1):
        """Advance k physics steps of dt with the held torque."""
        if type(k) is not int and (isinstance(k, bool) or not isinstance(k, np.integer)) or k < 1:
            raise ArgumentError('k', f'expected a positive integer number of steps, got {k!r}')
        m, d, dist = self.model, self.data, self._disturbance
        if self._brake is None and self._spec.spring is None and self._surface is None and \
                not (self._friction_active or dist.has_joint_torque or dist.has_force):
            d.qfrc_applied[self._v_at] = self._tau   # every dof is a controlled joint's (the others are fixed)
            for _ in range(int(k)):                  # a load that does not depend on the state: one call a step
                mujoco.mj_step(m, d)
                self.t_ns += self.dt_ns
            return
        for _ in range(int(k)):
            mujoco.mj_step1(m, d)
            d.qfrc_applied[:] = 0.0
            d.qfrc_applied[self._v_at] = self._environment()
            if self._tip is not None and self._disturbance.has_force:
                mujoco.mj_applyFT(m, d, self._disturbance.cartesian_force, np.zeros(3), d.xpos[self._tip],
                                  self._tip, d.qfrc_applied)
            if self._surface is not None:
                self._surface.apply(m, d, d.qfrc_applied)
            d.qfrc_applied[self._v_at] += self._drive()
            mujoco.mj_step2(m, d)
            self.t_ns += self.dt_ns

    def _environment(self):
        """Joint loads of the environment at the step's state: disturbance and mass-spring, (n,)."""
        tau = self._disturbance.joint_torque.copy()
        if self._spec.spring is not None:
            x, xd = self.data.qpos[self._qadr[0]], self.data.qvel[self._dadr[0]]
            tau[0] -= self._spec.spring[0] * x ** 3 + self._spec.spring[1] * xd
        return tau

    def _drive(self):
        """The joint torque of the step (n,) given the loads already in qfrc_applied: the brake's while braked,
        else the held torque with the joints' friction and armature (sim_bridge.joint_friction)."""
        if self._brake is not None:
            self._brake_applied = self._brake_torque()
            return self._brake_applied
        if not self._friction_active:
            return self._tau
        fr, d = self.friction, self.data
        qd = d.qvel[self._v_at]
        if not fr.exact:                        # viscous alone: -b qd, no solve
            self._loss = fr.viscous * qd
            return self._tau - self._loss
        mass = mujoco_model.mass_matrix(self.model, d)[np.ix_(self._dadr, self._dadr)]
        r = self._tau + d.qfrc_applied[self._v_at] - fr.viscous * qd - d.qfrc_bias[self._v_at]
        f, qdd, self._loss, self._sets = step_loss(fr, inertia(fr, mass), qd, r, self.dt, self._sets)
        return self._tau + f - fr.armature * qdd - fr.viscous * qd

    def _brake_torque(self):
        """The brake's joint torque (n,) at the step's state, given the loads already in qfrc_applied."""
        d = self.data
        q, qd = d.qpos[self._qadr], d.qvel[self._dadr]
        qacc = np.zeros(self.model.nv)
        qacc[self._dadr] = -(qd + (q - self._brake) / (BRAKE_STEPS * self.dt)) / self.dt
        need = mujoco_model.inverse_dynamics(self.model, d, qacc)[self._dadr] - d.qfrc_applied[self._dadr]
        return np.clip(need, -self._brake_limit, self._brake_limit)

    # -- readings ------------------------------------------------------------------------------
    def state(self):
        """(q (n,), qd (n,), tau_applied (n,)): the clipped command, or the brake's torque while braked."""
        return self.state_into(np.empty(self.n), np.empty(self.n), np.empty(self.n))

    def _applied(self):
        return self._tau if self._brake is None else self._brake_applied

    def state_values(self):
        """state() as three tuples of n floats."""
        return (tuple(self.data.qpos[self._q_at].tolist()), tuple(self.data.qvel[self._v_at].tolist()),
                tuple(self._applied().tolist()))

    def state_into(self, q_out, qd_out, tau_out):
        """state() written into three float64 (n,) arrays; returns them."""
        q_out[:], qd_out[:], tau_out[:] = self.data.qpos[self._q_at], self.data.qvel[self._v_at], self._applied()
        return q_out, qd_out, tau_out

    def tip_position(self):
        """World position of the tip frame origin, m, (3,), at the current state."""
        if self._tip is None:
            raise ArgumentError('tip', 'this world has no tip link')
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.xpos[self._tip].copy()

    def contact_wrench(self):
        """(force (3,) N, torque (3,) N m) exerted by the robot on the surface in the last step, world axes,
        torque about the world origin; zeros without a surface or contact."""
        if self._surface is None:
            return np.zeros(3), np.zeros(3)
        force, torque = self._surface.wrench
        return force.copy(), torque.copy()
