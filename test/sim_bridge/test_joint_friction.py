"""Joint friction and armature of the simulated robot (sim_bridge.joint_friction through the World),
measured against the equations of its docstring, on both engines (the world_on fixture) but where PyBullet's
own mechanism is the point (joint damping, its tip force).

Figures asserted: a joint held by less than its Coulomb torque moves < 1e-9 in 1 s (single link; the iiwa,
every joint at once; every scenario in 0.5 s); above it qdd = (tau - g - F_c sign) / (M_ii + I_a) within 1e-9
relative (force_1dof, single link); a free joint's velocity decays as (1 - b dt / m)^k (exp(-b t / m)
within 1e-3) and PyBullet's joint damping is bit-identical to an applied -b qd; the acceleration under
armature is (M + I_a)^-1 (tau - g) within 1e-9 relative on the iiwa, 1e-4 on every scenario (the Panda's
held fingers: 8e-6); the Coulomb solver satisfies its complementarity conditions on random coupled
systems; pressed on a surface, the contact balances the push within the Coulomb band (1e-3 N without);
the brakes hold whatever the friction.
"""
import numpy as np
import pytest

from robot_control import scenarios
from robot_control.models import for_scenario
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params, joint_friction, physics_check
from sim_bridge.engines import make_world
from sim_bridge.joint_friction import JointFriction, _coordinate_descent, coulomb_sets, coulomb_torque

DT = 0.001
IIWA_COULOMB = (1.0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5)


def g_of(world):
    """g(q) of the controlled joints at the current state, the controller's model of the scenario (Pinocchio on
    the URDF for the arms: both engines agree with it to 1e-13)."""
    return for_scenario(world.scenario.name).g(world.state()[0])


def M_of(world):
    """M(q) of the controlled joints at the current state, the controller's model of the scenario."""
    return for_scenario(world.scenario.name).M(world.state()[0])


def acceleration(world, tau, steps=1):
    """Mean acceleration over `steps` steps from the current state under torque tau, rad/s^2 or m/s^2."""
    world.set_torque(tau)
    qd0 = world.state()[1]
    world.step(steps)
    return (world.state()[1] - qd0) / (steps * world.dt)


# -- Coulomb friction and stiction -------------------------------------------------------------------------
@pytest.mark.parametrize('below', [0.9, -0.9, 0.0])
def test_a_joint_held_by_less_than_its_coulomb_torque_stays_at_rest(world_on, below):
    fc = 3.0
    world = world_on('single_link', q0=(0.4,), friction={'coulomb': [fc]})
    q0 = world.state()[0]
    world.set_torque(g_of(world) + below * fc)
    world.step(1000)
    assert np.abs(world.state()[0] - q0).max() < 1e-9


def test_every_iiwa_joint_sticks_at_once_below_its_coulomb_torque(world_on):
    """Coupled joints: the holding torques of all seven are solved together (drift < 1e-9 in 1 s); without
    friction the same torque moves the arm."""
    fc = np.array(IIWA_COULOMB)
    world = world_on('iiwa', surface=False, friction={'coulomb': fc})
    q0 = world.state()[0]
    tau = g_of(world) + 0.9 * fc * np.array([1, -1, 1, -1, 1, -1, 1])
    world.set_torque(tau)
    world.step(1000)
    assert np.abs(world.state()[0] - q0).max() < 1e-9
    world.set_friction(None)
    world.step(100)
    assert np.abs(world.state()[0] - q0).max() > 1e-4


@pytest.mark.parametrize('armature', [0.0, 0.5])
def test_above_the_breakaway_the_acceleration_is_net_force_over_mass(world_on, armature):
    """force_1dof (m = 1 kg, prismatic, no gravity along x): qdd = (u - F_c sign(u)) / (m + I_a), both ways."""
    fc, m = 2.0, 1.0
    world = world_on('force_1dof', surface=False, q0=(0.0,), friction={'coulomb': [fc], 'armature': [armature]})
    for u in (5.0, -5.0):
        world.reset()
        world.step()                    # at rest, stuck: the first step breaks away
        a = acceleration(world, [u], steps=10)
        expected = (u - fc * np.sign(u)) / (m + armature)
        assert a[0] == pytest.approx(expected, rel=1e-9)


def test_a_sliding_single_link_feels_coulomb_against_its_motion(world_on):
    """qdd = (tau - g - F_c sign(qd)) / (M + I_a) at each step of a swing (1e-9 relative; M, g at the step's start)."""
    fc, ia = 0.5, 0.05
    world = world_on('single_link', q0=(0.3,), friction={'coulomb': [fc], 'armature': [ia]})
    world.set_torque([0.0])
    world.step(50)                      # swinging down
    for _ in range(5):
        qd = world.state()[1]
        assert abs(qd[0]) > 0.1
        expected = (0.0 - g_of(world)[0] - fc * np.sign(qd[0])) / (M_of(world)[0, 0] + ia)
        assert acceleration(world, [0.0])[0] == pytest.approx(expected, rel=1e-9)


def test_coulomb_torque_satisfies_complementarity_on_coupled_systems():
    """Random SPD inertias, velocities and breakaway torques: A (qd+ - qd) / dt = r + f; |f| <= F_c;
    a joint that moves (qd+ != 0, not even by round-off) feels -F_c sign(qd+)."""
    rng = np.random.default_rng(3)
    for _ in range(2000):
        n = int(rng.integers(1, 8))
        a = rng.normal(size=(n, n))
        A = a @ a.T + 0.05 * np.eye(n)
        qd, r = rng.normal(size=n) * 0.01, rng.normal(size=n)
        fc = rng.uniform(0.0, 2.0, n) * (rng.uniform(size=n) > 0.2)
        f, v = coulomb_torque(A, A @ qd / DT + r, DT, fc)
        stuck = (v == 0.0) & (fc > 0)
        np.testing.assert_allclose(A @ (v - qd) / DT, r + f, atol=1e-9)
        assert np.all(np.abs(f) <= fc * (1 + 1e-9) + 1e-15)
        slip = ~stuck & (fc > 0)
        np.testing.assert_allclose(f[slip], -fc[slip] * np.sign(v[slip]), rtol=1e-9)
        assert np.all(f[fc == 0] == 0)


def test_the_solver_started_from_any_sets_finds_the_same_friction_to_the_bit():
    """coulomb_sets started from random active sets (the World starts each step from the last step's) ends at
    the f and qd+ of the first guess, bit for bit (the solution is unique, its sets decide it); started from the
    sets it ended with, it ends with those sets and the same f."""
    rng = np.random.default_rng(11)
    for _ in range(2000):
        n = int(rng.integers(1, 8))
        a = rng.normal(size=(n, n))
        A = a @ a.T + 0.05 * np.eye(n)
        b = A @ (rng.normal(size=n) * 0.01) / DT + rng.normal(size=n)
        fc = rng.uniform(0.0, 2.0, n) * (rng.uniform(size=n) > 0.2)
        f, v = coulomb_torque(A, b, DT, fc)
        start = ((rng.uniform(size=n) < 0.5) & (fc > 0), rng.choice([-1.0, 1.0], n))
        f_started, v_started, sets = coulomb_sets(A, b, DT, fc, start)
        assert np.array_equal(f_started, f) and np.array_equal(v_started, v)
        if sets is not None:
            again = coulomb_sets(A, b, DT, fc, sets)
            assert np.array_equal(again[0], f) and np.array_equal(again[2][0], sets[0])


def test_the_fallback_solver_finds_the_same_friction():
    """coulomb_torque's fallback (projected Gauss-Seidel, for active sets that would not settle) agrees with
    the active sets on random coupled systems (1e-9 of F_c)."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 8))
        a = rng.normal(size=(n, n))
        A = a @ a.T + 0.5 * np.eye(n)
        b = A @ rng.normal(size=n) * 0.01 / DT + rng.normal(size=n)
        fc = rng.uniform(0.1, 2.0, n)
        f, _ = coulomb_torque(A, b, DT, fc)
        np.testing.assert_allclose(_coordinate_descent(DT * np.linalg.inv(A), DT * np.linalg.solve(A, b), fc), f,
                                   atol=1e-9 * fc.max())


def test_the_fallback_inside_the_solver_ends_at_the_active_sets_solution(monkeypatch):
    """With no active-set pass allowed, solve_sets takes its fallback (projected Gauss-Seidel, then the sets it
    points to) and returns the f and qd+ of the active sets, bit for bit, and no sets."""
    rng = np.random.default_rng(8)
    cases = []
    for _ in range(100):
        n = int(rng.integers(1, 8))
        a = rng.normal(size=(n, n))
        A = a @ a.T + 0.5 * np.eye(n)
        cases.append((A, A @ rng.normal(size=n) * 0.01 / DT + rng.normal(size=n), rng.uniform(0.1, 2.0, n)))
    expected = [coulomb_torque(A, b, DT, fc) for A, b, fc in cases]
    monkeypatch.setattr(joint_friction, 'max_passes', lambda n: 0)
    for (A, b, fc), (f, v) in zip(cases, expected):
        f_fallback, v_fallback, sets = coulomb_sets(A, b, DT, fc)
        assert sets is None
        assert np.array_equal(f_fallback, f) and np.array_equal(v_fallback, v)


# -- viscous friction --------------------------------------------------------------------------------------
def test_viscous_friction_decays_a_free_velocity_exponentially(world_on):
    """force_1dof, m = 1 kg, b = 0.5 N s/m: qd_k = qd_0 (1 - b dt / m)^k (semi-implicit Euler of
    m qdd = -b qd), exp(-b t / m) within 1e-3 over 2 s."""
    b, m = 0.5, 1.0
    world = world_on('force_1dof', surface=False, q0=(0.0,), friction={'viscous': [b]})
    world.set_torque([1.0])
    world.step(100)
    world.set_torque([0.0])
    v0 = world.state()[1][0]
    world.step(2000)
    v = world.state()[1][0]
    assert v / v0 == pytest.approx((1 - b * DT / m) ** 2000, rel=1e-12)
    assert v / v0 == pytest.approx(np.exp(-b * 2.0 / m), rel=1e-3)


def test_viscous_friction_is_the_torque_minus_b_qd(world_on):
    """The viscous friction equals an applied -b qd step by step (bit-identical), on the iiwa (PyBullet: its joint
    damping)."""
    b = np.full(7, 0.5)
    damped = world_on('iiwa', surface=False, friction={'viscous': b})
    applied = world_on('iiwa', surface=False)
    for _ in range(300):
        applied.set_torque(-b * applied.state()[1])
        damped.step()
        applied.step()
    assert np.array_equal(damped.state()[0], applied.state()[0])
    assert np.abs(damped.state()[1]).max() > 0.1


# -- armature ----------------------------------------------------------------------------------------------
def test_armature_adds_to_the_diagonal_of_the_mass_matrix(world_on):
    """iiwa at rest, armature 0.1 kg m^2 per joint: qdd = (M + I_a)^-1 (tau - g) (1e-9 relative), unlike
    M^-1 (tau - g)."""
    ia = np.full(7, 0.1)
    world = world_on('iiwa', surface=False, friction={'armature': ia})
    q0 = world.state()[0]
    tau = g_of(world) + np.array([2.0, -1.0, 1.5, 1.0, -0.5, 0.3, 0.2])
    expected = np.linalg.solve(M_of(world) + np.diag(ia), tau - g_of(world))
    without = np.linalg.solve(M_of(world), tau - g_of(world))
    a = acceleration(world, tau)
    np.testing.assert_allclose(a, expected, rtol=1e-9, atol=1e-9)
    assert np.abs(a - without).max() > 0.1 * np.abs(without).max()


def test_armature_holds_under_a_cartesian_disturbance(world_on):
    """iiwa held by g(q), armature 0.1: a force at the tip accelerates the arm as (M + I_a)^-1 J^T F
    (within 1e-3 rad/s^2: PyBullet's own tip force differs from J^T F by 5e-4 rad/s^2 on joint 7 without
    armature too)."""
    ia = np.full(7, 0.1)
    force = np.array([0.0, 20.0, -10.0])
    world = world_on('iiwa', surface=False, friction={'armature': ia}, disturbance={'cartesian_force': force})
    J = for_scenario('iiwa').J(world.state()[0])
    expected = np.linalg.solve(M_of(world) + np.diag(ia), J.T @ force)
    without = np.linalg.solve(M_of(world), J.T @ force)
    a = acceleration(world, g_of(world))
    np.testing.assert_allclose(a, expected, rtol=1e-4, atol=1e-3)
    assert np.abs(a - without).max() > 0.1 * np.abs(without).max()


@pytest.mark.parametrize('name', tuple(scenarios.SCENARIOS))
def test_every_scenario_sticks_and_carries_its_armature(world_on, name):
    """Every robot (closed forms through their generated URDFs, iiwa, Panda, UR5): held at 0.8 F_c (alternating
    signs) it moves < 1e-9 in 0.5 s; with armature 0.2 its acceleration is (M + I_a)^-1 (tau - g) within 1e-4
    relative (the Panda's fingers, held by position motors, couple in at 8e-6; the others agree to 2e-14)."""
    n = len(scenarios.get(name).joints)
    stuck = world_on(name, surface=False, friction={'coulomb': np.full(n, 2.0)})
    q0, g = stuck.state()[0], g_of(stuck)
    stuck.set_torque(g + 1.6 * np.where(np.arange(n) % 2, 1.0, -1.0))
    stuck.step(500)
    assert np.abs(stuck.state()[0] - q0).max() < 1e-9
    ia = np.full(n, 0.2)
    world = world_on(name, surface=False, friction={'armature': ia})
    expected = np.linalg.solve(M_of(world) + np.diag(ia), np.ones(n))
    np.testing.assert_allclose(acceleration(world, g + 1.0), expected, rtol=1e-4, atol=1e-4 * np.abs(expected).max())


@pytest.mark.parametrize('friction,band', [({'viscous': [5.0], 'armature': [0.5]}, 1e-3),
                                           ({'coulomb': [0.5], 'viscous': [5.0], 'armature': [0.5]}, 0.5)])
def test_pressed_on_the_surface_the_contact_balances_the_push(world_on, friction, band):
    """force_1dof pushing with u = 20 N on its wall (k_e = 1000 N/m): at rest (within 20 s; PyBullet's implicit
    contact is at rest after 6 s, MuJoCo's explicit spring, damped by b alone, decays as exp(-b t / 2 (m + I_a))),
    the contact force is u within the Coulomb band (1e-3 N without Coulomb friction). The armature's torque
    -I_a qdd follows the acceleration the contact allows (PyBullet's constraint torque of the last step, carried
    into the next; MuJoCo's contact force is known in the step)."""
    world = world_on('force_1dof', friction=friction)
    world.set_torque([20.0])
    world.step(6000)
    while abs(world.state()[1][0]) >= 1e-5 and world.t < 20.0:
        world.step(1000)
    assert abs(world.state()[1][0]) < 1e-5
    assert abs(world.contact_wrench()[0][0] - 20.0) <= band


def test_the_brakes_hold_whatever_the_friction_and_armature(world_on):
    world = world_on('iiwa', surface=False, friction={'coulomb': IIWA_COULOMB, 'armature': np.full(7, 0.1)})
    q0 = world.state()[0]
    world.brake(True)
    world.set_torque(np.full(7, 50.0))
    world.step(500)
    assert np.abs(world.state()[0] - q0).max() < 1e-3
    world.brake(False)
    world.step(50)
    assert np.abs(world.state()[0] - q0).max() > 1e-2


# -- the World's interface -----------------------------------------------------------------------------------
def test_friction_survives_reset_and_changes_at_run_time(world_on):
    world = world_on('force_1dof', surface=False, q0=(0.0,), friction={'coulomb': [2.0]})
    world.set_torque([1.5])
    world.step(100)
    world.reset()
    world.step(100)
    assert world.state()[0][0] == 0.0
    world.set_torque([1.5])
    world.step(100)
    assert world.state()[0][0] == 0.0
    world.set_friction({'coulomb': [1.0]})
    assert world.friction.coulomb.tolist() == [1.0] and world.friction.armature.tolist() == [0.0]
    world.step(100)
    assert world.state()[0][0] > 0.0


def test_a_step_prepared_ahead_is_the_same_step_to_the_bit(world_on):
    """World.prepare between steps (the bridge's call once a state is published) changes nothing: the iiwa with
    Coulomb friction, viscous friction and armature, sticking and slipping, pushed at the tip, braked and
    released, its friction changed after a prepare, prepared twice on some steps, prepared for the torque it then
    holds (solved ahead) or for another, follows the same trajectory bit for bit as without."""
    friction = {'coulomb': [1.8, 1.8, 1.0, 1.0, 0.63, 0.23, 0.23], 'viscous': [0.17, 0.17, 0.09, 0.09, 0.06, 0.02, 0.02],
                'armature': [0.1] * 7}
    worlds = [world_on('iiwa', friction=friction) for _ in range(2)]
    amplitude = np.array([3.0, 6.0, 2.0, 4.0, 1.0, 0.5, 0.4])
    runs = [[], []]
    for k in range(1200):
        for world, run in zip(worlds, runs):
            tau = g_of(world) + amplitude * np.sin(0.01 * k * np.arange(1, 8)) * (1 + k // 200 % 2)
            if world is worlds[1] and k:
                world.prepare(None if k % 4 == 0 else (tau + 0.5 * (k % 4 == 1)).tolist())
                if k % 3 == 0:
                    world.prepare(tau.tolist())         # a second call before the step does nothing
            if k == 300:
                world.set_disturbance(cartesian_force=[0.0, 5.0, -20.0])
            if k == 500:
                world.brake(True)
            if k == 550:
                world.brake(False)
            if k == 700:
                world.set_friction({**friction, 'coulomb': [0.5] * 7})
            world.set_torque(tau)
            world.step()
            run.append(np.concatenate([*world.state()[:2], world.joint_friction_torque()]))
    assert np.array_equal(np.array(runs[0]), np.array(runs[1]))


def test_a_step_prepared_for_the_torque_it_holds_is_solved_once(monkeypatch):
    """World.prepare(tau) solves the next step's friction for tau ahead; the step holding tau takes that solution
    (one solve per step), a step holding another torque solves again. (PyBullet's World: MuJoCo's joint physics
    is its own.)"""
    solves = []
    solve = joint_friction.StepPlan.solve
    monkeypatch.setattr(joint_friction.StepPlan, 'solve', lambda plan, x=None: solves.append(1) or solve(plan, x))
    world = make_world('pybullet', 'iiwa', friction={'coulomb': [1.0] * 7, 'armature': [0.1] * 7})
    try:
        world.brake(False)
        tau = g_of(world).tolist()
        world.set_torque(tau)
        world.step()
        for expected, held in ((1, tau), (2, [t + 1.0 for t in tau])):
            solves.clear()
            world.prepare(tau)
            world.set_torque(held)
            world.step()
            assert len(solves) == expected
    finally:
        world.close()


@pytest.mark.parametrize('friction,name', [({'coulomb': [-1.0]}, 'friction.coulomb'),
                                           ({'viscous': [1.0, 2.0]}, 'friction.viscous'),
                                           ({'armature': [np.nan]}, 'armature'),
                                           ({'stiction': [1.0]}, 'friction'), ([1.0], 'friction')])
def test_bad_friction_names_what_is_wrong(friction, name):
    with pytest.raises(ArgumentError) as info:
        JointFriction.of(1, friction)
    assert info.value.name == name


def test_the_bridge_shows_zero_friction_by_default_and_passes_what_is_set():
    values = bridge_params.defaults('iiwa')
    assert all(values[k] == (0.0,) * 7 for k in ('friction.coulomb', 'friction.viscous', 'armature'))
    cfg = bridge_params.validate(bridge_params.defaults('iiwa', **{'friction.coulomb': IIWA_COULOMB}))
    assert cfg.friction == JointFriction.of(7, {'coulomb': IIWA_COULOMB})
    with pytest.raises(ArgumentError) as info:
        bridge_params.validate(bridge_params.defaults('polar_two_link', **{'friction.viscous': [1.0]}))
    assert info.value.name == 'friction.viscous'
