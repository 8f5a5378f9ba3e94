"""Friction compensation (robot_control.laws.friction_compensation): tau_f = Fc tanh(v / v_s) + Fv v added to
every law's torque before saturation.

The function against its equation; the configuration (off when Fc = Fv = 0, errors named); in the tick,
the torque with compensation minus the torque without it is tau_f of the reference (or measured) velocity;
saturation comes after it. In process on the simulated iiwa (sim_bridge.world.World, 1 kHz), the joints'
friction -Fc sign(qd) - Fv qd applied as a disturbance torque every control tick during a 0.3 rad/s
constant-velocity stretch of every joint. Fc = 0.5 N m on joints 1-4, 0.2 on 5-6, 0.02 on 7 (Fv 0.2, 0.05,
0.005 N m s/rad): the simulated link 7 has 0.001 kg m^2 about its axis, and a Coulomb torque applied
explicitly for a 1 ms step changes its speed by Fc dt / M_77 (0.5 rad/s for 0.5 N m, more than the speed
itself: the sign flips every step). Measured, the largest |E| over 1.5-3 s: joint impedance (K = 100
N m/rad) lags by (Fc + Fv v) / K (5.6, 2.15, 0.22 mrad) without compensation and by 4e-11 to 6e-7 rad with
it (reference or measured velocity); computed torque (kp = 36 1/s^2) by 0.012-0.77 rad without and by
6e-6 to 1.4e-4 rad with it (measured velocity): 160x.
Checked: >= 10x smaller with compensation on every joint, for both laws.
"""
import numpy as np
import pytest

from robot_control.core.config import ControllerConfig
from robot_control.laws.servo import gain_params
from robot_control.core.tick import ControllerCore
from robot_control.gains import design
from robot_control.laws.friction_compensation import PREFIX, FrictionCompensation, friction_compensation
from robot_control.models import for_scenario, make_model
from robot_control.ros import controller_params as params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.param_table import ParameterError
from robot_control.validation import ArgumentError
from sim_bridge.world import World

DT = 0.001
FC = np.array([0.5, 0.5, 0.5, 0.5, 0.2, 0.2, 0.02])       # N m
FV = FC * [0.4, 0.4, 0.4, 0.4, 0.25, 0.25, 0.25]         # N m s/rad
SPEED = 0.3                                               # rad/s
POLAR = make_model('polar_two_link', m=2.0, gravity=9.8)
GAINS = design(1.0, 12.0).gains(2)


def test_the_function_is_its_equation():
    v = np.array([-0.2, -0.005, 0.0, 0.01, 1.0])
    Fc, Fv = np.array([1.0, 2.0, 3.0, 0.5, 0.0]), np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    expected = [1.0 * np.tanh(-20.0) - 0.02, -2.0 * np.tanh(0.5) - 0.001, 0.0, 0.5 * np.tanh(1.0) + 0.004, 0.5]
    np.testing.assert_allclose(friction_compensation(v, Fc, Fv, 0.01), expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(friction_compensation(v, 1.0, 0.0, 0.01), np.tanh(v / 0.01), rtol=1e-12)


@pytest.mark.parametrize('kwargs, name', [({'v': [np.nan]}, 'v'), ({'coulomb': [-1.0]}, 'coulomb'),
                                          ({'viscous': [1.0, 2.0]}, 'viscous'),
                                          ({'velocity_threshold': 0.0}, 'velocity_threshold')])
def test_argument_errors_name_the_argument(kwargs, name):
    args = dict(v=[0.1], coulomb=1.0, viscous=0.5, velocity_threshold=0.01)
    with pytest.raises(ArgumentError) as err:
        friction_compensation(**{**args, **kwargs})
    assert err.value.name == name


def test_the_configuration_holds_it_or_none_when_off():
    def held(value):
        return ControllerConfig(POLAR, law_params=gain_params(GAINS), friction_compensation=value).friction_compensation
    assert held(None) is None and held({'coulomb': [0.0], 'viscous': ()}) is None
    comp = held({'coulomb': [1.5], 'velocity': 'measured'})
    assert comp == FrictionCompensation((1.5, 1.5), (0.0, 0.0), 0.01, 'measured')
    for value, name in (({'coulomb': [1.0, 2.0, 3.0]}, 'friction_compensation.coulomb'),
                        ({'viscous': [-1.0]}, 'friction_compensation.viscous'),
                        ({'coulomb': [1.0], 'velocity_threshold': 0.0}, 'friction_compensation.velocity_threshold'),
                        ({'coulomb': [1.0], 'velocity': 'estimated'}, 'friction_compensation.velocity'),
                        ({'stiction': [1.0]}, 'friction_compensation'), ([1.0], 'friction_compensation')):
        with pytest.raises(ArgumentError) as err:
            ControllerConfig(POLAR, law_params=gain_params(GAINS), friction_compensation=value)
        assert err.value.name == name, err.value


@pytest.mark.parametrize('velocity', ['reference', 'measured'])
def test_the_tick_adds_tau_f_to_the_law_s_torque_before_saturation(velocity):
    """Computed torque on the polar arm along a move: tau(on) - tau(off) = Fc tanh(v / v_s) + Fv v, v the
    reference velocity or the measured one; with an effort limit the sum is clipped."""
    comp = {'coulomb': [2.0, 3.0], 'viscous': [0.5, 0.7], 'velocity_threshold': 0.05, 'velocity': velocity}
    off = ControllerConfig(POLAR, law_params=gain_params(GAINS))
    cores = [ControllerCore(off), ControllerCore(off.replace(friction_compensation=comp))]
    q, qd = np.array([0.3, 0.8]), np.array([0.02, -0.03])
    for core in cores:
        core.set_goal([0.6, 0.5], 1.0)
    for k in range(50):
        tau_off, tau_on = (core.update(k * DT, q, qd).copy() for core in cores)
        v = qd if velocity == 'measured' else cores[1].joint_reference[1]
        np.testing.assert_allclose(tau_on - tau_off, friction_compensation(v, comp['coulomb'], comp['viscous'], 0.05),
                                   rtol=1e-12, atol=1e-12)
    limit = 0.9 * np.abs(tau_on)
    clipped = ControllerCore(off.replace(friction_compensation=comp, effort_limit=limit))
    clipped.set_goal([0.6, 0.5], 1.0)
    for k in range(50):
        clipped.update(k * DT, q, qd)
    np.testing.assert_allclose(clipped.tau, np.clip(tau_on, -limit, limit), rtol=1e-12, atol=1e-12)
    assert clipped.saturated.all()


def test_the_parameters_reach_the_configuration_through_the_config_builder():
    rows, values = params.TABLE.resolve()
    assert rows[PREFIX + 'velocity'].default == 'reference' and values[PREFIX + 'coulomb'] == ()
    cfg = ConfigBuilder()(params.TABLE.validate({'scenario': 'polar_two_link', PREFIX + 'coulomb': [1.0, 2.0],
                                                  PREFIX + 'velocity_threshold': 0.02}))
    assert cfg.friction_compensation == FrictionCompensation((1.0, 2.0), (0.0, 0.0), 0.02, 'reference')
    with pytest.raises(ParameterError, match='^friction_compensation.velocity_threshold: expected a positive'):
        params.TABLE.validate({'friction_compensation.velocity_threshold': 0.0})
    with pytest.raises(ArgumentError) as err:
        ConfigBuilder()(params.TABLE.validate({'scenario': 'polar_two_link', PREFIX + 'viscous': [1.0] * 3}))
    assert err.value.name == 'friction_compensation.viscous'


def constant_velocity_lag(config):
    """The iiwa from its scenario's start: a quintic start to SPEED rad/s on every joint in 0.5 s, then SPEED
    until 3 s, the joints' friction -Fc sign(qd) - Fv qd applied by the World every tick; the largest |E| per
    joint over 1.5-3 s (a constant velocity since 0.5 s)."""
    with World('iiwa', dt=DT) as world:
        core = ControllerCore(config)
        lags = []
        for k in range(3000):
            q, qd, _ = world.state()
            world.set_disturbance(joint_torque=-FC * np.sign(qd) - FV * qd)
            world.set_torque(core.update(k * DT, q, qd))
            if k == 0:
                ramp = np.ones(7) * SPEED
                core.set_trajectory([0.5, 3.0], [q + 0.25 * ramp, q + 2.75 * ramp], [ramp, ramp], [0 * ramp, 0 * ramp])
            if k >= 1500:
                lags.append(np.abs(core.error[0]))
            world.step(1)
        return np.max(lags, axis=0)


@pytest.mark.parametrize('law, velocity', [('joint_impedance', 'reference'), ('joint_impedance', 'measured'),
                                           ('computed_torque', 'measured')])
def test_the_compensation_cancels_the_joints_friction_at_constant_velocity(law, velocity):
    iiwa = for_scenario('iiwa')
    off = ControllerConfig(iiwa, law=law,
                           law_params=gain_params(design(1.0, 12.0).gains(7) if law == 'computed_torque' else None))
    without = constant_velocity_lag(off)
    with_ = constant_velocity_lag(off.replace(friction_compensation={'coulomb': FC, 'viscous': FV,
                                                                      'velocity': velocity}))
    assert (with_ * 10 <= without).all(), (with_, without)
    if law == 'joint_impedance':
        np.testing.assert_allclose(without, (FC + FV * SPEED) / 100.0, rtol=0.05)
