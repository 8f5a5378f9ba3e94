"""A simulated robot that is not the controller's model (sim_bridge.true_robot through the World and the
bridge's parameters): its gravity torque and mass matrix measured in PyBullet.

Figures asserted: with mass_scale s on every link PyBullet's g(q) is s g_URDF(q) and Pinocchio's g of the
rewritten URDF (1e-9 N m); inertia_scale leaves g and changes M; com_offset moves g as Pinocchio says;
a bridge URDF carrying 2 kg that the model lacks differs from the model's g by J_p^T m g0 (1e-9 N m).
"""
import os

import numpy as np
import pybullet as p
import pytest

from robot_control import urdf as urdf_files
from robot_control.models import for_scenario
from robot_control.models.urdf_model import UrdfModel
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params

Q = np.array([0.3, 0.7, -0.2, -1.1, 0.4, 0.9, 0.2])
G0 = 9.81


def pybullet_g(world, q):
    z = [0.0] * len(q)
    return np.array(p.calculateInverseDynamics(world.body, list(q), z, z, physicsClientId=world.client))


def pybullet_M(world, q):
    return np.array(p.calculateMassMatrix(world.body, list(q), physicsClientId=world.client))


def model_of(world):
    """Pinocchio's model of the URDF the World simulates."""
    with open(world.urdf, encoding='utf-8') as f:
        return UrdfModel(f.read(), joints=world.joint_names)


def test_mass_scale_shows_in_the_gravity_torque(make_world):
    nominal = for_scenario('iiwa')
    world = make_world('iiwa', surface=False, params={'mass_scale': [1.5]})
    g = pybullet_g(world, Q)
    np.testing.assert_allclose(g, model_of(world).g(Q), atol=1e-9)
    np.testing.assert_allclose(g, 1.5 * nominal.g(Q), atol=1e-9)
    assert world.report == []           # PyBullet simulates the rewritten URDF


def test_per_link_mass_scale_adds_that_links_share(make_world):
    """Only link 4 twice as heavy: g - g_URDF is link 4's own gravity torque, nothing on joints 4.. beyond it."""
    scale = [1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0]
    world = make_world('iiwa', surface=False, params={'mass_scale': scale})
    g, nominal = pybullet_g(world, Q), for_scenario('iiwa').g(Q)
    np.testing.assert_allclose(g, model_of(world).g(Q), atol=1e-9)
    assert np.abs(g - nominal)[:4].max() > 0.5 and np.abs(g - nominal)[4:].max() < 1e-12


def test_inertia_scale_changes_the_mass_matrix_not_gravity(make_world):
    world = make_world('iiwa', surface=False, params={'inertia_scale': [3.0]})
    nominal = for_scenario('iiwa')
    np.testing.assert_allclose(pybullet_g(world, Q), nominal.g(Q), atol=1e-9)
    M = pybullet_M(world, Q)
    np.testing.assert_allclose(M, model_of(world).M(Q), atol=1e-9)
    assert np.abs(M - nominal.M(Q)).max() > 1e-2


def test_com_offset_moves_the_gravity_torque(make_world):
    offset = np.zeros(21)
    offset[3 * 6:] = (0.0, 0.05, 0.02)                 # link 7's centre of mass
    world = make_world('iiwa', surface=False, params={'com_offset': offset})
    g = pybullet_g(world, Q)
    np.testing.assert_allclose(g, model_of(world).g(Q), atol=1e-9)
    assert np.abs(g - for_scenario('iiwa').g(Q)).max() > 1e-2


def test_a_bridge_urdf_with_a_payload_the_model_lacks(make_world, tmp_path):
    """The model-error experiment through `urdf`: the bridge simulates the iiwa with 2 kg 5 cm out along
    its last link, the controller's model has none; g_sim - g_model = J_p(q)^T (0, 0, m g0), the payload's
    gravity torque (J_p: the linear Jacobian of the payload's centre)."""
    mass, com = 2.0, (0.0, 0.0, 0.05)
    xml, where = urdf_files.read('kuka_iiwa/model.urdf')
    xml = urdf_files.with_absolute_meshes(xml, os.path.dirname(where))
    path = tmp_path / 'iiwa_payload.urdf'
    path.write_text(urdf_files.with_payload(xml, 'lbr_iiwa_link_7', mass, com))
    cfg = bridge_params.validate(bridge_params.defaults('iiwa', urdf=str(path)))     # the bridge accepts it
    world = make_world('iiwa', surface=False, urdf=cfg.urdf)
    z = [0.0] * 7
    J = np.array(p.calculateJacobian(world.body, 6, list(com), list(Q), z, z, physicsClientId=world.client)[0])
    difference = pybullet_g(world, Q) - for_scenario('iiwa').g(Q)
    np.testing.assert_allclose(difference, J.T @ np.array([0.0, 0.0, mass * G0]), atol=1e-9)
    assert np.abs(difference).max() > 1.0


def test_the_bridge_shows_the_links_the_simulator_uses():
    """Defaults are the URDF's own (ones, zeros), one per joint; a set value reaches the World's params."""
    values = bridge_params.defaults('iiwa')
    assert values['sim_params.mass_scale'] == (1.0,) * 7 and values['sim_params.com_offset'] == (0.0,) * 21
    cfg = bridge_params.validate(bridge_params.defaults('iiwa', **{'sim_params.mass_scale': [1.2]}))
    assert cfg.sim_params['mass_scale'] == (1.2,)
    assert 'sim_params.mass_scale' not in bridge_params.defaults('polar_two_link')      # closed forms: m, l ...


@pytest.mark.parametrize('changes,name', [({'sim_params.mass_scale': [1.0, 2.0]}, 'sim_params.mass_scale'),
                                          ({'sim_params.inertia_scale': [0.0]}, 'sim_params.inertia_scale'),
                                          ({'sim_params.com_offset': [0.1, 0.0, 0.0]}, 'sim_params.com_offset')])
def test_bad_link_changes_name_the_parameter(changes, name):
    with pytest.raises(ArgumentError) as info:
        bridge_params.validate(bridge_params.defaults('iiwa', **changes))
    assert info.value.name == name


def test_the_world_refuses_link_changes_it_cannot_apply():
    from sim_bridge.world import World
    with pytest.raises(ArgumentError, match='^sim_params.mass_scale'):
        World('iiwa', params={'mass_scale': [1.0, -2.0, 1.0, 1.0, 1.0, 1.0, 1.0]})
    with pytest.raises(ArgumentError, match='^params'):
        World('iiwa', params={'mass': 2.0})
