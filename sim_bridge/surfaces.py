"""Elastic surfaces for the PyBullet world: a static box the robot's tip presses on.

The lecture's environment is a spring, f = k_e (x_N - x_e), with x_N the task coordinate of
the tip along the surface normal. It is realised with PyBullet's own soft contact: the box gets
changeDynamics(contactStiffness=k_e, contactDamping=b_e, lateralFriction=0) and the tip link
carries a single collision sphere of radius r centred on the tip frame origin (the closed-form
URDFs already have one; for other URDFs the tip's collision shapes are replaced by it). The box
face sits r beyond x_e, so contact begins exactly when the tip frame reaches x_e. With
contactSlop = 0 the steady-state contact force is k_e times the penetration to solver
precision. Every robot-surface contact point counts in the wrench.
"""
import os
import tempfile
import xml.etree.ElementTree as ET

import numpy as np
import pybullet as p

from robot_control import urdf as urdf_files
from robot_control import validation
from robot_control.scenarios import Surface
from robot_control.validation import ArgumentError

#: radius of the probe sphere put on a URDF robot's tip, m (the closed-form URDFs use 0.01 too)
PROBE_RADIUS = 0.01
#: half thickness of the surface box, m (deeper than any penetration the effort limits allow)
HALF_THICKNESS = 0.5
#: lateral half extent of the box around the tip's start position, m: walls of the closed-form
#: robots, and the table of URDF arms (small enough to stay clear of the arm's base)
HALF_WIDTH_WALL = 1.0
HALF_WIDTH_TABLE = 0.25

_WORLD_AXES = {'x': 0, 'y': 1, 'z': 2}


def surface_normal(task_axes, axis, closed_form):
    """World unit vector (3,) of task axis `axis` (the direction in which x_N grows).

    URDF robots: the task space is the tip's world position, so axis i is world axis i.
    Closed-form robots (urdf_gen convention): the lecture's horizontal x is world x, its
    vertical y is world z for the planar (2-D) task spaces; 3-D task spaces are the world's.
    """
    if not 0 <= axis < len(task_axes):
        raise ArgumentError('surface', f'axis {axis} is not a task axis of {list(task_axes)}')
    name = task_axes[axis]
    if closed_form and len(task_axes) == 2 and name == 'y':
        name = 'z'
    n = np.zeros(3)
    n[_WORLD_AXES[name]] = 1.0
    return n


def check_surface(surface):
    """`surface` as a Surface with a finite x_e, positive k_e and sign +-1, or ValueError."""
    if not isinstance(surface, Surface):
        raise ArgumentError('surface', f'expected True, False or a Surface, got {surface!r}')
    validation.scalar('surface.x_e', surface.x_e)
    validation.scalar('surface.k_e', surface.k_e, positive=True)
    if surface.sign not in (1.0, -1.0):
        raise ArgumentError('surface.sign', f'expected +1 or -1, got {surface.sign}')
    return surface


def probe_urdf(path, tip, out_dir, radius=PROBE_RADIUS):
    """Write a copy of URDF `path` in `out_dir` whose link `tip` collides only through a sphere
    of `radius` (m) at its frame origin; relative mesh paths are made absolute. Returns the copy."""
    with open(path, encoding='utf-8') as f:
        root = ET.fromstring(urdf_files.with_absolute_meshes(f.read(), os.path.dirname(os.path.abspath(path))))
    links = [ln for ln in root.iter('link') if ln.get('name') == tip]
    if not links:
        raise ArgumentError('tip', f'no link {tip!r} in {path}')
    for old in links[0].findall('collision'):
        links[0].remove(old)
    collision = ET.SubElement(links[0], 'collision')
    ET.SubElement(collision, 'origin', xyz='0 0 0', rpy='0 0 0')
    ET.SubElement(ET.SubElement(collision, 'geometry'), 'sphere', radius=repr(float(radius)))
    fd, out = tempfile.mkstemp(suffix='.urdf', dir=out_dir)
    os.close(fd)
    ET.ElementTree(root).write(out)
    return out


def tip_radius(client, body, tip_link):
    """Radius (m) of the tip link's single collision sphere, or ValueError."""
    shapes = p.getCollisionShapeData(body, tip_link, physicsClientId=client)
    if len(shapes) != 1 or shapes[0][2] != p.GEOM_SPHERE:
        raise ArgumentError('surface', 'the tip link must collide through one sphere at its origin')
    # PyBullet reports the shape's frame relative to the link's inertial frame
    com, orn = p.getDynamicsInfo(body, tip_link, physicsClientId=client)[3:5]
    centre, _ = p.multiplyTransforms(com, orn, shapes[0][5], shapes[0][6])
    if np.linalg.norm(centre) > 1e-9:
        raise ArgumentError('surface', 'the tip link\'s collision sphere is at {centre}, not at the link origin')
    return float(shapes[0][3][0])


class Wall:
    """A static box with spring-damper contact, face normal to `normal` (world, unit).

    surface: the lecture's Surface (x_e in m along `normal`, k_e in N/m, sign +1 when the tip
    presses towards +normal). damping: contact damping b_e, N s/m (0: the lecture's pure spring).
    tip_start: the tip's world position at the start, m, (3,) (centres the box laterally).
    """

    def __init__(self, client, surface, normal, radius, tip_start, damping=0.0, half_width=HALF_WIDTH_WALL):
        self.client, self.surface = client, surface
        self.normal = np.asarray(normal, dtype=float)
        damping = validation.scalar('surface_damping', damping, nonnegative=True)
        face = surface.x_e + surface.sign * radius           # along `normal`, m
        centre = np.asarray(tip_start, dtype=float).copy()
        centre += (face + surface.sign * HALF_THICKNESS - self.normal @ centre) * self.normal
        half = np.full(3, half_width) * (1.0 - self.normal) + HALF_THICKNESS * self.normal
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half.tolist(), physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half.tolist(), rgbaColor=[0.5, 0.6, 0.5, 0.6],
                                     physicsClientId=client)
        self.body = p.createMultiBody(0.0, shape, visual, basePosition=centre.tolist(), physicsClientId=client)
        p.changeDynamics(self.body, -1, contactStiffness=surface.k_e, contactDamping=damping,
                         lateralFriction=0.0, spinningFriction=0.0, rollingFriction=0.0, restitution=0.0,
                         physicsClientId=client)

    def wrench(self, robot):
        """(force (3,) N, torque (3,) N m): exerted by the robot on the surface, world axes,
        torque about the world origin; zeros without contact. Valid after a step."""
        fx = fy = fz = mx = my = mz = 0.0
        for cp in p.getContactPoints(bodyA=robot, bodyB=self.body, physicsClientId=self.client):
            # f = -(f_n n + f_1 d_1 + f_2 d_2), n = contactNormalOnB (from the surface to the robot: the
            # robot pushes along -n), d_1, d_2 the friction directions; torque r x f, r = positionOnB
            (nx, ny, nz), _distance, fn, f1, (ax, ay, az), f2, (bx, by, bz) = cp[7:14]
            x, y, z = -(fn * nx + f1 * ax + f2 * bx), -(fn * ny + f1 * ay + f2 * by), -(fn * nz + f1 * az + f2 * bz)
            rx, ry, rz = cp[6]
            fx, fy, fz = fx + x, fy + y, fz + z
            mx, my, mz = mx + ry * z - rz * y, my + rz * x - rx * z, mz + rx * y - ry * x
        return np.array([fx, fy, fz]), np.array([mx, my, mz])
