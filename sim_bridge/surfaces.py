"""Elastic surfaces of the simulated worlds, engine-free: a static box the robot's tip presses on.

The lecture's environment is a spring, f = k_e (x_N - x_e), with x_N the task coordinate of
the tip along the surface normal. The tip link carries a single collision sphere of radius r
centred on the tip frame origin (the closed-form URDFs already have one; for other URDFs the tip's
collision shapes are replaced by it, probe_urdf). The box face sits r beyond x_e (box), so contact
begins exactly when the tip frame reaches x_e. Each engine realises the spring its way:
sim_bridge.pybullet_surface with PyBullet's soft contact, sim_bridge.mujoco_world with
spring_force applied at the tip.
"""
import os
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

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


def box(surface, normal, radius, tip_start, half_width):
    """(centre (3,) m, half extents (3,) m) of the surface's box, world axes: its face r = `radius` beyond x_e
    along `normal` (unit, world), HALF_THICKNESS deep, `half_width` wide laterally around the tip's start
    position `tip_start` (3,) m."""
    normal = np.asarray(normal, dtype=float)
    face = surface.x_e + surface.sign * radius           # along `normal`, m
    centre = np.asarray(tip_start, dtype=float).copy()
    centre += (face + surface.sign * HALF_THICKNESS - normal @ centre) * normal
    return centre, np.full(3, half_width) * (1.0 - normal) + HALF_THICKNESS * normal


def spring_force(k_e, b_e, depth, depth_rate):
    """The surface's normal force on the tip, N (>= 0: a surface pushes, never pulls):

        f = max(k_e d + b_e dd, 0) where d > 0, else 0

    k_e N/m, b_e N s/m, d = sign (x_N - x_e) the penetration, m, dd its rate, m/s."""
    if depth <= 0.0:
        return 0.0
    return max(k_e * depth + b_e * depth_rate, 0.0)


def probe_radius(xml, tip):
    """Radius (m) of link `tip`'s single collision sphere in URDF text `xml`, or ArgumentError naming surface
    (none, several, or one off the link origin)."""
    links = [ln for ln in ET.fromstring(xml.lstrip()).findall('link') if ln.get('name') == tip]
    shapes = links[0].findall('collision') if links else []
    sphere = shapes[0].find('geometry/sphere') if len(shapes) == 1 else None
    if sphere is None:
        raise ArgumentError('surface', 'the tip link must collide through one sphere at its origin')
    origin = shapes[0].find('origin')
    xyz = [float(v) for v in origin.get('xyz', '0 0 0').split()] if origin is not None else [0.0, 0.0, 0.0]
    if np.linalg.norm(xyz) > 1e-9:
        raise ArgumentError('surface', f'the tip link\'s collision sphere is at {xyz}, not at the link origin')
    return float(sphere.get('radius'))
