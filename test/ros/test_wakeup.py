"""--cpu-wakeup-latency (robot_control.ros.wakeup, robot_control.ros.entry): a node holds a Linux PM QoS
request on /dev/cpu_dma_latency while it runs, the kernel keeps every CPU within that wake-up latency meanwhile,
and a request the process may not hold is refused with the flag named (status 2) before the node starts."""
import os
import signal
import struct
import subprocess
import sys
import time

import pytest

from robot_control.ros import controller_node, wakeup

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WRITABLE = os.path.exists(wakeup.PATH) and os.access(wakeup.PATH, os.W_OK)
NEEDS_DEVICE = pytest.mark.skipif(not WRITABLE, reason=f'{wakeup.PATH} is not writable by this user')


def holders(pid):
    """The file descriptors of process `pid` open on wakeup.PATH."""
    fds = f'/proc/{pid}/fd'
    return [fd for fd in os.listdir(fds) if os.path.realpath(os.path.join(fds, fd)) == wakeup.PATH]


def test_a_request_writes_its_bound_as_a_32_bit_integer(tmp_path):
    path = tmp_path / 'latency'
    path.write_bytes(b'')
    fd = wakeup.request(25, path=str(path))
    try:
        assert path.read_bytes() == struct.pack('=i', 25)
    finally:
        os.close(fd)
    with pytest.raises(OSError):
        wakeup.request(0, path=str(tmp_path / 'absent' / 'latency'))


@NEEDS_DEVICE
def test_the_kernel_keeps_the_bound_while_the_request_is_held_and_drops_it_on_close():
    fd = wakeup.request(3)
    try:
        assert wakeup.bound() <= 3
        assert len(holders(os.getpid())) == 1
    finally:
        os.close(fd)
    assert holders(os.getpid()) == []


@NEEDS_DEVICE
def test_a_node_started_with_the_flag_holds_the_request_until_it_stops():
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1')
    proc = subprocess.Popen([sys.executable, '-m', 'robot_control.ros.controller_node', '--cpu-wakeup-latency', '0',
                             '--ros-args', '-p', 'scenario:=single_link'], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60.0
        while not holders(proc.pid):
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate(timeout=10)
            time.sleep(0.05)
        assert wakeup.bound() == 0
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_a_request_the_process_may_not_hold_is_refused_naming_the_flag(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(wakeup, 'PATH', str(tmp_path / 'absent' / 'cpu_dma_latency'))
    assert controller_node.main(['controller_node', '--cpu-wakeup-latency', '0']) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'controller_node: --cpu-wakeup-latency: cannot hold the request on {wakeup.PATH}: ')
    assert 'write access' in err
