"""Integration at rest (integral_rest_velocity, robot_control.laws.integral.moving) against the hunting integral.

In process on the simulated iiwa (sim_bridge.world.World at 1 kHz) with the typical profile's joint
friction and rotor inertia (config/realism/iiwa_typical.yaml: friction.coulomb, friction.viscous,
armature), a 0.2 rad move of every joint in 1 s, then a hold:
  - computed torque PID (kp, kv, ki = 108, 18, 216: the designed PID of omega_res = 12 rad/s) hunts:
    joint 7 swings over 1.02 rad in the last 10 s of 30 s (0.5-1.0 rad between 5 and 15 s, measured),
    checked > 0.1 rad in 5-15 s. The cause is its integral on the unmodelled armature (Routh, see
    robot_control.laws.integral), bounded by the friction: without any friction it grows to +-3 rad;
  - the same with integral_rest_velocity = 0.01 rad/s: in the last 10 s of 30 s no joint moves more
    than 2e-6 rad (measured), checked <= 1 mrad. Its final error is 0.1-1.9 mrad on joints 1-5, 3.2 and
    16 mrad on joints 6-7 (measured; not asserted): computed torque's wrist stiffness M_ii kp (0.11 N m/rad
    on joint 7) cannot move against 0.23 N m of friction, the integral at rest does it alone and winds at
    M_ii ki E (N m/s);
  - joint_impedance with its integral (K = 100 N m/rad, ki = 100 N m/(rad s)) and the same setting: final
    error <= 0.012 mrad, no motion in the last 10 s of 20 s (measured), checked <= 2 mrad and <= 1 mrad.
    Joint impedance does not hunt there without it either (final 0.012 mrad, no motion over 10-30 s,
    measured): the simulator's stiction equals its Coulomb friction, and the law's damping is designed
    on the true stiffness K.
"""
import numpy as np
import pytest

from robot_control.core.config import ControllerConfig
from robot_control.laws.servo import gain_params
from robot_control.core.tick import ControllerCore
from robot_control.gains import ServoGains
from robot_control.laws.integral import moving
from robot_control.models import for_scenario, make_model
from robot_control.validation import ArgumentError
from sim_bridge.world import World

DT = 0.001
STEP = 0.2
TYPICAL_FRICTION = {'coulomb': [1.8, 1.8, 1.0, 1.0, 0.63, 0.23, 0.23],
                    'viscous': [0.17, 0.17, 0.093, 0.093, 0.058, 0.021, 0.021], 'armature': [0.1] * 7}
PID = ServoGains([108.0] * 7, [18.0] * 7, [216.0] * 7)


def test_an_entry_integrates_only_while_its_error_is_at_rest():
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    cfg = ControllerConfig(model, integral=True, law_params=gain_params(ServoGains([4.0] * 2, [4.0] * 2, [1.0] * 2)),
                           integral_rest_velocity=0.01)
    core = ControllerCore(cfg)
    core.update(0.0, [0.0, 1.0], [0.0, 0.0])
    core.set_goal([0.1, 1.1], 1e-3)
    core.update(0.002, [0.0, 1.0], [0.0, 0.0])            # both at rest: E = 0.1 each integrated 2 ms
    np.testing.assert_allclose(core.integral_value, [2e-4, 2e-4], rtol=1e-12)
    core.update(0.004, [0.0, 1.0], [0.02, 0.005])         # joint 1 moves (|Ed| = 0.02 > 0.01): held
    np.testing.assert_allclose(core.integral_value, [2e-4, 4e-4], rtol=1e-12)
    np.testing.assert_array_equal(moving(np.array([0.01, -0.011]), 0.01), [False, True])
    assert moving(np.zeros(2), np.inf) is None
    with pytest.raises(ArgumentError, match='^integral_rest_velocity'):
        cfg.replace(integral_rest_velocity=0.0)


def _hold(config, seconds):
    """Positions minus the target, (k, 7), of `config` on the iiwa with the typical friction: a 0.2 rad move of
    every joint in 1 s from the scenario's start, then the hold."""
    with World('iiwa', dt=DT, friction=TYPICAL_FRICTION) as world:
        q0 = np.array(world.state()[0])
        core = ControllerCore(config)
        core.set_goal(q0 + STEP, 1.0)
        ticks = int(round(seconds / DT))
        q = np.empty((ticks, 7))
        for k in range(ticks):
            q[k], qd, _ = world.state()
            world.set_torque(core.update(k * DT, q[k], qd))
            world.step(1)
    return q - q0 - STEP


def _travel(errors):
    """Largest minus smallest position per joint, rad."""
    return errors.max(axis=0) - errors.min(axis=0)


def test_computed_torque_pid_hunts_under_the_friction_and_stops_when_integrating_at_rest():
    model = for_scenario('iiwa')
    hunting = _hold(ControllerConfig(model, law_params=gain_params(PID), integral=True), 15.0)
    assert _travel(hunting[5000:])[6] > 0.1, _travel(hunting[5000:])
    at_rest = _hold(ControllerConfig(model, law_params=gain_params(PID), integral=True, integral_rest_velocity=0.01),
                    30.0)
    assert _travel(at_rest[-10000:]).max() <= 1e-3, _travel(at_rest[-10000:])


def test_joint_impedance_holds_within_2_mrad_under_the_friction_when_integrating_at_rest():
    errors = _hold(ControllerConfig(for_scenario('iiwa'), law='joint_impedance', integral=True,
                                    integral_rest_velocity=0.01), 20.0)
    assert np.abs(errors[-1]).max() <= 2e-3, errors[-1]
    assert _travel(errors[-10000:]).max() <= 1e-3, _travel(errors[-10000:])
