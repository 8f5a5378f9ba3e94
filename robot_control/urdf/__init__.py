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
