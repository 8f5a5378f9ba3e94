"""Constants and time conversions shared by every layer (one definition each).

Times on the wire are builtin_interfaces/Time: (sec, nanosec). Inside the package a time is an
integer number of nanoseconds (exact) or, in the control core, a float number of seconds.
"""

#: nanoseconds per second
NS_PER_S = 1_000_000_000
#: default gravitational acceleration, m/s^2 (along world -z for URDF robots)
GRAVITY = 9.81
#: unit of the effort along a coordinate, by the coordinate's unit: a torque about an angle (rad),
#: a force along a length (m)
EFFORT_UNIT = {'rad': 'N m', 'm': 'N'}


def stamp_ns(sec, nanosec):
    """(sec, nanosec) of a builtin_interfaces/Time -> integer nanoseconds."""
    return sec * NS_PER_S + nanosec


def split_ns(ns):
    """Integer nanoseconds -> (sec, nanosec), nanosec in [0, 1e9)."""
    return divmod(ns, NS_PER_S)


def seconds(ns):
    """Integer nanoseconds -> float seconds."""
    return ns / NS_PER_S


def to_ns(seconds_):
    """Float seconds -> integer nanoseconds (rounded)."""
    return round(seconds_ * NS_PER_S)
