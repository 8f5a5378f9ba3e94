"""Your own arm, end to end: two arms the package does not ship (the example-robot-data wheel's xArm7 and
SO-100), each brought up from a parameter file written like a user writes one (config/templates/your_robot.yaml,
its four marked lines changed for the SO-100), sim_bridge_node and controller_node as processes over DDS
(loopback, a domain claimed from OWN_ARM_DOMAINS), lockstep, driven as a user would with `ros2 param set` and
messages: the file's law gravity_compensation holds the arm (drift < 1e-3 rad over 2 s); computed torque
tracks a 2 s quintic move (final error < 1e-3 rad); impedance with every default (task_space auto, the designed
stiffness) reaches a target pose: the tip within 1 mm (the xArm7's orientation too; the SO-100's five joints
get the position task space). No tick saturates, no law falls back, the controller logs no warning.
"""
import numpy as np
import pinocchio as pin
import pytest
import yaml

from support.e2e import OWN_ARM_DOMAINS, Lockstep
from robot_control.models import make_model
from robot_control.tools.processes import DomainClaim
from robot_control.trajectory import point_to_point

TEMPLATE = 'config/templates/your_robot.yaml'
SO100 = {'urdf': 'so_arm_description/urdf/so100.urdf', 'tip': 'gripper',
         'joints': ['shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll'],   # the gripper: locked
         'initial_positions': [0.2, 0.5, -0.6, 0.4, 0.3]}
#: arm -> (its changes to the template (None: the template's xArm7), joint move rad, target offset m, turn rad)
ARMS = {
    'xarm7': (None, [0.4, 0.3, -0.3, 0.4, 0.3, -0.3, 0.5], [0.03, -0.02, 0.02], [0.0, 0.0, 0.15]),
    'so100': (SO100, [0.3, -0.2, 0.3, 0.2, 0.4], [0.01, 0.01, -0.01], None),
}
HOLD = 2.0            # s of gravity compensation
MOVE = 2.0            # s, the quintic move
SETTLE = 0.5          # s after it
REACH = 2.0           # s of impedance toward the target pose
AHEAD = 0.05          # s: the target pose is stamped this far ahead of the paused state


def user_file(tmp_path, changes):
    """The template with the law gravity_compensation (check the model first, docs/your-robot.md) and, for
    another arm, its urdf, joints (both sections), tip and initial_positions changed: the path of the file."""
    with open(TEMPLATE, encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    ctrl, bridge = doc['/**/controller']['ros__parameters'], doc['/**/sim_bridge']['ros__parameters']
    ctrl['law'] = 'gravity_compensation'
    if changes is not None:
        ctrl.update(urdf=changes['urdf'], joints=list(changes['joints']), tip=changes['tip'])
        bridge.update(urdf=changes['urdf'], joints=list(changes['joints']),     # copies: no YAML aliases
                      initial_positions=list(changes['initial_positions']))
        bridge['disturbance']['joint_torque'] = [0.0] * len(changes['joints'])
    path = tmp_path / 'my_arm.yaml'
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path, ctrl


def pose_message(x, stamp_ns):
    """PoseStamped of the task pose x ((3,) position or (6,) with the rotation vector), in the base frame."""
    from robot_control.ros import conversions
    quaternion = (0.0, 0.0, 0.0, 1.0)
    if len(x) == 6:
        quat = pin.Quaternion(pin.exp3(np.asarray(x[3:])))
        quaternion = (quat.x, quat.y, quat.z, quat.w)
    return conversions.pose_stamped(x[:3], quaternion, stamp_ns)


def bring_up(arm, tmp_path):
    """Run the three phases on `arm`; the figures and what the controller said."""
    from geometry_msgs.msg import PoseStamped
    from robot_control.ros.qos import REFERENCE_QOS
    changes, move, offset, turn = ARMS[arm]
    path, ctrl = user_file(tmp_path, changes)
    joints = ctrl['joints']
    model = make_model('urdf', urdf=ctrl['urdf'], joints=joints, tip=ctrl['tip'], task_space='auto')
    out = {'task_axes': model.task_axes}
    with DomainClaim(OWN_ARM_DOMAINS, timeout=600.0) as claim, \
            Lockstep(claim.domain_id, tmp_path / 'logs', str(path)) as run:
        # 1. gravity compensation, the file's law
        t = run.advance(HOLD)
        _, q, _ = run.states()
        out['drift'] = np.abs(q - q[0]).max()
        # 2. computed torque: a 2 s quintic move sent as a trajectory from the current state
        run.set_controller(law='computed_torque')
        q0 = q[-1]
        goal = q0 + np.array(move)
        times = np.linspace(0.0, MOVE, 21)
        pos, vel, acc = (np.array(a) for a in zip(*(point_to_point(q0, goal, MOVE).sample(s) for s in times)))
        run.send_trajectory(joints, times, pos, vel, acc)
        t = run.advance(t + MOVE + SETTLE)
        _, q, _ = run.states()
        out['final_error'] = np.abs(q[-1] - goal).max()
        # 3. impedance with the defaults toward a target pose stamped just ahead
        run.set_controller(law='impedance')
        x0 = model.fk(q[-1])
        target = x0.copy()
        target[:3] += offset
        if turn is not None:
            target[3:] = pin.log3(pin.exp3(np.array(turn)) @ pin.exp3(x0[3:]))
        node = run.control.node
        pub = node.create_publisher(PoseStamped, '/controller/target_pose', REFERENCE_QOS)
        run.control.spin_until(lambda: pub.get_subscription_count() > 0, 30.0, run.live.alive, 'target_pose')
        pub.publish(pose_message(target, int(round((t + AHEAD) * 1e9))))
        t = run.advance(t + REACH)
        _, q, _ = run.states()
        x = model.fk(q[-1])
        out['position_error'] = np.linalg.norm(x[:3] - target[:3])
        out['rotation_error'] = (np.linalg.norm(pin.log3(pin.exp3(target[3:]) @ pin.exp3(x[3:]).T))
                                 if turn is not None else None)
        # the controller's counts, from a /diagnostics message sent after the last tick
        seen = len(run.diagnostics(': effort saturation'))
        run.control.spin_until(lambda: len(run.diagnostics(': effort saturation')) >= seen + 2, 30.0,
                               run.live.alive, '/diagnostics after the last tick')
        out['saturation'] = run.diagnostics(': effort saturation')[-1][2]
        out['law'] = run.diagnostics(': control law')[-1][2]
        out['log'] = run.log()
        out['warnings'] = run.log(30)           # rcl_interfaces/Log WARN
    return out


@pytest.fixture(scope='module', params=sorted(ARMS))
def arm_run(request, tmp_path_factory):
    return request.param, bring_up(request.param, tmp_path_factory.mktemp(request.param))


def test_gravity_compensation_holds_the_arm_from_the_user_s_file(arm_run):
    arm, out = arm_run
    print(f'{arm}: gravity compensation, drift over {HOLD} s {out["drift"]:.3g} rad')
    assert out['drift'] < 1e-3


def test_computed_torque_tracks_a_two_second_quintic_move(arm_run):
    arm, out = arm_run
    print(f'{arm}: computed torque, final error {out["final_error"]:.3g} rad, {SETTLE} s after the move')
    assert out['final_error'] < 1e-3


def test_impedance_with_the_defaults_reaches_the_target_pose_without_saturating(arm_run):
    arm, out = arm_run
    sat, law = out['saturation'], out['law']
    rotation = out['rotation_error']
    print(f'{arm}: impedance (task axes {out["task_axes"]}), position error {out["position_error"] * 1e3:.3g} mm'
          + (f', rotation error {rotation * 1e3:.3g} mrad' if rotation is not None else '')
          + f'; saturated ticks {sat["saturated_ticks"]} of {sat["ticks"]}, fallbacks {law["fallbacks"]}')
    assert out['task_axes'] == (('x', 'y', 'z', 'rx', 'ry', 'rz') if arm == 'xarm7' else ('x', 'y', 'z'))
    assert out['position_error'] < 1e-3
    assert rotation is None or rotation < 1e-3
    assert int(sat['saturated_ticks']) == 0 and int(sat['ticks']) > 0.9e3 * (HOLD + MOVE + SETTLE + REACH)
    assert int(law['fallbacks']) == 0
    assert out['warnings'] == [], out['warnings']
    assert any(line.startswith('trajectory accepted') for line in out['log']), out['log']
