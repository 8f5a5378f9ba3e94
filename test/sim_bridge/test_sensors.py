"""The robot's driver (sim_bridge.sensors) over a real World: noise statistics, encoder counts, the link-side
joint torque, the F/T sensor's bias and noise, measurement and actuation delays through the bridge's loop
(sim_bridge.bridge_loop), and one seed -> one bit-identical run; on each engine (the `engine` fixture)."""
import numpy as np
import pytest

from robot_control.models import make_model
from sim_bridge import bridge_params
from sim_bridge.bridge_loop import make_loop
from sim_bridge.sensors import Driver, Sensors, encoder_counts
from sim_bridge.engines import make_world

MS = 1_000_000
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
JOINTS = ['theta1', 'r']
Q0 = np.array([0.0, 0.5])
SAMPLES = 5000


def sensor_model(**params):
    """The SensorModel of the bridge's parameters (keys as in ROS, e.g. {'noise.position_std': [...]})."""
    return bridge_params.validate(bridge_params.defaults('polar_two_link', **params)).sensors


@pytest.fixture
def world(engine):
    w = make_world(engine, 'polar_two_link')
    yield w
    w.close()


def held_run(world, sensors, ticks=SAMPLES):
    """`ticks` control ticks holding g(q0) (the robot stays at q0): per tick the published (q, qd, effort,
    wrench (6,)) and the World's own (q, qd, tau) as four and three (ticks, .) arrays."""
    world.hold_torque(POLAR.g(Q0))
    published, true = [], []
    for _ in range(ticks):
        world.step()
        sensors.measure()
        published.append((*sensors.state_values(), np.concatenate(sensors.contact_wrench())))
        true.append(world.state_values())
    return [np.array(x) for x in zip(*published)], [np.array(x) for x in zip(*true)]


def assert_gaussian(noise, std):
    """Measured std within 5 % of `std` per column and the mean within 4 standard errors of 0."""
    np.testing.assert_allclose(noise.std(axis=0), std, rtol=0.05)
    assert np.all(np.abs(noise.mean(axis=0)) < 4.0 * np.asarray(std) / np.sqrt(len(noise)))


# -- what the sensors deliver -------------------------------------------------------------------------------
def test_joint_noise_has_the_set_std_and_zero_mean(world):
    model = sensor_model(**{'noise.position_std': [1e-3, 2e-4], 'noise.velocity_std': [0.05, 0.01],
                            'noise.effort_std': [0.3, 0.1]})
    (q, qd, effort, _), (q_true, qd_true, tau) = held_run(world, Sensors(world, model, MS))
    assert np.abs(q_true - Q0).max() < 1e-6                   # the robot stands still: the spread is the noise
    assert_gaussian(q - q_true, [1e-3, 2e-4])
    assert_gaussian(qd - qd_true, [0.05, 0.01])
    assert_gaussian(effort - tau, [0.3, 0.1])
    streams = [q - q_true, qd - qd_true, effort - tau]
    assert all(abs(np.corrcoef(a[:, 0], b[:, 0])[0, 1]) < 0.05 for a, b in zip(streams, streams[1:]))


def test_wrench_is_the_true_one_plus_bias_plus_noise(world):
    bias, std = [1.0, -2.0, 0.5, 0.1, 0.0, -0.3], [0.2, 0.2, 0.4, 0.02, 0.02, 0.05]
    sensors = Sensors(world, sensor_model(wrench_bias=bias, **{'noise.wrench_std': std}), MS)
    (_, _, _, wrench), _ = held_run(world, sensors)
    assert not np.any(np.concatenate(world.contact_wrench()))  # no surface: the true wrench is zero
    assert_gaussian(wrench - bias, std)


def test_positions_are_whole_encoder_counts_and_velocities_their_differences(world):
    """r pushed at 1 m/s^2 from rest crosses many counts of 1e-4 m in 0.5 s; theta1 has no encoder."""
    r = 1e-4
    sensors = Sensors(world, sensor_model(encoder_resolution=[0.0, r]), MS)
    world.hold_torque(POLAR.g(Q0) + [0.0, 2.0])
    q, qd, q_true = [], [], []
    for _ in range(500):
        world.step()
        sensors.measure()
        q.append(sensors.state_values()[0])
        qd.append(sensors.state_values()[1])
        q_true.append(world.state_values()[0])
    q, qd, q_true = np.array(q), np.array(qd), np.array(q_true)
    counts = q[:, 1] / r
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)        # whole counts
    steps = np.diff(q[:, 1])
    moved = steps[steps != 0.0]
    assert len(moved) > 100
    np.testing.assert_allclose(moved, r * np.round(moved / r), rtol=0, atol=1e-12)    # whole counts per tick
    assert np.abs(q[:, 1] - q_true[:, 1]).max() <= r / 2 + 1e-12
    np.testing.assert_allclose(qd[1:, 1], steps / 1e-3, rtol=1e-9)                  # the driver's differences
    assert q[:, 0].tolist() == q_true[:, 0].tolist()                               # no encoder, no noise: exact
    assert encoder_counts(np.array([0.30, -0.26]), np.array([0.1, 0.0])).tolist() == [0.1 * 3, -0.26]


def test_noise_before_the_encoder_leaves_whole_counts(world):
    r = 1e-3
    sensors = Sensors(world, sensor_model(encoder_resolution=[r, r], **{'noise.position_std': [2e-3, 2e-3]}), MS)
    (q, _, _, _), (q_true, _, _) = held_run(world, sensors, 2000)
    np.testing.assert_allclose(q / r, np.round(q / r), rtol=0, atol=1e-6)
    assert 0.8 * 2e-3 < (q - q_true).std() < 1.2 * 2e-3 and len(np.unique(q[:, 0])) > 5


def test_effort_is_the_applied_torque_without_a_friction_model(world):
    sensors = Sensors(world, sensor_model(**{'noise.position_std': [1e-3, 1e-3]}), MS)
    (_, _, effort, _), (_, _, tau) = held_run(world, sensors, 50)
    assert effort.tolist() == tau.tolist()
    np.testing.assert_allclose(effort, np.tile(POLAR.g(Q0), (50, 1)), rtol=1e-12)


def test_effort_is_the_motor_torque_less_friction_and_rotor_inertia(engine):
    """A link-side torque sensor: held at rest by stiction, the link needs g(q0) whatever the motor gives
    within the breakaway band, so the effort reads g(q0) while the motor applies g(q0) + 0.3; slipping at
    speed under Coulomb and viscous friction and armature it reads tau_motor - (F_c sign(qd) + b qd + I_a qdd)."""
    friction = {'coulomb': [1.0, 1.0], 'viscous': [0.0, 0.0], 'armature': [0.0, 0.0]}
    with make_world(engine, 'polar_two_link', q0=Q0, friction=friction) as w:
        driver = Driver(w, sensor_model(), MS)
        assert driver.measured is not w                          # the friction model alone turns the sensor on
        motor = POLAR.g(Q0) + 0.3
        w.hold_torque(motor)
        for _ in range(20):
            driver.step(1)
        q, _, effort = driver.measured.state_values()
        np.testing.assert_allclose(q, Q0, atol=1e-12)           # stuck: 0.3 N m is inside the band
        np.testing.assert_allclose(effort, POLAR.g(Q0), atol=1e-9)
        assert w.state()[2].tolist() == motor.tolist()          # the motor torque the World reports
    friction = {'coulomb': [0.5, 0.0], 'viscous': [0.2, 0.0], 'armature': [0.3, 0.0]}
    with make_world(engine, 'polar_two_link', q0=Q0, friction=friction) as w:
        driver = Driver(w, sensor_model(), MS)
        motor = POLAR.g(Q0) + np.array([3.0, 0.0])
        w.hold_torque(motor)
        for _ in range(200):
            q_before, qd_before, _ = w.state()
            driver.step(1)
        q, qd, effort = driver.measured.state_values()
        qdd = (qd[0] - qd_before[0]) / 1e-3
        loss = 0.5 * np.sign(qd[0]) + 0.2 * qd[0] + 0.3 * qdd
        assert qd[0] > 0.1
        assert effort[0] == pytest.approx(motor[0] - loss, rel=2e-3)


def test_the_driver_prepares_the_next_step_for_the_torque_it_will_hold():
    """Driver.prepare hands the World the torque the next tick holds when that is known: with an actuation line the
    command falling due (the torque held when none does), without one the held torque once the answer is in."""
    with make_world('pybullet', 'polar_two_link', q0=Q0, friction={'coulomb': [1.0, 1.0]}) as w:
        seen, prepare = [], w.prepare
        w.prepare = lambda tau=None: seen.append(None if tau is None else list(tau)) or prepare(tau)
        w.hold_torque([0.5, 0.5])
        driver = Driver(w, sensor_model(), MS)
        driver.hold([1.0, 2.0])
        driver.prepare()
        driver.prepare(answered=True)
        assert seen == [None, [1.0, 2.0]]
        delayed = Driver(w, sensor_model(**{'delay.actuation_ticks': 1}), MS)
        delayed.hold([3.0, 4.0])
        delayed.prepare()                                  # nothing due yet: the torque held
        delayed.step(1)
        delayed.prepare()                                  # [3, 4] falls due at the next tick
        assert seen[2:] == [[1.0, 2.0], [3.0, 4.0]]


def test_with_nothing_modelled_the_loop_publishes_and_steps_the_world_itself(world):
    driver = Driver(world, sensor_model(), MS)
    assert driver.measured is world and driver.step == world.step and driver.hold == world.hold_torque
    assert driver.warm_up_ticks == 0


# -- through the loop: delays and seeds -----------------------------------------------------------------------
class Recorder:
    """The node's side of the loop: per publication the published stamp, q, qd, effort and wrench, and the
    World's time, position and held torque at that moment."""

    def __init__(self, world):
        self.world = world
        self.loop = None
        self.now = 0
        self.rows = []

    def publish_state(self, in_loop, with_clock):
        m, w = self.loop.measured, self.world
        q, qd, effort = m.state_values()
        self.rows.append({'stamp': m.t_ns, 't': w.t_ns, 'q': list(q), 'qd': list(qd), 'effort': list(effort),
                          'wrench': np.concatenate(m.contact_wrench()).tolist(), 'q_true': list(w.state_values()[0]),
                          'held': list(w.state_values()[2]), 'braked': w.braked})
        return self.now


@pytest.fixture
def loop(engine):
    """loop(**parameters) -> (a started loop over a polar_two_link World, its Recorder)."""
    worlds = []

    def make(**params):
        cfg = bridge_params.validate(bridge_params.defaults('polar_two_link', engine=engine, **params))
        worlds.append(make_world(engine, 'polar_two_link', dt=cfg.physics_step))
        rec = Recorder(worlds[-1])
        rec.loop = make_loop(worlds[-1], cfg, publish_state=rec.publish_state, count_publishers=lambda: [1, 0],
                             publish_diagnostics=lambda: None, log=lambda level, text: None, clock=lambda: rec.now,
                             restart_timer=lambda: None)
        rec.loop.start()
        return rec.loop, rec
    yield make
    for w in worlds:
        w.close()


def pd(q, qd):
    return (POLAR.g(np.array(q)) + 36.0 * ([0.5, 0.8] - np.array(q)) - 12.0 * np.array(qd)).tolist()


def answer(loop, rec, ticks, law=pd):
    """Lockstep: answer the latest published state `ticks` times with `law`(q, qd), stamped like it."""
    for _ in range(ticks):
        row = rec.rows[-1]
        loop.on_joint_command(row['stamp'], JOINTS, law(row['q'], row['qd']))


def test_lockstep_measurement_delay_publishes_the_state_of_d_ticks_ago_stamped_then(loop):
    d = 3
    lp, rec = loop(mode='lockstep', **{'delay.measurement_ticks': d})
    first = rec.rows[0]
    assert (first['stamp'], first['t'], first['q']) == (0, d * MS, Q0.tolist())   # after the braked warm-up
    answer(lp, rec, 300)
    assert lp.ticks == 300 and lp.gate.late == lp.gate.future == 0                 # every answer paired
    assert [r['stamp'] for r in rec.rows] == [k * MS for k in range(301)]          # new, later stamps only
    truth = {r['t']: r['q_true'] for r in rec.rows}
    for r in rec.rows[1:]:
        assert r['t'] - r['stamp'] == d * MS
        if r['stamp'] in truth:
            assert r['q'] == truth[r['stamp']]
    assert rec.rows[-1]['q'][1] > 0.6 and not lp.brakes_engaged and not rec.rows[-1]['braked']    # PD at work


def test_realtime_measurement_delay_answers_are_timely_and_paired_by_the_published_stamp(loop):
    """Realtime, d = 2: pacing starts after the braked warm-up; a command answering the latest published state
    (stamped 2 ticks before the World's time) is fresh, releases the brakes and counts as a deadline hit."""
    lp, rec = loop(**{'delay.measurement_ticks': 2})
    assert (rec.rows[0]['stamp'], rec.rows[0]['t'], lp.ticks) == (0, 2 * MS, 0) and rec.world.braked
    for k in range(1, 51):
        row = rec.rows[-1]
        lp.on_joint_command(row['stamp'], JOINTS, pd(row['q'], row['qd']))
        rec.now = k * MS
        lp.on_timer()
    assert [r['stamp'] for r in rec.rows] == [k * MS for k in range(51)]
    assert all(r['t'] - r['stamp'] == 2 * MS for r in rec.rows)
    assert lp.outdated_commands == 0 and not lp.brakes_engaged and not rec.world.braked
    values = {s.name: s.values for s in lp.diagnostics()}
    assert values['pacing']['deadline_hits'] == 50 and values['pacing']['deadline_misses'] == 0


def test_lockstep_actuation_delay_changes_the_held_torque_d_ticks_after_the_command(loop):
    a = 2
    lp, rec = loop(mode='lockstep', **{'delay.actuation_ticks': a})
    answer(lp, rec, 10, law=lambda q, qd: [float(len(rec.rows)), -1.0])       # command i: [i, -1] at tick i - 1
    held = [r['held'] for r in rec.rows[1:]]                                  # during the step after answer i
    assert held[:a] == [[0.0, 0.0]] * a                                      # nothing in force yet
    assert held[a:] == [[float(i), -1.0] for i in range(1, 11 - a)]


def test_realtime_brakes_release_when_the_releasing_command_takes_effect(loop):
    a = 3
    lp, rec = loop(**{'delay.actuation_ticks': a})
    assert lp.brakes_engaged and rec.world.braked                            # no command yet
    lp.on_joint_command(0, JOINTS, POLAR.g(Q0).tolist())
    assert not lp.brakes_engaged
    braked = []
    for k in range(1, 6):
        rec.now = k * MS
        lp.on_timer()
        braked.append(rec.rows[-1]['braked'])
    assert braked == [True] * a + [False] * 2
    np.testing.assert_allclose(rec.rows[-1]['held'], POLAR.g(Q0))


NOISY = {'noise.position_std': [1e-3, 1e-3], 'noise.velocity_std': [0.01, 0.01], 'noise.effort_std': [0.1, 0.1],
         'noise.wrench_std': [0.1] * 6, 'encoder_resolution': [0.0, 2e-4], 'wrench_bias': [0.5] * 6,
         'delay.measurement_ticks': 2, 'delay.actuation_ticks': 1}


def noisy_run(loop, seed, reset=False):
    lp, rec = loop(mode='lockstep', seed=seed, **NOISY)
    answer(lp, rec, 200)
    if reset:
        lp.reset()
        del rec.rows[:-1]
        answer(lp, rec, 200)
    return np.array([r['q'] + r['qd'] + r['effort'] + r['wrench'] for r in rec.rows])


def test_one_seed_gives_bit_identical_published_streams_and_another_seed_others(loop):
    first, again, other = noisy_run(loop, 7), noisy_run(loop, 7), noisy_run(loop, 8)
    assert first.tobytes() == again.tobytes()
    assert np.abs(first - other).max() > 1e-3
    assert noisy_run(loop, 7, reset=True).tobytes() == first.tobytes()       # reset restarts every stream


def test_noise_drawn_ahead_between_ticks_is_the_same_noise():
    """Sensors.prepare (the bridge's call once a state is published) draws the next measurement's noise ahead:
    prepared on some ticks, twice on some, not on others, and restarted after a prepare, the published streams are
    the same bit for bit as without."""
    model = sensor_model(**{k: v for k, v in NOISY.items() if not k.startswith('delay')})
    runs = []
    for ahead in (False, True):
        world = make_world('pybullet', 'polar_two_link')
        try:
            sensors = Sensors(world, model, MS)
            world.hold_torque(POLAR.g(Q0) + 0.5)
            rows = []
            for k in range(300):
                if ahead and k % 3:
                    for _ in range(k % 3):
                        sensors.prepare()
                if k == 150:
                    sensors.restart()
                world.step()
                sensors.measure()
                rows.append(np.concatenate([*sensors.state_values(), *sensors.contact_wrench()]))
            runs.append(np.array(rows))
        finally:
            world.close()
    assert runs[0].tobytes() == runs[1].tobytes()


def test_a_realtime_measurement_delay_must_stay_below_command_timeout():
    with pytest.raises(ValueError, match='^delay.measurement_ticks: realtime'):
        bridge_params.validate(bridge_params.defaults('polar_two_link', **{'delay.measurement_ticks': 50}))
    assert bridge_params.validate(bridge_params.defaults(
        'polar_two_link', mode='lockstep', **{'delay.measurement_ticks': 50})).sensors.measurement_ticks == 50


@pytest.mark.parametrize('name, value', [('noise.position_std', [0.1]), ('noise.wrench_std', [0.1] * 5),
                                         ('encoder_resolution', [-1e-3, 0.0]), ('delay.actuation_ticks', -1),
                                         ('seed', -1)])
def test_bad_sensor_parameters_are_named(name, value):
    with pytest.raises(ValueError, match=f'^{name}:'):
        bridge_params.validate(bridge_params.defaults('polar_two_link', **{name: value}))
