"""Fast codec for sensor_msgs/JointState and geometry_msgs/WrenchStamped in their serialized form
(CDR, little endian).

The bytes are those rclpy hands a subscription created with ``raw=True`` and those
``Publisher.publish(bytes)`` sends: a 4-byte encapsulation header (0x00 0x01 = CDR little
endian, then 2 option bytes, 0x00 0x00 here and ignored), then the plain CDR (XCDR1) body,
aligned from the body start (byte 4):

    int32 sec, uint32 nanosec, string frame_id,        # std_msgs/Header
    sequence<string> name,
    sequence<double> position, velocity, effort          # JointState

    int32 sec, uint32 nanosec, string frame_id,        # std_msgs/Header
    double force x, y, z, torque x, y, z                 # WrenchStamped (aligned to 8)

A string is a uint32 length counting the terminating NUL, the UTF-8 bytes, then the NUL. A
sequence is a uint32 count aligned to 4, then its items; doubles are aligned to 8, and an empty
sequence adds no padding.

rclpy's ``serialize_message`` returns a buffer of Fast-DDS's *estimated* size, which counts
every double sequence as padded to 8 even when empty: its output may end with up to 12 bytes
past the data. A typed publish puts only the data on the wire, and so does the encoder (readers
such as rosbags insist on the exact size). rclpy leaves all padding unwritten, i.e. heap
garbage; the encoder writes zeros there. The decoder ignores padding and trailing bytes.

No rclpy here: the caller falls back to ``rclpy.serialization`` when
`JointStateDecoder.decode` or `decode_wrench` returns None.
"""
import collections
import operator
import struct

import numpy as np

from robot_control.units import NS_PER_S

INT32_MAX = 2 ** 31 - 1
_MAX_STAMP_NS = (INT32_MAX + 1) * NS_PER_S - 1     # the last stamp whose seconds fit in int32
FIELDS = ('position', 'velocity', 'effort')

_F8 = np.dtype('<f8')
_EMPTY = np.empty(0, _F8)
_EMPTY.flags.writeable = False
_HEAD = struct.Struct('<BBxxiI')      # encapsulation id (2 bytes), options, sec, nanosec
_U32 = struct.Struct('<I')
_STAMP = struct.Struct('<iI')
_BODY = 4                             # body start: CDR alignment counts from here
_FRAME_ID = 12                        # offset of the frame_id length
_ERRORS = (struct.error, ValueError, IndexError, TypeError, OverflowError)


def _align4(off):
    """Offset `off` (bytes from the buffer start) rounded up to a 4-aligned body offset."""
    return (off + 3) & ~3


def _align8(off):
    """Offset `off` (bytes from the buffer start) rounded up to an 8-aligned body offset."""
    return off + ((_BODY - off) & 7)


class StampedFrame(tuple):
    """Read-only stand-in for a received message with a std_msgs/Header: `.header.stamp.sec` (s),
    `.header.stamp.nanosec` (ns), `.header.frame_id` (str). To stay light, `.header` and
    `.header.stamp` are the frame itself (one object per message), so `.sec`, `.nanosec` and
    `.frame_id` also read directly."""

    __slots__ = ()
    header = property(lambda self: self, doc='std_msgs/Header stand-in: .stamp, .frame_id (the frame itself)')
    stamp = property(lambda self: self, doc='builtin_interfaces/Time stand-in: .sec, .nanosec (the frame itself)')
    sec = property(operator.itemgetter(0), doc='stamp: whole seconds (s, int32)')
    nanosec = property(operator.itemgetter(1), doc='stamp: nanoseconds within the second (ns, < 1e9)')
    frame_id = property(operator.itemgetter(2), doc='frame id (str)')


class JointStateFrame(StampedFrame):
    """Read-only stand-in for a received sensor_msgs/JointState, with the same attribute names.

    The header as `StampedFrame`; `.name` (list of str: may be the decoder's cached list, do not
    modify), `.position` (rad or m), `.velocity` (rad/s or m/s), `.effort` (N*m or N): read-only
    float64 1-D arrays, possibly views into the received buffer (tuples of float from a decoder
    made with arrays=False).
    """

    __slots__ = ()
    name = property(operator.itemgetter(3), doc='joint names (list of str)')
    position = property(operator.itemgetter(4), doc='joint positions (rad or m), float64 array')
    velocity = property(operator.itemgetter(5), doc='joint velocities (rad/s or m/s), float64 array')
    effort = property(operator.itemgetter(6), doc='joint efforts (N*m or N), float64 array')

    def __repr__(self):
        return (f'JointStateFrame(sec={self.sec}, nanosec={self.nanosec}, frame_id={self.frame_id!r}, '
                f'name={self.name!r}, position={list(self.position)}, velocity={list(self.velocity)}, '
                f'effort={list(self.effort)})')


def _string(buf, off, size):
    """(str, end offset) of the CDR string whose length field is at `off`; raises ValueError if malformed."""
    (length,) = _U32.unpack_from(buf, off)
    start = off + 4
    end = start + length
    if length == 0 or end > size or buf[end - 1] != 0 or buf.find(0, start, end - 1) >= 0:
        raise ValueError('malformed string')  # rclpy would cut at an inner NUL: leave that to it
    return buf[start:end - 1].decode(), end


def _names(buf, off, size):
    """(list of str, end offset, parts) of the sequence<string> whose count is at `off` (4-aligned).

    `parts` are the (offset from `off`, bytes) of the count and of each string: the block
    without its padding."""
    (count,) = _U32.unpack_from(buf, off)
    if count * 5 > size - off:  # each string takes at least 4 + 1 bytes
        raise ValueError('name count runs past the end')
    start, off = off, off + 4
    names, parts = [], [(0, buf[start:off])]
    for _ in range(count):
        string = _align4(off)
        name, off = _string(buf, string, size)
        names.append(name)
        parts.append((string - start, buf[string:off]))
    return names, off, parts


def _has_parts(buf, off, parts):
    """True when `buf` holds each (offset from `off`, bytes) of `parts`."""
    for rel, raw in parts:
        if not buf.startswith(raw, off + rel):
            return False
    return True


def _doubles(buf, off, size):
    """(read-only float64 array, end offset) of the sequence<double> whose count is at `off` (4-aligned)."""
    (count,) = _U32.unpack_from(buf, off)
    off += 4
    if not count:
        return _EMPTY, off
    off = _align8(off)
    end = off + 8 * count
    if end > size:
        raise ValueError('double count runs past the end')
    return np.frombuffer(buf, _F8, count, off), end


def _three_doubles(buf, off, size):
    """(position, velocity, effort) arrays of the three sequence<double> from `off` (4-aligned)."""
    position, off = _doubles(buf, off, size)
    velocity, off = _doubles(buf, _align4(off), size)
    effort, off = _doubles(buf, _align4(off), size)
    return position, velocity, effort


def _equal_doubles(buf, off, size):
    """Like `_three_doubles` when the three have the same count n > 0 (the usual case), else None.

    Their layouts then repeat with a stride of 8 n + 8 bytes (count and padding), so one 2-D
    view serves all three: faster than three np.frombuffer calls."""
    (count,) = _U32.unpack_from(buf, off)
    start = _align8(off + 4)
    stride = 8 * count + 8
    if (not count or start + 3 * stride - 8 > size or _U32.unpack_from(buf, start + stride - 8)[0] != count
            or _U32.unpack_from(buf, start + 2 * stride - 8)[0] != count):
        return None
    rows = np.ndarray((3, count), _F8, buf, start, (stride, 8))
    return rows[0], rows[1], rows[2]


class JointStateDecoder:
    """Decodes serialized sensor_msgs/JointState bytes into `JointStateFrame`s.

    Remembers the last frame_id and name block: a message whose names are byte-identical to
    the previous ones gets the very same `name` list object, without decoding strings. The
    whole block is compared first (one memcmp); if that fails, its parts without the padding,
    which rclpy's serialize_message leaves as garbage. A stream of messages of one layout (same
    size, frame_id, names and counts, only stamp and values change: a robot's joint_states with
    positions, velocities and efforts, or a controller's commands with efforts only) is read by
    comparing the bytes that fix the layout with the last message's.

    `arrays=False`: the frames' position, velocity and effort are tuples of float instead of
    arrays (read with struct, no numpy: for a consumer that wants Python floats anyway).
    """

    __slots__ = ('_frame_raw', '_frame_id', '_names_raw', '_names_parts', '_names', '_layout', '_arrays')

    def __init__(self, arrays=True):
        self._frame_raw = b'\x01\x00\x00\x00\x00'   # frame_id '' as CDR: length 1, NUL
        self._frame_id = ''
        self._names_raw = None
        self._names_parts = ()
        self._names = None
        self._layout = None     # see _remember_layout
        self._arrays = bool(arrays)

    def decode(self, buf):
        """`JointStateFrame` of the CDR bytes `buf`, or None (never raises) if they are not
        well-formed little-endian CDR JointState; trailing bytes after the effort are ignored."""
        try:
            return self._decode(buf if type(buf) is bytes else bytes(buf))
        except _ERRORS:
            return None

    def _decode(self, buf):
        lay = self._layout
        if lay is not None:
            # the remembered layout: same size and bytes from frame_id to the first double (frame_id, names,
            # the counts before it), the same counts after it; the full decode would read the same offsets
            size, head, fixed, count, second, third, start, shape, strides, floats = lay
            if (len(buf) == size and buf.startswith(head) and buf.startswith(fixed, _FRAME_ID)
                    and buf.startswith(count, second) and buf.startswith(count, third)):
                sec, nanosec = _STAMP.unpack_from(buf, _BODY)
                if floats is not None:
                    values = floats.unpack_from(buf, start)
                    n = shape[1]
                    if shape[0] == 3:
                        position, velocity, effort = values[:n], values[n:2 * n], values[2 * n:]
                    else:
                        position, velocity, effort = (), (), values
                else:
                    rows = np.ndarray(shape, _F8, buf, start, strides)
                    if shape[0] == 3:
                        position, velocity, effort = rows[0], rows[1], rows[2]
                    else:
                        position, velocity, effort = _EMPTY, _EMPTY, rows[0]
                return tuple.__new__(JointStateFrame, (sec, nanosec, self._frame_id, self._names,
                                                       position, velocity, effort))
            self._layout = None
        encoding, kind, sec, nanosec = _HEAD.unpack_from(buf)
        if encoding != 0 or kind != 1:
            return None
        size = len(buf)
        off = self._frame_id_end(buf, size)
        off = self._names_end(buf, _align4(off), size)
        off = _align4(off)
        arrays = _equal_doubles(buf, off, size)
        if arrays is None:
            arrays = _three_doubles(buf, off, size)
        self._remember_layout(buf, off, arrays)
        if not self._arrays:
            arrays = tuple(tuple(a.tolist()) for a in arrays)
        return tuple.__new__(JointStateFrame, (sec, nanosec, self._frame_id, self._names) + arrays)

    def _remember_layout(self, buf, off, arrays):
        """After a full decode whose counts start at `off`, the layout _decode's first test checks, for the
        two layouts of a control loop: three equal counts (a robot's joint_states) and efforts only (a
        command). That is the size, the encapsulation, the bytes from frame_id to the first double, a
        count's bytes and where it repeats after that, the first double's offset, the arrays' shape and
        strides, and (arrays=False) the struct that reads the doubles."""
        n = arrays[2].shape[0]
        if n and arrays[0].shape[0] == arrays[1].shape[0] == n:
            start, stride = _align8(off + 4), 8 * n + 8
            count, repeats, shape = buf[off:off + 4], (start + stride - 8, start + 2 * stride - 8), (3, n)
        elif n and not arrays[0].shape[0] and not arrays[1].shape[0]:
            start, stride = _align8(off + 12), 8 * n
            count, repeats, shape = b'', (0, 0), (1, n)     # every count is before the data: nothing repeats
        else:
            return
        floats = None if self._arrays else struct.Struct('<' + f'{n}d8x' * (shape[0] - 1) + f'{n}d')
        self._layout = (len(buf), buf[:_BODY], buf[_FRAME_ID:start], count, *repeats, start, shape, (stride, 8),
                        floats)

    def _frame_id_end(self, buf, size):
        """Reads frame_id into the cache (unless unchanged); returns the offset after it."""
        raw = self._frame_raw
        if buf.startswith(raw, _FRAME_ID):
            return _FRAME_ID + len(raw)
        self._frame_id, end = _string(buf, _FRAME_ID, size)
        self._frame_raw = buf[_FRAME_ID:end]
        return end

    def _names_end(self, buf, off, size):
        """Reads the name sequence at `off` into the cache (unless unchanged); returns its end."""
        raw = self._names_raw
        if raw is not None and buf.startswith(raw, off):
            return off + len(raw)
        if raw is not None and _has_parts(buf, off, self._names_parts):
            end = off + len(raw)
        else:
            self._names, end, self._names_parts = _names(buf, off, size)
        self._names_raw = buf[off:end]
        return end


def _pad(out, align):
    """Appends zero bytes to the bytearray `out` up to the buffer offset `align(len(out))`."""
    out += bytes(align(len(out)) - len(out))


def _encoded_names(names):
    """UTF-8 bytes of each joint name; ValueError naming 'names' unless a sequence of NUL-free str."""
    if isinstance(names, (str, bytes)) or not hasattr(names, '__iter__'):
        raise ValueError(f'names: must be a sequence of str, got {type(names).__name__}')
    names = list(names)
    for i, name in enumerate(names):
        if not isinstance(name, str):
            raise ValueError(f'names[{i}]: must be str, got {type(name).__name__}')
        if '\x00' in name:
            raise ValueError(f'names[{i}]: must not contain NUL')
    return [name.encode() for name in names]


def _layout(encoded, fields):
    """(zeroed message bytearray with all counts written, {field: (offset of its doubles, count)}).

    The message ends with its last byte of data, as a typed publish puts it on the wire (rclpy's
    serialize_message returns a buffer up to 12 bytes longer: its size estimate)."""
    out = bytearray(b'\x00\x01\x00\x00') + bytes(8) + _U32.pack(1) + b'\x00'   # stamp, frame_id ''
    _pad(out, _align4)
    out += _U32.pack(len(encoded))
    for name in encoded:
        _pad(out, _align4)
        out += _U32.pack(len(name) + 1) + name + b'\x00'
    slots = {}
    for field in FIELDS:
        count = len(encoded) if field in fields else 0
        _pad(out, _align4)
        out += _U32.pack(count)
        if count:
            _pad(out, _align8)
        slots[field] = (len(out), count)
        out += bytes(8 * count)
    return out, slots


class JointStateEncoder:
    """Serializes sensor_msgs/JointState for a fixed joint name list (frame_id '') into CDR bytes.

    The message layout is built once; `encode` writes the stamp and values in place. Output is
    byte-identical to what a typed publish of the same message puts on the wire, which is
    rclpy's serialize_message without its size-estimate tail (padding as zeros).
    Fields not in `fields` are sent as empty sequences.
    """

    __slots__ = ('_buf', '_n', '_views', '_pack', '_data', '_only')

    def __init__(self, names, fields=FIELDS):
        """`names`: joint names (sequence of str); `fields`: the subset of 'position', 'velocity',
        'effort' that carries one value per joint (initially zeros)."""
        if isinstance(fields, str) or not set(fields) <= set(FIELDS):
            raise ValueError(f'fields: must be a subset of {FIELDS}, got {fields!r}')
        encoded = _encoded_names(names)
        self._n = len(encoded)
        self._buf, slots = _layout(encoded, fields)
        self._views = {f: np.frombuffer(self._buf, _F8, n, off) for f, (off, n) in slots.items() if f in fields}
        # one field, or all three: their doubles (with the two counts between three: n, then 4 zero bytes
        # of padding) are written by one struct call
        n, listed = self._n, [f for f in FIELDS if f in fields]
        packs = n and len(listed) in (1, 3)
        self._pack = struct.Struct('<' + 'I4x'.join([f'{n}d'] * len(listed))).pack if packs else None
        self._data = slice(slots[listed[0]][0], slots[listed[-1]][0] + 8 * n) if packs else None
        self._only = FIELDS.index(listed[0]) if packs and len(listed) == 1 else None

    def encode(self, stamp_ns, position=None, velocity=None, effort=None):
        """CDR bytes of the JointState stamped `stamp_ns` (int ns since the epoch, >= 0).

        Each listed field given as a sequence of len(names) floats (rad or m; rad/s or m/s;
        N*m or N) replaces its values; None keeps the previous ones. ValueError names the
        offending argument; nothing is written then. Returns a fresh bytes object."""
        sec, nanosec = _stamp(stamp_ns)
        if position is not None or velocity is not None or effort is not None:
            data = self._packed(position, velocity, effort)
            if data is not None:
                self._buf[self._data] = data
            else:
                writes = [(self._view(field, value), value)
                          for field, value in zip(FIELDS, (position, velocity, effort)) if value is not None]
                for view, value in writes:
                    view[...] = value
        _STAMP.pack_into(self._buf, _BODY, sec, nanosec)
        return bytes(self._buf)

    def _packed(self, position, velocity, effort):
        """The data of the encoder's fields packed in one struct call, when exactly those fields are given,
        each as n numbers in a list, a tuple or a float64 array; None otherwise, and for anything struct
        refuses (the checked path then writes it, or names the field)."""
        n, only = self._n, self._only
        if self._pack is None:
            return None
        if only is not None:
            if (position is None) + (velocity is None) + (effort is None) != 2:
                return None
            args = _items((position, velocity, effort)[only], n)
            if args is None:
                return None
        else:
            p, v, e = _items(position, n), _items(velocity, n), _items(effort, n)
            if p is None or v is None or e is None:
                return None
            args = (*p, n, *v, n, *e)
        try:
            return self._pack(*args)
        except struct.error:
            return None

    def values(self, field):
        """The float64 (n,) values of `field` inside the message, writable in place: what the next
        `encode` sends (fill them, then `encode(stamp_ns)`). ValueError naming `field` unless listed."""
        view = self._views.get(field)
        if view is None:
            raise ValueError(f'{field}: not among the encoder\'s fields {tuple(self._views)}')
        return view

    def _view(self, field, value):
        """The float64 view of `field` in the message; ValueError naming `field` unless it is
        listed and `value` has one entry per joint."""
        view = self.values(field)
        shape = value.shape if isinstance(value, np.ndarray) else np.shape(value)
        if shape != view.shape:
            raise ValueError(f'{field}: expected {self._n} values (one per name), got shape {shape}')
        return view


def _items(value, n):
    """The n values of a list or tuple (itself) or of a float64 (n,) array (a list); None for anything else."""
    kind = type(value)
    if kind is tuple or kind is list:
        return value if len(value) == n else None
    if kind is np.ndarray and value.dtype is _F8 and value.shape == (n,):
        return value.tolist()
    return None


def _stamp(stamp_ns):
    """(sec, nanosec) of `stamp_ns` (int ns); ValueError naming 'stamp_ns' if negative or beyond int32 s."""
    if type(stamp_ns) is int and 0 <= stamp_ns <= _MAX_STAMP_NS:     # the usual case, checked at once
        return divmod(stamp_ns, NS_PER_S)
    if type(stamp_ns) is not int:
        try:
            stamp_ns = operator.index(stamp_ns)
        except TypeError:
            raise ValueError(f'stamp_ns: must be an int (ns), got {type(stamp_ns).__name__}') from None
    sec, nanosec = divmod(stamp_ns, NS_PER_S)
    if stamp_ns < 0 or sec > INT32_MAX:
        raise ValueError(f'stamp_ns: {stamp_ns} outside [0, {INT32_MAX} s]')
    return sec, nanosec


# -- geometry_msgs/WrenchStamped ------------------------------------------------------------------
Vector3Frame = collections.namedtuple('Vector3Frame', 'x y z')
Vector3Frame.__doc__ = 'Read-only stand-in for a geometry_msgs/Vector3: .x, .y, .z (float).'
_SIX = struct.Struct('<6d')


class WrenchFrame(StampedFrame):
    """Read-only stand-in for a received geometry_msgs/WrenchStamped, with the same attribute names.

    The header as `StampedFrame`; `.wrench.force` (N) and `.wrench.torque` (N m) are `Vector3Frame`s.
    `.wrench` is the frame itself, so `.force` and `.torque` also read directly."""

    __slots__ = ()
    wrench = property(lambda self: self, doc='geometry_msgs/Wrench stand-in: .force, .torque (the frame itself)')
    force = property(operator.itemgetter(3), doc='force (N): Vector3Frame')
    torque = property(operator.itemgetter(4), doc='torque (N m): Vector3Frame')

    def __repr__(self):
        return (f'WrenchFrame(sec={self.sec}, nanosec={self.nanosec}, frame_id={self.frame_id!r}, '
                f'force={tuple(self.force)}, torque={tuple(self.torque)})')


def decode_wrench(buf):
    """`WrenchFrame` of the CDR bytes `buf`, or None (never raises) if they are not a well-formed
    little-endian CDR WrenchStamped; trailing bytes after the torque are ignored."""
    try:
        buf = buf if type(buf) is bytes else bytes(buf)
        encoding, kind, sec, nanosec = _HEAD.unpack_from(buf)
        if encoding != 0 or kind != 1:
            return None
        frame_id, off = _string(buf, _FRAME_ID, len(buf))
        fx, fy, fz, tx, ty, tz = _SIX.unpack_from(buf, _align8(off))
    except _ERRORS:
        return None
    return tuple.__new__(WrenchFrame, (sec, nanosec, frame_id, tuple.__new__(Vector3Frame, (fx, fy, fz)),
                                       tuple.__new__(Vector3Frame, (tx, ty, tz))))


class WrenchEncoder:
    """Serializes geometry_msgs/WrenchStamped with a fixed frame_id into CDR bytes: byte-identical to
    what a typed publish of the same message puts on the wire (padding as zeros)."""

    __slots__ = ('_buf', '_data')

    def __init__(self, frame_id=''):
        """`frame_id`: the header's frame (str without NUL); ValueError naming 'frame_id' otherwise."""
        if not isinstance(frame_id, str) or '\x00' in frame_id:
            raise ValueError(f'frame_id: must be a str without NUL, got {frame_id!r}')
        raw = frame_id.encode()
        out = bytearray(b'\x00\x01\x00\x00') + bytes(8) + _U32.pack(len(raw) + 1) + raw + b'\x00'
        _pad(out, _align8)
        self._data = len(out)
        self._buf = out + bytes(_SIX.size)

    def encode(self, stamp_ns, force, torque):
        """CDR bytes of the WrenchStamped stamped `stamp_ns` (int ns since the epoch, >= 0) with `force`
        (3 numbers, N) and `torque` (3 numbers, N m), e.g. float64 (3,) arrays. ValueError names the
        offending argument; nothing is written then. Returns a fresh bytes object."""
        sec, nanosec = _stamp(stamp_ns)
        for name, value in (('force', force), ('torque', torque)):
            if len(value) != 3:
                raise ValueError(f'{name}: expected 3 numbers, got {len(value)}')
        try:
            data = _SIX.pack(*force, *torque)
        except struct.error as exc:
            raise ValueError(f'force, torque: must be numbers ({exc})') from None
        self._buf[self._data:] = data
        _STAMP.pack_into(self._buf, _BODY, sec, nanosec)
        return bytes(self._buf)
