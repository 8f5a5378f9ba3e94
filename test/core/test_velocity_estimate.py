"""The velocity estimated from the positions (robot_control.core.velocity) and the Controller using it.

The filter against its equation (Tustin coefficients, a ramp's velocity exactly, the gain at f_c), its
restarts; a JointState without velocities answered with the estimate; velocity_filter.cutoff_hz replacing
the message's velocities; /diagnostics naming the source.

In process on the simulated iiwa (sim_bridge.world.World at 1 kHz with the typical profile's joint
friction, rotor inertia and, through sim_bridge.sensors, its encoder (1.8e-4 rad per count, velocities
as count differences) and velocity noise (0.0075 rad/s)), joint_impedance (K = 100 N m/rad), f_c = 50 Hz:
  - at rest for 1 s, the std of tau_k - tau_{k-1} per joint falls from 0.0065-0.34 N m (the driver's
    velocities) to 4e-5-5.8e-3 N m (the estimate): 47x to 229x less (measured), checked >= 5x;
  - a 0.5 rad quintic move of every joint in 2 s (2.5 s run): the RMS tracking error with noise and the
    estimate is 1.00x the noise-free one with the driver's exact velocities (0.999-1.003, measured; the
    friction's 2-17 mrad dominates), checked <= 1.5x.
Without the friction the noise-free RMS is 1.5e-6-6e-5 rad and the estimate's lag (about 1 / w_c = 3.2 ms
of the acceleration's velocity change) makes it 6-30x that; at rest the chatter then falls 4x (joint 7)
to 23x: those figures are not asserted.
"""
import math

import numpy as np
import pytest

from robot_control.core.config import ControllerConfig
from robot_control.core.controller import Command, Controller, Rejection
from robot_control.core.velocity import DEFAULT_CUTOFF_HZ, VelocityEstimator, tustin_coefficients
from robot_control.models import for_scenario, make_model
from robot_control.validation import ArgumentError
from sim_bridge.sensors import Driver, SensorModel
from sim_bridge.world import World

T = 0.001
NS = 1_000_000
TYPICAL_FRICTION = {'coulomb': [1.8, 1.8, 1.0, 1.0, 0.63, 0.23, 0.23],      # config/realism/iiwa_typical.yaml
                    'viscous': [0.17, 0.17, 0.093, 0.093, 0.058, 0.021, 0.021], 'armature': [0.1] * 7}
ENCODER, VELOCITY_STD = 1.8e-4, 0.0075                                        # rad per count, rad/s


def test_the_coefficients_are_tustin_s_of_w_s_over_s_plus_w():
    w = 2 * math.pi * 50.0
    a, b = tustin_coefficients(50.0, T)
    assert a == pytest.approx((2 - w * T) / (2 + w * T), rel=1e-14)
    assert b == pytest.approx(2 * w / (2 + w * T), rel=1e-14)


def test_a_ramp_s_velocity_is_estimated_exactly_and_a_sine_at_f_c_at_about_1_over_sqrt_2():
    est = VelocityEstimator(2)
    v = np.array([0.3, -1.2])
    for k in range(200):                  # 200 ms = 63 time constants of 1 / w_c
        qd = est.update(k * T, v * k * T, None, 50.0)
    np.testing.assert_allclose(qd, v, rtol=1e-12)
    est.reset()
    f = 50.0
    q = [np.array([math.sin(2 * math.pi * f * k * T), 0.0]) for k in range(400)]
    out = np.array([est.update(k * T, q[k], None, f)[0] for k in range(400)])
    amplitude = np.abs(out[200:]).max() / (2 * math.pi * f)
    assert amplitude == pytest.approx(1 / math.sqrt(2), rel=0.02)


def test_a_restart_starts_from_the_measured_velocity_or_from_rest():
    est = VelocityEstimator(2)
    np.testing.assert_array_equal(est.update(0.0, np.zeros(2), np.array([1.0, 2.0]), 50.0), [1.0, 2.0])
    est.update(0.001, np.array([0.001, 0.002]), None, 50.0)
    np.testing.assert_array_equal(est.update(0.0005, np.zeros(2), None, 50.0), [0.0, 0.0])    # time went back
    est.update(0.0015, np.array([0.5, 0.5]), None, 50.0)
    est.reset()
    np.testing.assert_array_equal(est.update(0.1, np.zeros(2), np.array([3.0, 4.0]), 50.0), [3.0, 4.0])


def _ramp_controller(cutoff=0.0):
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    return Controller(ControllerConfig(model, law='joint_impedance', velocity_cutoff_hz=cutoff), 0.5), model


def _ramp(controller, velocities, ticks=300, v=(0.2, 0.05)):
    """States of q = q0 + v t at 1 kHz; velocities(k) -> the message's velocities. The last result."""
    names, q0, v = controller.config.joints, np.array([0.0, 1.0]), np.array(v)
    for k in range(ticks):
        result = controller.step(k * NS, names, (q0 + v * k * T).tolist(), velocities(k, v))
        assert isinstance(result, Command), result.reason
    return result


def _law_value(controller, name='velocity'):
    (_, _, _, values) = [s for s in controller.statuses('c', 0, 0) if s[0] == 'c: control law'][0]
    return dict(values)[name]


def test_a_joint_state_without_velocities_is_answered_with_the_estimate():
    """After 0.3 s of a ramp (95 time constants) the command equals the one for the exact velocities."""
    exact, _ = _ramp_controller()
    tau_exact = _ramp(exact, lambda k, v: v.tolist()).tau.copy()
    assert _law_value(exact) == 'measured'
    none, _ = _ramp_controller()
    tau = _ramp(none, lambda k, v: []).tau
    np.testing.assert_allclose(tau, tau_exact, rtol=1e-9, atol=1e-9)
    assert _law_value(none) == f'estimated: first-order low-pass differentiator, Tustin, f_c = {DEFAULT_CUTOFF_HZ:g} Hz'
    bad = none.step(300 * NS, none.config.joints, [0.0, 1.0], [0.0])       # one velocity for two joints
    assert isinstance(bad, Rejection) and bad.reason.startswith('velocity: expected one entry per name (2) or none')
    nan = none.step(300 * NS, none.config.joints, [math.nan, 1.0], [])
    assert isinstance(nan, Rejection) and nan.reason.startswith('position: not finite for')


def test_cutoff_hz_replaces_the_message_s_velocities_by_the_estimate():
    exact, _ = _ramp_controller()
    tau_exact = _ramp(exact, lambda k, v: v.tolist()).tau.copy()
    filtered, _ = _ramp_controller(cutoff=20.0)
    wrong = _ramp(filtered, lambda k, v: (v + (-1.0) ** k).tolist())       # +-1 rad/s of alternating noise
    np.testing.assert_allclose(wrong.tau, tau_exact, rtol=1e-9, atol=1e-9)
    assert _law_value(filtered).endswith('f_c = 20 Hz')
    with pytest.raises(ArgumentError, match='^velocity_cutoff_hz'):
        ControllerConfig(make_model('polar_two_link', m=2.0, gravity=9.8), velocity_cutoff_hz=-1.0)


def _run_iiwa(noise, cutoff, move, seconds):
    """joint_impedance on the iiwa with the typical friction, the driver's sensors with or without the
    typical encoder and velocity noise: (torques (k, 7), errors q - q_d (k, 7))."""
    z = np.zeros(7)
    sensors = SensorModel(z, np.full(7, VELOCITY_STD) if noise else z, z, np.full(7, ENCODER) if noise else z,
                          np.zeros(6), np.zeros(6), 0, 0, 1)
    config = ControllerConfig(for_scenario('iiwa'), law='joint_impedance', velocity_cutoff_hz=cutoff)
    with World('iiwa', dt=T, friction=TYPICAL_FRICTION) as world:
        driver = Driver(world, sensors, NS)
        driver.restart()
        controller = Controller(config, 0.5)
        if move:
            controller.core.set_goal(np.array(world.state()[0]) + 0.5, 2.0)
        ticks = int(round(seconds / T))
        taus, errors = np.empty((ticks, 7)), np.empty((ticks, 7))
        for k in range(ticks):
            q, qd, _ = driver.measured.state_values()
            command = controller.step(k * NS, config.joints, q, qd)
            taus[k] = command.tau
            errors[k] = world.state()[0] - controller.core.joint_reference[0]
            driver.hold(command.values)
            driver.step(1)
    return taus, errors


def test_on_the_iiwa_the_estimate_cuts_the_chatter_at_rest_5x_and_keeps_the_tracking():
    chatter = {cutoff: np.diff(_run_iiwa(True, cutoff, False, 1.0)[0], axis=0).std(axis=0) for cutoff in (0.0, 50.0)}
    ratio = chatter[0.0] / np.maximum(chatter[50.0], 1e-12)
    assert ratio.min() >= 5.0, (ratio, chatter)
    rms = {noise: np.sqrt((_run_iiwa(noise, 50.0 if noise else 0.0, True, 2.5)[1] ** 2).mean(axis=0))
           for noise in (False, True)}
    assert (rms[True] / rms[False]).max() <= 1.5, rms
