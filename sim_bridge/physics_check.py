"""Is the simulated robot the URDF? PyBullet's physics against Pinocchio's on the same URDF text, as
lines of a start-up report. No rclpy.

    M(q) and g(q): PyBullet's calculateMassMatrix and calculateInverseDynamics(q, 0, 0) against
    Pinocchio's CRBA and generalized gravity (robot_control.models.UrdfModel), every movable joint,
    at the start state.
    Per link: the mass (kg), centre of mass (m, link frame) and rotational inertia about it (kg m^2,
    link axes) PyBullet's getDynamicsInfo reports, against the link's <inertial> (none: all zero).

A difference above ATOL + RTOL |value| is a line naming the joint or link; no line, no difference.
"""
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pybullet as p

from robot_control.models.urdf_model import UrdfModel
from robot_control.validation import ArgumentError
from sim_bridge.world_base import in_link_axes, urdf_inertials

#: tolerances of the comparison: PyBullet diagonalises each inertia tensor (Jacobi iterations), so
#: equal physics agree to round-off and that (xArm7: M within 3e-11 kg m^2, g within 2e-15 N m)
RTOL, ATOL = 1e-6, 1e-9


def pybullet_inertials(client, body):
    """{link: (mass kg, com (3,) m, inertia (3, 3) kg m^2 about the com in link axes)} of every
    non-base link of `body`, as PyBullet simulates it (getDynamicsInfo)."""
    out = {}
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        name = p.getJointInfo(body, j, physicsClientId=client)[12].decode()
        mass, _, diagonal, com, orientation = p.getDynamicsInfo(body, j, physicsClientId=client)[:5]
        rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        out[name] = (mass, np.array(com), in_link_axes(rotation, np.diag(diagonal)))
    return out


def _differ(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return bool(np.any(np.abs(a - b) > ATOL + RTOL * np.maximum(np.abs(a), np.abs(b))))


def link_differences(client, body, xml):
    """Lines naming each link whose simulated mass, centre of mass or inertia is not the URDF's."""
    expected, lines = urdf_inertials(xml), []
    for name, (mass, com, inertia) in pybullet_inertials(client, body).items():
        m_u, com_u, inertia_u = expected.get(name, (0.0, np.zeros(3), np.zeros((3, 3))))
        if _differ(mass, m_u) or (m_u > 0.0 and _differ(com, com_u)) or _differ(inertia, inertia_u):
            lines.append(f'link {name!r}: simulated with mass {mass:.6g} kg, inertia diagonal '
                         f'{np.round(np.diag(inertia), 9).tolist()} kg m^2, centre of mass {np.round(com, 9).tolist()} m; '
                         f'the URDF (and the controller\'s model) gives {m_u:.6g} kg, '
                         f'{np.round(np.diag(inertia_u), 9).tolist()} kg m^2, {np.round(com_u, 9).tolist()} m')
    return lines


def movable_joints(client, body):
    """{joint name: PyBullet joint index} of the movable joints, in PyBullet's degree-of-freedom order."""
    out = {}
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, j, physicsClientId=client)
        if info[2] != p.JOINT_FIXED:
            out[info[1].decode()] = j
    return out


def dynamics_differences(client, body, xml, gravity):
    """Lines for the joints where PyBullet's g(q) or row of M(q) at the body's current state differ from
    Pinocchio's on URDF text `xml` (gravity m/s^2 along world -z), with the largest difference."""
    joints = movable_joints(client, body)
    names = list(joints)
    q = [s[0] for s in p.getJointStates(body, list(joints.values()), physicsClientId=client)]
    try:
        model = UrdfModel(xml, joints=names, gravity=(0.0, 0.0, -gravity))
    except ArgumentError as exc:
        return [f'the simulated robot cannot be compared with its Pinocchio model: {exc}']
    zeros = [0.0] * len(names)
    g_b = np.array(p.calculateInverseDynamics(body, q, zeros, zeros, physicsClientId=client))
    m_b = np.array(p.calculateMassMatrix(body, q, physicsClientId=client))
    q = np.array(q)
    g_p, m_p = model.g(q), model.M(q)
    lines = []
    for k, name in enumerate(names):
        dg, dm = abs(g_b[k] - g_p[k]), np.abs(m_b[k] - m_p[k]).max()
        if _differ(g_b[k], g_p[k]) or _differ(m_b[k], m_p[k]):
            lines.append(f'joint {name!r} at q = {q[k]:.6g}: simulated g {g_b[k]:.6g} N m vs model {g_p[k]:.6g} '
                         f'(difference {dg:.3g}), M row differs by up to {dm:.3g} kg m^2')
    return lines


def report(client, body, xml, gravity):
    """The start-up report of a simulated robot loaded from URDF text `xml`: dynamics_differences, then
    link_differences, each line prefixed by what it compares. Empty when PyBullet simulates the URDF."""
    lines = [f'physics differs from the URDF: {line}' for line in dynamics_differences(client, body, xml, gravity)]
    return lines + [f'physics differs from the URDF: {line}' for line in link_differences(client, body, xml)]
