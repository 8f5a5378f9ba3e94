"""The PyBullet world (sim_bridge.world): the simulated robots obey the controller's models.

Figures asserted here: g(q) holds every robot (drift < 1e-4 over 2 s); free motion
matches the model's RK4 solution (< 1e-3 over 0.5 s) and, at the production 1 ms step, the
model integrated with PyBullet's own semi-implicit Euler (< 1e-9); wall/table penetration is
F / k_e within 2 % (on both engines); reset is bit-identical; efforts are clipped; brakes hold (< 1e-3 over 1 s);
disturbances act as set; bad input raises ValueError naming the argument.
"""
import os
import re
import subprocess
import sys

import numpy as np
import pybullet
import pytest

from robot_control import scenarios
from robot_control import urdf as urdf_files
from robot_control.models import for_scenario, make_model
from robot_control.scenarios import Surface
from sim_bridge import physics_check
from sim_bridge.world import World

DT = 0.001
NAMES = tuple(scenarios.SCENARIOS)
#: starts for free motion from rest that stay inside the URDF travel for 0.5 s
FREE_STARTS = {
    'mass_spring_cubic': (0.3,),
    'single_link': (0.0,),
    'polar_two_link': (0.5, 0.6),
    'planar_two_link': (0.0, 0.5),
    'hybrid_cartesian_xy': (0.0, 0.5),
    'hybrid_cartesian_xyz': (0.0, 0.0, 0.5),
    'iiwa': (0.3, 0.3, 0.2, -0.6, 0.4, 0.5, 0.3),
    'panda': (0.3, 0.1, 0.2, -1.4, 0.4, 1.2, 0.3),
    'ur5': (0.3, -1.0, 1.2, -1.5, -1.2, 0.3),
}


def hold_with(world, tau_of_q, steps):
    """Run `steps` steps with tau = tau_of_q(q, qd); returns the (steps + 1, n) positions."""
    qs = [world.state()[0]]
    for _ in range(steps):
        q, qd, _ = world.state()
        world.set_torque(tau_of_q(q, qd))
        world.step()
        qs.append(world.state()[0])
    return np.array(qs)


def free_positions(world, steps):
    """Positions (steps + 1, n) under zero torque."""
    qs = [world.state()[0]]
    for _ in range(steps):
        world.step()
        qs.append(world.state()[0])
    return np.array(qs)


def rk4(model, q, T, h):
    """The model's free motion from rest (tau = 0) by RK4 with step h: positions (T/h + 1, n)."""
    n = model.n

    def f(x):
        return np.concatenate([x[n:], model.forward_dynamics(x[:n], x[n:], np.zeros(n))])
    x = np.concatenate([q, np.zeros(n)])
    out = [x[:n].copy()]
    for _ in range(round(T / h)):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        out.append(x[:n].copy())
    return np.array(out)


def semi_implicit_euler(model, q, T, h):
    """Free motion from rest with PyBullet's integrator: qd += h qdd; q += h qd."""
    qd, out = np.zeros(model.n), [np.array(q, dtype=float)]
    for _ in range(round(T / h)):
        qd = qd + h * model.forward_dynamics(out[-1], qd, np.zeros(model.n))
        out.append(out[-1] + h * qd)
    return np.array(out)


def dls_ik(model, q, target, iterations=60):
    """Joint positions putting the model's tip at `target` (damped least squares)."""
    for _ in range(iterations):
        J = model.J(q)
        q = q + J.T @ np.linalg.solve(J @ J.T + 1e-9 * np.eye(3), target - model.fk(q))
    return q


# -- 1. gravity hold -----------------------------------------------------------------------------
@pytest.mark.parametrize('name,q0', [(n, None) for n in NAMES] + [('mass_spring_cubic', (0.2,))])
def test_model_gravity_torque_holds_robot_still(make_world, name, q0):
    world, model = make_world(name, q0=q0), for_scenario(name)
    qs = hold_with(world, lambda q, qd: model.g(q), 2000)
    assert np.abs(qs - qs[0]).max() < 1e-4
    assert world.t_ns == 2000 * 1_000_000 and isinstance(world.t_ns, int)


def test_gravity_torque_of_the_default_model_does_not_hold_a_heavier_robot(make_world):
    heavy = make_world('polar_two_link', params={'m': 2.5})
    truth, nominal = make_model('polar_two_link', m=2.5, gravity=9.8), for_scenario('polar_two_link')
    held = hold_with(heavy, lambda q, qd: truth.g(q), 2000)
    assert np.abs(held - held[0]).max() < 1e-4
    heavy.reset()
    drop = hold_with(heavy, lambda q, qd: nominal.g(q), 500)
    assert np.abs(drop[-1] - drop[0]).max() > 1e-2


def test_a_payload_on_the_tip_is_held_by_the_model_that_knows_it(make_world):
    """2 kg 5 cm out along the iiwa's last link: g(q) of the model with the payload holds the arm
    (PyBullet and Pinocchio load the same URDF text); the model without it lets the arm sag."""
    payload = (2.0, (0.0, 0.0, 0.05))
    q0 = scenarios.get('iiwa').q0
    world = make_world('iiwa', payload=payload, surface=False)
    loaded, bare = for_scenario('iiwa', payload=payload), for_scenario('iiwa')
    held = hold_with(world, lambda q, qd: loaded.g(q), 1000)
    assert np.abs(held - held[0]).max() < 1e-4
    world.reset(q0)
    sag = hold_with(world, lambda q, qd: bare.g(q), 1000)
    assert np.abs(sag[-1] - sag[0]).max() > 1e-2


# -- 2. free motion ------------------------------------------------------------------------------
@pytest.mark.parametrize('name', sorted(FREE_STARTS))
def test_free_motion_matches_rk4_of_the_model(make_world, name):
    dt, h = 1e-4, 5e-4       # semi-implicit Euler error ~ a t dt / 2: 2.5e-4 m for a free fall
    world, model = make_world(name, q0=FREE_STARTS[name], dt=dt, surface=False), for_scenario(name)
    sim = free_positions(world, 5000)[::round(h / dt)]
    ref = rk4(model, np.array(FREE_STARTS[name]), 0.5, h)
    assert np.abs(sim - ref).max() < 1e-3


#: the Panda's fingers are held by PyBullet position motors (a constraint the solver meets to ~5e-8 m while
#: the arm falls), where the model welds them: the falling arm departs from the model by 1.6e-9 rad in 0.5 s
FREE_TOL = {'panda': 1e-8}


@pytest.mark.parametrize('name', sorted(FREE_STARTS))
def test_free_motion_at_1ms_is_the_model_under_the_same_integrator(make_world, name):
    world, model = make_world(name, q0=FREE_STARTS[name], surface=False), for_scenario(name)
    sim = free_positions(world, 500)
    assert np.abs(sim - semi_implicit_euler(model, FREE_STARTS[name], 0.5, DT)).max() < FREE_TOL.get(name, 1e-9)
    assert np.abs(sim[-1] - sim[0]).max() > 0.05          # it did move


def test_the_pandas_fingers_stay_held_closed_while_the_arm_falls(make_world):
    world = make_world('panda', q0=FREE_STARTS['panda'], surface=False)
    body, client = world.body, world.client
    fingers = [i for i in range(pybullet.getNumJoints(body, physicsClientId=client))
               if pybullet.getJointInfo(body, i, physicsClientId=client)[1].decode().startswith('panda_finger')]
    assert len(fingers) == 2 and world.joint_names == scenarios.get('panda').joints
    travel = 0.0
    for _ in range(500):
        world.set_torque(np.zeros(world.n))
        world.step()
        travel = max(travel, *(abs(s[0]) for s in pybullet.getJointStates(body, fingers, physicsClientId=client)))
    assert np.abs(world.state()[0] - FREE_STARTS['panda']).max() > 1.0     # the arm fell
    assert travel < 1e-6                                                     # m: measured 4.5e-8


# -- 3. surfaces (both engines) ---------------------------------------------------------------------------------
def _pressing_start(name, model):
    """Closed forms: the scenario's q0; URDF arms: tip 2 mm above the table under its q0 position."""
    sc = scenarios.get(name)
    if sc.model != 'urdf':
        return None
    above = model.fk(np.array(sc.q0))
    above[sc.surface.axis] = sc.surface.x_e - sc.surface.sign * 0.002
    return dls_ik(model, np.array(sc.q0), above)


@pytest.mark.parametrize('name', ['force_1dof', 'hybrid_cartesian_xy', 'hybrid_cartesian_xyz', 'iiwa', 'panda'])
def test_surface_penetration_is_force_over_stiffness(world_on, name):
    model, s = for_scenario(name), scenarios.get(name).surface
    world = world_on(name, q0=_pressing_start(name, model))
    push_dir = np.eye(model.task_dim)[s.axis] * s.sign
    for F in (5.0, 20.0, 80.0):
        # gravity compensation + a constant push F along the normal + mass-weighted damping
        hold_with(world, lambda q, qd: model.g(q) + model.J(q).T @ (F * push_dir) - model.M(q) @ (20.0 * qd), 1500)
        q = world.state()[0]
        penetration = s.sign * (model.fk(q)[s.axis] - s.x_e)
        force, torque = world.contact_wrench()
        normal = force / np.linalg.norm(force)
        assert penetration == pytest.approx(F / s.k_e, rel=0.02)
        assert np.linalg.norm(force) == pytest.approx(s.k_e * penetration, rel=0.02)
        assert np.isclose(abs(normal).max(), 1.0)                  # along one world axis
    contact = world.tip_position()                                 # on the surface's face, below the probe
    axis = int(np.argmax(abs(normal)))
    contact[axis] = s.x_e + s.sign * 0.01
    assert np.allclose(torque, np.cross(contact, force), atol=1e-6 * np.linalg.norm(force))


@pytest.mark.parametrize('name', ['force_1dof', 'hybrid_cartesian_xy', 'iiwa'])
def test_both_engines_press_with_the_same_steady_force(name):
    """The same push (gravity compensation + J^T F along the normal, F = 20 N, mass-weighted damping) for 1.5 s:
    the steady contact force on MuJoCo (the lecture's spring at the tip) is PyBullet's (its soft contact)
    within 5 % (measured: within 6e-7 relative on all three)."""
    from sim_bridge.engines import make_world
    model, s = for_scenario(name), scenarios.get(name).surface
    forces = []
    for engine in ('pybullet', 'mujoco'):
        with make_world(engine, name, q0=_pressing_start(name, model)) as world:
            direction = np.eye(model.task_dim)[s.axis] * s.sign
            hold_with(world, lambda q, qd: model.g(q) + model.J(q).T @ (20.0 * direction) - model.M(q) @ (20.0 * qd),
                      1500)
            forces.append(np.linalg.norm(world.contact_wrench()[0]))
    print(f'{name}: steady force pybullet {forces[0]:.6f} N, mujoco {forces[1]:.6f} N')
    assert forces[1] == pytest.approx(forces[0], rel=0.05)
    assert forces[0] == pytest.approx(20.0, rel=0.02)


def test_surface_pushes_only_on_contact_and_away_from_the_wall(world_on):
    world = world_on('force_1dof', q0=(0.09,))
    world.set_torque([0.0])
    world.step(10)
    assert np.array_equal(world.contact_wrench()[0], np.zeros(3))
    world.reset(q0=(0.1,))
    world.set_torque([10.0])
    world.step(50)
    force = world.contact_wrench()[0]
    assert force[0] > 0.0 and np.allclose(force[1:], 0.0)          # the robot pushes the wall along +x


def test_surface_override_and_disabled_surface(world_on):
    stiff = world_on('force_1dof', q0=(0.1,), surface=Surface(axis=0, x_e=0.1, k_e=4000.0))
    free = world_on('force_1dof', q0=(0.1,), surface=False)
    for world in (stiff, free):
        hold_with(world, lambda q, qd: np.array([20.0]) - 60.0 * qd, 1500)
    assert stiff.state()[0][0] - 0.1 == pytest.approx(20.0 / 4000.0, rel=0.02)
    assert free.state()[0][0] > 0.2 and np.array_equal(free.contact_wrench()[0], np.zeros(3))


# -- 4. determinism ------------------------------------------------------------------------------
def _pd_run(world, steps=800):
    """A PD + gravity run with a disturbance; returns (q, qd, wrench) history."""
    model = for_scenario(world.scenario.name)
    q_d = world.state()[0] + 0.05
    out = []
    for _ in range(steps):
        q, qd, _ = world.state()
        world.set_torque(model.g(q) + 100.0 * (q_d - q) - 10.0 * qd)
        world.step()
        out.append(np.concatenate([q, qd, world.contact_wrench()[0]]))
    return np.array(out)


@pytest.mark.parametrize('name', ['polar_two_link', 'hybrid_cartesian_xy', 'iiwa'])
def test_reset_reproduces_bit_identical_trajectories(make_world, name):
    world = make_world(name, disturbance={'joint_torque': np.full(len(scenarios.get(name).joints), 0.3)})
    first = _pd_run(world)
    world.brake(True)
    world.step(5)
    world.reset()
    assert world.t_ns == 0 and not world.braked
    assert np.array_equal(_pd_run(world), first)
    twin = make_world(name, disturbance={'joint_torque': np.full(world.n, 0.3)})
    assert np.array_equal(_pd_run(twin), first)


# -- 5. effort limits ----------------------------------------------------------------------------
def test_torque_is_clipped_to_the_effort_limits(make_world):
    world = make_world('hybrid_cartesian_xyz', surface=False)
    limit = world.effort_limit
    assert np.array_equal(limit, [200.0, 200.0, 200.0])
    applied = world.set_torque([1e4, -1e4, 50.0])
    assert np.array_equal(applied, [200.0, -200.0, 50.0])
    world.step()
    q, qd, tau = world.state()
    assert np.array_equal(tau, applied)
    model = for_scenario('hybrid_cartesian_xyz')
    qdd = qd / world.dt                           # one step from rest: qd = dt qdd
    assert np.allclose(model.M(q) @ qdd + model.g(q), applied, rtol=1e-9, atol=1e-9)


def test_iiwa_effort_limits_come_from_the_urdf(make_world):
    assert np.array_equal(make_world('iiwa', surface=False).effort_limit, np.full(7, 300.0))


# -- 6. brakes -----------------------------------------------------------------------------------
@pytest.mark.parametrize('name', ['polar_two_link', 'planar_two_link', 'iiwa'])
def test_brakes_hold_against_gravity_and_release(make_world, name):
    world, model = make_world(name, surface=False), for_scenario(name)
    world.set_torque(np.zeros(world.n))
    world.brake(True)
    q0 = world.state()[0]
    world.step(1000)
    q, qd, tau = world.state()
    assert np.abs(q - q0).max() < 1e-3
    assert np.allclose(tau, model.g(q0), atol=1e-3 * np.abs(model.g(q0)).max() + 1e-6)   # motors carry g
    world.brake(False)
    world.step(200)
    assert np.abs(world.state()[0] - q0).max() > 1e-3      # the zero-torque command applies again


def test_a_list_command_is_held_as_a_copy(make_world):
    """set_torque keeps its own copy of a list (the bridge's commands are lists): changing the
    caller's list afterwards changes nothing; numbers that are not floats are taken as floats."""
    world, model = make_world('polar_two_link'), for_scenario('polar_two_link')
    tau = model.g(world.state()[0]).tolist()
    held = world.set_torque(tau)
    tau[1] = 1e3
    world.step(200)
    q, qd, applied = world.state()
    assert np.array_equal(applied, held) and np.abs(qd).max() < 1e-9
    world.set_torque([0, 0])
    world.step(1)
    assert world.state()[2].tolist() == [0.0, 0.0]
    world.hold_torque((1.0, 2.0))        # set_torque without the returned array
    world.step(1)
    assert world.state()[2].tolist() == [1.0, 2.0]


def test_torque_set_while_braked_applies_on_release(make_world):
    world, model = make_world('polar_two_link'), for_scenario('polar_two_link')
    world.brake(True)
    world.set_torque(model.g(world.state()[0]) + [0.0, 5.0])
    world.step(100)
    q_braked, _, tau_brake = world.state()
    assert np.allclose(tau_brake, model.g(q_braked), rtol=1e-3)     # the motors carry g, not the command
    assert world.state_values() == tuple(tuple(a.tolist()) for a in world.state())   # floats, no numpy
    world.brake(False)
    world.step()
    q, qd, tau = world.state()
    assert np.array_equal(tau, model.g(q_braked) + [0.0, 5.0])
    assert world.state_values() == (tuple(q.tolist()), tuple(qd.tolist()), tuple(tau.tolist()))
    assert qd[1] / world.dt == pytest.approx(5.0 / 2.0, rel=1e-3)    # r: m rdd = 5 N


# -- 7. disturbances -----------------------------------------------------------------------------
def _measured_generalized_force(world, model):
    """From rest under tau = g(q): one step gives qd = dt M^-1 (external load); returns that load."""
    q0 = world.state()[0]
    world.set_torque(model.g(q0))
    world.step()
    return model.M(q0) @ (world.state()[1] / world.dt)


def test_joint_torque_disturbance_enters_the_dynamics(make_world):
    world, model = make_world('polar_two_link'), for_scenario('polar_two_link')
    world.set_disturbance(joint_torque=[1.5, -4.0])
    assert np.allclose(_measured_generalized_force(world, model), [1.5, -4.0], rtol=1e-9, atol=1e-9)


def test_cartesian_force_disturbance_acts_at_the_tip(make_world):
    world, model = make_world('polar_two_link'), for_scenario('polar_two_link')
    world.set_disturbance(cartesian_force=[3.0, 0.0, -2.0])           # world x, z = lecture x, y
    expected = model.J(world.state()[0]).T @ np.array([3.0, -2.0])
    assert np.allclose(_measured_generalized_force(world, model), expected, rtol=1e-9, atol=1e-9)
    iiwa, arm = make_world('iiwa', disturbance={'cartesian_force': [10.0, -5.0, 20.0]}), for_scenario('iiwa')
    expected = arm.J(iiwa.state()[0]).T @ np.array([10.0, -5.0, 20.0])
    assert np.allclose(_measured_generalized_force(iiwa, arm), expected, rtol=1e-5, atol=1e-5)


def test_state_into_fills_the_given_arrays_with_pybullets_joint_states(make_world):
    world = make_world('iiwa', dt=0.001)
    tau = np.linspace(-5.0, 5.0, 7)
    world.set_torque(tau)
    world.step(20)
    out = tuple(np.full(7, np.nan) for _ in range(3))
    q, qd, applied = world.state_into(*out)
    assert all(a is b for a, b in zip((q, qd, applied), out))
    raw = pybullet.getJointStates(world.body, world._idx, physicsClientId=world.client)
    np.testing.assert_array_equal(q, [s[0] for s in raw])
    np.testing.assert_array_equal(qd, [s[1] for s in raw])
    np.testing.assert_array_equal(applied, tau)
    world.brake(True)
    world.step(5)
    world.state_into(*out)
    raw = pybullet.getJointStates(world.body, world._idx, physicsClientId=world.client)
    np.testing.assert_array_equal(out[2], [s[3] for s in raw])   # the brake motors' torque while braked


def test_lecture_disturbance_rejection_steady_state_error(make_world):
    """Mass-spring with the partitioned PD law: e_ss = d / (m kp) (lecture 2.2)."""
    world, model = make_world('mass_spring_cubic'), for_scenario('mass_spring_cubic')
    kp, kv, d, x_d = 36.0, 12.0, 2.0, 0.1
    world.set_disturbance(joint_torque=[-d])         # the lecture's m xdd + b xd + k x^3 + d = u
    qs = hold_with(world, lambda q, qd: model.M(q) @ (kp * (x_d - q) - kv * qd) + model.C_qd(q, qd) + model.g(q),
                   4000)
    assert x_d - qs[-1, 0] == pytest.approx(d / (model.m * kp), rel=0.01)


# -- any URDF ------------------------------------------------------------------------------------
def test_any_urdf_with_a_joint_subset_loads_and_holds(make_world):
    joints = scenarios.IIWA_JOINTS[:4]
    world = make_world(None, urdf='kuka_iiwa/model.urdf', joints=joints, q0=(0.2, 0.4, -0.3, -1.0))
    model = make_model('urdf', urdf='kuka_iiwa/model.urdf', joints=joints)
    assert world.joint_names == joints and world.tip is None
    qs = hold_with(world, lambda q, qd: model.g(q), 2000)
    assert np.abs(qs - qs[0]).max() < 1e-4


XARM = 'xarm_description/urdf/xarm7.urdf'
XARM_JOINTS = tuple(f'joint{i}' for i in range(1, 8))


def _iiwa_copy(tmp_path, edit=lambda xml: xml):
    """A copy of pybullet_data's iiwa in tmp_path (its meshes made absolute), edited by `edit`."""
    path = urdf_files.resolve('kuka_iiwa/model.urdf')
    xml = urdf_files.with_absolute_meshes(urdf_files.read(path)[0], os.path.dirname(path))
    out = tmp_path / 'iiwa.urdf'
    out.write_text(edit(xml), encoding='utf-8')
    return str(out)


def test_a_link_without_inertial_is_massless_in_the_simulation(make_world):
    """The xArm7's link_eef: PyBullet's default would be 1 kg and 1 kg m^2; the World loads it as the URDF
    (and Pinocchio) mean it, and finds nothing to report."""
    world = make_world(None, urdf=XARM, joints=XARM_JOINTS)
    eef = [j for j in range(pybullet.getNumJoints(world.body, physicsClientId=world.client))
           if pybullet.getJointInfo(world.body, j, physicsClientId=world.client)[12] == b'link_eef']
    mass, _, inertia = pybullet.getDynamicsInfo(world.body, eef[0], physicsClientId=world.client)[:3]
    assert mass == 0.0 and inertia == (0.0, 0.0, 0.0)
    assert world.report == []


def test_the_physics_report_names_the_links_pybullet_simulates_otherwise():
    """The unmodified xArm7 as PyBullet loads it alone: link_eef 1 kg; g and M differ on the joints before it."""
    path = urdf_files.resolve(XARM)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
        body = pybullet.loadURDF(path, useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                                 physicsClientId=client)
        for i, q in zip(physics_check.movable_joints(client, body).values(), (0.3, -0.5, 0.2, 0.6, -0.3, 0.8, 0.4)):
            pybullet.resetJointState(body, i, q, 0.0, physicsClientId=client)
        lines = physics_check.report(client, body, urdf_files.read(path)[0], 9.81)
    finally:
        pybullet.disconnect(client)
    links = [line for line in lines if 'link ' in line]
    assert len(links) == 1 and "link 'link_eef': simulated with mass 1 kg" in links[0], lines
    assert "joint 'joint2' at q = -0.5: simulated g -8.80195 N m vs model -5.44633" in '\n'.join(lines)


def test_a_copy_of_a_urdf_saved_elsewhere_finds_its_package_meshes(make_world, tmp_path):
    """xarm7.urdf's package://example-robot-data/... meshes resolve through the wheel's prefix."""
    copy = tmp_path / 'my_arm.urdf'
    copy.write_text(urdf_files.read(XARM)[0], encoding='utf-8')
    world = make_world(None, urdf=str(copy), joints=XARM_JOINTS)
    model = make_model('urdf', urdf=str(copy), joints=XARM_JOINTS)
    qs = hold_with(world, lambda q, qd: model.g(q), 500)
    assert np.abs(qs - qs[0]).max() < 1e-9


def test_a_mesh_found_nowhere_is_an_error_naming_the_mesh_and_the_places(tmp_path):
    xml = urdf_files.read(XARM)[0].replace('meshes/xarm7/visual/link3.stl', 'meshes/xarm7/visual/link3_lost.stl')
    copy = tmp_path / 'my_arm.urdf'
    copy.write_text(xml, encoding='utf-8')
    with pytest.raises(ValueError) as info:
        World(None, urdf=str(copy), joints=XARM_JOINTS)
    text = str(info.value)
    assert info.value.name == 'urdf' and "link 'link3': mesh 'package://example-robot-data/robots/" in text
    assert 'link3_lost.stl' in text and os.path.join('share', 'example-robot-data', 'robots') in text
    assert f'{tmp_path} and every directory above it' in text


def test_urdf_problems_are_errors_or_start_up_warnings(make_world, tmp_path):
    """robot_control.urdf.checks in the World: a misread number and a joint moving no mass are errors,
    a moved link without <inertial> a line of the start-up report (and massless in the simulation)."""
    with pytest.raises(ValueError, match="^urdf: .*link 'lbr_iiwa_link_5'.*1.7kg"):
        World(None, urdf=_iiwa_copy(tmp_path, lambda x: x.replace('"1.7"', '"1.7kg"')), joints=scenarios.IIWA_JOINTS)
    no_link_7 = re.compile(r'(<link name="lbr_iiwa_link_7">\s*)<inertial>.*?</inertial>', re.S)
    with pytest.raises(ValueError, match="^urdf: .*joint 'lbr_iiwa_joint_7' moves no mass"):
        World(None, urdf=_iiwa_copy(tmp_path, lambda x: no_link_7.sub(r'\1', x)), joints=scenarios.IIWA_JOINTS)
    no_link_3 = re.compile(r'(<link name="lbr_iiwa_link_3">\s*)<inertial>.*?</inertial>', re.S)
    path = _iiwa_copy(tmp_path, lambda x: no_link_3.sub(r'\1', x))
    world = make_world(None, urdf=path, joints=scenarios.IIWA_JOINTS, q0=(0.2, 0.4, -0.3, -1.0, 0.3, 0.5, 0.1))
    assert len(world.report) == 1 and "link 'lbr_iiwa_link_3' (moved by joint 'lbr_iiwa_joint_3')" in world.report[0]
    model = make_model('urdf', urdf=path, joints=scenarios.IIWA_JOINTS)
    qs = hold_with(world, lambda q, qd: model.g(q), 1000)
    assert np.abs(qs - qs[0]).max() < 1e-9


def test_shipped_urdf_path_without_scenario(make_world):
    from robot_control.models.urdf_gen import SHIPPED_DIR
    world = make_world(None, urdf=f'{SHIPPED_DIR}/polar_two_link.urdf', joints=['r', 'theta1'], q0=(0.5, 0.0),
                       params={'gravity': 9.8}, tip='tip')
    model = for_scenario('polar_two_link')
    qs = hold_with(world, lambda q, qd: model.g(q[::-1])[::-1], 1000)
    assert np.abs(qs - qs[0]).max() < 1e-4


# -- 8. bad input --------------------------------------------------------------------------------
@pytest.mark.parametrize('kwargs,argument', [
    ({'scenario': 'no_such_robot'}, 'scenario'),
    ({'scenario': 42}, 'scenario'),
    ({'scenario': None}, 'urdf'),
    ({'scenario': None, 'urdf': 'missing/robot.urdf', 'joints': ['a']}, 'urdf'),
    ({'scenario': None, 'urdf': 'kuka_iiwa/model.urdf'}, 'joints'),
    ({'scenario': 'iiwa', 'joints': ['lbr_iiwa_joint_1', 'elbow'], 'q0': (0.0, 0.0)}, 'joints'),
    ({'scenario': 'polar_two_link', 'q0': (0.0, 0.5, 1.0)}, 'q0'),
    ({'scenario': 'polar_two_link', 'q0': (0.0, 5.0)}, 'q0'),
    ({'scenario': 'polar_two_link', 'params': {'m': -1.0}}, 'params'),
    ({'scenario': 'polar_two_link', 'params': {'mass': 2.0}}, 'params'),
    ({'scenario': 'iiwa', 'params': {'m': 2.0}}, 'params'),
    ({'scenario': 'polar_two_link', 'dt': 0.0}, 'dt'),
    ({'scenario': 'polar_two_link', 'dt': float('nan')}, 'dt'),
    ({'scenario': 'polar_two_link', 'surface': 'wall'}, 'surface'),
    ({'scenario': 'polar_two_link', 'disturbance': {'joint_torque': [1.0]}}, 'joint_torque'),
    ({'scenario': 'polar_two_link', 'disturbance': {'torque': [1.0, 2.0]}}, 'disturbance'),
    ({'scenario': 'polar_two_link', 'tip': 'hand'}, 'tip'),
])
def test_bad_construction_raises_value_error_naming_the_argument(kwargs, argument):
    with pytest.raises(ValueError, match=f'^{argument}'):
        World(**kwargs)


def test_bad_commands_are_rejected_and_never_reach_pybullet(make_world):
    world, model = make_world('polar_two_link'), for_scenario('polar_two_link')
    held = world.set_torque(model.g(world.state()[0]))
    for bad in ([1.0], [1.0, 2.0, 3.0], [np.nan, 0.0], [0.0, np.inf], 'tau', [[1.0, 2.0]], ['a', 0.0],
                [None, 0.0], [1j, 0.0], (np.nan, 0.0)):
        with pytest.raises(ValueError, match='^tau'):
            world.set_torque(bad)
    world.step(500)
    q, qd, tau = world.state()
    assert np.array_equal(tau, held) and np.all(np.isfinite(q)) and np.abs(qd).max() < 1e-9
    for kwargs, argument in (({'joint_torque': [np.nan, 0.0]}, 'joint_torque'),
                             ({'cartesian_force': [1.0, 2.0]}, 'cartesian_force')):
        with pytest.raises(ValueError, match=f'^{argument}'):
            world.set_disturbance(**kwargs)
    for k in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match='^k'):
            world.step(k)
    with pytest.raises(ValueError, match='^q0'):
        world.reset(q0=(0.0, 0.0))                 # r below its 0.1 m limit: the old world is kept
    world.step()
    assert world.t_ns == 501 * 1_000_000


def test_cartesian_force_needs_a_tip(make_world):
    world = make_world(None, urdf='kuka_iiwa/model.urdf', joints=scenarios.IIWA_JOINTS)
    with pytest.raises(ValueError, match='^cartesian_force'):
        world.set_disturbance(cartesian_force=[0.0, 0.0, 1.0])


def test_world_imports_no_ros():
    code = ('import sys, sim_bridge.world; '
            'bad = [m for m in sys.modules if m.startswith("rclpy") or m.split(".")[0].endswith("_msgs")]; '
            'assert not bad, bad')
    subprocess.run([sys.executable, '-c', code], check=True, capture_output=True)
