"""The PyBullet world: the "real robot" of every scenario. No rclpy, no messages.

    (M(q) + diag(I_a)) qdd + C(q, qd) qd + g(q) = tau + tau_env + tau_f,   tau = clip(command, effort limits)

tau_env holds what the world adds: the mass-spring's -k x^3 - b xd, contact with the surface,
and the configured disturbance; tau_f and the armature I_a are the joints' friction and rotor inertia
(sim_bridge.joint_friction; zero unless configured). The simulated robot is the given URDF, or the
scenario's closed form with `params`, with its links changed by `params` (sim_bridge.true_robot).
Units SI (rad, m, N m, N, s); time is kept as integer nanoseconds. Each World owns one PyBullet
physics client (DIRECT unless gui=True).

PyBullet facts respected: URDF loaded with URDF_USE_INERTIA_FROM_FILE and a fixed
base, from a copy whose links without <inertial> have an explicit zero one (PyBullet's default
would be 1 kg, 1 kg m^2) and whose meshes are absolute file:// URIs; default velocity motors
disabled (VELOCITY_CONTROL, force 0); link linear/angular damping (default 0.04) and URDF joint
damping zeroed (joint damping then carries friction.viscous alone); the torque is re-sent before
every stepSimulation (PyBullet clears applied torques after each step); fixed step dt without substeps.
"""
import math
import shutil
import tempfile

import numpy as np
import pybullet as p

from robot_control.validation import ArgumentError
from robot_control import validation
from sim_bridge import physics_check, pybullet_surface, surfaces
from sim_bridge.disturbance import Disturbance
from sim_bridge.joint_friction import JointFriction
from sim_bridge.joint_physics import JointPhysics
from sim_bridge.world_base import UNLIMITED_BRAKE, check_travel, clip_torque, resolve, scenario_of, whole_ns

def _zero_damping(client, body):
    """No hidden damping: PyBullet's default link and joint damping would act on every joint."""
    for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
        p.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                         physicsClientId=client)


def _hold(client, body, joints):
    """Lock the movable joints that are not controlled at 0 (as UrdfModel locks them at neutral)."""
    if joints:
        k = len(joints)
        p.setJointMotorControlArray(body, joints, p.POSITION_CONTROL, targetPositions=[0.0] * k,
                                    forces=[UNLIMITED_BRAKE] * k, physicsClientId=client)


def _indices(client, body, joints, tip):
    """(PyBullet indices of the controlled `joints`, their travel [(lower, upper)], the indices of the other
    movable joints, the effort limits (n,) N m or N (inf where the URDF sets none), the index of link `tip`
    or None); ArgumentError naming joints or tip when the URDF lacks one."""
    movable, links, limits, travel = {}, {}, {}, {}
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, j, physicsClientId=client)
        links[info[12].decode()] = j
        if info[2] != p.JOINT_FIXED:
            movable[info[1].decode()] = j
            limits[j] = info[10] if info[10] > 0.0 else math.inf
            travel[j] = (info[8], info[9])
    unknown = [name for name in joints if name not in movable]
    if unknown:
        raise ArgumentError('joints', f'unknown {unknown}; the URDF\'s movable joints are {list(movable)}')
    idx = [movable[name] for name in joints]
    if tip is not None and tip not in links:
        raise ArgumentError('tip', f'unknown link {tip!r}; the URDF\'s links are {list(links)}')
    return (idx, [travel[j] for j in idx], [j for j in movable.values() if j not in idx],
            np.array([limits[j] for j in idx]), links.get(tip) if tip is not None else None)


def _make_wall(world, client, body, tip):
    """The surface of `world`'s spec (sim_bridge.pybullet_surface.Wall) that only the tip link `tip` touches."""
    spec = world._spec
    normal = surfaces.surface_normal(spec.task_axes, spec.surface.axis, spec.closed_form)
    radius = pybullet_surface.tip_radius(client, body, tip)
    half = surfaces.HALF_WIDTH_WALL if spec.closed_form else surfaces.HALF_WIDTH_TABLE
    wall = pybullet_surface.Wall(client, spec.surface, normal, radius, world.tip_position(), spec.surface_damping,
                                 half)
    # The lecture's environment is a spring on the tip: only the tip's probe touches the surface.
    # (The iiwa's wrist, lbr_iiwa_link_6, reaches the table top next to lbr_iiwa_link_7's origin.)
    for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
        if link != tip:
            p.setCollisionFilterPair(body, wall.body, link, -1, 0, physicsClientId=client)
    return wall


class World:
    """A PyBullet world stepping one robot under a held joint torque.

    scenario: name or Scenario (robot_control.scenarios), or None with urdf= and joints=.
    gui: open the PyBullet GUI instead of DIRECT. dt: physics step, s (a whole number of ns).
    params: physical overrides of the simulated robot (e.g. {'m': 2.5}: heavier than the
      controller's model); closed-form URDFs are regenerated; 'gravity' (m/s^2) for any robot; for a
      URDF robot 'mass_scale', 'inertia_scale' ((n,) or one factor) and 'com_offset' ((3 n,) m) change the
      link each joint moves (sim_bridge.true_robot).
    urdf, joints, q0, tip: override the scenario's URDF file, joint names (command order),
      start positions (rad or m) and tip link.
    surface: True (the scenario's), False, or a scenarios.Surface. surface_damping: N s/m.
    payload: None or (mass kg, com (3,) m in the tip link's frame): robot_control.urdf.with_payload.
    disturbance: None or {'joint_torque': (n,), 'cartesian_force': (3,)} (see set_disturbance).
    friction: None or {'coulomb': (n,) N m or N, 'viscous': (n,) N m s/rad or N s/m, 'armature': (n,)
      kg m^2 or kg} of the joints (sim_bridge.joint_friction; see set_friction); None: all zero. The
      attribute `friction` is the JointFriction in force (read it; change it with set_friction), `held` the
      torque held for the next step (read it; change it with set_torque or hold_torque).
    report: the start-up report, a list of strings: the URDF's warnings and where PyBullet's physics at the
      start state differs from Pinocchio's on the same URDF (sim_bridge.physics_check.report).
    """

    def __init__(self, scenario=None, gui=False, dt=0.001, params=None, urdf=None, joints=None, q0=None,
                 surface=True, disturbance=None, tip=None, surface_damping=0.0, payload=None, friction=None):
        self.scenario = scenario_of(scenario)
        self.dt_ns = whole_ns(dt)
        self.dt = self.dt_ns * 1e-9
        self._tmpdir = tempfile.mkdtemp(prefix='sim_bridge_')
        self._client = None
        try:
            self._spec = resolve(self.scenario, params, urdf, joints, q0, surface, tip, surface_damping,
                                  payload, self._tmpdir)
            self._disturbance = Disturbance.from_config(self.n, disturbance, self._spec.tip is not None)
            self.friction = JointFriction.of(self.n, friction)
            self._client = p.connect(p.GUI if gui else p.DIRECT)
            if self._client < 0:
                raise RuntimeError('pybullet: cannot connect a physics client')
            self._build(self._spec.q0)
            with open(self._spec.urdf, encoding='utf-8') as f:
                self.report = self._spec.warnings + physics_check.report(self._client, self._body, f.read(),
                                                                         self._spec.gravity)
        except BaseException:
            self.close()
            raise

    # -- properties ----------------------------------------------------------------------------
    @property
    def n(self):
        """Number of controlled joints."""
        return len(self._spec.joints)

    @property
    def joint_names(self):
        """Controlled joint names, in the order of every joint vector."""
        return self._spec.joints

    @property
    def effort_limit(self):
        """Per-joint effort limit from the URDF, N m or N, (n,); inf where the URDF sets none."""
        return self._limit.copy()

    @property
    def urdf(self):
        """Path of the URDF file the simulated robot was loaded from: the checked copy of the given or
        generated URDF (absolute file:// meshes, explicit zero <inertial>s, probe and payload if any)."""
        return self._spec.urdf

    @property
    def gravity(self):
        """Gravitational acceleration along world -z, m/s^2."""
        return self._spec.gravity

    @property
    def surface(self):
        """The surface in the world (scenarios.Surface), or None."""
        return self._spec.surface

    @property
    def tip(self):
        """Tip link name (task point, Cartesian disturbance, contact probe), or None."""
        return self._spec.tip

    @property
    def t(self):
        """Simulation time, s (t_ns * 1e-9)."""
        return self.t_ns * 1e-9

    @property
    def braked(self):
        """True while the brakes hold the arm."""
        return self._brake is not None

    @property
    def client(self):
        """PyBullet physics client id of this world."""
        return self._client

    @property
    def body(self):
        """PyBullet body id of the robot."""
        return self._body

    # -- build ---------------------------------------------------------------------------------
    def _build(self, q0):
        """(Re)create the whole simulation from the spec, starting at q0: same inputs, same results."""
        c, spec = self._client, self._spec
        p.resetSimulation(physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, contactSlop=0.0,
                                    deterministicOverlappingPairs=1, physicsClientId=c)
        p.setGravity(0.0, 0.0, -spec.gravity, physicsClientId=c)
        try:
            self._body = p.loadURDF(spec.urdf, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE,
                                    physicsClientId=c)
        except p.error as exc:
            raise ArgumentError('urdf', f'PyBullet cannot load {spec.urdf}: {exc}') from None
        indices = _indices(c, self._body, spec.joints, spec.tip)
        self._idx, self._travel, self._others, self._limit, self._tip = indices
        self._limit_min = float(np.min(self._limit))
        self._brake_force = np.where(np.isfinite(self._limit), self._limit, UNLIMITED_BRAKE).tolist()
        _zero_damping(c, self._body)
        self._joints = JointPhysics(c, self._body, self._idx, self._tip, self.dt, self.friction)
        _hold(c, self._body, self._others)
        p.setJointMotorControlArray(self._body, self._idx, p.VELOCITY_CONTROL, forces=[0.0] * self.n,
                                    physicsClientId=c)
        check_travel(self._spec.joints, q0, self._travel)
        for i, q in zip(self._idx, q0):
            p.resetJointState(self._body, i, float(q), 0.0, physicsClientId=c)
        self._wall = _make_wall(self, c, self._body, self._tip) if spec.surface is not None else None
        self.t_ns = 0
        self.held = [0.0] * self.n              # the torque held for the next step, as PyBullet is sent it
        self._brake = None

    def reset(self, q0=None):
        """Rebuild the world exactly: t = 0, q = q0 (default: the start given at construction), qd = 0,
        zero torque, brakes off. The disturbance in force is kept. Same inputs -> bit-identical run."""
        q0 = self._spec.q0 if q0 is None else validation.vector('q0', q0, self.n)
        check_travel(self._spec.joints, q0, self._travel)          # before tearing the old world down
        self._build(q0)

    def close(self):
        """Disconnect the physics client and delete temporary URDFs (idempotent)."""
        if self._client is not None and self._client >= 0:
            try:
                p.disconnect(physicsClientId=self._client)
            except p.error:
                pass
        self._client = None
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # -- commands ------------------------------------------------------------------------------
    def set_torque(self, tau):
        """Hold joint torque `tau` (n,), N m or N, clipped to the effort limits, until changed.

        Non-finite or wrong-length tau -> ValueError; the previous torque stays. Returns the
        clipped torque (what will be applied; while braked it is stored for the release), a new array."""
        self.hold_torque(tau)
        return np.array(self.held, dtype=float)

    def hold_torque(self, tau):
        """set_torque without the returned array: the bridge's call, once per control period (no numpy: clip_torque)."""
        self.held = clip_torque(tau, self.n, self._limit, self._limit_min)

    def set_disturbance(self, joint_torque=None, cartesian_force=None):
        """Replace the disturbance: joint_torque (n,) N m or N added at the joints, cartesian_force
        (3,) N in world axes at the tip frame origin. None means zero; held until changed."""
        self._disturbance = Disturbance(self.n, joint_torque, cartesian_force, self._tip is not None)

    def joint_friction_torque(self):
        """tau_loss = tau_friction + I_a qdd (n,), N m or N, of the last step: what the drive's friction (Coulomb
        and viscous b qd) and rotor inertia take from the motor torque, so that a link-side joint torque sensor
        reads tau_motor - tau_loss (sim_bridge.sensors). Zeros without friction and armature, or while braked."""
        fr = self.friction
        if not fr.active or self._brake is not None:
            return np.zeros(self.n)
        if self._joints.exact:
            return np.zeros(self.n) if self._joints.loss is None else self._joints.loss
        return fr.viscous * np.array(self.state_values()[1])

    def set_friction(self, friction):
        """Replace the joints' friction and armature (the World's `friction` argument), from the next step."""
        self.friction = JointFriction.of(self.n, friction)
        self._joints.set(self.friction)

    @property
    def disturbance(self):
        """(joint_torque (n,), cartesian_force (3,)) in force, read-only arrays."""
        return self._disturbance.joint_torque, self._disturbance.cartesian_force

    def brake(self, on):
        """Engage (True) or release (False) the brakes.

        Engaged: position motors hold the joint positions at engagement, with at most the effort
        limit; the held torque command is not applied (it is kept for the release). Released: torque
        control resumes with the held command."""
        if bool(on) == self.braked:
            return
        c = self._client
        if on:
            self._brake = self.state()[0]
            p.setJointMotorControlArray(self._body, self._idx, p.POSITION_CONTROL,
                                        targetPositions=self._brake.tolist(), targetVelocities=[0.0] * self.n,
                                        forces=self._brake_force, physicsClientId=c)
        else:
            self._brake = None
            p.setJointMotorControlArray(self._body, self._idx, p.VELOCITY_CONTROL, forces=[0.0] * self.n,
                                        physicsClientId=c)

    # -- stepping ------------------------------------------------------------------------------
    def step(self, k=1):
        """Advance k physics steps of dt with the held torque (re-sent before every step)."""
        if type(k) is not int and (isinstance(k, bool) or not isinstance(k, np.integer)) or k < 1:
            raise ArgumentError('k', f'expected a positive integer number of steps, got {k!r}')
        for _ in range(int(k)):
            self._apply_loads()
            p.stepSimulation(physicsClientId=self._client)
            self.t_ns += self.dt_ns

    def prepare(self, tau=None):
        """Between steps (the bridge: once a state is published, or answered), form ahead what the next step's joint
        friction and armature need of the state alone (JointPhysics.prepare), and solve that step for `tau` (n,),
        N m or N, the torque it will hold, when known now (None: not known). Same results."""
        if self._joints.exact and self._brake is None:
            if tau is None:
                self._joints.prepare()
            else:
                forces, force = self._loads(clip_torque(tau, self.n, self._limit, self._limit_min))
                self._joints.prepare((list(forces), None if force is None else force.copy()))

    def _apply_loads(self):
        """Joint torque (actuator unless braked, disturbance, mass-spring, friction and armature) and the
        Cartesian force."""
        c, dist = self._client, self._disturbance
        forces, force = self._loads(self.held)
        if self._joints.exact:
            forces = self._joints.torque(forces, force, self._brake is not None)
        p.setJointMotorControlArray(self._body, self._idx, p.TORQUE_CONTROL, forces=forces, physicsClientId=c)
        if dist.has_force:
            p.applyExternalForce(self._body, self._tip, self._disturbance.cartesian_force.tolist(),
                                 self.tip_position().tolist(), p.WORLD_FRAME, physicsClientId=c)

    def _loads(self, tau_list):
        """(forces, cartesian force): the joint torque before friction and armature (list of n floats) of actuator
        torque tau_list (unless braked), disturbance and mass-spring; the Cartesian disturbance (3,) N or None."""
        spec, dist = self._spec, self._disturbance
        if self._brake is None and spec.spring is None and not dist.has_joint_torque:
            forces = tau_list               # the common case: the actuator torque alone
        else:
            tau = dist.joint_torque + (0.0 if self._brake is not None else np.array(tau_list))
            if spec.spring is not None:
                x, xd = p.getJointState(self._body, self._idx[0], physicsClientId=self._client)[:2]
                tau = tau - (spec.spring[0] * x ** 3 + spec.spring[1] * xd)
            forces = tau.tolist()
        return forces, (dist.cartesian_force if dist.has_force else None)

    # -- readings ------------------------------------------------------------------------------
    def state(self):
        """(q (n,) rad or m, qd (n,) rad/s or m/s, tau_applied (n,) N m or N).

        tau_applied is the actuator torque of the last step: the clipped command, or the brake
        motors' torque while braked (environment loads and disturbances are not included)."""
        n = self.n
        return self.state_into(np.empty(n), np.empty(n), np.empty(n))

    def state_values(self):
        """state() as three tuples of n floats, without numpy (what the bridge serializes)."""
        q, qd, _, applied = zip(*p.getJointStates(self._body, self._idx, physicsClientId=self._client))
        return q, qd, applied if self._brake is not None else tuple(self.held)

    def state_into(self, q_out, qd_out, tau_out):
        """state() written into three float64 (n,) arrays (no allocation); returns them."""
        q_out[:], qd_out[:], tau_out[:] = self.state_values()
        return q_out, qd_out, tau_out

    def tip_position(self):
        """World position of the tip frame origin, m, (3,)."""
        if self._tip is None:
            raise ArgumentError('tip', 'this world has no tip link')
        link = p.getLinkState(self._body, self._tip, computeForwardKinematics=True, physicsClientId=self._client)
        return np.array(link[4])

    def contact_wrench(self):
        """(force (3,) N, torque (3,) N m) exerted by the robot on the surface, world axes, torque
        about the world origin; zeros without a surface or contact. Valid after a step."""
        if self._wall is None:
            return np.zeros(3), np.zeros(3)
        return self._wall.wrench(self._body)
