"""The 6-D task space of URDF models (pose: position and orientation), and a payload on the tip.

Checked against finite differences on SO(3) (the orientation error log3(R_d R^T)) and against
Pinocchio with the payload's inertia appended to the tip's joint by hand.
"""
import numpy as np
import pinocchio as pin
import pytest

from robot_control import urdf
from robot_control.models import for_scenario
from robot_control.models.urdf_model import UrdfModel
from robot_control.scenarios import IIWA_JOINTS

RNG = np.random.default_rng(20261123)
TIP = 'lbr_iiwa_link_7'


@pytest.fixture(scope='module')
def pose_model():
    return for_scenario('iiwa', task_space='pose')


def _state():
    return RNG.uniform(-1.5, 1.5, 7), RNG.uniform(-1.0, 1.0, 7), RNG.uniform(-2.0, 2.0, 7)


def test_the_pose_task_space_has_six_axes_position_then_rotation_vector(pose_model):
    assert pose_model.task_axes == ('x', 'y', 'z', 'rx', 'ry', 'rz') and pose_model.task_dim == 6
    position = for_scenario('iiwa')
    q, _, _ = _state()
    x = pose_model.fk(q)
    np.testing.assert_allclose(x[:3], position.fk(q), rtol=0, atol=1e-14)
    data = pose_model.model.createData()
    pin.framesForwardKinematics(pose_model.model, data, q)
    np.testing.assert_allclose(pin.exp3(x[3:]), data.oMf[pose_model.frame_id].rotation, rtol=0, atol=1e-12)


def test_the_jacobian_is_the_derivative_of_the_pose_on_so3(pose_model):
    """Column j: (x(q + h e_j) [-] x(q - h e_j)) / 2h, orientation by log3(R+ R-^T): world angular velocity."""
    h = 1e-6
    for _ in range(5):
        q, qd, qdd = _state()
        J = pose_model.J(q)
        for j in range(7):
            e = np.zeros(7)
            e[j] = h
            diff = pose_model.task_difference(pose_model.fk(q + e), pose_model.fk(q - e)) / (2 * h)
            np.testing.assert_allclose(J[:, j], diff, rtol=0, atol=1e-7)
        x, xd, xdd = pose_model._task_motion(q, qd, qdd)
        np.testing.assert_allclose(xd, J @ qd, rtol=0, atol=1e-12)
        np.testing.assert_allclose(xdd, J @ qdd + pose_model.Jdot_qd(q, qd), rtol=0, atol=1e-10)
        Jdot = (pose_model.J(q + h * qd) - pose_model.J(q - h * qd)) / (2 * h)
        np.testing.assert_allclose(pose_model.Jdot_qd(q, qd), Jdot @ qd, rtol=0, atol=2e-6)


def test_the_orientation_error_is_the_log_of_the_relative_rotation(pose_model):
    q, _, _ = _state()
    x = pose_model.fk(q)
    turn = np.array([0.0, 0.0, 0.3])                       # 0.3 rad about world z
    target = np.concatenate([x[:3] + [0.01, 0.0, 0.0], pin.log3(pin.exp3(turn) @ pin.exp3(x[3:]))])
    np.testing.assert_allclose(pose_model.task_difference(target, x), [0.01, 0.0, 0.0, 0.0, 0.0, 0.3],
                               rtol=0, atol=1e-12)


def test_a_payload_is_the_same_as_pinocchio_with_the_body_appended(pose_model):
    """2 kg at 5 cm along the tip's z: M and g equal Pinocchio's model with that inertia appended to the
    tip's joint (a solid sphere of urdf.PAYLOAD_RADIUS)."""
    mass, com = 2.0, np.array([0.0, 0.0, 0.05])
    loaded = for_scenario('iiwa', payload=(mass, com))
    ref = pin.buildModelFromUrdf(urdf.resolve('kuka_iiwa/model.urdf'))
    frame = ref.frames[ref.getFrameId(TIP)]
    sphere = np.eye(3) * 0.4 * mass * urdf.PAYLOAD_RADIUS ** 2       # isotropic: the same in any frame
    ref.appendBodyToJoint(frame.parentJoint, pin.Inertia(mass, frame.placement.act(com), sphere), pin.SE3.Identity())
    data = ref.createData()
    for _ in range(5):
        q, qd, qdd = _state()
        np.testing.assert_allclose(loaded.g(q), pin.computeGeneralizedGravity(ref, data, q), rtol=0, atol=1e-9)
        np.testing.assert_allclose(loaded.inverse_dynamics(q, qd, qdd), pin.rnea(ref, data, q, qd, qdd),
                                   rtol=0, atol=1e-9)
    q = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0])
    assert np.abs(loaded.g(q) - for_scenario('iiwa').g(q)).max() > 1.0   # 2 kg matter: > 1 N m somewhere


def test_task_space_and_payload_are_checked():
    with pytest.raises(ValueError, match="^task_space: expected one of") as info:
        UrdfModel(urdf.resolve('kuka_iiwa/model.urdf'), tip=TIP, task_space='twist')
    assert info.value.name == 'task_space'
    with pytest.raises(ValueError, match='^payload.mass:'):
        UrdfModel(urdf.resolve('kuka_iiwa/model.urdf'), joints=IIWA_JOINTS, tip=TIP, payload=(-1.0, (0, 0, 0)))
    with pytest.raises(ValueError, match='^payload: a payload needs the tip'):
        UrdfModel(urdf.resolve('kuka_iiwa/model.urdf'), payload=(1.0, (0, 0, 0)))
