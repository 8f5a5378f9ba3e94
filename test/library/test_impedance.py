"""Cartesian impedance (robot_control.laws.impedance) against its closed-loop equation.

With the model as the plant and an external wrench F on the tip (M qdd + C qd + g = tau + J^T F):
the tip settles at x_d + K^-1 F from its target; a moving target is followed; on a Cartesian robot
(J = I, Lambda = M) the designed damping is the critical 2 sqrt(m k); the law inside the controller
core equals the library function.
"""
import numpy as np
import pinocchio as pin
import pytest

from support.loops import integrate
from robot_control.core.config import ControllerConfig
from robot_control.core.tick import ControllerCore
from robot_control.laws import impedance
from robot_control.laws.impedance import DESIGN_STIFFNESS, _damping, max_frequency
from robot_control.laws.operational_space import _task_inertia
from robot_control.models import for_scenario, make_model

Q0 = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0])
K6 = (1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0)


@pytest.fixture(scope='module')
def iiwa():
    return for_scenario('iiwa', task_space='pose')


def _loop(model, target, wrench, **kw):
    """y = [q, qd] under impedance toward target(t) = (x_d, xd_d, xdd_d), external wrench(t) (m,) on the tip."""
    n = model.n

    def rhs(t, y):
        q, qd = y[:n], y[n:]
        tau = impedance(model, q, qd, *target(t), K6, q_posture=Q0, **kw)
        return np.concatenate([qd, model.forward_dynamics(q, qd, tau + model.J(q).T @ wrench(t))])
    return rhs


def test_under_a_constant_push_the_tip_settles_at_k_inverse_f_from_its_target(iiwa):
    """10 N along -z and 1 N m about x: the tip goes 10 mm down and turns 10 mrad about x, the rest < 1e-6."""
    x0 = iiwa.fk(Q0)
    push = np.array([0.0, 0.0, -10.0, 1.0, 0.0, 0.0])
    target = (x0, np.zeros(6), np.zeros(6))
    _, ys = integrate(_loop(iiwa, lambda t: target, lambda t: push), np.concatenate([Q0, np.zeros(7)]), 3.0, dt=2e-3)
    offset = iiwa.task_difference(iiwa.fk(ys[-1, :7]), x0)
    np.testing.assert_allclose(offset, push / np.array(K6), rtol=0, atol=2e-6)
    assert np.abs(ys[-1, 7:]).max() < 1e-5


def test_a_moving_target_is_followed_and_the_error_stays_zero(iiwa):
    """The target of a joint motion seen in the task space, from rest at the start: E stays ~0."""
    q_goal = Q0 + np.array([0.3, -0.2, 0.1, 0.3, 0.0, -0.2, 0.4])

    def joint(t):
        s = min(t / 1.5, 1.0)
        a, ad, add = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / 1.5, \
            (60 * s - 180 * s ** 2 + 120 * s ** 3) / 1.5 ** 2
        d = q_goal - Q0
        return Q0 + a * d, ad * d, add * d
    target = lambda t: iiwa._task_motion(*joint(t))     # noqa: E731
    ts, ys = integrate(_loop(iiwa, target, lambda t: np.zeros(6)), np.concatenate([Q0, np.zeros(7)]), 2.0, dt=2e-3)
    worst = max(np.abs(iiwa.task_difference(target(t)[0], iiwa.fk(y[:7]))).max() for t, y in zip(ts, ys))
    assert worst < 1e-6, worst


def test_on_a_cartesian_robot_the_designed_damping_is_critical():
    """J = I, Lambda = M = diag(m): D = 2 zeta sqrt(m k) per axis, and the loop is m e'' + d e' + k e = 0."""
    model = make_model('cartesian_xyz')
    M = model.M(np.zeros(3))
    K = np.array([1000.0, 400.0, 2500.0])
    np.testing.assert_allclose(_damping(np.sqrt(M), np.sqrt(K), 1.0), np.diag(2.0 * np.sqrt(np.diag(M) * K)), rtol=1e-12)
    q, qd = np.array([0.1, 0.2, 0.3]), np.array([0.5, -0.2, 0.1])
    x_d = np.array([0.15, 0.2, 0.25])
    tau = impedance(model, q, qd, x_d, np.zeros(3), np.zeros(3), (1000.0, 400.0, 2500.0, 0, 0, 0))
    qdd = model.forward_dynamics(q, qd, tau)
    m = np.diag(M)
    np.testing.assert_allclose(m * qdd, K * (x_d - q) - 2.0 * np.sqrt(m * K) * qd, rtol=1e-12, atol=1e-9)


def test_the_task_inertia_and_its_root_come_from_one_eigendecomposition(iiwa):
    """Lambda = (J M^-1 J^T)^-1 and its symmetric square root; a singular Jacobian is refused naming q."""
    q = np.array(Q0)
    J = iiwa.J(q)
    Lambda, root = _task_inertia(iiwa, q, J, root=True)
    np.testing.assert_array_equal(_task_inertia(iiwa, q, J), Lambda)
    np.testing.assert_allclose(Lambda, np.linalg.inv(J @ np.linalg.inv(iiwa.M(q)) @ J.T), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(root @ root, Lambda, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(root, root.T, atol=1e-12)
    planar = make_model('planar_two_link')
    stretched = np.array([0.3, 0.0])
    with pytest.raises(ValueError, match='^q: task Jacobian singular'):
        _task_inertia(planar, stretched, planar.J(stretched))
    with pytest.raises(ValueError, match='^q: task Jacobian singular'):
        impedance(planar, stretched, np.zeros(2), planar.fk(stretched), np.zeros(2), np.zeros(2), (1000.0,) * 6)


def test_the_error_fed_to_the_law_is_bounded(iiwa):
    """A target 1 m away acts like one 0.1 m away in the same direction (max_pose_error (0.1 m, 0.5 rad))."""
    x0 = iiwa.fk(Q0)
    far, near = x0.copy(), x0.copy()
    far[0] += 1.0
    near[0] += 0.1
    zero = np.zeros(6)
    tau_far = impedance(iiwa, Q0, np.zeros(7), far, zero, zero, K6, max_pose_error=(0.1, 0.5))
    tau_near = impedance(iiwa, Q0, np.zeros(7), near, zero, zero, K6, max_pose_error=(0.1, 0.5))
    np.testing.assert_allclose(tau_far, tau_near, rtol=0, atol=1e-9)


def test_the_core_runs_the_library_law(iiwa):
    """Inside the controller core the target is the pose at the start; a step of the target arrives as
    the library law with the same E bound."""
    core = ControllerCore(ControllerConfig(iiwa, law='impedance'))
    q, qd = Q0 + 0.01, np.full(7, 0.05)
    core.update(0.0, Q0, np.zeros(7))
    x0 = iiwa.fk(Q0)
    tau = core.update(0.001, q, qd)
    want = impedance(iiwa, q, qd, x0, np.zeros(6), np.zeros(6), K6, q_posture=Q0, max_pose_error=(0.1, 0.5))
    np.testing.assert_allclose(tau, want, rtol=0, atol=1e-9)
    target = x0 + np.array([0.02, 0.0, 0.0, 0.0, 0.0, 0.0])
    core.set_target_pose(target)
    core.set_target_wrench([0.0, 0.0, -5.0, 0.0, 0.0, 0.0])
    tau = core.update(0.002, q, qd)
    want = impedance(iiwa, q, qd, target, np.zeros(6), np.zeros(6), K6, F_ff=[0, 0, -5.0, 0, 0, 0], q_posture=Q0,
                     max_pose_error=(0.1, 0.5))
    np.testing.assert_allclose(tau, want, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(core.reference[0], target)


@pytest.mark.parametrize('kwargs, name', [
    ({'stiffness': (1.0, 2.0)}, 'stiffness'), ({'stiffness': (-1.0, 0, 0, 0, 0, 0)}, 'stiffness'),
    ({'x_d': [np.nan] * 6}, 'x_d'), ({'max_pose_error': (0.0, 1.0)}, 'max_pose_error'),
    ({'F_ff': [1.0]}, 'F_ff'), ({'damping': (1.0,) * 5}, 'damping'),
])
def test_bad_input_names_the_argument(iiwa, kwargs, name):
    args = dict(x_d=iiwa.fk(Q0), xd_d=np.zeros(6), xdd_d=np.zeros(6), stiffness=K6)
    args.update(kwargs)
    with pytest.raises(ValueError) as info:
        impedance(iiwa, Q0, np.zeros(7), **args)
    assert info.value.name == name


def test_orientation_axes_are_servoed_on_so3(iiwa):
    """A target turned 0.2 rad about world z: E's rotation part is exactly (0, 0, 0.2)."""
    x0 = iiwa.fk(Q0)
    turned = np.concatenate([x0[:3], pin.log3(pin.exp3(np.array([0.0, 0.0, 0.2])) @ pin.exp3(x0[3:]))])
    core = ControllerCore(ControllerConfig(iiwa, law='impedance'))
    core.update(0.0, Q0, np.zeros(7))
    core.set_target_pose(turned)
    core.update(0.001, Q0, np.zeros(7))
    np.testing.assert_allclose(core.error[0], [0, 0, 0, 0, 0, 0.2], rtol=0, atol=1e-12)


# -- the designed stiffness, capped for the control rate ----------------------------------------------------
XARM = 'xarm_description/urdf/xarm7.urdf'
XARM_JOINTS = tuple(f'joint{i}' for i in range(1, 8))
XARM_START = np.array([0.0, -0.3, 0.0, 0.6, 0.0, 0.9, 0.0])      # config/templates/your_robot.yaml


@pytest.mark.parametrize('zeta', [0.5, 1.0, 2.0, 4.0])
@pytest.mark.parametrize('delay', [0, 1])
def test_an_axis_at_the_capped_frequency_is_stable_at_the_control_period(zeta, delay):
    """The double integrator e'' = u, u = -w^2 e - 2 zeta w e' computed from the state of t_k and held for dt
    (delay: from the state of t_(k-1)), exactly discretized, at w = w_max: every pole inside the unit circle."""
    dt = 0.001
    w = max_frequency(dt, zeta)
    kp, kv = w * w, 2 * zeta * w
    hold = np.array([[1.0, dt], [0.0, 1.0]]), np.array([dt * dt / 2, dt])
    if delay:       # state (e, e', u_held)
        A = np.zeros((3, 3))
        A[:2, :2], A[:2, 2], A[2, :2] = hold[0], hold[1], [-kp, -kv]
    else:
        A = hold[0] - np.outer(hold[1], [kp, kv])
    radius = np.abs(np.linalg.eigvals(A)).max()
    print(f'zeta {zeta}, delay {delay}: w_max dt = {w * dt:.3f}, pole radius {radius:.4f}')
    assert radius < 1.0 - 1e-3


def test_the_designed_stiffness_is_capped_per_axis_each_tick_and_the_law_is_the_library_s():
    """xArm7, pose: the rz axis has (Lambda^-1)_zz ~ 7e3 1/(kg m^2): 100 N m/rad would ring at 849 rad/s;
    the law takes K_i = min(K_design_i, w_max^2 / (J M^-1 J^T)_ii) with the damping designed from it."""
    xarm = make_model('urdf', urdf=XARM, joints=XARM_JOINTS, tip='link7', task_space='pose')
    core = ControllerCore(ControllerConfig(xarm, law='impedance'))
    q, qd = XARM_START + 0.02, np.full(7, 0.05)
    core.update(0.0, XARM_START, np.zeros(7))
    tau = core.update(0.001, q, qd)
    J = xarm.J(q)
    inverse_inertia = np.diag(J @ np.linalg.inv(xarm.M(q)) @ J.T)
    w_max = np.pi / 10 / 0.001
    K = np.minimum(DESIGN_STIFFNESS, w_max ** 2 / inverse_inertia)
    print(f'capped K {K.round(2).tolist()}')
    assert K[5] < 20.0 and np.all(K[:5] == DESIGN_STIFFNESS[:5])
    want = impedance(xarm, q, qd, xarm.fk(XARM_START), np.zeros(6), np.zeros(6), K, q_posture=XARM_START,
                     max_pose_error=(0.1, 0.5))
    np.testing.assert_allclose(tau, want, rtol=0, atol=1e-9)


def test_the_xarm7_under_impedance_with_the_defaults_holds_its_pose_without_saturating():
    """In the simulated World at 1 ms: 3 s of impedance holding the start pose, no tick at an effort limit
    (uncapped, joint 7 saturated in 1547 of 3000 ticks and the arm drifted 0.21 rad)."""
    from robot_control.core.controller import Controller
    from sim_bridge.world import World
    xarm = make_model('urdf', urdf=XARM, joints=XARM_JOINTS, tip='link7', task_space='auto')
    ctrl = Controller(ControllerConfig(xarm, law='impedance'), 0.5)
    world = World(None, urdf=XARM, joints=XARM_JOINTS, q0=XARM_START)
    try:
        for k in range(3000):
            q, qd, _ = world.state()
            world.set_torque(ctrl.step(k * 1_000_000, XARM_JOINTS, q, qd).tau)
            world.step()
        drift = np.abs(world.state()[0] - XARM_START).max()
    finally:
        world.close()
    print(f'xArm7 impedance, defaults: {ctrl.core.saturated_ticks} saturated ticks of {ctrl.core.ticks}, '
          f'drift {drift:.2g} rad')
    assert ctrl.core.saturated_ticks == 0 and ctrl.core.fallbacks == 0
    assert drift < 1e-6
