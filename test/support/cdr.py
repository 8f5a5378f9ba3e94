"""Serialized messages the nodes' fast decoder (robot_control.ros.cdr) declines, for the fallback tests."""
import struct


def big_endian(s):
    """Hand-written big-endian CDR (encapsulation 0x00 0x00) of a sensor_msgs/JointState spec: a dict
    of names, stamp_ns, frame_id, position, velocity, effort (what a big-endian DDS writer sends)."""
    out = bytearray(b'\x00\x00\x00\x00')

    def align(n):
        out.extend(bytes(-(len(out) - 4) % n))

    def string(text):
        align(4)
        raw = text.encode() + b'\x00'
        out.extend(struct.pack('>I', len(raw)) + raw)

    out += struct.pack('>iI', *divmod(s['stamp_ns'], 10 ** 9))
    string(s['frame_id'])
    align(4)
    out += struct.pack('>I', len(s['names']))
    for name in s['names']:
        string(name)
    for field in ('position', 'velocity', 'effort'):
        align(4)
        out += struct.pack('>I', len(s[field]))
        if s[field]:
            align(8)
            out += struct.pack(f'>{len(s[field])}d', *s[field])
    return bytes(out)


def big_endian_wrench(stamp_ns, frame_id, force, torque):
    """Hand-written big-endian CDR (encapsulation 0x00 0x00) of a geometry_msgs/WrenchStamped: `force` (3,) N and
    `torque` (3,) N m."""
    raw = frame_id.encode() + b'\x00'
    out = bytearray(b'\x00\x00\x00\x00') + struct.pack('>iII', *divmod(stamp_ns, 10 ** 9), len(raw)) + raw
    out.extend(bytes(-(len(out) - 4) % 8))
    return bytes(out + struct.pack('>6d', *force, *torque))
