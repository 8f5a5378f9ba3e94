"""What a URDF must satisfy before Pinocchio or PyBullet reads it, checked on its XML (xml.etree), and
the explicit zero <inertial> that makes PyBullet simulate what the URDF says.

check(xml, where): numbers that urdfdom would read wrongly are errors (urdfdom takes `1.7kg` as a
massless link and says so on stderr only), and so is a movable joint that moves nothing with mass
(its row of M(q) is zero: M is singular). A moved link without mass or inertia whose joint still
moves mass beyond it is a warning when it has no <inertial> (an explicit zero one says it is meant) and no
link fixed to it carries mass (a rigid body of several links): it is massless in the model and, once
with_zero_inertials has rewritten the URDF, in the simulation too. Both the controller's model (UrdfModel) and the simulated
world call check.

with_zero_inertials(xml): a link without <inertial> gets mass 0 and inertia 0, which is the URDF
meaning (urdfdom, Pinocchio); PyBullet would otherwise give it 1 kg and 1 kg m^2 about each axis.
"""
import math
import re
import xml.etree.ElementTree as ET

from robot_control.validation import ArgumentError

#: numeric attributes urdfdom reads, by element, and how many numbers each holds
NUMERIC = {
    'origin': {'xyz': 3, 'rpy': 3},
    'mass': {'value': 1},
    'inertia': {'ixx': 1, 'ixy': 1, 'ixz': 1, 'iyy': 1, 'iyz': 1, 'izz': 1},
    'limit': {'lower': 1, 'upper': 1, 'effort': 1, 'velocity': 1},
    'axis': {'xyz': 3},
    'dynamics': {'damping': 1, 'friction': 1},
}
#: a decimal number as strtod reads it whole (no unit, no Python-only forms such as 1_000)
NUMBER = re.compile(r'[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?')
#: the inertia entries of <inertia>
INERTIA = ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')
#: a link's inertial meaning "no mass": origin at the link frame, mass and inertia zero
ZERO_INERTIAL = {'mass': {'value': '0'}, 'inertia': dict.fromkeys(INERTIA, '0')}


def _root(xml, where):
    try:
        root = ET.fromstring(xml.lstrip())
    except ET.ParseError as exc:
        raise ArgumentError('urdf', f'{where} is not well-formed XML: {exc}') from None
    if root.tag != 'robot':
        raise ArgumentError('urdf', f'{where} has root element <{root.tag}>, expected <robot>')
    return root


def _numbers(owner, kind, where):
    """Every numeric attribute below `owner` (a <link> or <joint>) read as urdfdom needs it, or
    ArgumentError naming `urdf`, the link or joint, the element and the attribute."""
    name = owner.get('name')
    for element in owner.iter():
        for attribute, count in NUMERIC.get(element.tag, {}).items():
            text = element.get(attribute)
            if text is None:
                continue
            words = text.split()
            if len(words) != count or not all(NUMBER.fullmatch(w) and math.isfinite(float(w)) for w in words):
                what = 'a finite number' if count == 1 else f'{count} finite numbers'
                raise ArgumentError('urdf', f'{where}: {kind} {name!r}: <{element.tag} {attribute}="{text}"/> '
                                            f'is not {what}')
    mass = owner.find('inertial/mass')
    if mass is not None and float(mass.get('value', '0')) < 0.0:
        raise ArgumentError('urdf', f'{where}: link {name!r}: negative mass {mass.get("value")} kg')


def _carries_mass(link):
    """True when `link` has an <inertial> with a nonzero mass or a nonzero inertia entry."""
    inertial = link.find('inertial') if link is not None else None
    if inertial is None:
        return False
    mass, inertia = inertial.find('mass'), inertial.find('inertia')
    values = [float(mass.get('value', '0'))] if mass is not None else []
    if inertia is not None:
        values += [float(inertia.get(k, '0')) for k in INERTIA]
    return any(v != 0.0 for v in values)


def _massless(root, where):
    """Warnings for massless moved bodies; ArgumentError for a joint that moves no mass at all.

    A joint moves a rigid body, its child link with the links fixed to it, and everything beyond."""
    links = {link.get('name'): link for link in root.findall('link')}
    children = {}
    for joint in root.findall('joint'):
        children.setdefault(joint.find('parent').get('link'), []).append(
            (joint.find('child').get('link'), joint.get('type') == 'fixed'))

    def carries_mass(name, fixed_only):
        seen, todo = set(), [name]
        while todo:
            link = todo.pop()
            if _carries_mass(links.get(link)):
                return True
            seen.add(link)
            todo += [c for c, fixed in children.get(link, ()) if c not in seen and (fixed or not fixed_only)]
        return False

    warnings = []
    for joint in root.findall('joint'):
        name, child = joint.get('name'), joint.find('child').get('link')
        if joint.get('type') == 'fixed' or carries_mass(child, fixed_only=True):
            continue
        if not carries_mass(child, fixed_only=False):
            raise ArgumentError('urdf', f'{where}: joint {name!r} moves no mass: link {child!r} and every link '
                                        'beyond it have no mass and no inertia (M(q) would be singular); give '
                                        f'link {child!r} an <inertial>')
        if links.get(child) is not None and links[child].find('inertial') is None:
            warnings.append(f'{where}: link {child!r} (moved by joint {name!r}) has no <inertial>, nor has any link '
                            'fixed to it: massless in the model and in the simulation; the joint moves only the '
                            'links beyond')
    return warnings


def check(xml, where='URDF'):
    """Check URDF text `xml` (`where` names it in messages); return the warnings, a list of strings.

    Errors (ArgumentError naming `urdf`, the link or joint and the attribute): XML that is not a
    <robot>; a numeric attribute of <origin>, <mass>, <inertia>, <limit>, <axis> or <dynamics> that
    is not that many finite numbers; a negative mass; a movable joint whose child link and every
    link beyond it carry neither mass nor inertia. Warnings: a link moved by a joint that has no
    <inertial>, and no link fixed to it carries mass (the joint still moves the mass beyond it)."""
    root = _root(xml, where)
    for kind in ('link', 'joint'):
        for owner in root.findall(kind):
            _numbers(owner, kind, where)
    for joint in root.findall('joint'):
        if joint.find('parent') is None or joint.find('child') is None:
            raise ArgumentError('urdf', f'{where}: joint {joint.get("name")!r} needs a <parent> and a <child>')
    return _massless(root, where)


def with_zero_inertials(xml):
    """URDF text `xml` in which every link without <inertial> has an explicit zero one (mass 0 kg,
    inertia 0 kg m^2 at the link origin), so that PyBullet simulates it massless, as the URDF means."""
    root = ET.fromstring(xml.lstrip())
    for link in root.findall('link'):
        if link.find('inertial') is None:
            inertial = ET.SubElement(link, 'inertial')
            ET.SubElement(inertial, 'origin', xyz='0 0 0', rpy='0 0 0')
            for tag, attributes in ZERO_INERTIAL.items():
                ET.SubElement(inertial, tag, attributes)
    return ET.tostring(root, encoding='unicode')
