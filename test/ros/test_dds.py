"""robot_control.ros.dds: the Fast DDS settings the nodes give themselves, and what a user's own settings do."""
import ast
import subprocess
import sys
import xml.etree.ElementTree as ET

from robot_control.ros import dds

FASTDDS_XML = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'


def test_both_settings_are_applied_where_the_environment_has_none():
    env = {'ROS_DOMAIN_ID': '7'}
    assert dds.apply_defaults(env) == dds.DEFAULTS
    assert env == {'ROS_DOMAIN_ID': '7', 'FASTDDS_BUILTIN_TRANSPORTS': 'DEFAULT?non_blocking=true',
                   'FASTRTPS_DEFAULT_PROFILES_FILE': dds.PROFILE}


def test_a_users_own_settings_win():
    env = {'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4', 'FASTRTPS_DEFAULT_PROFILES_FILE': '/etc/mine.xml'}
    assert dds.apply_defaults(env) == {}
    assert env == {'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4', 'FASTRTPS_DEFAULT_PROFILES_FILE': '/etc/mine.xml'}
    env = {'FASTDDS_BUILTIN_TRANSPORTS': ''}               # set but empty: as unset
    assert dds.apply_defaults(env) == dds.DEFAULTS


def test_the_profile_gives_every_writer_a_100_ms_heartbeat():
    root = ET.parse(dds.PROFILE).getroot()
    assert root.tag == FASTDDS_XML + 'profiles'
    writers = root.findall(FASTDDS_XML + 'data_writer')
    assert [w.get('is_default_profile') for w in writers] == ['true']
    period = writers[0].find(f'{FASTDDS_XML}times/{FASTDDS_XML}heartbeatPeriod')
    assert (period.findtext(FASTDDS_XML + 'sec'), period.findtext(FASTDDS_XML + 'nanosec')) == ('0', '100000000')


def test_run_node_applies_the_settings_before_rclpy_starts():
    """spin.run_node sets them before rclpy.init (its participant reads them when the first node is made)."""
    code = ('import os, rclpy\n'
            'from robot_control.ros import spin\n'
            'seen = {}\n'
            'real_init = rclpy.init\n'
            'def init(*a, **k):\n'
            '    seen.update((n, os.environ.get(n)) for n in ("FASTDDS_BUILTIN_TRANSPORTS", '
            '"FASTRTPS_DEFAULT_PROFILES_FILE"))\n'
            '    raise SystemExit(0)\n'
            'rclpy.init = init\n'
            'try:\n'
            '    spin.run_node(["probe"], lambda: None)\n'
            'finally:\n'
            '    print(seen)\n')
    env = {'PATH': '/usr/bin:/bin', 'PYTHONDONTWRITEBYTECODE': '1', 'PYTHONPATH': ':'.join(sys.path)}
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True, timeout=60)
    assert ast.literal_eval(out.stdout.strip().splitlines()[-1]) == dds.DEFAULTS, out.stderr
