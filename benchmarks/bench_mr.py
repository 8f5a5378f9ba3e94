"""The benchmark's peer: a Pinocchio serial chain as modern_robotics parameters (Mlist, Glist, Slist, g).

modern_robotics (Lynch & Park) conventions: Slist (6, n) holds the joints' screw axes [w; v] in
the space frame at the home configuration (q = 0); link frame {i} sits at the centre of mass of
link i (here with the axes of Pinocchio's joint frame i); Mlist[i] = M_{i,i+1} is frame {i+1}
in frame {i} at home ({0} = the base frame, {n+1} = the tool frame = {n}: no tool, Ftip = 0);
Glist[i] = diag(I_i, m_i 1) is the spatial inertia of link i in frame {i} (rotational inertia
about the CoM first, modern_robotics' [angular; linear] order, Pinocchio's is [linear; angular]).
Pinocchio's bodies already include the links merged through fixed joints.
"""
import numpy as np
import pinocchio as pin


def check_serial_chain(model):
    """ValueError unless `model` is a serial chain of 1-DOF joints (joint i's parent is i - 1)."""
    n = model.njoints - 1
    if model.nq != n or model.nv != n:
        raise ValueError(f'model: expected {n} 1-DOF joints, got nq={model.nq}, nv={model.nv}')
    if any(model.parents[i] != i - 1 for i in range(1, n + 1)):
        raise ValueError(f'model: expected a serial chain, got parents {list(model.parents)}')


def space_screw_axes(model):
    """Slist (6, n): Pinocchio's world-frame joint Jacobian at q = 0, rows reordered to [w; v]."""
    data = model.createData()
    J = pin.computeJointJacobians(model, data, pin.neutral(model))
    return np.vstack([J[3:], J[:3]])


def com_frames(model):
    """Home placements (SE3) of the CoM frames {1..n} in the base frame, axes of the joint frames."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    return [data.oMi[i] * pin.SE3(np.eye(3), model.inertias[i].lever) for i in range(1, model.njoints)]


def spatial_inertia(inertia):
    """6x6 [angular; linear] spatial inertia of a Pinocchio Inertia about its CoM."""
    G = np.zeros((6, 6))
    G[:3, :3] = inertia.inertia
    G[3:, 3:] = inertia.mass * np.eye(3)
    return G


def mr_chain(model):
    """(Mlist (n+1, 4, 4), Glist (n, 6, 6), Slist (6, n), g (3,)) of Pinocchio `model` for modern_robotics."""
    check_serial_chain(model)
    frames = [pin.SE3.Identity()] + com_frames(model)
    Mlist = [(frames[i - 1].inverse() * frames[i]).homogeneous for i in range(1, len(frames))]
    Mlist.append(np.eye(4))
    Glist = [spatial_inertia(model.inertias[i]) for i in range(1, model.njoints)]
    return np.array(Mlist), np.array(Glist), space_screw_axes(model), np.array(model.gravity.linear)
