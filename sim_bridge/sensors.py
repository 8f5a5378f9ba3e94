"""The robot's driver as the bridge models it, free of rclpy: what the sensors deliver (noise, encoder
counts, the link-side joint torque, a biased F/T sensor, a measurement delay) and when commands act (an
actuation delay). Everything is off by default: the node then publishes the World's readings as they are
and the loop does no extra work (Driver hands out the World's own methods).

Per control tick k, after its physics step, with q, qd (n,) the World's joint positions and velocities,
tau (n,) the actuator torque it applied, w = (f, m) (6,) its contact wrench (N, N m, world axes) and
every n_x ~ N(0, std_x) drawn anew per tick and entry from the stream x:

    position  y_q   = Q_r(q + n_q),         Q_r(x) = r round(x / r) where r > 0, x where r = 0
    velocity  y_qd  = (y_q[k] - y_q[k-1]) / T + n_qd    where r > 0 (T = control_period)
              y_qd  = qd + n_qd                          where r = 0
    effort    y_tau = tau - tau_loss + n_tau,   tau_loss = tau_friction + I_a qdd
    wrench    y_w   = w + b + n_w

- Encoder (r = encoder_resolution, rad or m per count): the noise is on the signal the encoder reads,
  the count is digital, so a published position is always a whole number of counts (steps of r, error
  within r / 2 without noise). Its driver reports the velocity as the difference of consecutive counts
  over the control period (steps of r / T; the first measurement after start or reset reports the
  World's velocity), with velocity noise n_qd added like any joint's.
- Effort: the torque a link-side joint torque sensor measures (the iiwa and the Panda have one in every
  joint): what the motor applies less what the drive's friction and the rotor's inertia (armature I_a)
  take, tau_sensor = tau_motor - tau_friction - I_a qdd. tau_loss is the World's
  `joint_friction_torque()` ((n,) N m or N, of the last step) when friction or armature is set
  (sim_bridge.joint_friction), else 0: then the effort is the actuator torque applied (the clipped
  command, or the brake motors' torque while braked).
- F/T sensor: the bias b (wrench_bias) and the noise are in the axes of the published wrench (world).
- Random streams: position, velocity, effort, wrench, each a numpy Generator of its own child of
  SeedSequence(seed); all restart on start and reset, and draws happen once per tick (never per
  publication: a re-published state is the same message), so a lockstep run is bit-identical for a seed.

Delays, in control ticks:
- measurement_ticks d: the state published at tick k is the measurement of tick k - d, stamped t_{k-d}
  (when it was measured, as a real driver stamps it); joint_states and ft_sensor/wrench alike. At start
  and on reset the World first runs d ticks with its brakes engaged (the warm-up: the robot stands still,
  as a real one does before its controller takes over), so the first state published is the measurement
  of t_0 = 0 and every published stamp is new and later than the one before: the controller's time line
  is monotonic, lockstep pairs the command stamped t_{k-d} with the state it answers, exactly as without
  delay (the gate expects the published stamp), and a run stays deterministic. The World and /clock run
  d ticks ahead of the stamps, as a controller's clock runs ahead of a driver's measurements. Realtime
  pacing starts after the warm-up; a command there answers a state at least d ticks old, so d times
  control_period must stay below command_timeout (checked).
- actuation_ticks a: a command that arrives before tick k's physics step is held from the step of tick
  k + a on (lockstep: the answer to the state published at tick k acts from tick k + a; realtime: the
  newest command of a tick). Until then the World holds the torque in force before. The brakes engage at
  once (they are the bridge's), but a command that releases them does so when it takes effect.
"""
import collections
from dataclasses import dataclass

import numpy as np

from robot_control.param_table import ParameterError, Row, gt_eq, lt_eq, size

#: the random streams, in the order SeedSequence(seed).spawn() gives them their seeds
STREAMS = ('position', 'velocity', 'effort', 'wrench')
WRENCH = ('fx', 'fy', 'fz', 'tx', 'ty', 'tz')
MAX_DELAY_TICKS = 1000


def _fixed(*args, **kwargs):
    return Row(*args, read_only=True, **kwargs)


def rows(values):
    """The sensor model's parameters, a stage of sim_bridge.bridge_params.TABLE (read-only)."""
    n = len(values['joints'] or ())
    per_joint, six = size('joints', 'joint', empty_ok=True), size(6, empty_ok=True)
    zeros, delay = (0.0,) * n, [gt_eq(0), lt_eq(MAX_DELAY_TICKS)]
    return [
        _fixed('noise.position_std', 'double_array', zeros, 'Standard deviation of the Gaussian noise on the '
               'published joint positions, rad or m, in joints order (before the encoder counts).',
               [per_joint, gt_eq(0)]),
        _fixed('noise.velocity_std', 'double_array', zeros, 'Standard deviation of the Gaussian noise on the '
               'published joint velocities, rad/s or m/s, in joints order.', [per_joint, gt_eq(0)]),
        _fixed('noise.effort_std', 'double_array', zeros, 'Standard deviation of the Gaussian noise on the '
               'published joint torques (effort), N m or N, in joints order.', [per_joint, gt_eq(0)]),
        _fixed('encoder_resolution', 'double_array', zeros, 'Encoder resolution, rad or m per count, in joints '
               'order: positions published as whole counts, velocities as count differences over '
               'control_period; 0 = no encoder (the simulated values).', [per_joint, gt_eq(0)]),
        _fixed('noise.wrench_std', 'double_array', (0.0,) * 6, 'Standard deviation of the Gaussian noise on '
               'ft_sensor/wrench, (fx, fy, fz) N and (tx, ty, tz) N m, world axes.', [six, gt_eq(0)]),
        _fixed('wrench_bias', 'double_array', (0.0,) * 6, 'Constant bias added to ft_sensor/wrench, (fx, fy, '
               'fz) N and (tx, ty, tz) N m, world axes.', [six]),
        _fixed('delay.measurement_ticks', 'integer', 0, 'Measurement delay in control ticks: the state '
               'published at tick k is the one measured at tick k - d, stamped with its own time.', delay),
        _fixed('delay.actuation_ticks', 'integer', 0, 'Actuation delay in control ticks: a command takes effect '
               'this many ticks after it arrives.', delay),
        _fixed('seed', 'integer', 0, 'Seed of every random stream of the sensor noise (restarted on ~/reset): '
               'one seed, one bit-identical lockstep run.', [gt_eq(0)]),
    ]


def _vector(value, n):
    """An array parameter as a float array; empty = zeros(n)."""
    return np.array(value, dtype=float) if value else np.zeros(n)


@dataclass(frozen=True)
class SensorModel:
    """The sensor model's parameters (see rows()): std and resolution arrays (n,), wrench ones (6,)."""

    position_std: np.ndarray
    velocity_std: np.ndarray
    effort_std: np.ndarray
    encoder_resolution: np.ndarray
    wrench_std: np.ndarray
    wrench_bias: np.ndarray
    measurement_ticks: int
    actuation_ticks: int
    seed: int

    @property
    def wrench_modelled(self):
        """A bias, noise or delay on ft_sensor/wrench."""
        return bool(np.any(self.wrench_std) or np.any(self.wrench_bias) or self.measurement_ticks)

    @property
    def measuring(self):
        """Anything between the World's joint readings and joint_states."""
        return bool(self.wrench_modelled or np.any(self.position_std) or np.any(self.velocity_std)
                    or np.any(self.effort_std) or np.any(self.encoder_resolution))


def model(values):
    """SensorModel from checked parameter values (rows()' rules hold), or ParameterError naming
    delay.measurement_ticks when, in realtime mode, the delay (ticks x control_period) reaches command_timeout."""
    n = len(values['joints'])
    d = values['delay.measurement_ticks']
    if values['mode'] == 'realtime' and d * values['control_period'] >= values['command_timeout']:
        raise ParameterError('delay.measurement_ticks',
                             f'realtime: {d} ticks x control_period {values["control_period"]} s must stay below '
                             f'command_timeout {values["command_timeout"]} s (a command answers a state that old)')
    return SensorModel(
        position_std=_vector(values['noise.position_std'], n), velocity_std=_vector(values['noise.velocity_std'], n),
        effort_std=_vector(values['noise.effort_std'], n),
        encoder_resolution=_vector(values['encoder_resolution'], n),
        wrench_std=_vector(values['noise.wrench_std'], 6), wrench_bias=_vector(values['wrench_bias'], 6),
        measurement_ticks=d, actuation_ticks=values['delay.actuation_ticks'], seed=values['seed'])


# -- the equations --------------------------------------------------------------------------------------------
def gaussian(rng, std):
    """n ~ N(0, std) per entry: std * z, z standard normal drawn from `rng` (a numpy Generator), shape of std."""
    return std * rng.standard_normal(std.shape)


class Encoder:
    """The encoders of resolution r (n,) >= 0, rad or m per count: `counts(x)`; `on` (n,) bool where r > 0,
    `every` when r > 0 for every joint. What does not change from tick to tick is formed once."""

    def __init__(self, resolution):
        self.on = resolution > 0.0
        self.every = bool(self.on.all())
        self._r = np.where(self.on, resolution, 1.0)

    def counts(self, x):
        """Q_r(x) = r round(x / r) where r > 0, x where r = 0 (x (n,), rad or m): whole counts as positions
        (round half to even)."""
        q = self._r * np.rint(x / self._r)
        return q if self.every else np.where(self.on, q, x)


def encoder_counts(x, resolution):
    """Encoder(resolution).counts(x): x (n,) as whole counts of resolution (n,), rad or m."""
    return Encoder(resolution).counts(x)


def count_velocity(q, q_prev, period):
    """(q - q_prev) / T, rad/s or m/s: the velocity an encoder's driver reports (q (n,), T s)."""
    return (q - q_prev) / period


def link_torque(tau_motor, tau_loss):
    """tau_sensor = tau_motor - tau_loss (n,), N m or N; tau_loss = tau_friction + I_a qdd."""
    return tau_motor - tau_loss


# -- the measurement ------------------------------------------------------------------------------------------
class Sensors:
    """The World's readings as the driver delivers them (module docstring), with the World's reading interface
    (t_ns, state_values(), contact_wrench()), so the node publishes either. `loss`: the World's
    joint_friction_torque method (friction or armature set), or None."""

    def __init__(self, world, sensor_model, control_period_ns, loss=None):
        self._world, self._m = world, sensor_model
        self._period = control_period_ns * 1e-9
        self._loss = loss
        m = sensor_model
        self._stds = (m.position_std, m.velocity_std, m.effort_std, m.wrench_std)      # in the order of STREAMS
        self._noisy = [bool(np.any(std)) for std in self._stds]
        self._encoder = Encoder(m.encoder_resolution) if np.any(m.encoder_resolution) else None
        self._wrench = m.wrench_modelled
        self._line = collections.deque(maxlen=m.measurement_ticks + 1)
        self.restart()

    def restart(self):
        """Start over (start-up, reset): every stream from the seed, an empty delay line; measure the World now."""
        seeds = np.random.SeedSequence(self._m.seed).spawn(len(STREAMS))
        self._rng = [np.random.default_rng(s) for s in seeds]
        self._line.clear()
        self._q_prev = self._ahead = None
        self.measure()

    def prepare(self):
        """Draw the next measurement's noise now, between ticks (each stream still draws once per measurement:
        the same values), so that the measurement after the next step does less."""
        if self._ahead is None:
            self._ahead = self._noise()

    def _noise(self):
        """The noise of one measurement: n_x (gaussian) of each stream of STREAMS, None where its std is zero."""
        return [gaussian(rng, std) if noisy else None for rng, std, noisy in zip(self._rng, self._stds, self._noisy)]

    def measure(self):
        """Measure the World now (after a tick) into the delay line; the reading becomes the line's oldest."""
        noise = self._noise() if self._ahead is None else self._ahead
        self._ahead = None
        q, qd, tau = np.array(self._world.state_values())
        if noise[0] is not None:
            q = q + noise[0]
        encoder = self._encoder
        if encoder is not None:
            q = encoder.counts(q)
            if self._q_prev is not None:
                counted = count_velocity(q, self._q_prev, self._period)
                qd = counted if encoder.every else np.where(encoder.on, counted, qd)
            self._q_prev = q
        if noise[1] is not None:
            qd = qd + noise[1]
        if self._loss is not None:
            tau = link_torque(tau, self._loss())
        if noise[2] is not None:
            tau = tau + noise[2]
        wrench = self._measure_wrench(noise[3]) if self._wrench else None
        self._line.append((self._world.t_ns, q.tolist(), qd.tolist(), tau.tolist(), wrench))
        self.t_ns, self._q, self._qd, self._tau, self._w = self._line[0]

    def _measure_wrench(self, noise):
        """(force (3,) N, torque (3,) N m) = the World's contact wrench + bias + noise (6,) (None: none)."""
        w = np.concatenate(self._world.contact_wrench()) + self._m.wrench_bias
        if noise is not None:
            w = w + noise
        return w[:3], w[3:]

    def state_values(self):
        """(position, velocity, effort) as published: three lists of n floats, of the measurement stamped t_ns."""
        return self._q, self._qd, self._tau

    def contact_wrench(self):
        """(force (3,) N, torque (3,) N m) as published with the state stamped t_ns (world axes)."""
        return self._world.contact_wrench() if self._w is None else self._w


# -- the actuation ---------------------------------------------------------------------------------------------
class ActuationLine:
    """Commands to `world` act `ticks` (>= 1) control ticks after they arrive (module docstring). A command is
    a list of n floats the caller does not change afterwards; one that releases the brakes carries that."""

    def __init__(self, world, ticks):
        self._world, self._ticks = world, ticks
        self.clear()

    def clear(self):
        """Nothing in the line (start-up, reset)."""
        self._line = collections.deque([None] * self._ticks)
        self._arrived = None

    def command(self, values, release=False):
        """A command arrived; it replaces one that arrived earlier in the same tick (keeping its release)."""
        release = release or (self._arrived is not None and self._arrived[1])
        self._arrived = (values, release)

    def cancel_release(self):
        """The brakes engaged: no command in the line releases them any more."""
        self._line = collections.deque(None if e is None else (e[0], False) for e in self._line)
        if self._arrived is not None:
            self._arrived = (self._arrived[0], False)

    def due(self):
        """The values of the command the next tick() makes the World hold, None when none falls due then."""
        due = self._line[0]
        return None if due is None else due[0]

    def tick(self):
        """Before a tick's physics step: the command that arrived `ticks` ticks ago takes effect."""
        self._line.append(self._arrived)
        self._arrived = None
        due = self._line.popleft()
        if due is not None:
            if due[1]:
                self._world.brake(False)
            self._world.hold_torque(due[0])


class Driver:
    """Between the loop and `world` for `sensor_model` (a SensorModel): `measured` is what the node publishes
    (the World itself when nothing is modelled), `hold(values)` a valid command, `release(values)` the
    brakes released by a command, `engage()` the brakes engaged, `step(k)` one control tick of k physics
    steps (the actuation line moves, then physics, then the measurement), `restart()` after the World was
    (re)built, `warm_up_ticks` the ticks the loop runs with the brakes engaged before the first state, `prepare()`
    between ticks."""

    def __init__(self, world, sensor_model, control_period_ns):
        self._world = world
        friction = getattr(world, 'friction', None)     # the drive's friction and rotor inertia, when modelled
        loss = world.joint_friction_torque if friction is not None and friction.active else None
        self._sensors = (Sensors(world, sensor_model, control_period_ns, loss)
                         if sensor_model.measuring or loss is not None else None)
        self._line = ActuationLine(world, sensor_model.actuation_ticks) if sensor_model.actuation_ticks else None
        self.measured = world if self._sensors is None else self._sensors
        self.warm_up_ticks = sensor_model.measurement_ticks
        self.hold = world.hold_torque if self._line is None else self._line.command
        self.step = world.step if self._sensors is None and self._line is None else self._step

    def prepare(self, answered=False):
        """Between ticks (lockstep: once a state is published; realtime: once its answer is in, `answered`): what the
        next tick needs that no command changes, formed ahead (World.prepare, Sensors.prepare); and the next tick's
        step for the torque it will hold when that is known now: the command the actuation line has due, or else
        the torque held, with no line once the answer is in. The same results; a second call before the tick does
        nothing."""
        held = None
        if self._line is not None:
            held = self._line.due()
            held = self._world.held if held is None else held
        elif answered:
            held = self._world.held
        self._world.prepare(held)
        if self._sensors is not None:
            self._sensors.prepare()

    def _step(self, k):
        if self._line is not None:
            self._line.tick()
        self._world.step(k)
        if self._sensors is not None:
            self._sensors.measure()

    def release(self, values):
        if self._line is None:
            self._world.brake(False)
            self._world.hold_torque(values)
        else:
            self._line.command(values, release=True)

    def engage(self):
        self._world.brake(True)
        if self._line is not None:
            self._line.cancel_release()

    def restart(self):
        if self._line is not None:
            self._line.clear()
        if self._sensors is not None:
            self._sensors.restart()
