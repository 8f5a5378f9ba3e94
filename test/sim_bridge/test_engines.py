"""Both physics engines behind one interface (sim_bridge.engines.make_world): the same closed loop,
the same commands, the same results.

Computed torque (robot_control.laws.computed_torque, kp = 100, kv = 20 on every joint, the
controller's model of the scenario) tracks a 2 s rest-to-rest quintic from an initial error of
0.02 rad (m) and holds the end for 0.5 s, in process at a 1 ms step with a zero-order hold: the
tracking RMS (4.47 mrad, mostly the initial error's decay) is below 6 mrad on both engines and within
1 mrad of each other (measured: the runs agree to 5e-16 rad on the iiwa and the polar robot: MuJoCo's
and PyBullet's semi-implicit Euler steps of the same dynamics). Brakes hold against a disturbance with at most the effort limit; disturbances act
as J^T f; efforts are clipped; reset is bit-identical; time is integer nanoseconds.
"""
import functools

import numpy as np
import pytest

from robot_control.gains import ServoGains
from robot_control.laws import computed_torque
from robot_control.models import for_scenario
from robot_control.validation import ArgumentError
from sim_bridge.engines import make_world

DT = 0.001
MOVES = {'iiwa': (np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0]), np.array([0.4, 0.8, -0.3, -0.9, 0.3, 0.7, 0.2])),
         'polar_two_link': (np.array([0.0, 0.5]), np.array([0.8, 0.8]))}


def quintic(q0, q1, T, t):
    """Rest-to-rest quintic from q0 to q1 in T s: (q, qd, qdd) at time t (held after T)."""
    s = min(max(t / T, 0.0), 1.0)
    d = q1 - q0
    return (q0 + d * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5), d * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / T,
            d * (60 * s - 180 * s ** 2 + 120 * s ** 3) / T ** 2)


@functools.lru_cache(maxsize=None)
def tracking(name, engine):
    """(positions (steps + 1, n), tracking errors (steps + 1, n)) of computed torque on `engine`."""
    q0, q1 = MOVES[name]
    model, gains = for_scenario(name), ServoGains.uniform(len(q0), 100.0, 20.0)
    world = make_world(engine, name, surface=False, q0=q0 + 0.02)
    try:
        qs, errors = [], []
        for k in range(2501):
            q_d, qd_d, qdd_d = quintic(q0, q1, 2.0, world.t)
            q, qd, _ = world.state()
            qs.append(q)
            errors.append(q_d - q)
            if k < 2500:
                world.hold_torque(computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains))
                world.step()
        assert world.t_ns == 2500 * 1_000_000
        return np.array(qs), np.array(errors)
    finally:
        world.close()


def _rms(errors):
    return float(np.sqrt(np.mean(errors ** 2)))


@pytest.mark.parametrize('name', sorted(MOVES))
def test_computed_torque_tracks_the_quintic_and_holds(name, engine):
    _, errors = tracking(name, engine)
    assert _rms(errors) < 6e-3
    assert np.abs(errors[-1]).max() < 1e-4            # holding the end, the initial error gone
    assert np.abs(errors[0]).max() == pytest.approx(0.02)


@pytest.mark.parametrize('name', sorted(MOVES))
def test_both_engines_track_alike(name):
    (q_b, e_b), (q_m, e_m) = tracking(name, 'pybullet'), tracking(name, 'mujoco')
    print(f'{name}: RMS pybullet {_rms(e_b):.3e}, mujoco {_rms(e_m):.3e}, max |q_b - q_m| {np.abs(q_b - q_m).max():.1e}')
    assert abs(_rms(e_b) - _rms(e_m)) < 1e-3


def test_the_brakes_hold_with_at_most_the_effort_limit(world_on):
    world = world_on('iiwa', surface=False)
    q0 = world.state()[0]
    world.set_disturbance(joint_torque=np.full(world.n, 20.0))
    world.brake(True)
    world.set_torque(np.full(world.n, 50.0))            # kept for the release, not applied
    world.step(1000)
    q, _, applied = world.state()
    assert world.braked and np.abs(q - q0).max() < 1e-3
    assert np.all(np.abs(applied) <= world.effort_limit + 1e-9)
    world.brake(False)
    assert not world.braked and world.state()[2] == pytest.approx(np.minimum(50.0, world.effort_limit))


def test_a_brake_weaker_than_the_load_slips(world_on):
    world = world_on('single_link', surface=False)
    world.set_disturbance(joint_torque=[1.5 * world.effort_limit[0]])
    world.brake(True)
    world.step(200)
    assert world.state()[0][0] > 0.01 and world.state()[2][0] == pytest.approx(-world.effort_limit[0])


def test_a_cartesian_force_acts_as_jacobian_transpose(world_on):
    world = world_on('iiwa', surface=False)
    model = for_scenario('iiwa')
    q = world.state()[0]
    f = np.array([5.0, -3.0, 8.0])
    world.set_disturbance(cartesian_force=f)
    world.hold_torque(model.g(q))
    world.step()
    _, qd, _ = world.state()
    expected = np.linalg.solve(model.M(q), model.J(q).T @ f) * DT     # from rest: qd = M^-1 J^T f dt
    assert np.abs(qd - expected).max() < 1e-4 * np.abs(expected).max()


def test_torque_is_clipped_and_reset_is_exact(world_on):
    world = world_on('polar_two_link', surface=False)
    assert world.set_torque([1e6, -1e6]) == pytest.approx([world.effort_limit[0], -world.effort_limit[1]])
    world.step(100)
    first = world.state()
    world.reset()
    assert world.t_ns == 0 and world.state()[0] == pytest.approx(np.array([0.0, 0.5]), abs=0)
    world.set_torque([1e6, -1e6])
    world.step(100)
    for a, b in zip(first, world.state()):
        np.testing.assert_array_equal(a, b)


def test_the_tip_position_is_the_models_forward_kinematics(world_on):
    """To 1e-7 m: PyBullet reports link states in single precision."""
    world = world_on('iiwa', surface=False)
    world.set_torque(np.full(world.n, 5.0))
    world.step(50)
    assert world.tip_position() == pytest.approx(for_scenario('iiwa').fk(world.state()[0]), abs=1e-7)


def test_an_unknown_engine_is_named():
    with pytest.raises(ArgumentError) as err:
        make_world('ode', 'iiwa')
    assert err.value.name == 'engine'


def test_a_heavier_robot_is_the_same_on_both_engines():
    """mass_scale 1.4 and inertia_scale 1.2 on every iiwa link (sim_bridge.true_robot, the `sim.*` parameters):
    one step from rest under the nominal model's g(q) is the same on both engines (1e-9 relative), and unlike
    the nominal robot's (it sags)."""
    params = {'mass_scale': np.full(7, 1.4), 'inertia_scale': np.full(7, 1.2)}
    g = for_scenario('iiwa').g(MOVES['iiwa'][0])
    qd = {}
    for engine, p in (('pybullet', params), ('mujoco', params), ('nominal', None)):
        with make_world('mujoco' if engine == 'nominal' else engine, 'iiwa', surface=False, params=p) as world:
            world.hold_torque(g)
            world.step()
            qd[engine] = world.state()[1]
    np.testing.assert_allclose(qd['mujoco'], qd['pybullet'], rtol=1e-9, atol=1e-9 * np.abs(qd['pybullet']).max())
    assert np.abs(qd['nominal']).max() < 1e-9 < 1e-3 * np.abs(qd['mujoco']).max()
