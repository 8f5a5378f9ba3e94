"""The surfaces of sim_bridge.surfaces in a PyBullet world: PyBullet's own soft contact.

The box gets changeDynamics(contactStiffness=k_e, contactDamping=b_e, lateralFriction=0); with
contactSlop = 0 the steady-state contact force is k_e times the penetration to solver precision.
Every robot-surface contact point counts in the wrench.
"""
import numpy as np
import pybullet as p

from robot_control import validation
from robot_control.validation import ArgumentError
from sim_bridge.surfaces import HALF_WIDTH_WALL, box


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
        centre, half = box(surface, self.normal, radius, tip_start, half_width)
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
