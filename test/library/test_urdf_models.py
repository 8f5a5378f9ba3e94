"""URDF robots: generator, UrdfModel (Pinocchio) and PyBullet against the lecture's closed forms.

Tolerances (measured on 100 seeded random states, then widened for other BLAS/compilers):
- closed form vs Pinocchio on the generated URDFs: max abs error 4e-15 (M, C qd, g, fk, J, Jdot qd
  with |values| <= 60); checked at rtol 1e-9 plus atol 1e-9 (the brief's 1e-9).
- closed form vs PyBullet (calculateMassMatrix / calculateInverseDynamics): max 7e-15, atol 1e-9.
- one PyBullet step: qdd = (qd1 - qd0) / dt agrees with the closed form within 2.1e-13, the
  rounding of qd (~4e-16) divided by dt = 1e-3; checked at 1e-8.
- iiwa, Pinocchio vs PyBullet on kuka_iiwa/model.urdf: M 2.2e-15, inverse dynamics 2.8e-14 for
  |tau| <= 65 N m; checked at 1e-9. PyBullet's link frame position (getLinkState) agrees only
  to 8e-8 (it composes the inertial offset in single precision); checked at 1e-6.
"""
import math
import os
import xml.etree.ElementTree as ET

import numpy as np
import pybullet
import pytest

from robot_control import scenarios
from robot_control.models import CLOSED_FORM, for_scenario, make_model
from robot_control.models import urdf_gen
from robot_control.models.urdf_model import URDF_DIR, UrdfModel, resolve_urdf

RNG_SEED = 20261122
MODELS = urdf_gen.MODELS
SHIPPED = urdf_gen.shipped_params()
IIWA = 'kuka_iiwa/model.urdf'
IIWA_JOINTS = tuple(f'lbr_iiwa_joint_{i}' for i in range(1, 8))
IIWA_TIP = 'lbr_iiwa_link_7'
TOL = 1e-9


def close(actual, expected, tol=TOL, msg=''):
    np.testing.assert_allclose(actual, expected, rtol=tol, atol=tol, err_msg=msg)


def closed_form(name, **overrides):
    """The closed form on the shipped parameters. The mass-spring's b xd and k x^3 are applied
    by the simulator, not the URDF: its rigid-body part is the closed form with b = k = 0."""
    params = {**SHIPPED[name], **overrides}
    if name == 'mass_spring_cubic':
        params.update(b=0.0, k=0.0)
    return make_model(name, **params)


def gravity_of(params):
    return (0.0, 0.0, -params.get('gravity', 9.81))


def random_state(rng, name, n):
    q = rng.uniform(-2.0, 2.0, n)
    if name == 'polar_two_link':
        q[1] = rng.uniform(*urdf_gen.POLAR_R_LIMITS)
    return q, rng.uniform(-3.0, 3.0, n), rng.uniform(-5.0, 5.0, n)


# -- generator and shipped files ---------------------------------------------------------------
def test_every_closed_form_model_has_a_urdf():
    assert set(MODELS) == set(CLOSED_FORM)
    assert sorted(f for f in os.listdir(URDF_DIR) if f.endswith('.urdf')) == [f'{m}.urdf' for m in MODELS]


@pytest.mark.parametrize('name', MODELS)
def test_shipped_urdf_equals_generator_output(name):
    with open(os.path.join(URDF_DIR, f'{name}.urdf'), encoding='utf-8') as f:
        assert f.read() == urdf_gen.urdf_xml(name, **SHIPPED[name]), \
            'regenerate with: python -m robot_control.models.urdf_gen'


def test_shipped_params_are_the_scenario_defaults():
    by_model = {s.model: s.params for s in scenarios.SCENARIOS.values()}
    for name in MODELS:
        assert SHIPPED[name] == by_model[name]
    assert SHIPPED['polar_two_link']['m'] == 2.0


def test_urdf_xml_rejects_unknown_model_and_bad_parameters():
    with pytest.raises(ValueError, match='^model_name:'):
        urdf_gen.urdf_xml('scara')
    with pytest.raises(ValueError, match='^m:'):
        urdf_gen.urdf_xml('polar_two_link', m=-1.0)
    with pytest.raises(ValueError, match='^params:'):
        urdf_gen.urdf_xml('polar_two_link', mass=2.0)


@pytest.mark.parametrize('name', MODELS)
def test_joint_names_equal_scenario_joints(name):
    scenario = next(s for s in scenarios.SCENARIOS.values() if s.model == name)
    model = UrdfModel(resolve_urdf(name))   # all movable joints, URDF order
    assert set(model.joint_names) == set(scenario.joints)
    assert UrdfModel(resolve_urdf(name), joints=scenario.joints).joint_names == scenario.joints


# -- closed form == Pinocchio -------------------------------------------------------------------
@pytest.mark.parametrize('name', MODELS)
def test_closed_form_equals_pinocchio_on_shipped_urdf(name):
    cf = closed_form(name)
    um = UrdfModel(resolve_urdf(name), joints=cf.joint_names, tip='tip', gravity=gravity_of(SHIPPED[name]))
    rows = list(urdf_gen.WORLD_AXES[name])
    others = [i for i in range(3) if i not in rows]
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(100):
        q, qd, qdd = random_state(rng, name, cf.n)
        m = um.M(q)
        close(m, cf.M(q), msg='M')
        np.testing.assert_array_equal(m, m.T)
        assert np.all(np.linalg.eigvalsh(m) > 0)
        close(um.C_qd(q, qd), cf.C_qd(q, qd), msg='C qd')
        close(um.C(q, qd) @ qd, cf.C_qd(q, qd), msg='C(q, qd) qd')
        close(um.g(q), cf.g(q), msg='g')
        close(um.inverse_dynamics(q, qd, qdd), cf.inverse_dynamics(q, qd, qdd), msg='tau')
        close(um.forward_dynamics(q, qd, cf.inverse_dynamics(q, qd, qdd)), qdd, msg='qdd')
        x, jac, bias = um.fk(q), um.J(q), um.Jdot_qd(q, qd)
        close(x[rows], cf.fk(q), msg='fk')
        close(jac[rows], cf.J(q), msg='J')
        close(bias[rows], cf.Jdot_qd(q, qd), msg='Jdot qd')
        # the motion stays in the robot's task axes (e.g. the vertical x-z plane)
        close(x[others], np.zeros(len(others)))
        close(jac[others], np.zeros((len(others), cf.n)))


@pytest.mark.parametrize('name, params', [
    ('planar_two_link', {'m1': 1.7, 'm2': 0.4, 'l1': 0.8, 'l2': 0.3, 'gravity': 9.7}),
    ('polar_two_link', {'m': 3.3, 'gravity': 1.62}),
    ('single_link', {'m': 0.25, 'l': 1.3}),
    ('cartesian_xyz', {'m1': 0.5, 'm2': 2.0, 'm3': 7.0}),
    ('cartesian_xy', {'m1': 4.0, 'm2': 0.1}),
])
def test_generated_urdf_with_other_parameters_from_xml_string(name, params):
    cf = make_model(name, **params)
    um = UrdfModel(urdf_gen.urdf_xml(name, **params), joints=cf.joint_names, tip='tip',
                   gravity=gravity_of(params))
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(100):
        q, qd, _ = random_state(rng, name, cf.n)
        close(um.M(q), cf.M(q))
        close(um.C_qd(q, qd), cf.C_qd(q, qd))
        close(um.g(q), cf.g(q))


def test_cartesian_xy_pinocchio_order_differs_and_is_mapped():
    """Pinocchio orders y (the base stage) before x; joints=('x', 'y') must give M = diag(m1, m1 + m2)."""
    um = UrdfModel(resolve_urdf('cartesian_xy'), joints=('x', 'y'), tip='tip')
    assert tuple(um.model.names[1:]) == ('y', 'x')
    np.testing.assert_array_equal(um.M([0.1, 0.2]), np.diag([1.0, 2.0]))
    np.testing.assert_allclose(um.g([0.1, 0.2]), [0.0, 2.0 * 9.81], rtol=0, atol=1e-12)
    np.testing.assert_allclose(um.fk([0.1, 0.2]), [0.1, 0.0, 0.2], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(um.effort_limit, [urdf_gen.EFFORT_LIMIT] * 2)


def test_limits_come_from_the_urdf():
    um = UrdfModel(resolve_urdf('polar_two_link'), joints=('theta1', 'r'))
    np.testing.assert_array_equal(um.effort_limit, [200.0, 200.0])
    lower, upper = um.position_limits
    np.testing.assert_array_equal(lower, [-2 * math.pi, 0.1])
    np.testing.assert_array_equal(upper, [2 * math.pi, 1.2])
    np.testing.assert_array_equal(um.velocity_limit, [urdf_gen.VELOCITY_LIMIT] * 2)


def test_single_link_angle_is_from_the_horizontal_and_raises_the_mass():
    um = UrdfModel(resolve_urdf('single_link'), tip='tip')
    np.testing.assert_allclose(um.fk([0.0]), [0.5, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(um.fk([math.pi / 2]), [0.0, 0.0, 0.5], atol=1e-15)
    assert um.g([0.0])[0] == pytest.approx(1.0 * 9.81 * 0.5, abs=1e-12)


# -- PyBullet on the same files -----------------------------------------------------------------
@pytest.fixture
def bullet():
    client = pybullet.connect(pybullet.DIRECT)
    try:
        yield pybullet, client
    finally:
        pybullet.disconnect(client)


def load(bullet, path, gravity):
    p, cid = bullet
    p.resetSimulation(physicsClientId=cid)
    p.setGravity(*gravity, physicsClientId=cid)
    body = p.loadURDF(path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
    joints = {}
    for i in range(p.getNumJoints(body, physicsClientId=cid)):
        info = p.getJointInfo(body, i, physicsClientId=cid)
        if info[2] != p.JOINT_FIXED:
            joints[info[1].decode()] = i
    return body, joints


@pytest.mark.parametrize('name', MODELS)
def test_pybullet_dynamics_equal_closed_form(bullet, name):
    p, cid = bullet
    cf = closed_form(name)
    body, joints = load(bullet, resolve_urdf(name), gravity_of(SHIPPED[name]))
    order = list(joints)                          # PyBullet's dof order
    perm = [order.index(j) for j in cf.joint_names]
    masses = {}
    for i in range(p.getNumJoints(body, physicsClientId=cid)):
        link = p.getJointInfo(body, i, physicsClientId=cid)[12].decode()
        masses[link] = p.getDynamicsInfo(body, i, physicsClientId=cid)[0]
    root = ET.parse(resolve_urdf(name)).getroot()
    in_file = {e.get('name'): float(e.find('inertial/mass').get('value')) for e in root.iter('link')}
    del in_file['base_link']
    assert masses == in_file                      # massless links read as exactly 0, not Bullet's default 1 kg
    assert masses['tip'] > 0.0                    # the contact link has mass (see urdf_gen)
    rng = np.random.default_rng(RNG_SEED + 2)
    for _ in range(100):
        q, qd, qdd = random_state(rng, name, cf.n)
        qb, qdb, qddb = (np.empty(cf.n) for _ in range(3))
        qb[perm], qdb[perm], qddb[perm] = q, qd, qdd
        m = np.array(p.calculateMassMatrix(body, qb.tolist(), physicsClientId=cid))
        tau = np.array(p.calculateInverseDynamics(body, qb.tolist(), qdb.tolist(), qddb.tolist(),
                                                  physicsClientId=cid))
        close(m[np.ix_(perm, perm)], cf.M(q), msg='M')
        close(tau[perm], cf.inverse_dynamics(q, qd, qdd), msg='tau')


@pytest.mark.parametrize('name', MODELS)
def test_one_pybullet_step_accelerates_as_the_closed_form(bullet, name):
    """Torque control as the world does it: motors off, damping zeroed, 1 ms step, no substeps."""
    p, cid = bullet
    cf = closed_form(name)
    body, joints = load(bullet, resolve_urdf(name), gravity_of(SHIPPED[name]))
    dt = 1e-3
    p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, physicsClientId=cid)
    for i in range(-1, p.getNumJoints(body, physicsClientId=cid)):
        p.changeDynamics(body, i, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0, physicsClientId=cid)
    idx = [joints[j] for j in cf.joint_names]
    p.setJointMotorControlArray(body, idx, p.VELOCITY_CONTROL, forces=[0.0] * cf.n, physicsClientId=cid)
    rng = np.random.default_rng(RNG_SEED + 3)
    for _ in range(20):
        q, qd = rng.uniform(-0.9, 0.9, cf.n), rng.uniform(-3.0, 3.0, cf.n)   # well inside the limits
        if name == 'polar_two_link':
            q[1] = rng.uniform(0.2, 1.1)
        tau = rng.uniform(-20.0, 20.0, cf.n)
        for k, i in enumerate(idx):
            p.resetJointState(body, i, q[k], qd[k], physicsClientId=cid)
        p.setJointMotorControlArray(body, idx, p.TORQUE_CONTROL, forces=tau.tolist(), physicsClientId=cid)
        p.stepSimulation(physicsClientId=cid)
        qd1 = np.array([s[1] for s in p.getJointStates(body, idx, physicsClientId=cid)])
        close((qd1 - qd) / dt, cf.forward_dynamics(q, qd, tau), tol=1e-8)


# -- the iiwa (pybullet_data) ------------------------------------------------------------------
@pytest.fixture(scope='module')
def iiwa():
    return UrdfModel(resolve_urdf(IIWA), joints=IIWA_JOINTS, tip=IIWA_TIP)


def test_iiwa_loads_with_its_limits(iiwa):
    assert iiwa.n == 7 and iiwa.joint_names == IIWA_JOINTS and iiwa.task_axes == ('x', 'y', 'z')
    np.testing.assert_array_equal(iiwa.effort_limit, [300.0] * 7)
    lower, upper = iiwa.position_limits
    assert lower[1] == pytest.approx(-2.09439510239) and upper[6] == pytest.approx(3.05432619099)


def test_iiwa_mass_matrix_spd_and_mdot_minus_2c_skew(iiwa):
    rng = np.random.default_rng(RNG_SEED + 4)
    h = 1e-6
    for _ in range(50):
        q, qd = rng.uniform(-2.0, 2.0, 7), rng.uniform(-2.0, 2.0, 7)
        m = iiwa.M(q)
        np.testing.assert_array_equal(m, m.T)
        assert np.linalg.eigvalsh(m).min() > 1e-4
        mdot = (iiwa.M(q + h * qd) - iiwa.M(q - h * qd)) / (2 * h)
        n = mdot - 2.0 * iiwa.C(q, qd)
        np.testing.assert_allclose(n + n.T, 0.0, atol=1e-7)   # FD error ~1e-9 for |Mdot| ~ 10
        close(iiwa.C(q, qd) @ qd, iiwa.C_qd(q, qd))


def test_the_dynamics_terms_are_new_arrays_a_later_call_leaves_alone(iiwa):
    """M, C and g come back as arrays of their own (Pinocchio returns copies; UrdfModel makes none): the next
    evaluation at another state does not change them."""
    q, qd = np.full(7, 0.3), np.full(7, -0.7)
    terms = (iiwa.M(q), iiwa.C(q, qd), iiwa.g(q))
    kept = [a.copy() for a in terms]
    iiwa.M(-q), iiwa.C(-q, 2.0 * qd), iiwa.g(-q), iiwa._tick_terms(-q, 2.0 * qd)
    for term, copy in zip(terms, kept):
        np.testing.assert_array_equal(term, copy)
    assert not np.array_equal(iiwa.g(-q), kept[2])


def test_iiwa_jacobian_and_bias_match_finite_differences(iiwa):
    rng = np.random.default_rng(RNG_SEED + 5)
    h = 1e-6
    for _ in range(20):
        q, qd = rng.uniform(-2.0, 2.0, 7), rng.uniform(-2.0, 2.0, 7)
        j_fd = np.column_stack([(iiwa.fk(q + h * e) - iiwa.fk(q - h * e)) / (2 * h) for e in np.eye(7)])
        np.testing.assert_allclose(iiwa.J(q), j_fd, atol=1e-8)
        jdot = (iiwa.J(q + h * qd) - iiwa.J(q - h * qd)) / (2 * h)
        np.testing.assert_allclose(iiwa.Jdot_qd(q, qd), jdot @ qd, atol=1e-7)


def test_iiwa_inverse_dynamics_equals_pybullet(bullet, iiwa):
    p, cid = bullet
    body, joints = load(bullet, resolve_urdf(IIWA), (0.0, 0.0, -9.81))
    assert list(joints) == list(IIWA_JOINTS)
    rng = np.random.default_rng(RNG_SEED + 6)
    for _ in range(100):
        q, qd, qdd = rng.uniform(-2.0, 2.0, 7), rng.uniform(-2.0, 2.0, 7), rng.uniform(-3.0, 3.0, 7)
        tau_b = p.calculateInverseDynamics(body, q.tolist(), qd.tolist(), qdd.tolist(), physicsClientId=cid)
        close(iiwa.inverse_dynamics(q, qd, qdd), tau_b, msg='rnea')
        close(iiwa.M(q) @ qdd + iiwa.C_qd(q, qd) + iiwa.g(q), tau_b, msg='M qdd + C qd + g')
        close(iiwa.M(q), p.calculateMassMatrix(body, q.tolist(), physicsClientId=cid), msg='M')
        for k, i in enumerate(joints.values()):
            p.resetJointState(body, i, q[k], 0.0, physicsClientId=cid)
        link = p.getLinkState(body, joints[IIWA_JOINTS[-1]], computeForwardKinematics=True, physicsClientId=cid)
        close(iiwa.fk(q), link[4], tol=1e-6, msg='fk vs link frame')


# -- restriction to a subset of joints ---------------------------------------------------------
def test_restricted_model_equals_full_model_with_locked_joints(iiwa):
    sub = ('lbr_iiwa_joint_4', 'lbr_iiwa_joint_2')          # not in URDF order
    locked = {'lbr_iiwa_joint_1': 0.3, 'lbr_iiwa_joint_3': -0.7, 'lbr_iiwa_joint_5': 1.1,
              'lbr_iiwa_joint_6': 0.4, 'lbr_iiwa_joint_7': -0.2}
    um = UrdfModel(IIWA, joints=sub, tip=IIWA_TIP, q_locked=locked)
    assert um.joint_names == sub and um.n == 2
    cols = [IIWA_JOINTS.index(j) for j in sub]
    rng = np.random.default_rng(RNG_SEED + 7)
    for _ in range(50):
        q, qd, qdd = rng.uniform(-2.0, 2.0, 2), rng.uniform(-2.0, 2.0, 2), rng.uniform(-3.0, 3.0, 2)
        qf, qdf, qddf = np.array([locked.get(j, 0.0) for j in IIWA_JOINTS]), np.zeros(7), np.zeros(7)
        qf[cols], qdf[cols], qddf[cols] = q, qd, qdd
        close(um.M(q), iiwa.M(qf)[np.ix_(cols, cols)])
        close(um.C_qd(q, qd), iiwa.C_qd(qf, qdf)[cols])
        close(um.g(q), iiwa.g(qf)[cols])
        close(um.inverse_dynamics(q, qd, qdd), iiwa.inverse_dynamics(qf, qdf, qddf)[cols])
        close(um.fk(q), iiwa.fk(qf))
        close(um.J(q), iiwa.J(qf)[:, cols])
        close(um.Jdot_qd(q, qd), iiwa.Jdot_qd(qf, qdf))


def test_unlocked_joints_default_to_neutral(iiwa):
    um = UrdfModel(IIWA, joints=['lbr_iiwa_joint_2'])
    q = np.zeros(7)
    q[1] = 0.8
    close(um.g([0.8]), iiwa.g(q)[[1]])
    assert um.task_dim == 0
    with pytest.raises(NotImplementedError):
        um.fk([0.8])


# -- for_scenario, make_model, resolve_urdf ----------------------------------------------------
def test_for_scenario_builds_each_scenarios_model():
    for scenario in scenarios.SCENARIOS.values():
        model = for_scenario(scenario.name)
        assert model.joint_names == scenario.joints
        if scenario.model == 'urdf':
            assert isinstance(model, UrdfModel) and model.tip == scenario.tip
        else:
            assert isinstance(model, CLOSED_FORM[scenario.model])
            for key, value in scenario.params.items():
                assert getattr(model, key) == value
    assert for_scenario(scenarios.get('polar_two_link'), m=3.0).m == 3.0


def test_for_scenario_urdf_overrides_and_errors():
    model = for_scenario('iiwa', gravity=0.0, joints=IIWA_JOINTS[:3])
    assert model.n == 3
    np.testing.assert_array_equal(model.g(np.ones(3)), np.zeros(3))
    with pytest.raises(ValueError, match='^overrides:'):
        for_scenario('iiwa', mass=3.0)
    with pytest.raises(ValueError, match='^scenario:'):
        for_scenario('scara')
    with pytest.raises(ValueError, match='^scenario:'):
        for_scenario(42)


def test_make_model_urdf():
    model = make_model('urdf', urdf='polar_two_link', joints=('theta1', 'r'), tip='tip', gravity=(0, 0, -9.8))
    close(model.g([0.0, 0.5]), [2.0 * 9.8 * 0.5, 0.0])
    with pytest.raises(ValueError, match='^urdf:'):
        make_model('urdf', joints=('theta1',))


def test_resolve_urdf():
    assert resolve_urdf('polar_two_link') == os.path.join(URDF_DIR, 'polar_two_link.urdf')
    assert resolve_urdf('polar_two_link.urdf') == os.path.join(URDF_DIR, 'polar_two_link.urdf')
    assert resolve_urdf(IIWA).endswith(os.path.join('pybullet_data', 'kuka_iiwa', 'model.urdf'))
    with pytest.raises(ValueError, match='^urdf:'):
        resolve_urdf('no_such_robot.urdf')


# -- bad input -----------------------------------------------------------------------------------
@pytest.mark.parametrize('urdf', ['<robot name="r"><link name="a"></robot>',       # not well-formed
                                  '<model name="r"/>',                             # not a <robot>
                                  '<robot name="r"><joint name="j" type="revolute"/></robot>',
                                  '/no/such/file.urdf'])
def test_bad_urdf_is_rejected_naming_it(urdf):
    with pytest.raises(ValueError, match='^urdf:'):
        UrdfModel(urdf)


def test_bad_joints_tip_q_locked_gravity_are_named():
    path = resolve_urdf('planar_two_link')
    with pytest.raises(ValueError, match="^joints: unknown \\['elbow'\\]"):
        UrdfModel(path, joints=('theta1', 'elbow'))
    with pytest.raises(ValueError, match='^joints: duplicate'):
        UrdfModel(path, joints=('theta1', 'theta1'))
    with pytest.raises(ValueError, match="^tip: unknown frame 'hand'"):
        UrdfModel(path, tip='hand')
    with pytest.raises(ValueError, match='^q_locked:'):
        UrdfModel(path, joints=('theta1',), q_locked={'theta3': 0.1})
    with pytest.raises(ValueError, match='^q_locked:'):
        UrdfModel(path, joints=('theta1',), q_locked={'theta1': 0.1})
    with pytest.raises(ValueError, match='^gravity:'):
        UrdfModel(path, gravity=(0.0, -9.81))
    model = UrdfModel(path, tip='tip')
    with pytest.raises(ValueError, match='^q:'):
        model.M([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match='^qd:'):
        model.C_qd([0.1, 0.2], [float('nan'), 0.0])


# -- the equations (unchecked layer) ------------------------------------------------------------
@pytest.mark.parametrize('make', [
    lambda: UrdfModel(resolve_urdf(IIWA), joints=IIWA_JOINTS, tip=IIWA_TIP),           # Pinocchio's order
    lambda: UrdfModel(resolve_urdf('cartesian_xy'), joints=('x', 'y'), tip='tip'),     # reordered
    lambda: UrdfModel(IIWA, joints=('lbr_iiwa_joint_4', 'lbr_iiwa_joint_2'), tip=IIWA_TIP),  # reduced, reordered
])
def test_one_pass_terms_equal_the_public_methods(make):
    """_inverse_dynamics (RNEA), _task (one kinematics pass), _task_motion and _Minv = the checked methods."""
    model = make()
    rng = np.random.default_rng(RNG_SEED + 8)
    for _ in range(10):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, model.n))
        close(model._inverse_dynamics(q, qd, qdd), model.M(q) @ qdd + model.C_qd(q, qd) + model.g(q))
        x, jac, bias = model._task(q, qd)
        close(x, model.fk(q))
        close(jac, model.J(q))
        close(bias, model.Jdot_qd(q, qd))
        x2, xd, xdd = model._task_motion(q, qd, qdd)
        close(x2, model.fk(q))
        close(xd, model.J(q) @ qd)
        close(xdd, model.J(q) @ qdd + model.Jdot_qd(q, qd))
        close(model._Minv(q) @ model.M(q), np.eye(model.n))
        close(model.forward_dynamics(q, qd, model.inverse_dynamics(q, qd, qdd)), qdd)
