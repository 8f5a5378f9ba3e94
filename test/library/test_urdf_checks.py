"""URDF problems reported by link or joint name before Pinocchio (or PyBullet) reads the file
(robot_control.urdf.checks): numbers urdfdom would misread are errors, a joint that moves no mass is
an error, a moved link without <inertial> is a warning the model keeps (UrdfModel.urdf_warnings).

urdfdom reads `<mass value="1.7kg"/>` as a massless link and says so on stderr only: the iiwa's g_2
at the test's q then comes out -32.9 instead of -42.3 N m. Now it is an error naming the link.
"""
import re

import numpy as np
import pytest

from robot_control import urdf as urdf_files
from robot_control.models import make_model
from robot_control.urdf import checks
from robot_control.validation import ArgumentError

IIWA = 'kuka_iiwa/model.urdf'
IIWA_JOINTS = tuple(f'lbr_iiwa_joint_{i}' for i in range(1, 8))


def iiwa_text():
    return urdf_files.read(IIWA)[0]


def without_inertial(xml, link):
    """`xml` with link `link`'s <inertial> element removed."""
    out, count = re.subn(rf'(<link name="{link}">\s*)<inertial>.*?</inertial>', r'\1', xml, flags=re.S)
    assert count == 1
    return out


@pytest.mark.parametrize('old,new,owner', [
    ('<mass value="1.7"/>', '<mass value="1.7kg"/>', "link 'lbr_iiwa_link_5'"),
    ('<mass value="1.7"/>', '<mass value="-1.7"/>', "link 'lbr_iiwa_link_5'"),
    ('<mass value="1.7"/>', '<mass value="nan"/>', "link 'lbr_iiwa_link_5'"),
    ('<mass value="1.7"/>', '<mass value="1_7"/>', "link 'lbr_iiwa_link_5'"),
    ('<limit effort="300"', '<limit effort="300Nm"', "joint 'lbr_iiwa_joint_1'"),
    ('<origin rpy="0 0 0" xyz="0 0 0.1575"/>', '<origin rpy="0 0 0" xyz="0, 0, 0.1575"/>', "joint 'lbr_iiwa_joint_1'"),
    ('<origin rpy="0 0 0" xyz="0 0 0.1575"/>', '<origin rpy="0 0" xyz="0 0 0.1575"/>', "joint 'lbr_iiwa_joint_1'"),
    ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 one"/>', "joint 'lbr_iiwa_joint_1'"),
])
def test_a_number_urdfdom_would_misread_is_an_error_naming_the_link_or_joint(old, new, owner):
    xml = iiwa_text()
    assert old in xml
    bad = xml.replace(old, new, 1)
    with pytest.raises(ArgumentError) as info:
        make_model('urdf', urdf=bad, joints=IIWA_JOINTS)
    assert info.value.name == 'urdf' and owner in str(info.value), str(info.value)
    assert make_model('urdf', urdf=xml, joints=IIWA_JOINTS).n == 7


def test_the_mass_with_a_unit_used_to_load_as_a_massless_link():
    """What the check prevents: Pinocchio alone takes 1.7kg for 0 kg, g_2 -32.9 instead of -42.3 N m."""
    import pinocchio as pin
    q = np.array([0.3, 0.8, 0.2, -0.9, 0.4, 0.6, 0.3])
    good = pin.buildModelFromXML(iiwa_text())
    bad = pin.buildModelFromXML(iiwa_text().replace('<mass value="1.7"/>', '<mass value="1.7kg"/>'))
    g_good = pin.computeGeneralizedGravity(good, good.createData(), q)
    g_bad = pin.computeGeneralizedGravity(bad, bad.createData(), q)
    assert abs(g_good[1] - g_bad[1]) > 0.5
    np.testing.assert_allclose(make_model('urdf', urdf=iiwa_text(), joints=IIWA_JOINTS).g(q), g_good, atol=1e-12)


def test_a_joint_that_moves_no_mass_is_an_error_naming_it_and_its_link():
    with pytest.raises(ArgumentError) as info:
        make_model('urdf', urdf=without_inertial(iiwa_text(), 'lbr_iiwa_link_7'), joints=IIWA_JOINTS)
    assert info.value.name == 'urdf'
    assert "joint 'lbr_iiwa_joint_7' moves no mass: link 'lbr_iiwa_link_7'" in str(info.value)


def test_a_moved_link_without_inertial_is_a_warning_and_massless():
    xml = without_inertial(iiwa_text(), 'lbr_iiwa_link_3')
    model = make_model('urdf', urdf=xml, joints=IIWA_JOINTS)
    assert len(model.urdf_warnings) == 1
    assert "link 'lbr_iiwa_link_3' (moved by joint 'lbr_iiwa_joint_3') has no <inertial>" in model.urdf_warnings[0]
    assert make_model('urdf', urdf=iiwa_text(), joints=IIWA_JOINTS).urdf_warnings == ()
    zero = make_model('urdf', urdf=checks.with_zero_inertials(xml), joints=IIWA_JOINTS)
    q = np.array([0.3, 0.8, 0.2, -0.9, 0.4, 0.6, 0.3])
    np.testing.assert_array_equal(zero.g(q), model.g(q))       # no <inertial> means zero, as Pinocchio reads it
    np.testing.assert_array_equal(zero.M(q), model.M(q))
    assert zero.urdf_warnings == ()                            # an explicit zero <inertial> is meant


def test_a_massless_link_is_no_warning_when_a_link_fixed_to_it_carries_the_mass():
    """A rigid body of several links (the closed forms' rod and point mass): its mass counts."""
    xml = ('<robot name="r"><link name="base"/><link name="rod"/><link name="bob"><inertial><mass value="1"/>'
           '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
           '<joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/><axis xyz="0 1 0"/></joint>'
           '<joint name="weld" type="fixed"><parent link="rod"/><child link="bob"/><origin xyz="1 0 0"/></joint>'
           '</robot>')
    assert checks.check(xml) == []
    assert make_model('urdf', urdf=xml).M([0.0])[0, 0] == pytest.approx(1.0)


def test_with_zero_inertials_adds_an_explicit_zero_inertial_where_none_is():
    out = checks.with_zero_inertials(without_inertial(iiwa_text(), 'lbr_iiwa_link_3'))
    assert out.count('<inertial>') == iiwa_text().count('<inertial>')
    assert re.search(r'<link name="lbr_iiwa_link_3">.*?<mass value="0" />', out, flags=re.S)
