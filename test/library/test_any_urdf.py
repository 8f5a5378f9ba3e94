"""Any URDF robot: every URDF shipped by pybullet_data that Pinocchio parses loads as a UrdfModel
whose computed torque is pinocchio.rnea of the full model.

The expected values come from the full model built by pinocchio.buildModelFromUrdf, with the test's
own configuration: a joint the URDF declares `continuous` gets (cos, sin) of its angle, the others
their angle or travel. The URDFs Pinocchio cannot parse (7 in pybullet 3.2.7) must be refused with an
error naming `urdf`; URDFs without a movable joint (scenery, objects) with an error naming `joints`.

Tolerances (measured on 20 seeded states per robot, |tau| up to 1e4 N m): computed torque vs rnea
is exact with all joints selected (the same computation) and within 6e-15 relative with joints
locked; checked at rtol 1e-9 plus atol 1e-9. M qdd vs the rnea difference: 8e-15, checked at 1e-9.
forward_dynamics(inverse_dynamics(qdd)) - qdd: 2e-14 times cond(M), checked at 1e-9 cond(M).
"""
import glob
import math
import os
import tempfile
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pinocchio as pin
import pybullet_data
import pytest

from support.loops import critically_damped, integrate, joint_space_loop
from robot_control.gains import ServoGains
from robot_control.laws import computed_torque
from robot_control.models import make_model
from robot_control.models.urdf_model import UrdfModel
from robot_control.trajectory import point_to_point
from robot_control.validation import ArgumentError

DATA = pybullet_data.getDataPath()
SEED = 20261207
STATES = 10         # random states per robot
TOL = 1e-9
W_N = 6.0
KP, KV = W_N ** 2, 2 * W_N


def _urdfdom_error(path):
    """The first error urdfdom (Pinocchio's URDF parser) prints on stderr (file descriptor 2) for `path`."""
    with tempfile.TemporaryFile() as log:
        saved = os.dup(2)
        os.dup2(log.fileno(), 2)
        try:
            pin.buildModelFromUrdf(path)
        except (ValueError, RuntimeError):
            pass
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        log.seek(0)
        lines = log.read().decode(errors='replace').splitlines()
    return next((line.split(':', 1)[1].strip() for line in lines if line.startswith('Error:')), 'no message')


def _walk():
    """Every *.urdf under pybullet_data, relative paths: ({with movable joints: nv}, without, unparsed)."""
    robots, static, unparsed = {}, [], []
    for path in sorted(glob.glob(os.path.join(DATA, '**', '*.urdf'), recursive=True)):
        rel = os.path.relpath(path, DATA)
        try:
            nv = pin.buildModelFromUrdf(path).nv
        except (ValueError, RuntimeError):
            unparsed.append(rel)
            continue
        if nv:
            robots[rel] = nv
        else:
            static.append(rel)
    return robots, static, unparsed


DOFS, STATIC, UNPARSED = _walk()
ROBOTS = list(DOFS)


# -- the test's own view of a URDF, independent of UrdfModel ------------------------------------------
class Urdf:
    """A pybullet_data URDF: the full Pinocchio model and the <joint> elements of its XML."""

    def __init__(self, rel):
        self.path = os.path.join(DATA, rel)
        self.full = pin.buildModelFromUrdf(self.path)
        self.data = self.full.createData()
        with open(self.path, encoding='utf-8') as f:
            root = ET.fromstring(f.read().lstrip())
        self.xml = {j.get('name'): j for j in root.findall('joint')}   # not <transmission>'s
        self.names = tuple(self.full.names[1:])
        self.joints = self.full.joints[1:]

    def continuous(self, name):
        return self.xml[name].get('type') == 'continuous'

    def limit(self, name, key, default):
        element = self.xml[name].find('limit')
        return float(element.get(key, default)) if element is not None else default

    def positions(self, rng):
        """Random joint positions (one per joint): inside the URDF range, any angle for a continuous joint."""
        q = np.empty(len(self.names))
        for k, name in enumerate(self.names):
            lo, hi = self.limit(name, 'lower', 0.0), self.limit(name, 'upper', 0.0)
            q[k] = (rng.uniform(-3 * math.pi, 3 * math.pi) if self.continuous(name)
                    else rng.uniform(lo, hi) if lo < hi else rng.uniform(-math.pi, math.pi))
        return q

    def q(self, positions):
        """Pinocchio configuration (nq,) of one position per joint."""
        out = np.empty(self.full.nq)
        for name, jm, x in zip(self.names, self.joints, positions):
            if self.continuous(name):
                out[jm.idx_q:jm.idx_q + 2] = math.cos(x), math.sin(x)
            else:
                out[jm.idx_q] = x
        return out

    def v(self, values):
        """Pinocchio tangent vector (nv,) of one velocity (acceleration) per joint."""
        out = np.empty(self.full.nv)
        out[[jm.idx_v for jm in self.joints]] = values
        return out

    def rnea(self, q, qd, qdd):
        """Joint torques (one per joint) of the full model."""
        tau = pin.rnea(self.full, self.data, self.q(q), self.v(qd), self.v(qdd))
        return tau[[jm.idx_v for jm in self.joints]]

    def massless(self):
        """Joints whose subtree carries neither mass nor rotational inertia (their row of M is zero)."""
        inertias = self.full.inertias
        return [self.full.names[j] for j in range(1, self.full.njoints)
                if all(inertias[k].mass == 0.0 and not np.any(inertias[k].inertia) for k in self.full.subtrees[j])]


def rng_for(rel):
    return np.random.default_rng([SEED, zlib.crc32(rel.encode())])


def close(actual, expected, tol=TOL, msg=''):
    np.testing.assert_allclose(actual, expected, rtol=tol, atol=tol, err_msg=msg)


def gains(n):
    return ServoGains.uniform(n, KP, KV)


# -- the walk ---------------------------------------------------------------------------------------
def test_the_walk_covers_the_robots_of_pybullet_data():
    for rel in ('kuka_iiwa/model.urdf', 'pendulum5.urdf', 'quadruped/minitaur.urdf', 'franka_panda/panda.urdf',
                'differential/diff_ring.urdf'):
        assert rel in ROBOTS
    assert len(ROBOTS) > 30 and len(STATIC) > 1000
    with_continuous = [rel for rel in ROBOTS if any(map(Urdf(rel).continuous, Urdf(rel).names))]
    assert len(with_continuous) > 15


@pytest.mark.parametrize('rel', ROBOTS)
def test_computed_torque_is_rnea_of_the_full_model(rel):
    urdf, rng = Urdf(rel), rng_for(rel)
    model = UrdfModel(urdf.path)
    assert model.joint_names == urdf.names
    n = model.n
    for _ in range(STATES):
        q, q_d = urdf.positions(rng), urdf.positions(rng)
        qd, qd_d, qdd_d = rng.uniform(-2.0, 2.0, (3, n))
        tau = computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains(n))
        v = qdd_d + KV * (qd_d - qd) + KP * (q_d - q)
        close(tau, urdf.rnea(q, qd, v), msg=rel)


@pytest.mark.parametrize('rel', [rel for rel in ROBOTS if DOFS[rel] > 1])
def test_computed_torque_with_the_other_joints_locked_is_rnea_of_the_full_model(rel):
    """Every other joint selected, the rest locked at random positions (continuous ones by angle)."""
    urdf, rng = Urdf(rel), rng_for(rel)
    selected = list(range(0, len(urdf.names), 2))
    locked = [k for k in range(len(urdf.names)) if k not in selected]
    n = len(selected)
    for _ in range(STATES):
        q_full = urdf.positions(rng)
        model = UrdfModel(urdf.path, joints=[urdf.names[k] for k in selected],
                          q_locked={urdf.names[k]: q_full[k] for k in locked})
        q, q_d = q_full[selected], urdf.positions(rng)[selected]
        qd, qd_d, qdd_d = rng.uniform(-2.0, 2.0, (3, n))
        tau = computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains(n))
        qd_full, v_full = np.zeros(len(urdf.names)), np.zeros(len(urdf.names))
        qd_full[selected] = qd
        v_full[selected] = qdd_d + KV * (qd_d - qd) + KP * (q_d - q)
        close(tau, urdf.rnea(q_full, qd_full, v_full)[selected], msg=rel)


@pytest.mark.parametrize('rel', ROBOTS)
def test_mass_matrix_and_forward_dynamics(rel):
    """M symmetric, M qdd = rnea(q, qd, qdd) - rnea(q, qd, 0); positive definite, and forward dynamics
    inverting inverse dynamics, unless a joint moves no mass (then M is singular: a zero row)."""
    urdf, rng = Urdf(rel), rng_for(rel)
    model = UrdfModel(urdf.path)
    massless = urdf.massless()
    for _ in range(STATES):
        q = urdf.positions(rng)
        qd, qdd = rng.uniform(-2.0, 2.0, (2, model.n))
        M = model.M(q)
        np.testing.assert_array_equal(M, M.T)
        close(M @ qdd, urdf.rnea(q, qd, qdd) - urdf.rnea(q, qd, 0 * qdd), msg=rel)
        eig = np.linalg.eigvalsh(M)
        if massless:
            assert abs(eig[0]) <= TOL * eig[-1], (rel, massless, eig[0])
            continue
        assert eig[0] > 0.0, (rel, eig[0])
        back = model.forward_dynamics(q, qd, model.inverse_dynamics(q, qd, qdd))
        close(back, qdd, tol=TOL * eig[-1] / eig[0], msg=rel)


@pytest.mark.parametrize('rel', ROBOTS)
def test_limits_are_the_urdf_limits(rel):
    """effort, velocity: the URDF's <limit> (inf where 0 or absent); position: (lower, upper) where
    lower < upper, (-inf, inf) for continuous joints and where the URDF gives no range (PyBullet's rule)."""
    urdf = Urdf(rel)
    model = UrdfModel(urdf.path)
    lower, upper = model.position_limits
    for k, name in enumerate(urdf.names):
        for actual, key in ((model.effort_limit[k], 'effort'), (model.velocity_limit[k], 'velocity')):
            value = urdf.limit(name, key, 0.0)
            assert actual == (value if value > 0.0 else math.inf), (name, key)
        lo, hi = urdf.limit(name, 'lower', 0.0), urdf.limit(name, 'upper', 0.0)
        if urdf.continuous(name) or not lo < hi:
            lo, hi = -math.inf, math.inf
        assert (lower[k], upper[k]) == (lo, hi), name


def test_a_urdf_without_movable_joints_is_refused_naming_joints():
    for rel in STATIC:
        with pytest.raises(ArgumentError, match='no movable joint') as info:
            UrdfModel(os.path.join(DATA, rel))
        assert info.value.name == 'joints', rel


def test_a_urdf_pinocchio_cannot_parse_is_refused_naming_urdf():
    """The 7 of pybullet 3.2.7 (urdfdom's reasons, e.g. husky's unexpanded $(optenv ...)), all refused."""
    assert len(UNPARSED) == 7, [(rel, _urdfdom_error(os.path.join(DATA, rel))) for rel in UNPARSED]
    for rel in UNPARSED:
        with pytest.raises(ArgumentError, match='not') as info:
            UrdfModel(os.path.join(DATA, rel))
        assert info.value.name == 'urdf', (rel, _urdfdom_error(os.path.join(DATA, rel)))


# -- continuous joints --------------------------------------------------------------------------------
def test_continuous_joints_have_no_position_limits_and_keep_the_urdf_effort():
    pendulum = make_model('urdf', urdf='pendulum5.urdf')
    lower, upper = pendulum.position_limits
    assert np.all(lower == -np.inf) and np.all(upper == np.inf)
    assert np.all(pendulum.effort_limit == np.inf)          # pendulum5 has no <limit>
    minitaur = UrdfModel('quadruped/minitaur.urdf', joints=['motor_front_rightR_joint', 'knee_front_rightR_link'])
    assert np.all(minitaur.effort_limit == 100.0) and np.all(minitaur.velocity_limit == 100.0)
    lower, upper = minitaur.position_limits
    assert np.all(lower == -np.inf) and np.all(upper == np.inf)    # continuous; revolute without lower/upper


def test_computed_torque_tracks_a_continuous_joint_arm_through_several_turns():
    """pendulum5 (five continuous joints) follows a quintic from 0 to angles beyond +-pi: the angle
    keeps counting (no wrap) and the error is the critically damped e(t). The plant is the full
    Pinocchio model (ABA) on the test's own (cos, sin) configuration."""
    urdf = Urdf('pendulum5.urdf')
    model = make_model('urdf', urdf='pendulum5.urdf')
    goal = np.array([4.0, -4.5, 7.5, -3.6, 2 * math.pi + 0.3])
    path = point_to_point(np.zeros(5), goal, 2.0)

    def plant(q, qd, tau):
        return pin.aba(urdf.full, urdf.data, urdf.q(q), urdf.v(qd), urdf.v(tau))[[jm.idx_v for jm in urdf.joints]]

    e0, ed0 = np.array([0.05, -0.04, 0.03, 0.02, -0.05]), np.array([0.3, 0.2, -0.2, 0.1, 0.0])
    ts, ys = integrate(joint_space_loop(model, path.sample, gains(5), plant), np.concatenate([-e0, -ed0]), 3.0)
    E = np.array([path.sample(t)[0] for t in ts]) - ys[:, :5]
    err = np.max(np.abs(E - critically_damped(e0, ed0, W_N, ts)))
    assert err < 1e-6, f'max |e - e_analytic| = {err:.3g}'
    np.testing.assert_allclose(ys[-1, :5], goal, atol=1e-3)      # 7.5 rad, not 7.5 - 2 pi
    assert np.max(np.abs(E)) > 0.04                               # the error was there to decay


# -- Pinocchio's errors name the argument ----------------------------------------------------------------
INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>'


def _urdf(links, joints):
    bodies = ''.join(f'<link name="{name}">{INERTIAL}</link>' for name in links)
    return f'<robot name="r"><link name="base"/>{bodies}{joints}</robot>'


def _joint(name, kind, parent, child, extra=''):
    return f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>{extra}</joint>'


def test_a_joint_named_like_a_link_does_not_stop_locking_joints():
    """minitaur has fixed joints named like links: selecting some joints (a reduced model) works, and
    the tip of that name is the link."""
    urdf = Urdf('quadruped/minitaur.urdf')
    tip = 'motor_back_leftL_link'
    assert tip in urdf.xml and urdf.xml[tip].get('type') == 'fixed'
    joints = ['motor_back_leftL_joint', 'knee_back_leftL_link']
    model = UrdfModel(urdf.path, joints=joints, tip=tip)
    q_full = rng_for('minitaur tip').uniform(-2.0, 2.0, len(urdf.names))
    q_full[[urdf.names.index(j) for j in urdf.names if j not in joints]] = 0.0
    pin.framesForwardKinematics(urdf.full, urdf.data, urdf.q(q_full))
    link = urdf.data.oMf[urdf.full.getFrameId(tip, pin.FrameType.BODY)].translation
    close(model.fk(q_full[[urdf.names.index(j) for j in joints]]), link)


def test_a_joint_that_is_not_one_dof_is_refused_naming_the_argument():
    xml = _urdf(['a', 'b', 'c'], _joint('p', 'planar', 'base', 'a', '<axis xyz="0 0 1"/>')
                + _joint('f', 'floating', 'a', 'b') + _joint('r', 'continuous', 'b', 'c', '<axis xyz="0 1 0"/>'))
    with pytest.raises(ArgumentError, match='JointModelPlanar') as info:
        UrdfModel(xml, joints=['p', 'r'])
    assert info.value.name == 'joints'
    with pytest.raises(ArgumentError, match='full configuration') as info:
        UrdfModel(xml, joints=['r'], q_locked={'f': 0.1})
    assert info.value.name == 'q_locked'
    q_ref = pin.neutral(pin.buildModelFromXML(xml))
    q_ref[:2] = 2.0, 1.0                    # planar x, y: any value
    assert UrdfModel(xml, joints=['r'], q_locked=q_ref).n == 1
    q_ref[2] = 2.0                          # planar (cos, sin) no longer a unit vector
    with pytest.raises(ArgumentError, match=r'unit \(cos, sin\)') as info:
        UrdfModel(xml, joints=['r'], q_locked=q_ref)
    assert info.value.name == 'q_locked'


def test_frame_names_pinocchio_cannot_tell_apart_are_errors_naming_the_argument():
    """Link 'a', a fixed joint 'a' (its frame becomes 'a (joint)') and a revolute joint 'a (joint)':
    two frames of one name, which Pinocchio's lookups refuse."""
    xml = _urdf(['a', 'b', 'c'], _joint('j1', 'continuous', 'base', 'a', '<axis xyz="0 0 1"/>')
                + _joint('a', 'fixed', 'a', 'b', '<origin xyz="0 0 1"/>')
                + _joint('a (joint)', 'revolute', 'b', 'c', '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'))
    assert UrdfModel(xml).n == 2 and UrdfModel(xml, joints=['j1']).n == 1
    assert UrdfModel(xml, tip='a').fk([0.0, 0.0]) == pytest.approx([0.0, 0.0, 0.0])   # the link
    with pytest.raises(ArgumentError, match='cannot lock') as info:
        UrdfModel(xml, joints=['a (joint)'])
    assert info.value.name == 'joints'
    with pytest.raises(ArgumentError, match='ambiguous') as info:
        UrdfModel(xml, tip='a (joint)')
    assert info.value.name == 'tip'
