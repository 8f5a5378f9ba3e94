"""The arms beyond the iiwa: the Franka Panda of pybullet_data (seven arm joints, the two fingers held at
0 m) and the UR5 of example-robot-data (six joints), as the scenarios name them. The controller's model
(Pinocchio) must be the robot PyBullet simulates: the same masses and inertias, hence the same gravity
torque, mass matrix and inverse dynamics at any state.

Tolerances (measured on 50 seeded states each, |tau| up to 60 N m): Pinocchio vs PyBullet 1.1e-14 (g),
2.2e-15 (M), 2.1e-14 (inverse dynamics); checked at 1e-9. Computed torque vs pinocchio.rnea of the
URDF's full model: identical computation, checked at 1e-9.
"""
import math
import os
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pybullet
import pytest

from robot_control import scenarios
from robot_control import urdf as urdf_files
from robot_control.gains import ServoGains
from robot_control.laws import computed_torque
from robot_control.models import for_scenario

SEED = 20261123
TOL = 1e-9
ARMS = ('panda', 'ur5')


def close(actual, expected, tol=TOL, msg=''):
    np.testing.assert_allclose(actual, expected, rtol=tol, atol=tol, err_msg=msg)


@pytest.fixture
def bullet():
    client = pybullet.connect(pybullet.DIRECT)
    try:
        yield client
    finally:
        pybullet.disconnect(client)


def _load(client, path):
    """(body, {joint name: index}, [movable joint names in PyBullet's dof order]) of the URDF as World loads it."""
    pybullet.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
    body = pybullet.loadURDF(path, useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                             physicsClientId=client)
    index, movable = {}, []
    for i in range(pybullet.getNumJoints(body, physicsClientId=client)):
        info = pybullet.getJointInfo(body, i, physicsClientId=client)
        index[info[1].decode()] = i
        if info[2] != pybullet.JOINT_FIXED:
            movable.append(info[1].decode())
    return body, index, movable


def _inside(model, rng):
    """Joint positions inside 90 % of each joint's range (at most +-pi)."""
    lower, upper = (np.clip(x, -math.pi, math.pi) for x in model.position_limits)
    mid, half = (lower + upper) / 2, 0.45 * (upper - lower)
    return rng.uniform(mid - half, mid + half)


def _urdf_inertials(path):
    """{link: (mass kg, (ixx, iyy, izz) kg m^2)} as the URDF file states them (links without <inertial>: 0)."""
    out = {}
    for link in ET.parse(path).getroot().iter('link'):
        inertial = link.find('inertial')
        if inertial is None:
            out[link.get('name')] = (0.0, (0.0, 0.0, 0.0))
            continue
        i = inertial.find('inertia')
        out[link.get('name')] = (float(inertial.find('mass').get('value')),
                                 tuple(float(i.get(k)) for k in ('ixx', 'iyy', 'izz')))
    return out


@pytest.mark.parametrize('name', ARMS)
def test_pybullet_keeps_every_links_mass_and_inertia_from_the_urdf(bullet, name):
    """Unlike pybullet_data's xarm6 (two links' inertia zeroed): every link that carries mass in the URDF
    has it in PyBullet, with nonzero principal inertias, and massless frames stay massless."""
    path = urdf_files.resolve(scenarios.get(name).urdf)
    body, index, _ = _load(bullet, path)
    expected = _urdf_inertials(path)
    moving = 0
    for joint, i in index.items():
        link = pybullet.getJointInfo(body, i, physicsClientId=bullet)[12].decode()
        mass, _, inertia = pybullet.getDynamicsInfo(body, i, physicsClientId=bullet)[:3]
        assert mass == pytest.approx(expected[link][0], rel=1e-12, abs=0.0), link
        np.testing.assert_allclose(inertia, expected[link][1], rtol=1e-12, err_msg=link)
        if expected[link][0] > 0.0:
            assert min(inertia) > 0.0, f'{link}: PyBullet inertia {inertia}'
        if joint in scenarios.get(name).joints:
            moving += 1
            assert mass > 0.0 and min(inertia) > 0.0, f'{link} moves with {joint} but has no mass or inertia'
    assert moving == len(scenarios.get(name).joints)


@pytest.mark.parametrize('name', ARMS)
def test_pinocchio_model_is_the_robot_pybullet_simulates(bullet, name):
    """g(q), M(q) and M qdd + C qd + g of the scenario's model (the Panda's fingers locked at 0 m) against
    PyBullet's calculateInverseDynamics / calculateMassMatrix with the fingers at 0 m and at rest."""
    sc = scenarios.get(name)
    model = for_scenario(name)
    body, _, movable = _load(bullet, urdf_files.resolve(sc.urdf))
    held = [j for j in movable if j not in sc.joints]
    assert held == (['panda_finger_joint1', 'panda_finger_joint2'] if name == 'panda' else [])
    cols = [movable.index(j) for j in sc.joints]
    rng = np.random.default_rng([SEED, len(name)])
    zeros = [0.0] * len(movable)
    for _ in range(50):
        q, qd, qdd = _inside(model, rng), rng.uniform(-2.0, 2.0, model.n), rng.uniform(-3.0, 3.0, model.n)
        full = [np.zeros(len(movable)) for _ in range(3)]
        for x, part in zip(full, (q, qd, qdd)):
            x[cols] = part
        g_b = pybullet.calculateInverseDynamics(body, full[0].tolist(), zeros, zeros, physicsClientId=bullet)
        tau_b = pybullet.calculateInverseDynamics(body, *(x.tolist() for x in full), physicsClientId=bullet)
        m_b = np.array(pybullet.calculateMassMatrix(body, full[0].tolist(), physicsClientId=bullet))
        close(model.g(q), np.array(g_b)[cols], msg='gravity torque')
        close(model.M(q), m_b[np.ix_(cols, cols)], msg='M')
        close(model.inverse_dynamics(q, qd, qdd), np.array(tau_b)[cols], msg='inverse dynamics')
    assert np.abs(model.g(q)).max() > 1.0      # the check is not trivially about zeros


def test_ur5_computed_torque_is_rnea_of_its_urdf():
    """tau = M (qdd_d + Kv e_dot + Kp e) + C qd + g, checked against pinocchio.rnea on the URDF file's own
    model (built here by pinocchio.buildModelFromUrdf, gravity -9.81 z)."""
    sc = scenarios.get('ur5')
    model = for_scenario('ur5')
    path = urdf_files.resolve(sc.urdf)
    ref = pin.buildModelFromUrdf(path)
    data = ref.createData()
    assert tuple(ref.names[1:]) == sc.joints and ref.nq == ref.nv == 6
    assert np.allclose(ref.gravity.linear, [0.0, 0.0, -9.81])
    gains = ServoGains.uniform(6, 36.0, 12.0)
    rng = np.random.default_rng([SEED, 5])
    for _ in range(50):
        q, q_d = _inside(model, rng), _inside(model, rng)
        qd, qd_d, qdd_d = rng.uniform(-2.0, 2.0, (3, 6))
        tau = computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains)
        v = qdd_d + 12.0 * (qd_d - qd) + 36.0 * (q_d - q)
        close(tau, pin.rnea(ref, data, q, qd, v))


def test_ur5_has_no_redundancy_and_its_urdf_comes_from_example_robot_data():
    """Six joints for the tool's six-dimensional pose: a square Jacobian of full rank away from singularities,
    so no null space (the Panda's 7 x 6 has one)."""
    model = for_scenario('ur5', task_space='pose')
    assert model.n == 6 and model.tip == 'tool0'
    assert os.path.join('example-robot-data', 'robots', 'ur_description') in model.source
    rng = np.random.default_rng([SEED, 6])
    for _ in range(20):
        jac = model.J(_inside(model, rng))
        assert jac.shape == (6, 6) and np.linalg.matrix_rank(jac) == 6
    panda = for_scenario('panda', task_space='pose')
    assert panda.J(np.array(scenarios.get('panda').q0)).shape == (6, 7)
    np.testing.assert_array_equal(model.effort_limit, [150.0, 150.0, 150.0, 28.0, 28.0, 28.0])
