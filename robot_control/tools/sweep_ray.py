"""A sweep's episodes as Ray tasks on a running Ray cluster (`sweep run SPEC --ray auto|ADDRESS`).

Each episode is one task running sweep_engine.episode(k) (the same episode function as the local
workers: the Plan built once per worker process from the spec's text), so its row is the local run's bit
for bit; only `worker` (the node's address and the worker's pid) and `wall_s` tell the engines apart.
The driver (this process) is the table's one writer (sweep_engine.run_with): the run directory is on
the driver's machine, resumes the same way, and the nodes need only the package installed.

A worker process or a node that dies: Ray runs its unfinished tasks again (up to MAX_RETRIES times
each), and each task's result is taken once, so no episode is lost or counted twice. At most
IN_FLIGHT_PER_CPU tasks per CPU of the cluster wait at a time (a run of 100,000 episodes does not queue
them all at once). Ray is imported only here (`pip install ray`); the driver connects to a cluster that
is already running (`ray start`), and never starts one.
"""
import os
import socket
import sys

from robot_control.tools import sweep_engine
from robot_control.validation import ArgumentError

MAX_RETRIES = 5              # runs of a task again after its worker process or node died
IN_FLIGHT_PER_CPU = 4        # tasks submitted and not yet collected, per CPU of the cluster
CONNECT_TIMEOUT = 10.0       # s for the head's port to answer before ray.init

_DIGEST = None


def _task(text, digest, k):
    """Episode k of the spec of `text` (digest `digest`) in a Ray worker: its row, `worker` = node/pid."""
    global _DIGEST
    import ray
    if _DIGEST != digest:
        sweep_engine._init(text)
        _DIGEST = digest
    row = sweep_engine.episode(k)
    row['worker'] = f'{ray.util.get_node_ip_address()}/{os.getpid()}'
    return row


def connect(address):
    """ray.init(address) unless this process is connected already; True when it connected here."""
    try:
        import ray
    except ImportError:
        raise ArgumentError('ray', 'Ray is not installed (pip install ray)') from None
    if ray.is_initialized():
        return False
    if address != 'auto':
        host, _, port = address.rpartition(':')
        try:
            socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT).close()
        except (OSError, ValueError) as exc:      # ray.init would retry for minutes
            raise ArgumentError('ray', f'no Ray cluster answers at {address!r} (expected HOST:PORT of its head, '
                                       f'or auto): {exc}') from None
    try:
        ray.init(address=address, log_to_driver=False, logging_level='warning')
    except (ConnectionError, ValueError, RuntimeError) as exc:
        raise ArgumentError('ray', f'cannot connect to a Ray cluster at {address!r}: {exc}') from None
    return True


def executor(spec, say):
    """The engine for sweep_engine.run_with: episodes as Ray tasks, collected as they finish."""
    import ray
    remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_task)

    def execute(p, todo, rows, finished):
        cpus = int(ray.cluster_resources().get('CPU', 1))
        say(f'[sweep] Ray cluster: {sum(n["Alive"] for n in ray.nodes())} node(s), {cpus} CPU(s)')
        text = ray.put(spec.text)
        limit = IN_FLIGHT_PER_CPU * max(cpus, 1)
        waiting, left = [], list(reversed(todo))
        while left or waiting:
            while left and len(waiting) < limit:
                waiting.append(remote.remote(text, spec.digest, left.pop()))
            done, waiting = ray.wait(waiting, num_returns=1)
            finished(ray.get(done[0]))
    return execute


def run_ray(spec, out, address, say=lambda text: print(text, file=sys.stderr), stream=sys.stderr):
    """Run (or resume) every episode of Spec `spec` into directory `out` on the Ray cluster at `address`
    ('auto': the one whose address this machine knows, RAY_ADDRESS or a local `ray start`); returns
    (rows sorted by episode, Progress)."""
    connected = connect(address)
    import ray
    try:
        return sweep_engine.run_with(spec, out, executor(spec, say), say, stream)
    finally:
        if connected:
            ray.shutdown()
