"""~/identify_payload (std_srvs/Trigger) of the controller node: identify the payload, set payload.mass and .com.

The arm moves while the identification runs (robot_control.core.payload_id: poses, samples, least squares),
driven by the joint_states callback, so the node's executor must go on dispatching states while the call
waits. rclpy 7.1's EventsExecutor (the node's, robot_control.ros.spin) neither awaits a coroutine service
callback nor lets a callback answer later: a service callback must return its response. So the service is
served by a helper node of its own (`<controller>_identify`, same namespace and context), spun by a
SingleThreadedExecutor on a thread of its own: its callback hands a Job to the controller's side and waits
on the Job's event (at most TIMEOUT s) while the controller's executor runs on. Everything that touches the
Controller (start, samples, the solve, the parameter set) runs on the controller's executor, in on_state()
after each answered state; the service thread only enqueues and waits. The service's name is absolute, the
controller's fully qualified name + '/identify_payload', i.e. the controller's ~/identify_payload.

An answer that follows an identification ends with the stamp of the joint state it was reached at
(`answered_text`, read back by `answered_stamp_ns`): the answer itself travels in wall time, the stamp says
where on the joint_states' clock the payload parameters took effect.
"""
import collections
import re
import threading

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from robot_control.core.payload_id import PayloadIdentification, offsets_of
from robot_control.validation import ArgumentError

#: longest wall time a call waits for its identification, s
TIMEOUT = 600.0
#: longest wait of the helper's spin_once, s: how late it notices a stop
SPIN_PERIOD = 0.1
PREFIX = 'payload_identification.'
_STAMPED = re.compile(r'; at the joint state stamped (\d+)\.(\d{9}) s$')


def answered_text(message, stamp_ns):
    """`message`, then the stamp (ns) of the joint state the identification ended at."""
    return f'{message}; at the joint state stamped {stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d} s'


def answered_stamp_ns(message):
    """The stamp, ns, an answer of answered_text names; None when it names none."""
    match = _STAMPED.search(message)
    return None if match is None else int(match[1]) * 1_000_000_000 + int(match[2])


class Job:
    """One call: `done` is set once `success` and `message` are final."""

    def __init__(self):
        self.done = threading.Event()
        self.success, self.message = False, ''

    def finish(self, success, message):
        self.success, self.message = success, message
        self.done.set()


class PayloadService:
    """~/identify_payload for the Controller `controller` of `node` (module docstring). configure(values) with
    the node's parameter values (its payload_identification.* rows); on_state(stamp_ns, names, efforts) after
    each answered state; `active()`: True while the controller commands (a call is refused at once otherwise);
    stop() ends the calls with a failure; destroy() also stops the helper."""

    def __init__(self, node, controller, values, active):
        self._node, self._controller, self._active = node, controller, active
        self._values = values
        self._jobs = collections.deque()         # calls not started yet (appended by the service thread)
        self._job = self._ident = None           # the call being served, its identification
        self._helper = Node(f'{node.get_name()}_identify', namespace=node.get_namespace(), context=node.context)
        self._helper.create_service(Trigger, f'{node.get_fully_qualified_name()}/identify_payload', self._on_call)
        self._executor = SingleThreadedExecutor(context=node.context)
        self._executor.add_node(self._helper)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name='identify_payload', daemon=True)
        self._thread.start()

    def configure(self, values):
        """The node's parameter values after a change (read when the next identification starts)."""
        self._values = values

    # -- the service thread ---------------------------------------------------------------------------
    def _spin(self):
        try:
            while not self._stop.is_set() and self._node.context.ok():
                self._executor.spin_once(SPIN_PERIOD)
        except ExternalShutdownException:
            pass

    def _on_call(self, request, response):
        job = Job()
        self._jobs.append(job)
        if self._stop.is_set() or not self._active():
            job.finish(False, 'the controller is not active')
        if not job.done.wait(TIMEOUT):
            job.finish(False, f'no result within {TIMEOUT:g} s (is the controller active and receiving joint_states?)')
        response.success, response.message = job.success, job.message
        return response

    # -- the controller's executor --------------------------------------------------------------------
    def on_state(self, stamp_ns, names, efforts):
        """After an answered state (its stamp ns, names and efforts): start a call's identification, or feed it."""
        if self._ident is None:
            if self._jobs:
                job = self._jobs.popleft()
                if not job.done.is_set():        # else already answered (refused, or timed out)
                    self._start(job)
            return
        state = self._controller.core.state
        try:
            tau = self._controller.in_joint_order(names, efforts)
        except ArgumentError as exc:
            self._end(False, f'joint_states give no joint torques: {exc}')
            return
        self._ident.tick(self._controller.core, state.q, state.qd, tau)
        if self._ident.done:
            self._finished(self._ident, stamp_ns)

    def _start(self, job):
        self._job = job
        core, v = self._controller.core, self._values
        if not hasattr(core.config.model, 'payload_regressor') or core.config.model.tip is None:
            self._end(False, "needs model 'urdf' with a tip (the link that carries the payload)")
            return
        try:
            offsets = offsets_of(v[PREFIX + 'poses'], core.config.n)
        except ArgumentError as exc:
            self._end(False, str(exc))
            return
        self._ident = PayloadIdentification(offsets, v[PREFIX + 'move_time'], v[PREFIX + 'settle_time'],
                                            v[PREFIX + 'settle_velocity'], v[PREFIX + 'sample_time'])
        self._ident.start(core, core.state.q)
        self._node.get_logger().info(f'identifying the payload over {len(offsets)} poses')

    def _finished(self, ident, stamp_ns):
        if ident.error is not None:
            self._end(False, answered_text(str(ident.error), stamp_ns))
            return
        est = ident.estimate
        result = self._node.set_parameters_atomically([
            Parameter('payload.mass', Parameter.Type.DOUBLE, est.mass),
            Parameter('payload.com', Parameter.Type.DOUBLE_ARRAY, [float(c) for c in est.com])])
        if not result.successful:
            self._end(False, answered_text(f'{est.message()}; not set: {result.reason}', stamp_ns))
            return
        message = answered_text(est.message(), stamp_ns)
        self._node.get_logger().info(f'payload identified: {message}')
        self._end(True, message)

    def _end(self, success, message):
        job, self._job, self._ident = self._job, None, None
        if job is not None:
            job.finish(success, message)

    def stop(self):
        """The controller stopped: the running identification and the waiting calls end with a failure."""
        self._end(False, 'the controller stopped')
        while self._jobs:
            self._jobs.popleft().finish(False, 'the controller stopped')

    def destroy(self):
        """End every call with a failure, stop the helper thread, release the helper node."""
        self._stop.set()
        self.stop()
        self._thread.join()
        self._executor.shutdown()
        self._helper.destroy_node()
