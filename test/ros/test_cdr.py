"""robot_control.ros.cdr against rclpy.serialization: same bytes out, same messages in.

rclpy's serialize_message leaves CDR padding and the trailing bytes of its over-estimated
buffer unwritten (heap garbage), so its bytes are compared in a child interpreter whose
glibc malloc fills fresh memory with a known byte (GLIBC_TUNABLES perturb, tcache off):
0x00 for the byte-for-byte comparison, 0x55 to show which bytes rclpy never writes.
"""
import inspect
import json
import math
import os
import random
import struct
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState

from support.cdr import big_endian, big_endian_wrench
from robot_control.ros import cdr
from robot_control.ros.cdr import JointStateDecoder, JointStateEncoder, JointStateFrame, WrenchEncoder, WrenchFrame

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
IIWA = [f'lbr_iiwa_joint_{i}' for i in range(1, 8)]
NAME_LISTS = [['joint1'], ['theta1', 'r'], IIWA, ['abcdefghi'[:k] for k in range(1, 10)],  # every padding
              ['Gelenk_ä', 'θ2', '関節🤖'], []]
FIELD_SETS = [('effort',), ('position', 'velocity', 'effort'), ('position', 'velocity'), ()]
STAMPS = [0, 1, 999_999_999, 1_700_000_000_123_456_789, (2 ** 31 - 1) * 10 ** 9 + 999_999_999]
CHARS = 'abcxyz_019ABZ äθ関🤖'
SPECIAL = [0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 1.7976931348623157e308]


def message(spec):
    """sensor_msgs/JointState of a JSON-able spec dict (also run in the child interpreter)."""
    from sensor_msgs.msg import JointState
    msg = JointState(name=spec['names'], position=spec['position'], velocity=spec['velocity'], effort=spec['effort'])
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(spec['stamp_ns'], 10 ** 9)
    msg.header.frame_id = spec['frame_id']
    return msg


CHILD = textwrap.dedent(inspect.getsource(message)) + '''
import json, sys
from rclpy.serialization import serialize_message
print(json.dumps([serialize_message(message(spec)).hex() for spec in json.load(sys.stdin)]))
'''


def rclpy_bytes(specs, fill, child=CHILD):
    """serialize_message of each spec in a child whose fresh heap memory reads `fill` (a byte); `child`: the
    script that reads the specs and prints the hex of each message (CHILD: JointState, WRENCH_CHILD)."""
    env = dict(os.environ, GLIBC_TUNABLES=f'glibc.malloc.tcache_count=0:glibc.malloc.perturb={fill ^ 0xFF}')
    out = subprocess.run([sys.executable, '-c', child], input=json.dumps(specs), env=env, cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return [bytes.fromhex(h) for h in json.loads(out.stdout.strip().splitlines()[-1])]


def spec(names, stamp_ns=0, frame_id='', position=(), velocity=(), effort=()):
    """A message spec (see `message`)."""
    return {'names': list(names), 'stamp_ns': stamp_ns, 'frame_id': frame_id, 'position': list(position),
            'velocity': list(velocity), 'effort': list(effort)}


def bits(values):
    """The float64 little-endian bytes of `values`: equality is exact (NaN, -0.0)."""
    return struct.pack(f'<{len(values)}d', *values)


def assert_same(frame, msg):
    """Every field of the decoded `frame` equals the rclpy message `msg` exactly."""
    assert isinstance(frame, JointStateFrame)
    assert frame.header.stamp.sec == msg.header.stamp.sec
    assert frame.header.stamp.nanosec == msg.header.stamp.nanosec
    assert frame.header.frame_id == msg.header.frame_id
    assert frame.name == list(msg.name) and all(type(n) is str for n in frame.name)
    for field in ('position', 'velocity', 'effort'):
        got, want = getattr(frame, field), list(getattr(msg, field))
        if type(got) is tuple:          # JointStateDecoder(arrays=False)
            assert all(type(v) is float for v in got), field
            got = np.array(got)
        else:
            assert got.dtype == np.float64 and got.ndim == 1 and not got.flags.writeable, field
        assert bits(got.tolist()) == bits(want), field
        if not any(math.isnan(v) for v in want):
            assert got.tolist() == want, field


def random_text(rng, longest):
    return ''.join(rng.choice(CHARS) for _ in range(rng.randint(0, longest)))


def random_values(rng, count):
    return [rng.choice(SPECIAL) if rng.random() < 0.1 else rng.uniform(-1e3, 1e3) for _ in range(count)]


def random_spec(rng):
    """Names 0..8 (unicode, '' allowed), independent value counts 0..8, non-empty frame_id."""
    return spec([random_text(rng, 10) for _ in range(rng.randint(0, 8))],
                stamp_ns=rng.randint(0, 2 ** 31 - 1) * 10 ** 9 + rng.randint(0, 10 ** 9 - 1),
                frame_id=random_text(rng, 12) + 'f',
                position=random_values(rng, rng.randint(0, 8)), velocity=random_values(rng, rng.randint(0, 8)),
                effort=random_values(rng, rng.randint(0, 8)))


# --- encoder: byte-identical to serialize_message -------------------------------------------------------


@pytest.fixture(scope='module')
def encoded():
    """(our bytes, spec) for every name list x field set x stamp; values random (seeded), some kept (None)."""
    rng = random.Random(7)
    cases = []
    for names in NAME_LISTS:
        for fields in FIELD_SETS:
            encoder = JointStateEncoder(names, fields)
            current = {f: [0.0] * len(names) if f in fields else [] for f in ('position', 'velocity', 'effort')}
            for i, stamp in enumerate(STAMPS):
                given = {f: np.array(random_values(rng, len(names))) for f in fields if i == 0 or rng.random() < 0.6}
                if i == 1:
                    given = {f: v.tolist() for f, v in given.items()}  # plain lists work too
                if i == 2:    # every field as a tuple: all three at once take the one-struct path
                    given = {f: tuple(random_values(rng, len(names))) for f in fields}
                current.update({f: list(v) for f, v in given.items()})
                cases.append((encoder.encode(stamp, **given), spec(names, stamp, **current)))
    return cases


def test_encoder_output_is_byte_identical_to_serialize_message_without_its_estimate_tail(encoded):
    ours = [b for b, _ in encoded]
    theirs = rclpy_bytes([s for _, s in encoded], fill=0x00)
    for mine, ref, (_, s) in zip(ours, theirs, encoded):
        assert mine == ref[:len(mine)], s
        assert len(ref) - len(mine) <= 12 and not any(ref[len(mine):]), s


def test_encoder_output_has_the_exact_size_strict_readers_require(encoded):
    """rosbags (what reads our bags back) refuses a JointState whose CDR size is not exact."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    for mine, s in encoded:
        msg = store.deserialize_cdr(mine, 'sensor_msgs/msg/JointState')
        assert (list(msg.name), bits(msg.position.tolist()), bits(msg.velocity.tolist()), bits(msg.effort.tolist())) \
            == (s['names'], bits(s['position']), bits(s['velocity']), bits(s['effort'])), s


def test_the_bytes_rclpy_leaves_unwritten_are_the_zero_padding_we_write(encoded):
    """With fresh memory reading 0x55 instead, rclpy's output differs exactly at some of our zero bytes."""
    theirs = rclpy_bytes([s for _, s in encoded], fill=0x55)
    unwritten = 0
    for (mine, s), ref in zip(encoded, theirs):
        ref = ref[:len(mine)]
        differ = [i for i, (a, b) in enumerate(zip(mine, ref)) if a != b]
        assert all(mine[i] == 0 and ref[i] == 0x55 for i in differ), s
        unwritten += len(differ)
    assert unwritten > 0  # the fill took effect, so the zero-fill comparison above checks every byte


def test_encoder_output_deserializes_to_the_same_message_in_process(encoded):
    for mine, s in encoded:
        assert len(serialize_message(message(s))) - len(mine) in range(13)
        assert_same(JointStateDecoder().decode(mine), deserialize_message(mine, JointState))
        msg = deserialize_message(mine, JointState)
        assert (msg.name, bits(msg.position), bits(msg.velocity), bits(msg.effort)) == \
            (s['names'], bits(s['position']), bits(s['velocity']), bits(s['effort']))


def test_encoder_keeps_values_given_as_none_and_starts_at_zero():
    encoder = JointStateEncoder(['theta1', 'r'], ('position', 'effort'))
    msg = deserialize_message(encoder.encode(5), JointState)
    assert (list(msg.position), list(msg.velocity), list(msg.effort)) == ([0.0, 0.0], [], [0.0, 0.0])
    encoder.encode(6, position=[1.5, -2.0], effort=np.array([3.0, 4.0]))
    msg = deserialize_message(encoder.encode(7, effort=[5.0, 6.0]), JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (0, 7)
    assert (list(msg.position), list(msg.effort)) == ([1.5, -2.0], [5.0, 6.0])


def test_values_filled_in_place_are_what_encode_sends():
    encoder, reference = JointStateEncoder(IIWA), JointStateEncoder(IIWA)
    q, qd, tau = (encoder.values(f) for f in ('position', 'velocity', 'effort'))
    values = [np.linspace(-1.0, 1.0, 7) * k for k in (1.0, 2.0, 3.0)]
    q[:], qd[:], tau[:] = values
    assert encoder.encode(42) == reference.encode(42, *values)
    with pytest.raises(ValueError, match='^position:'):
        JointStateEncoder(IIWA, ('effort',)).values('position')


def test_encode_returns_independent_bytes():
    encoder = JointStateEncoder(['a'], ('position',))
    first = encoder.encode(1, position=[1.0])
    second = encoder.encode(2, position=[2.0])
    assert type(first) is bytes and deserialize_message(first, JointState).position.tolist() == [1.0]
    assert deserialize_message(second, JointState).position.tolist() == [2.0]


# --- encoder: errors -------------------------------------------------------------------------------------


@pytest.mark.parametrize('kwargs, field', [
    ({'position': [1.0] * 6}, 'position'),
    ({'velocity': [1.0] * 8}, 'velocity'),
    ({'effort': np.zeros((7, 1))}, 'effort'),
    ({'effort': 1.0}, 'effort'),
    ({'position': [1.0] * 7, 'velocity': []}, 'velocity'),
    ({'position': [1.0] * 6, 'velocity': (1.0,) * 8, 'effort': [1.0] * 7}, 'position'),   # 21 values in all
    ({'position': [1.0] * 7, 'velocity': (1.0,) * 7, 'effort': [1.0] * 8}, 'effort'),
])
def test_wrong_length_names_the_field_and_writes_nothing(kwargs, field):
    encoder = JointStateEncoder(IIWA)
    before = encoder.encode(1, position=np.arange(7.0))
    with pytest.raises(ValueError, match=f'^{field}'):
        encoder.encode(2, **kwargs)
    assert encoder.encode(1) == before


def test_a_field_not_listed_is_rejected():
    with pytest.raises(ValueError, match='^position'):
        JointStateEncoder(['a'], ('effort',)).encode(0, position=[1.0])


@pytest.mark.parametrize('stamp', [-1, -10 ** 9, 2 ** 31 * 10 ** 9, 10 ** 30, 1.5, '1', None])
def test_bad_stamp_names_stamp_ns(stamp):
    encoder = JointStateEncoder(['a'])
    with pytest.raises(ValueError, match='^stamp_ns'):
        encoder.encode(stamp, position=[1.0])
    assert deserialize_message(encoder.encode(0), JointState).position.tolist() == [0.0]


def test_numpy_integer_stamp_is_accepted():
    msg = deserialize_message(JointStateEncoder(['a']).encode(np.int64(3_000_000_004)), JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (3, 4)


@pytest.mark.parametrize('names', [['a', 1], [b'a'], 'abc', b'ab', None, 3, ['a\x00b']])
def test_bad_names_name_names(names):
    with pytest.raises(ValueError, match='^names'):
        JointStateEncoder(names)


@pytest.mark.parametrize('fields', [('pos',), 'position', ('position', 'torque')])
def test_bad_fields_name_fields(fields):
    with pytest.raises(ValueError, match='^fields'):
        JointStateEncoder(['a'], fields)


# --- decoder: equal to deserialize_message -----------------------------------------------------------------


def test_decode_equals_deserialize_message_for_random_messages():
    rng = random.Random(2024)
    shared, floats = JointStateDecoder(), JointStateDecoder(arrays=False)
    for _ in range(300):
        buf = serialize_message(message(random_spec(rng)))  # garbage padding and trailing bytes included
        want = deserialize_message(buf, JointState)
        assert_same(shared.decode(buf), want)
        assert_same(floats.decode(buf), want)
        assert_same(JointStateDecoder().decode(buf), want)
        assert_same(JointStateDecoder(arrays=False).decode(bytearray(buf)), want)


def test_decode_reads_the_names_and_values_of_a_typical_message():
    values = {'position': [0.1 * i for i in range(7)], 'velocity': [-1.0] * 7, 'effort': [2.5] * 7}
    frame = JointStateDecoder().decode(serialize_message(message(spec(IIWA, 12_000_000_345, 'base', **values))))
    assert (frame.header.stamp.sec, frame.header.stamp.nanosec, frame.header.frame_id) == (12, 345, 'base')
    assert frame.name == IIWA and frame.position.tolist() == values['position']
    assert frame.velocity.tolist() == values['velocity'] and frame.effort.tolist() == values['effort']


def test_frame_is_read_only():
    frame = JointStateDecoder().decode(JointStateEncoder(['a']).encode(0))
    with pytest.raises(ValueError):
        frame.position[0] = 1.0
    with pytest.raises(AttributeError):
        frame.name = ['b']
    assert 'name' in repr(frame)


def test_same_names_return_the_identical_list_and_a_changed_name_a_new_one():
    decoder = JointStateDecoder()
    first = decoder.decode(serialize_message(message(spec(IIWA, 1, position=[1.0] * 7))))
    second = decoder.decode(serialize_message(message(spec(IIWA, 2, 'other_frame', position=[2.0] * 7))))
    assert second.name is first.name and second.name == IIWA
    assert second.position.tolist() == [2.0] * 7 and second.header.frame_id == 'other_frame'
    changed = IIWA[:6] + ['lbr_iiwa_joint_8']  # same lengths, one byte differs
    third = decoder.decode(serialize_message(message(spec(changed, 3, effort=[3.0] * 7))))
    assert third.name is not first.name and third.name == changed and third.effort.tolist() == [3.0] * 7
    assert first.name == IIWA  # the earlier list is not modified
    fourth = decoder.decode(JointStateEncoder(changed).encode(4, velocity=[4.0] * 7))
    assert fourth.name is third.name and fourth.velocity.tolist() == [4.0] * 7


def _fields(frame):
    """Every field of a frame as comparable plain values (None stays None)."""
    if frame is None:
        return None
    return (frame.sec, frame.nanosec, frame.frame_id, list(frame.name), bits(list(frame.position)),
            bits(list(frame.velocity)), bits(list(frame.effort)))


@pytest.mark.parametrize('arrays', [True, False])
@pytest.mark.parametrize('fields', [('position', 'velocity', 'effort'), ('effort',)])
@pytest.mark.parametrize('names', [['theta1', 'r'], IIWA])
def test_what_a_decoder_remembers_never_changes_what_it_decodes(names, fields, arrays, monkeypatch):
    """A decoder that has just read a message of the same layout (names, counts, size: a state or a
    command) decodes every one-byte change of the next message (stamp, frame_id, names, counts, padding,
    values) exactly as a fresh decoder does: its shortcuts only skip work whose result they know. The
    same for a decoder of floats (arrays=False) against a fresh decoder of arrays."""
    values = {f: np.arange(len(names)) + k for f, k in zip(fields, (0.5, 10.5, 20.5))}
    first, second = (JointStateEncoder(names, fields).encode(t, **values) for t in (1, 2))
    want = _fields(JointStateDecoder().decode(second))
    warm = JointStateDecoder(arrays)
    warm.decode(first)
    with monkeypatch.context() as patch:   # a control loop's two layouts take the shortcut: no array parsing
        for parser in ('_equal_doubles', '_three_doubles'):
            patch.setattr(cdr, parser, lambda *args: pytest.fail('the remembered layout was not used'))
        assert _fields(warm.decode(second)) == want
    for i in range(len(second)):
        for byte in {0, 1, 0x7F, 0xFF, second[i] ^ 0x01}:
            mutated = second[:i] + bytes([byte]) + second[i + 1:]
            warm = JointStateDecoder(arrays)
            assert warm.decode(first) is not None
            assert _fields(warm.decode(mutated)) == _fields(JointStateDecoder().decode(mutated)), (i, byte)


def test_names_differing_only_in_padding_are_the_same_names():
    """serialize_message leaves the padding after each name as garbage: it must not defeat the cache."""
    buf = JointStateEncoder(IIWA).encode(1, position=np.arange(7.0))
    pads = [buf.index(name.encode()) + len(name) + 1 for name in IIWA]  # 2 padding bytes after each name
    assert all(buf[p:p + 2] == b'\x00\x00' for p in pads)
    decoder = JointStateDecoder()
    first = decoder.decode(buf)
    for trial in range(3):
        garbage = buf
        for i, p in enumerate(pads):
            garbage = put(garbage, p, bytes([trial, 0xA0 + i]))
        frame = decoder.decode(garbage)
        assert frame.name is first.name and frame.position.tolist() == list(range(7))
    other = put(garbage, pads[3] - 2, b'9')  # lbr_iiwa_joint_4 -> lbr_iiwa_joint_9
    assert decoder.decode(other).name == IIWA[:3] + ['lbr_iiwa_joint_9'] + IIWA[4:]


def test_encoder_output_takes_the_fast_path():
    encoder, decoder = JointStateEncoder(IIWA), JointStateDecoder()
    frames = [decoder.decode(encoder.encode(t, position=np.full(7, float(t)))) for t in range(3)]
    assert frames[0].name is frames[1].name is frames[2].name
    assert [f.position.tolist() for f in frames] == [[float(t)] * 7 for t in range(3)]


# --- decoder: None for anything else ----------------------------------------------------------------------


def test_big_endian_is_not_decoded():
    s = spec(['theta1', 'r'], 5_000_000_006, 'world', position=[1.0, 2.0], velocity=[3.0, 4.0], effort=[5.0, 6.0])
    buf = big_endian(s)
    msg = deserialize_message(buf, JointState)  # valid CDR: rclpy reads it
    stamp = msg.header.stamp
    assert (stamp.sec, stamp.nanosec, msg.header.frame_id, msg.name) == (5, 6, 'world', s['names'])
    assert (list(msg.position), list(msg.velocity), list(msg.effort)) == (s['position'], s['velocity'], s['effort'])
    assert JointStateDecoder().decode(buf) is None
    little = serialize_message(message(s))
    assert JointStateDecoder().decode(little) is not None
    assert JointStateDecoder().decode(b'\x00\x00' + little[2:]) is None  # header flipped only


@pytest.mark.parametrize('header', [b'\x01\x00', b'\x00\x03', b'\x00\x07', b'\x00\x09', b'\x01\x01'])
def test_other_encapsulations_are_not_decoded(header):
    buf = serialize_message(message(spec(['a'], position=[1.0])))
    assert JointStateDecoder().decode(header + buf[2:]) is None


def test_every_truncation_returns_none_unless_rclpy_accepts_it_too():
    """A prefix holding all the data (ending in rclpy's unwritten trailing bytes) is a whole message."""
    rng = random.Random(11)
    specs = [random_spec(rng) for _ in range(6)] + [spec(IIWA, 1, 'f', [1.0] * 7, [2.0] * 7, [3.0] * 7),
                                                    spec(['a'], effort=[1.0])]
    for s in specs:
        buf = serialize_message(message(s))
        decoder, accepted = JointStateDecoder(), []
        for length in range(len(buf) + 1):
            frame = decoder.decode(buf[:length])
            try:
                want = deserialize_message(buf[:length], JointState)
            except Exception:
                assert frame is None, (s, length)
                continue
            assert_same(frame, want)
            accepted.append(length)
        assert accepted and accepted == list(range(accepted[0], len(buf) + 1))
        assert len(buf) - accepted[0] <= 12


def put(buf, offset, raw):
    """`buf` with the bytes at `offset` replaced by `raw`."""
    return buf[:offset] + raw + buf[offset + len(raw):]


def test_huge_counts_and_lengths_return_none():
    buf = JointStateEncoder(['theta1', 'r']).encode(1, [1.0, 2.0], [3.0, 4.0], [5.0, 6.0])
    offsets = {'frame_id': 12, 'name count': 20, 'name length': 24, 'position': 44, 'velocity': 68, 'effort': 92}
    assert [struct.unpack_from('<I', buf, o)[0] for o in offsets.values()] == [1, 2, 7, 2, 2, 2]
    for what, offset in offsets.items():
        for count in (2 ** 32 - 1, 2 ** 31, 10 ** 6):
            assert JointStateDecoder().decode(put(buf, offset, struct.pack('<I', count))) is None, (what, count)


def test_invalid_strings_return_none():
    buf = serialize_message(message(spec(['ab', 'cd'], frame_id='fr')))
    assert (buf[16:19], buf[28:31], buf[36:39]) == (b'fr\x00', b'ab\x00', b'cd\x00')
    cases = {'invalid utf-8 name': put(buf, 36, b'\xff\xfe'),
             'invalid utf-8 frame_id': put(buf, 16, b'\xc3('),
             'NUL inside a name': put(buf, 37, b'\x00'),
             'no NUL at the end': put(buf, 30, b'X'),
             'zero length': put(buf, 24, struct.pack('<I', 0))}
    assert JointStateDecoder().decode(buf) is not None
    for what, bad in cases.items():
        assert len(bad) == len(buf) and JointStateDecoder().decode(bad) is None, what
    # rclpy itself reads invalid UTF-8 as U+FFFD and cuts at the NUL: the caller's fallback decides
    assert deserialize_message(cases['invalid utf-8 name'], JointState).name[1] != 'cd'
    assert deserialize_message(cases['NUL inside a name'], JointState).name == ['ab', 'c']


def test_decode_of_the_cached_names_still_checks_what_follows():
    decoder = JointStateDecoder()
    buf = serialize_message(message(spec(IIWA, position=[1.0] * 7)))
    assert decoder.decode(buf) is not None
    assert decoder.decode(buf[:buf.index(b'lbr_iiwa_joint_7') + 20]) is None


@pytest.mark.parametrize('thing', [None, 42, 'text', b'', b'\x00\x01\x00\x00', [0, 1, 0, 0]])
def test_non_messages_return_none(thing):
    assert JointStateDecoder().decode(thing) is None


# --- geometry_msgs/WrenchStamped ----------------------------------------------------------------------------


def wrench_message(spec):
    """geometry_msgs/WrenchStamped of a JSON-able spec dict: stamp_ns, frame_id, force, torque (also run in
    the child interpreter)."""
    from geometry_msgs.msg import WrenchStamped
    msg = WrenchStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(spec['stamp_ns'], 10 ** 9)
    msg.header.frame_id = spec['frame_id']
    f, t = msg.wrench.force, msg.wrench.torque
    (f.x, f.y, f.z), (t.x, t.y, t.z) = spec['force'], spec['torque']
    return msg


WRENCH_CHILD = textwrap.dedent(inspect.getsource(wrench_message)) + '''
import json, sys
from rclpy.serialization import serialize_message
print(json.dumps([serialize_message(wrench_message(spec)).hex() for spec in json.load(sys.stdin)]))
'''


def wrench_spec(stamp_ns=0, frame_id='', force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
    return {'stamp_ns': stamp_ns, 'frame_id': frame_id, 'force': list(force), 'torque': list(torque)}


def assert_same_wrench(frame, msg):
    """Every field of the decoded `frame` equals the rclpy message `msg` exactly."""
    assert isinstance(frame, WrenchFrame)
    assert (frame.header.stamp.sec, frame.header.stamp.nanosec, frame.header.frame_id) == \
        (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id)
    for part in ('force', 'torque'):
        got, want = getattr(frame.wrench, part), getattr(msg.wrench, part)
        assert all(type(v) is float for v in got), part
        assert bits([got.x, got.y, got.z]) == bits([want.x, want.y, want.z]), part


@pytest.fixture(scope='module')
def wrenches():
    """(our bytes, spec): frame_ids of every length 0..9 (every padding before the doubles), unicode, every stamp,
    random and special values, given as lists, tuples and float64 arrays."""
    rng = random.Random(5)
    frame_ids = ['abcdefghi'[:k] for k in range(10)] + ['tool0_ä', '関節🤖', random_text(rng, 20)]
    cases = []
    for frame_id in frame_ids:
        encoder = WrenchEncoder(frame_id)
        for i, stamp in enumerate(STAMPS):
            force, torque = random_values(rng, 3), random_values(rng, 3)
            given = [(force, torque), (tuple(force), tuple(torque)), (np.array(force), np.array(torque))][i % 3]
            cases.append((encoder.encode(stamp, *given), wrench_spec(stamp, frame_id, force, torque)))
    return cases


def test_wrench_encoder_output_is_byte_identical_to_serialize_message(wrenches):
    theirs = rclpy_bytes([s for _, s in wrenches], fill=0x00, child=WRENCH_CHILD)
    for (mine, s), ref in zip(wrenches, theirs):
        assert mine == ref, s


def test_the_wrench_bytes_rclpy_leaves_unwritten_are_the_zero_padding_we_write(wrenches):
    theirs = rclpy_bytes([s for _, s in wrenches], fill=0x55, child=WRENCH_CHILD)
    unwritten = 0
    for (mine, s), ref in zip(wrenches, theirs):
        differ = [i for i, (a, b) in enumerate(zip(mine, ref)) if a != b]
        assert len(ref) == len(mine) and all(mine[i] == 0 and ref[i] == 0x55 for i in differ), s
        unwritten += len(differ)
    assert unwritten > 0


def test_wrench_decode_equals_deserialize_message(wrenches):
    rclpy_made = [serialize_message(wrench_message(s)) for _, s in wrenches]   # its padding: whatever the heap held
    for buf in [b for b, _ in wrenches] + rclpy_made:
        assert_same_wrench(cdr.decode_wrench(buf), deserialize_message(buf, WrenchStamped))
    buf = WrenchEncoder('tcp').encode(7_000_000_008, [1.0, -2.0, 3.5], (0.0, 0.25, -1e3))
    frame = cdr.decode_wrench(bytearray(buf))
    assert (frame.sec, frame.nanosec, frame.frame_id, frame.force, frame.torque) == \
        (7, 8, 'tcp', (1.0, -2.0, 3.5), (0.0, 0.25, -1e3))
    assert (frame.wrench.force.z, frame.wrench.torque.y) == (3.5, 0.25)
    with pytest.raises(AttributeError):
        frame.force.x = 0.0


def test_wrench_encode_keeps_nothing_of_a_refused_call():
    encoder = WrenchEncoder('world')
    first = encoder.encode(5, (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))
    for args, match in [((5, (1.0, 2.0), (4.0, 5.0, 6.0)), '^force: expected 3 numbers, got 2'),
                        ((5, (1.0, 2.0, 3.0), np.zeros(4)), '^torque: expected 3 numbers, got 4'),
                        ((5, (1.0, 'x', 3.0), (4.0, 5.0, 6.0)), '^force, torque: must be numbers'),
                        ((-1, (1.0, 2.0, 3.0), (4.0, 5.0, 6.0)), '^stamp_ns:'),
                        ((0.5, (1.0, 2.0, 3.0), (4.0, 5.0, 6.0)), '^stamp_ns: must be an int')]:
        with pytest.raises(ValueError, match=match):
            encoder.encode(*args)
    assert encoder.encode(5, (1.0, 2.0, 3.0), (4.0, 5.0, 6.0)) == first
    for frame_id in (None, 3, 'a\x00b'):
        with pytest.raises(ValueError, match='^frame_id:'):
            WrenchEncoder(frame_id)


def test_wrench_decoder_declines_what_is_not_little_endian_cdr_wrench():
    s = wrench_spec(5_000_000_006, 'fr', (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))
    buf = WrenchEncoder('fr').encode(5_000_000_006, s['force'], s['torque'])
    assert (buf[16:19], len(buf)) == (b'fr\x00', 68)
    big = big_endian_wrench(5_000_000_006, 'fr', s['force'], s['torque'])
    assert_same_wrench(cdr.decode_wrench(buf), deserialize_message(big, WrenchStamped))  # rclpy reads big endian
    assert cdr.decode_wrench(big) is None
    for header in (b'\x01\x00', b'\x00\x03', b'\x01\x01'):
        assert cdr.decode_wrench(header + buf[2:]) is None, header
    bad_strings = {'invalid utf-8 frame_id': put(buf, 16, b'\xc3('), 'NUL inside': put(buf, 16, b'\x00'),
                   'no NUL at the end': put(buf, 18, b'X'), 'zero length': put(buf, 12, struct.pack('<I', 0)),
                   'length past the end': put(buf, 12, struct.pack('<I', 2 ** 31))}
    for what, bad in bad_strings.items():
        assert cdr.decode_wrench(bad) is None, what
    for thing in (None, 42, 'text', b'', b'\x00\x01\x00\x00', [0, 1, 0, 0]):
        assert cdr.decode_wrench(thing) is None, thing


def test_every_wrench_truncation_returns_none_unless_rclpy_accepts_it_too():
    for frame_id in ('', 'abc', 'abcdefgh'):
        buf = WrenchEncoder(frame_id).encode(3, (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))
        for length in range(len(buf)):
            try:
                want = deserialize_message(buf[:length], WrenchStamped)
            except Exception:
                assert cdr.decode_wrench(buf[:length]) is None, (frame_id, length)
                continue
            assert_same_wrench(cdr.decode_wrench(buf[:length]), want)
