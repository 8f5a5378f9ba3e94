"""The one place a simulated world is made: make_world(engine, ...) for either physics engine. No rclpy.

Both worlds take the same arguments and offer the same properties and methods (sim_bridge.world.World,
sim_bridge.mujoco_world.MujocoWorld); each engine is imported only when its world is made.
"""
from robot_control.validation import ArgumentError

#: the physics engines a world can run on (the bridge parameter `engine`)
ENGINES = ('pybullet', 'mujoco')


def make_world(engine, *args, **kwargs):
    """A World on `engine` ('pybullet' or 'mujoco') built from World's arguments; ArgumentError naming
    `engine` for another name."""
    if engine == 'pybullet':
        from sim_bridge.world import World
        return World(*args, **kwargs)
    if engine == 'mujoco':
        from sim_bridge.mujoco_world import MujocoWorld
        return MujocoWorld(*args, **kwargs)
    raise ArgumentError('engine', f'expected one of {list(ENGINES)}, got {engine!r}')


def world_of_config(cfg):
    """The World of a validated BridgeConfig (sim_bridge.bridge_params) on its engine: what the bridge node
    and the sweep's episodes simulate (the only place that maps the configuration to the World's arguments)."""
    import dataclasses

    import numpy as np

    from robot_control import scenarios
    dist = None
    if np.any(cfg.disturbance_joint_torque) or np.any(cfg.disturbance_cartesian_force):
        dist = {'joint_torque': cfg.disturbance_joint_torque, 'cartesian_force': cfg.disturbance_cartesian_force}
    surface = False
    if cfg.surface_enable:
        surface = dataclasses.replace(scenarios.get(cfg.scenario).surface, k_e=cfg.k_e, x_e=cfg.x_e)
    return make_world(cfg.engine, cfg.scenario or None, gui=cfg.gui, dt=cfg.physics_step,
                      params=cfg.sim_params or None, urdf=cfg.urdf or None, joints=cfg.joints,
                      q0=cfg.initial_positions, surface=surface, disturbance=dist, payload=cfg.payload,
                      friction=cfg.friction)
