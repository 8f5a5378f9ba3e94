"""Payload identification (robot_control.core.payload_id) on the simulated iiwa with the bridge's own sensor
model (sim_bridge.sensors.Driver over a World built from the bridge's parameters), driven by the Controller."""
import numpy as np
import pytest

from robot_control import scenarios
from robot_control.core.controller import Command, Controller
from robot_control.core.payload_id import PayloadIdentification, default_offsets, offsets_of, payload_torque, solve
from robot_control.models import make_model
from robot_control.ros import controller_params as params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params
from sim_bridge.engines import make_world
from sim_bridge.sensors import Driver
from support.realism import PAYLOAD, typical_profile


def identify(law, bridge_values, max_ticks=40000):
    """Run a PayloadIdentification (default poses, 1 s moves) on the iiwa controller of `law`, not told of
    any payload, against the bridge of `bridge_values`: the finished PayloadIdentification."""
    cfg = bridge_params.validate(bridge_params.defaults('iiwa', **bridge_values))
    world = make_world(cfg.engine, 'iiwa', dt=cfg.physics_step, params=cfg.sim_params or None, joints=cfg.joints,
                       q0=cfg.initial_positions, surface=False, payload=cfg.payload, friction=cfg.friction)
    try:
        driver = Driver(world, cfg.sensors, cfg.control_period_ns)
        controller = Controller(ConfigBuilder()(params.TABLE.validate({'scenario': 'iiwa', 'law': law})), 0.5)
        ident = PayloadIdentification(default_offsets(7), 1.0, 0.3, 0.05, 0.3)
        for k in range(max_ticks):
            q, qd, tau = (np.array(v) for v in driver.measured.state_values())
            command = controller.step(driver.measured.t_ns, cfg.joints, q, qd)
            assert type(command) is Command
            if k == 0:
                ident.start(controller.core, q)
                driver.release(command.values)
            else:
                ident.tick(controller.core, q, qd, tau)
                driver.hold(command.values)
            if ident.done:
                return ident
            driver.step(cfg.substeps)
    finally:
        world.close()
    raise AssertionError(f'not done after {max_ticks} ticks (pose {ident.pose})')


def test_the_regressor_gives_the_gravity_torque_a_payload_adds():
    sc = scenarios.get('iiwa')
    bare = make_model('urdf', urdf=sc.urdf, tip=sc.tip)
    loaded = make_model('urdf', urdf=sc.urdf, tip=sc.tip, payload=(1.5, (0.03, -0.02, 0.07)))
    theta = 1.5 * np.array([1.0, 0.03, -0.02, 0.07])
    for q in np.random.default_rng(3).uniform(-1.5, 1.5, (5, 7)):
        assert np.allclose(loaded.g(q) - bare.g(q), bare.payload_regressor(q) @ theta, atol=1e-12)
        Y, r = payload_torque(loaded, q, loaded.g(q))      # the model's own payload is part of what is measured
        assert np.allclose(r, Y @ theta, atol=1e-12)


@pytest.mark.parametrize('law', ['joint_impedance', 'computed_torque'])
def test_a_payload_the_controller_was_not_told_of_is_found_with_the_typical_friction_noise_and_delay(law):
    ident = identify(law, {**typical_profile('iiwa', mass_errors=False), **PAYLOAD})
    est = ident.error or ident.estimate
    assert abs(est.mass - 2.0) < 0.03 * 2.0, est.message()
    assert np.linalg.norm(est.com - [0.0, 0.0, 0.05]) < 0.005, est.message()
    assert est.residual < 0.05, est.message()


def test_link_masses_10_percent_heavier_than_the_model_bias_the_estimate_and_the_residual_shows_it():
    # the typical profile's sim_params.mass_scale 1.1: their gravity torque is partly explained as payload
    # (measured: 2.58 kg, com z 18 mm under joint_impedance), the rest stays in the fit's residual
    exact = identify('joint_impedance', {**typical_profile('iiwa', mass_errors=False), **PAYLOAD}).estimate
    biased = identify('joint_impedance', {**typical_profile('iiwa', mass_errors=True), **PAYLOAD}).estimate
    assert biased.mass > 2.3 and abs(biased.com[2] - 0.05) > 0.02, biased.message()
    assert biased.residual > 10.0 * exact.residual, (biased.message(), exact.message())


def test_one_pose_cannot_separate_the_payload_s_parameters():
    sc = scenarios.get('iiwa')
    model = make_model('urdf', urdf=sc.urdf, tip=sc.tip, payload=(2.0, (0.0, 0.0, 0.05)))
    q = np.array(sc.q0)
    with pytest.raises(ArgumentError, match='determine 3 of the 4') as err:
        solve(*zip(payload_torque(model, q, model.g(q) + 0.0 * q)))
    assert err.value.name == 'payload_identification.poses'


def test_poses_a_hundredth_of_a_degree_apart_are_refused_not_solved():
    # with exact torques any rank-4 fit is right; measured ones would be decided by their noise
    sc = scenarios.get('iiwa')
    model = make_model('urdf', urdf=sc.urdf, tip=sc.tip, payload=(2.0, (0.0, 0.0, 0.05)))
    poses = np.array(sc.q0) + default_offsets(7, amplitude=2e-4)
    with pytest.raises(ArgumentError, match='determine 3 of the 4'):
        solve(*zip(*(payload_torque(model, q, model.g(q)) for q in poses)))
    estimate = solve(*zip(*(payload_torque(model, q, model.g(q)) for q in np.array(sc.q0) + default_offsets(7))))
    assert estimate.mass == pytest.approx(2.0) and np.allclose(estimate.com, [0.0, 0.0, 0.05])


def test_the_poses_are_offsets_per_joint_or_the_wrist_default():
    assert offsets_of([], 7).shape == (7, 7)
    assert np.array_equal(offsets_of([0.1, 0.2, 0.3, 0.4], 2), [[0.1, 0.2], [0.3, 0.4]])
    with pytest.raises(ArgumentError, match='multiple of 7') as err:
        offsets_of([0.1] * 8, 7)
    assert err.value.name == 'payload_identification.poses'
