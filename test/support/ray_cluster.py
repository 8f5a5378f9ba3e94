"""A real Ray cluster on the two hosts of support.two_hosts: the head node in namespace `a`, a worker node
in namespace `b`, joined by the veth pair (or the head alone, `hosts=('a',)`).

Never on the machine's own interfaces: every Ray process runs inside a namespace and is bound to that
host's veth address (Ray ignores --node-ip-address=127.0.0.1 and would advertise the machine's
address). Small: one CPU per node, a small object store, no dashboard, no usage statistics; Ray's
temporary directory is a short directory of its own (Ray's socket paths must stay under 108 characters),
deleted on close. close() stops what runs inside the namespaces by pid (SIGTERM, then SIGKILL after a
grace period) and deletes them; `ray stop` is not used, since it stops every Ray process of the machine,
whoever started it. Use as a context manager (also on failure).
"""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from support.two_hosts import TwoHosts

PORT = 6380                      # the head's GCS port, inside namespace a
OBJECT_STORE_BYTES = 80 * 1024 * 1024
RAY = os.path.join(os.path.dirname(sys.executable), 'ray')
ENV = {'RAY_USAGE_STATS_ENABLED': '0', 'RAY_DISABLE_DOCKER_CPU_WARNING': '1'}
STOP_GRACE = 5.0                 # s between SIGTERM and SIGKILL on close


def env(extra=None):
    """The environment of the cluster's processes and its drivers (plus `extra`)."""
    out = {**os.environ, **ENV}
    for key in ('RAY_ADDRESS', 'http_proxy', 'https_proxy', 'HTTP_PROXY', 'HTTPS_PROXY'):
        out.pop(key, None)
    return {**out, **(extra or {})}


class RayCluster(TwoHosts):
    """Ray on `hosts` of the two hosts (support.two_hosts.TwoHosts, made and deleted with it): `.address` is
    the head's HOST:PORT on the link."""

    def __init__(self, hosts=('a', 'b'), tag=None):
        super().__init__(tag=tag, multicast=False)
        self.hosts = hosts
        self.ray_tmp = None
        self.address = None

    def open(self):
        super().open()
        self.ray_tmp = tempfile.mkdtemp(prefix='rcray')
        self.address = f'{self.addr["a"]}:{PORT}'
        for h in self.hosts:
            role = ['--head', f'--port={PORT}', '--include-dashboard=false'] if h == 'a' else \
                [f'--address={self.address}']
            argv = [RAY, 'start', *role, f'--node-ip-address={self.addr[h]}', '--num-cpus=1',
                    f'--object-store-memory={OBJECT_STORE_BYTES}', f'--temp-dir={os.path.join(self.ray_tmp, h)}',
                    '--disable-usage-stats']
            done = subprocess.run(self.argv(h, argv), env=env(), stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, timeout=180)
            if done.returncode != 0:
                raise RuntimeError(f'ray start on host {h} failed:\n{done.stdout[-3000:]}')
        return self

    def run(self, argv, timeout, extra_env=None, **kwargs):
        """Run argv (a Ray driver) on host a to its end: CompletedProcess (stdout, stderr as text)."""
        return subprocess.run(self.argv('a', argv), env=env(extra_env), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, timeout=timeout, **kwargs)

    def start(self, argv, extra_env=None, **kwargs):
        """Start argv (a Ray driver) on host a: its Popen (stdout, stderr as text pipes)."""
        return subprocess.Popen(self.argv('a', argv), env=env(extra_env), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, **kwargs)

    def workers(self, host):
        """The pids of host's Ray worker processes (their command line starts with 'ray::')."""
        out = []
        for pid in self.pids(host):
            try:
                with open(f'/proc/{pid}/cmdline', 'rb') as f:
                    if f.read().startswith(b'ray::'):
                        out.append(pid)
            except OSError:
                pass
        return out

    def close(self):
        """SIGTERM to every process inside the namespaces, SIGKILL to those left after STOP_GRACE s, then
        delete the namespaces and Ray's directory."""
        pids = [p for h in ('a', 'b') for p in self.pids(h)]
        for pid in pids:
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + STOP_GRACE
        while time.monotonic() < deadline and any(os.path.exists(f'/proc/{p}') for p in pids):
            time.sleep(0.05)
        super().close()              # SIGKILL to what is left, by pid; the namespaces deleted
        if self.ray_tmp is not None:
            shutil.rmtree(self.ray_tmp, ignore_errors=True)
            self.ray_tmp = None
