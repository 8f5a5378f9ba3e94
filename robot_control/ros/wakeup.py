"""A bound on the CPU wake-up latency while a node runs: a Linux PM QoS request on /dev/cpu_dma_latency.

A node at 1 kHz sleeps between its ticks. An idle CPU enters an idle state (on a virtual machine the
virtual CPU halts and the host runs something else), and leaving it costs time, then cold caches: on a
2-core VM, the hybrid controller's tick measured 56 us back to back, 159 us after sleeping 0.9 ms, and
77 us after the same sleep with a request of 0 us held. A request of `us` microseconds keeps every CPU
out of the idle states that take longer to leave (0: polling only), for as long as its file descriptor
stays open: the kernel drops it when the process ends, however it ends (kernel docs, power/pm_qos_interface).
cyclictest holds the same request while it measures. Writing the file needs root or a udev rule that gives
the user write access. The CPUs then stay busy when idle: it costs power, and CPU time of the host on a VM.
"""
import os
import struct

#: the kernel's CPU latency QoS file: a 32-bit integer written to it is the bound, us
PATH = '/dev/cpu_dma_latency'


def request(us, path=None):
    """Hold a request of at most `us` (int >= 0) microseconds of CPU wake-up latency on `path` (None: PATH);
    returns its file descriptor (os.close() releases it). OSError when the file cannot be opened or written."""
    fd = os.open(path or PATH, os.O_WRONLY)
    try:
        os.write(fd, struct.pack('=i', us))
    except OSError:
        os.close(fd)
        raise
    return fd


def bound(path=None):
    """The bound in force now, us: the least of every request held (the kernel's default when none is)."""
    with open(path or PATH, 'rb') as f:
        return struct.unpack('=i', f.read(4))[0]
