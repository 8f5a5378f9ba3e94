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
