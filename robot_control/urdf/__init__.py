"""The shipped URDFs (this directory) and the one lookup of a URDF by name.

A URDF is named by an existing file path, a shipped file ('polar_two_link' or
'polar_two_link.urdf'), or a path relative to pybullet_data ('kuka_iiwa/model.urdf').
"""
import os
from robot_control.validation import ArgumentError

#: directory of the shipped URDFs
DIR = os.path.dirname(os.path.abspath(__file__))


def search_dirs():
    """Where names are looked up: the shipped URDFs, then pybullet_data (if installed)."""
    dirs = [DIR]
    try:
        import pybullet_data  # data-only package: does not import pybullet
        dirs.append(pybullet_data.getDataPath())
    except ImportError:
        pass
    return dirs


def resolve(name):
    """Absolute path of URDF `name` (see the module docstring); ValueError naming `urdf` when none exists."""
    if not isinstance(name, (str, os.PathLike)) or not os.fspath(name).strip():
        raise ArgumentError('urdf', f'expected a URDF file name, got {name!r}')
    name = os.fspath(name)
    candidates = []
    if not os.path.isabs(name):
        for base in search_dirs():
            candidates.append(os.path.join(base, name))
            if not name.endswith('.urdf'):
                candidates.append(os.path.join(base, name + '.urdf'))
    candidates.append(name)
    for path in candidates:
        if os.path.isfile(path):
            return os.path.abspath(path)
    raise ArgumentError('urdf', f'no URDF file {name!r} in {search_dirs()} nor as a path')


def read(urdf):
    """(xml text, where) of URDF XML text, a file path or a name resolve() knows; where is the file
    path or 'URDF XML string'. ValueError naming `urdf`."""
    if not isinstance(urdf, (str, os.PathLike)):
        raise ArgumentError('urdf', f'expected a file path or URDF XML text, got {type(urdf).__name__}')
    text = os.fspath(urdf)
    if text.lstrip().startswith('<'):
        return text, 'URDF XML string'
    path = resolve(text)
    with open(path, encoding='utf-8') as f:
        return f.read(), path


def with_absolute_meshes(xml, base):
    """URDF text `xml` whose relative mesh file names are made absolute against directory `base` (the
    original file's), so the text can be written and loaded anywhere."""
    import xml.etree.ElementTree as ET
    root = ET.fromstring(xml.lstrip())
    for mesh in root.iter('mesh'):
        name = mesh.get('filename', '')
        if name and '://' not in name and not os.path.isabs(name):
            mesh.set('filename', os.path.join(base, name))
    return ET.tostring(root, encoding='unicode')


#: radius of the solid sphere a payload is modelled as, m (its rotational inertia 2/5 m r^2)
PAYLOAD_RADIUS = 0.02


def with_payload(xml, tip, mass, com):
    """URDF text `xml` with a payload on link `tip`: a solid sphere of `mass` kg (radius PAYLOAD_RADIUS)
    centred at `com` (3,) m in the tip link's frame, as a link '<tip>_payload' on a fixed joint.

    The controller's model (robot_control.models.UrdfModel) and the simulated robot (sim_bridge.world)
    both load this text, so a payload means the same to both. ArgumentError naming tip, payload.mass or
    payload.com."""
    import xml.etree.ElementTree as ET

    from robot_control import validation
    mass = validation.scalar('payload.mass', mass, positive=True)
    com = validation.vector('payload.com', com, 3)
    root = ET.fromstring(xml.lstrip())
    if root.find(f"link[@name='{tip}']") is None:
        raise ArgumentError('tip', f'no link {tip!r} to carry the payload')
    name = f'{tip}_payload'
    inertia = 0.4 * mass * PAYLOAD_RADIUS ** 2
    xyz = ' '.join(repr(float(v)) for v in com)
    link = ET.SubElement(root, 'link', name=name)
    inertial = ET.SubElement(link, 'inertial')
    ET.SubElement(inertial, 'origin', xyz=xyz, rpy='0 0 0')
    ET.SubElement(inertial, 'mass', value=repr(mass))
    ET.SubElement(inertial, 'inertia', ixx=repr(inertia), ixy='0', ixz='0', iyy=repr(inertia), iyz='0',
                  izz=repr(inertia))
    joint = ET.SubElement(root, 'joint', name=f'{name}_joint', type='fixed')
    ET.SubElement(joint, 'parent', link=tip)
    ET.SubElement(joint, 'child', link=name)
    ET.SubElement(joint, 'origin', xyz='0 0 0', rpy='0 0 0')
    return ET.tostring(root, encoding='unicode')
