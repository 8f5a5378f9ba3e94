"""The command line of the nodes' executables (controller_node, sim_bridge_node): one for every node.

    <prog> [-h] [--executor {events,single}] [--cpu-wakeup-latency US]
           [--ros-args --params-file FILE -p NAME:=VALUE ...]

The node's own flags are read from the arguments outside --ros-args (rclpy.utilities.remove_ros_args);
the ROS arguments go to rclpy.init untouched. --help lists the node's parameters, generated from its
table (robot_control.param_table: the rows the tables of docs/parameters.md come from), with the
defaults they have when no parameter is set.

Exit statuses, the same for every node:
    0  stopped by SIGINT or SIGTERM (robot_control.ros.spin stops cleanly on both); --help
    2  a usage error (argparse's status and message) or a bad start-up parameter, reported on
       stderr as '<prog>: bad parameter <name>: <reason>'; a --cpu-wakeup-latency request the
       process may not hold, as '<prog>: --cpu-wakeup-latency: <reason>'
"""
import argparse
import os
import sys
import textwrap

import rclpy.utilities

from robot_control import param_table
from robot_control.param_table import ParameterError
from robot_control.ros import spin, wakeup

#: exit status of a bad start-up parameter: argparse's for a usage error
BAD_PARAMETER = 2
#: columns of the parameter listing in --help
WIDTH = 100


def bad_parameter(exc):
    """'bad parameter <name>: <reason>' of a ParameterError (a node's log line, the executable's message)."""
    return f'bad parameter {exc.name}: {exc.reason}'


class Entry:
    """The executable `prog` of a node: make_node() builds it (raising ParameterError on a bad
    parameter), `table` is its parameter table, `example` a sample of its ROS arguments."""

    def __init__(self, prog, description, make_node, table, example):
        self.prog, self.description, self.make_node = prog, description, make_node
        self.table, self.example = table, example

    def parser(self):
        """The argparse parser: the node's flags; its parameters in the epilog."""
        parser = argparse.ArgumentParser(prog=self.prog, description=self.description, epilog=self.epilog(),
                                         formatter_class=argparse.RawDescriptionHelpFormatter)
        parser.add_argument('--executor', choices=spin.EXECUTORS, default='events',
                            help='rclpy executor: events (EventsExecutor, the fastest; default) or single '
                                 '(SingleThreadedExecutor)')
        parser.add_argument('--cpu-wakeup-latency', type=_microseconds, metavar='US', default=None,
                            help='hold a Linux PM QoS request of at most US microseconds of CPU wake-up latency while '
                                 f'the node runs (0: no idle state but polling; writes {wakeup.PATH}, which needs '
                                 'root or a udev rule): a realtime loop then does not pay for waking idle CPUs')
        return parser

    def epilog(self):
        """ROS arguments, then every parameter of the table (name, type, default, settable or read-only,
        meaning with units, bounds), with the defaults of no parameter set."""
        heading = textwrap.fill(f'Parameters of {self.table.node}, set with -p NAME:=VALUE or --params-file FILE; '
                                'the defaults are those with no parameter set (setting scenario changes many):',
                                WIDTH)
        return (f'ROS arguments follow --ros-args, e.g. --ros-args {self.example}\n\n{heading}\n'
                + param_table.plain_text(self.table.markdown_rows(), WIDTH))

    def options(self, argv):
        """The node's own options in `argv` (as sys.argv: the program first; ROS arguments skipped).
        A usage error or --help exits as argparse does (2, 0)."""
        return self.parser().parse_args(rclpy.utilities.remove_ros_args(list(argv))[1:])

    def main(self, args=None):
        """Run the node until SIGINT/SIGTERM; returns the exit status (see the module's docstring)."""
        argv = sys.argv if args is None else list(args)
        opts = self.options(argv)
        try:
            request = None if opts.cpu_wakeup_latency is None else wakeup.request(opts.cpu_wakeup_latency)
        except OSError as exc:
            print(f'{self.prog}: --cpu-wakeup-latency: cannot hold the request on {wakeup.PATH}: {exc.strerror} '
                  '(it needs write access: run as root, or give the user write access with a udev rule)',
                  file=sys.stderr, flush=True)
            return BAD_PARAMETER
        try:
            return spin.run_node(argv, self.make_node, opts.executor, startup_errors=(ParameterError,),
                                 on_startup_error=self._refuse)
        finally:
            if request is not None:
                os.close(request)             # the kernel drops the request (also if the process dies)

    def _refuse(self, exc):
        print(f'{self.prog}: {bad_parameter(exc)}', file=sys.stderr, flush=True)
        return BAD_PARAMETER


def _microseconds(text):
    """--cpu-wakeup-latency's value: a whole number of microseconds >= 0."""
    try:
        us = int(text)
    except ValueError:
        us = -1
    if us < 0:
        raise argparse.ArgumentTypeError(f'expected a whole number of microseconds >= 0, got {text!r}')
    return us
