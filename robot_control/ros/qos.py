"""QoS profiles shared by the controller node and the simulator bridge (both ends must agree).

CONTROL_QOS is used for the control loop's topics: `joint_states` (bridge -> controller),
`robot_joint_commands` and `effort_controller/commands` (controller -> bridge) and
`ft_sensor/wrench` (bridge -> controller).

Choice: RELIABLE, KEEP_LAST depth 1, VOLATILE.
- depth 1: a controller only ever wants the newest state and the bridge only the newest
  command; a queue would add latency (acting on stale data) after any hiccup.
- RELIABLE rather than BEST_EFFORT: in lockstep pacing the bridge waits for the command that
  answers each state; a lost sample would stall the loop until the bridge's re-publish
  timeout. On loopback Fast DDS reliable costs no measurable latency for one small message
  (no retransmissions happen), and a RELIABLE publisher also serves BEST_EFFORT subscribers
  (e.g. `ros2 topic echo --qos-reliability best_effort`), while the reverse does not hold.
  A real robot whose driver publishes joint_states BEST_EFFORT needs the controller's
  subscription switched to BEST_EFFORT (a one-line change here).
- VOLATILE: an old state or command must never be replayed to a late joiner.

REFERENCE_QOS (trajectories, wrench references: commands a user sends once) is RELIABLE,
KEEP_LAST 10, so a burst of goals is not silently dropped before the controller sees it.
DIAGNOSTICS_QOS matches diagnostic_updater's default publisher (RELIABLE, KEEP_LAST 10).
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

CONTROL_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

REFERENCE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

DIAGNOSTICS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Publishers of the loop's topics (joint_states, ft_sensor/wrench, robot_joint_commands, ~/reference,
#: ~/error, /clock): as CONTROL_QOS / REFERENCE_QOS but with a deep writer history. A reliable writer
#: can only repair a sample a reader missed while the sample is still in its history; with depth 1 an
#: observer that falls behind under CPU load (a recorder, `ros2 bag record`, a plotter, the demo's
#: collector) loses whole blocks of ticks for good. Fast DDS repairs after the writer's next heartbeat
#: (every 3 s), so the history must hold 3 s of a lockstep loop (about 3000 ticks per second): 10000.
#: Acknowledged samples leave the history: measured, 20000 JointState publications raise the peak RSS
#: by 0.25 MB at depth 10000. Subscribers in the loop keep depth 1 (newest only), so the loop's latency
#: is unchanged.
PUBLISHER_DEPTH = 10000
CONTROL_PUB_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=PUBLISHER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
REFERENCE_PUB_QOS = CONTROL_PUB_QOS
#: robot_description as robot_state_publisher offers it: reliable, transient local (a late
#: subscriber gets the URDF), the latest only
DESCRIPTION_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)

__all__ = ['CONTROL_QOS', 'REFERENCE_QOS', 'DIAGNOSTICS_QOS', 'CONTROL_PUB_QOS', 'REFERENCE_PUB_QOS',
           'PUBLISHER_DEPTH', 'DESCRIPTION_QOS']
