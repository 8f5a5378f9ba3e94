"""Executors of the nodes: which one, and how to spin it so that a signal stops it.

rclpy's EventsExecutor (rclpy.experimental) dispatches a message without rebuilding a wait set
over every entity of the node in Python, as SingleThreadedExecutor does on each wake-up: about
half the CPU per message. Its spin() does not notice a shutdown by signal, so it is spun with
spin_once in a loop, as here; `--executor single` selects SingleThreadedExecutor instead.
"""
import signal
import threading

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from robot_control.ros import dds

EXECUTORS = ('events', 'single')
#: longest wait of one spin_once, s: how late a shutdown by signal is noticed at worst
SPIN_PERIOD = 0.1


def make_executor(kind='events', context=None):
    """'events': rclpy.experimental.EventsExecutor (SingleThreadedExecutor where this rclpy lacks
    it); 'single': rclpy SingleThreadedExecutor. ValueError for anything else."""
    if kind not in EXECUTORS:
        raise ValueError(f'executor: expected one of {list(EXECUTORS)}, got {kind!r}')
    if kind == 'events':
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:
            return SingleThreadedExecutor(context=context)
        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def init_with_stop_on_signals(args=None):
    """rclpy.init without rclpy's signal handlers; SIGINT and SIGTERM set the returned Event.

    rclpy's own handlers shut the context down from inside the signal handler, which raced with
    the executor now and then (an abort, or death by SIGTERM, in about 1 of 16 quick stops);
    a flag checked between spin_once calls ends the node in at most SPIN_PERIOD, always cleanly.
    """
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda _signum, _frame: stop.set())
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    return stop


def spin(executor, context=None, stop=None):
    """Spin until `stop` is set (a signal) or the context is shut down."""
    while rclpy.ok(context=context) and not (stop is not None and stop.is_set()):
        executor.spin_once(SPIN_PERIOD)


def run_node(argv, make_node, executor='events', startup_errors=(), on_startup_error=None):
    """The body of every main(): DDS settings, init, build the node, spin until SIGINT/SIGTERM, clean up.

    The Fast DDS settings of robot_control.ros.dds go into the environment first (where it does not
    set them already): a network link that fails never blocks the node's publishing. make_node()
    builds the node; an exception of `startup_errors` (invalid parameters) raised there is handed to
    on_startup_error(exc), whose return is returned (the exit status; robot_control.ros.entry).
    Returns 0 after a signal.
    """
    dds.apply_defaults()
    stop = init_with_stop_on_signals(argv)
    ex = make_executor(executor)
    node = None
    try:
        try:
            node = make_node()
        except startup_errors as exc:
            return on_startup_error(exc)
        ex.add_node(node)
        spin(ex, stop=stop)
    except ExternalShutdownException:
        pass
    finally:
        ex.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
