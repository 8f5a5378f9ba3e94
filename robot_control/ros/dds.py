"""Fast DDS settings the nodes apply to themselves before rclpy starts: a link failure blocks nothing.

Fast DDS (the RMW of ROS 2 Jazzy) publishes synchronously: `publish()` hands the sample to the UDP
socket in the caller's thread. Its UDP sockets block by default, so when the link to a remote reader
goes down the kernel keeps the unsent datagrams (waiting for the address resolution of the
unreachable peer), the socket's send buffer fills, and the next `publish()` waits in `sendto` until
the kernel gives up on them, seconds later: the node's control loop stops with the network.

apply_defaults() sets, where the environment does not already say otherwise:
- FASTDDS_BUILTIN_TRANSPORTS = 'DEFAULT?non_blocking=true': the default transports (shared memory
  on the host, UDPv4 across hosts) with non-blocking UDP sends. A datagram the socket cannot take is
  dropped at once, as if the network had lost it; a reliable writer sends it again when the reader
  asks. Publishing stays synchronous, so a sample still leaves in the publishing thread with no hand-off
  to another thread and the lockstep loop's latency is unchanged.
- FASTRTPS_DEFAULT_PROFILES_FILE = the shipped fastdds_profile.xml (beside this module): a heartbeat
  every 100 ms on every writer (Fast DDS: 3 s). A reliable reader that missed samples waits for the
  writer's next heartbeat before it asks for them again, and holds every newer sample meanwhile: after
  a link failure the loop resumes within about 0.2 s of the link's return instead of up to 3 s. And room
  for 200000 samples in every reader (Fast DDS: 5000), so that a deep subscription (a recorder) keeps what
  its KEEP_LAST depth says while its process is busy.

Fast DDS reads the transports whenever it creates a participant (the first node of an rclpy context) and
the profiles file once per process, with its first participant; so robot_control.ros.spin.run_node, the
body of both nodes' main(), calls this before rclpy.init, and a process that builds the node classes
itself calls it before its first node. A user's own settings win: FASTDDS_BUILTIN_TRANSPORTS set to
anything (append '?non_blocking=true' to keep this behaviour), or FASTRTPS_DEFAULT_PROFILES_FILE naming
another file (copy the shipped data_writer block into it). Other RMW implementations ignore both.
"""
import os

#: Fast DDS's built-in transports (shared memory + UDPv4) with non-blocking UDP sends
TRANSPORTS = 'DEFAULT?non_blocking=true'
#: the shipped Fast DDS profile (writers' heartbeat period, readers' room)
PROFILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'fastdds_profile.xml')
#: the environment variables apply_defaults sets, and their values
DEFAULTS = {'FASTDDS_BUILTIN_TRANSPORTS': TRANSPORTS, 'FASTRTPS_DEFAULT_PROFILES_FILE': PROFILE}


def apply_defaults(environ=None):
    """Set each variable of DEFAULTS that `environ` (default os.environ) lacks; {name: value} of those set."""
    environ = os.environ if environ is None else environ
    applied = {name: value for name, value in DEFAULTS.items() if not environ.get(name)}
    environ.update(applied)
    return applied


__all__ = ['TRANSPORTS', 'PROFILE', 'DEFAULTS', 'apply_defaults']
