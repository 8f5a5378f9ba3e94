"""The shipped URDFs (this directory) and the one lookup of a URDF by name.

A URDF is named by an existing file path, a shipped file ('polar_two_link' or
'polar_two_link.urdf'), a path relative to pybullet_data ('kuka_iiwa/model.urdf'), or a path relative
to the robots of example-robot-data, the wheel's or a ROS install's ('ur_description/urdf/ur5_robot.urdf').
"""
import os
import sys
from robot_control.validation import ArgumentError

#: directory of the shipped URDFs
DIR = os.path.dirname(os.path.abspath(__file__))


#: where example-robot-data keeps its robots below an install prefix
EXAMPLE_ROBOT_DATA = os.path.join('share', 'example-robot-data', 'robots')


def _prefixes():
    """Install prefixes that may hold example-robot-data: the wheel's (cmeel.prefix in a sys.path
    directory), then a ROS install's (each AMENT_PREFIX_PATH entry)."""
    for entry in sys.path:
        yield os.path.join(entry or os.curdir, 'cmeel.prefix')
    for entry in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if entry:
            yield entry


def search_dirs():
    """Where names are looked up: the shipped URDFs, then pybullet_data and example-robot-data's robots
    (each if installed; the first example-robot-data found)."""
    dirs = [DIR]
    try:
        import pybullet_data  # data-only package: does not import pybullet
        dirs.append(pybullet_data.getDataPath())
    except ImportError:
        pass
    for prefix in _prefixes():
        robots = os.path.join(prefix, EXAMPLE_ROBOT_DATA)
        if os.path.isdir(robots):
            dirs.append(os.path.abspath(robots))
            break
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


#: URI schemes PyBullet drops from a mesh file name before it looks for the file
MESH_SCHEMES = ('file://', 'package://', 'model://')


def package_dirs(package):
    """Directories that may be ROS package `package`, in lookup order: share/<package> below each
    AMENT_PREFIX_PATH entry (the ament index) and below the example-robot-data wheel's prefix
    (cmeel.prefix), then <entry>/<package> for each ROS_PACKAGE_PATH entry, and the entry itself when it
    is named `package`."""
    ament = [e for e in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if e]
    wheels = [prefix for prefix in _prefixes() if os.path.isdir(prefix) and prefix not in ament]
    dirs = [os.path.join(prefix, 'share', package) for prefix in ament + wheels]
    for entry in os.environ.get('ROS_PACKAGE_PATH', '').split(os.pathsep):
        if entry:
            dirs.append(os.path.join(entry, package))
            if os.path.basename(os.path.normpath(entry)) == package:
                dirs.append(entry)
    return dirs


def mesh_lookup(name, base):
    """(file, places) for mesh file name `name` of a URDF in directory `base`.

    'package://<pkg>/<rest>' is <rest> in the first of package_dirs(<pkg>) that holds it; failing
    that, and for any other name, the 'file://', 'package://' or 'model://' prefix is dropped and the
    name is found as PyBullet finds it: `base`/name, `base`/../name, ... up to the root directory. An
    absolute name is itself. file: the absolute path, None when no such file exists (or for other
    URIs); places: where it was looked for (strings, for an error message)."""
    scheme = next((s for s in MESH_SCHEMES if name.startswith(s)), '')
    rest = name[len(scheme):]
    if not rest or '://' in rest:
        return None, ['nowhere: not a file name, nor a file://, package:// or model:// URI']
    if os.path.isabs(rest):
        return (rest if os.path.isfile(rest) else None), [rest]
    places = []
    if scheme == 'package://' and '/' in rest:
        package, inner = rest.split('/', 1)
        for directory in package_dirs(package):
            path = os.path.join(directory, inner)
            places.append(path)
            if os.path.isfile(path):
                return os.path.normpath(path), places
    directory = os.path.abspath(base)
    places.append(f'{rest} in {directory} and every directory above it')
    while True:
        path = os.path.join(directory, rest)
        if os.path.isfile(path):
            return os.path.normpath(path), places
        parent = os.path.dirname(directory)
        if parent == directory:
            return None, places
        directory = parent


def mesh_path(name, base):
    """The absolute file a URDF in directory `base` means by mesh file name `name` (mesh_lookup), or None."""
    return mesh_lookup(name, base)[0]


def with_absolute_meshes(xml, base):
    """URDF text `xml` whose mesh file names are made absolute 'file://' URIs (which PyBullet and ROS's
    resource retriever both read) against directory `base` (the original file's) by mesh_lookup, so the
    text can be written and loaded anywhere. A mesh found nowhere is an ArgumentError naming `urdf`,
    the link, the mesh and the places looked."""
    import xml.etree.ElementTree as ET
    root = ET.fromstring(xml.lstrip())
    for link in root.iter('link'):
        for mesh in link.iter('mesh'):
            name = mesh.get('filename', '')
            path, places = mesh_lookup(name, base)
            if path is None:
                raise ArgumentError('urdf', f'link {link.get("name")!r}: mesh {name!r} not found; looked in '
                                            + '; '.join(places))
            mesh.set('filename', 'file://' + path)
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
