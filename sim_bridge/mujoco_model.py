"""A URDF as a MuJoCo model with the URDF's rigid-body dynamics, nothing else. No rclpy.

    M(q) qdd + C(q, qd) qd + g(q) = tau,   M, C, g those of the URDF's links and joints (as Pinocchio's)

MuJoCo compiles URDF itself; what it would add or refuse is taken out:
- <visual> and <collision> elements are dropped (dynamics need no geometry; no meshes to find, so no
  .dae or package:// paths), compiled with discardvisual, balanceinertia and fusestatic off: every
  link is one body named like it, its inertial as written.
- The movable joints that are not controlled become fixed at 0 (the Panda's fingers: what
  robot_control.models.UrdfModel's locking at neutral and the PyBullet world's position hold mean).
- MuJoCo refuses a moving body whose mass or principal inertia is below mjMINVAL (1e-15) unless a
  fixed child carries some (the closed-form robots' massless links and point masses). Such a link is
  compiled with a placeholder inertial and its URDF inertial is written back into the compiled model
  with the subtree masses: the dynamics are the URDF's exactly. (mj_setConst is not called: at the
  reference configuration q = 0 such a model's M may be singular, the polar robot's at r = 0; the
  constraint scales it would recompute, dof_invweight0 for the joint limits, keep the compiled ones.)
- Joint damping, armature and friction loss are zeroed; contacts are off (there are no geoms); the
  Jacobian is dense (MuJoCo's sparse path is for large models, nv >= 60, and is never taken here).
Units SI; gravity along world -z.
"""
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from sim_bridge.world_base import urdf_inertials

#: the threshold of MuJoCo's compiler check on moving bodies (mjMINVAL)
MINVAL = 1e-15
_PLACEHOLDER = {'mass': {'value': '1'},
                'inertia': {'ixx': '1', 'ixy': '0', 'ixz': '0', 'iyy': '1', 'iyz': '0', 'izz': '1'}}


def _too_light(mass, inertia):
    """True when MuJoCo's compiler would refuse a moving body of this mass (kg) and inertia (3, 3)."""
    return mass < MINVAL or bool(np.any(np.linalg.eigvalsh(inertia) < MINVAL))


def compilable_urdf(xml, joints):
    """(URDF text MuJoCo compiles, the links given a placeholder inertial) of URDF text `xml` whose
    movable joints other than `joints` are made fixed (see the module docstring)."""
    root = ET.fromstring(xml.lstrip())
    inertials = urdf_inertials(xml)
    placeholders = []
    for link in root.findall('link'):
        for tag in ('visual', 'collision'):
            for element in link.findall(tag):
                link.remove(element)
        if _too_light(*inertials[link.get('name')][::2]):
            inertial = link.find('inertial')
            for tag, attributes in _PLACEHOLDER.items():
                element = inertial.find(tag)
                if element is None:
                    element = ET.SubElement(inertial, tag)
                element.attrib.clear()
                element.attrib.update(attributes)
            placeholders.append(link.get('name'))
    for joint in root.findall('joint'):
        if joint.get('type') != 'fixed' and joint.get('name') not in joints:
            joint.set('type', 'fixed')
    extension = ET.SubElement(root, 'mujoco')
    ET.SubElement(extension, 'compiler', discardvisual='true', balanceinertia='false', fusestatic='false',
                  angle='radian')
    return ET.tostring(root, encoding='unicode'), placeholders


def _principal(inertia):
    """(principal moments (3,), quaternion (4,) w x y z of the principal axes in link axes) of a
    symmetric inertia (3, 3): the link's inertia is R diag(moments) R^T."""
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0.0:
        axes[:, 0] = -axes[:, 0]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, axes.flatten())
    return np.maximum(moments, 0.0), quat


def _write_back(model, links, inertials):
    """Give the compiled bodies `links` their URDF inertials (mass, com, inertia); recompute the
    subtree masses (kg)."""
    for name in links:
        mass, com, inertia = inertials[name]
        body = model.body(name).id
        model.body_mass[body] = mass
        model.body_ipos[body] = com
        model.body_inertia[body], model.body_iquat[body] = _principal(inertia)
    model.body_subtreemass[:] = model.body_mass
    for body in range(model.nbody - 1, 0, -1):      # children come after their parents
        model.body_subtreemass[model.body_parentid[body]] += model.body_subtreemass[body]


def load(xml, joints, gravity, dt):
    """The MuJoCo model (mujoco.MjModel) of URDF text `xml` with movable `joints` (names), gravity
    (m/s^2 along world -z) and time step dt (s); ValueError from MuJoCo's compiler naming what it
    refused."""
    text, placeholders = compilable_urdf(xml, joints)
    model = mujoco.MjModel.from_xml_string(text)
    _write_back(model, placeholders, urdf_inertials(xml))
    model.dof_damping[:] = 0.0
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.jnt_stiffness[:] = 0.0
    model.opt.gravity[:] = (0.0, 0.0, -gravity)
    model.opt.timestep = dt
    model.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    return model


def dofs(model, joints):
    """(qpos addresses, dof addresses) of the named single-dof joints of `model`, in the order of `joints`."""
    ids = [model.joint(name).id for name in joints]
    return np.array([model.jnt_qposadr[j] for j in ids]), np.array([model.jnt_dofadr[j] for j in ids])


def mass_matrix(model, data):
    """M(q) (nv, nv) at data's state (after mj_forward or mj_step1), kg m^2 / kg, MuJoCo's dof order."""
    out = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, out)
    return out


def inverse_dynamics(model, data, qacc):
    """M(q) qacc + C(q, qd) qd + g(q) (nv,) at data's state (positions and velocities computed), N m or N."""
    out = np.zeros(model.nv)
    saved = data.qacc.copy()
    data.qacc[:] = qacc
    mujoco.mj_rne(model, data, 1, out)
    data.qacc[:] = saved
    return out
