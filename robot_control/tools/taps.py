"""Serialized messages with their DDS timestamps, taken through rclpy's public API.

A Tap subscribes `raw=True` to a set of topics on a node that an executor spins. Each message is
kept as `(data, source_ns, received_ns)`: the serialized CDR bytes, the writer's publication
time and the reception time in this process, both from the message's MessageInfo, in integer
nanoseconds of the system clock that all processes of this machine share. Nothing is
deserialized on arrival; the caller deserializes what it needs, when it needs it.

Spin the node with rclpy's EventsExecutor (robot_control.ros.spin.make_executor('events')):
it hands each message from C++ straight to the callback, where SingleThreadedExecutor rebuilds
its wait set in Python for every few messages, several times the CPU per message. `spin_for`
and `spin_until_idle` run either executor for a while.
"""
import inspect
import time

#: s, one round of spin_until_idle: a round without a new message ends it
IDLE_ROUND = 0.005


class WithMessageInfo:
    """Subscription callback calling fn(msg, info) with the message's MessageInfo, under either executor.

    rclpy passes the message and its MessageInfo (a dict with 'source_timestamp' and
    'received_timestamp', ns) to a callback that takes two arguments; it tells the kinds of
    callback apart by their signature, declared here. SingleThreadedExecutor calls callback(msg, info); the
    EventsExecutor of rclpy 7.1 calls callback((msg, info)), one tuple: both forms are accepted.
    """

    __signature__ = inspect.Signature([inspect.Parameter('msg', inspect.Parameter.POSITIONAL_ONLY),
                                       inspect.Parameter('info', inspect.Parameter.POSITIONAL_ONLY)])

    def __init__(self, fn):
        self._fn = fn

    def __call__(self, msg, info=None):
        if info is None:
            msg, info = msg
        self._fn(msg, info)


class Tap:
    """Raw subscriptions of `node` to `topics` ({name: message class}) with `qos`.

    `rows[topic]` is the list of (data, source_ns, received_ns) received so far, in arrival
    order; the subscription's callback appends to that very list, which pop() empties.
    """

    def __init__(self, node, topics, qos):
        self.rows = {topic: [] for topic in topics}
        self.subs = {topic: node.create_subscription(cls, topic, WithMessageInfo(_appender(self.rows[topic])), qos,
                                                     raw=True)
                     for topic, cls in topics.items()}

    def count(self, topic=None):
        """Messages held of `topic` (None: of every topic)."""
        if topic is not None:
            return len(self.rows[topic])
        return sum(len(r) for r in self.rows.values())

    def pop(self, topic):
        """The rows of `topic` received so far; the tap keeps nothing of them."""
        rows = self.rows[topic]
        out = rows[:]
        del rows[:]
        return out

    def publishers(self, topic):
        """Publishers matched by the subscription to `topic`."""
        return self.subs[topic].get_publisher_count()


def _appender(rows):
    append = rows.append

    def keep(data, info):
        append((data, info['source_timestamp'], info['received_timestamp']))
    return keep


def spin_for(executor, seconds):
    """Run the callbacks of `executor` that come within `seconds` s of wall time.

    Works alike for SingleThreadedExecutor and EventsExecutor, whose spin_once() runs one
    callback only. With seconds = 0: what is ready now (EventsExecutor), one callback (others).
    """
    from rclpy.task import Future
    executor.spin_until_future_complete(Future(), timeout_sec=seconds)


def spin_until_idle(executor, count, limit=1.0, round_s=IDLE_ROUND):
    """Spin `executor` in rounds of `round_s` s until one brings no change of count() (an int:
    messages received so far), at most `limit` s: hands over what DDS has delivered already."""
    deadline = time.monotonic() + limit
    while True:
        before = count()
        spin_for(executor, round_s)
        if count() == before or time.monotonic() >= deadline:
            return
