"""What an install of robot_control may hold: the packages robot_control and sim_bridge, never the
workshop beside them in the checkout (benchmarks/, dev/, test/), which stays out of every install."""
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PACKAGES = ('robot_control', 'sim_bridge')
WORKSHOP = ('benchmarks', 'dev', 'test')


def workshop_modules():
    """Names of the modules of benchmarks/ and dev/ in this checkout ('bench', 'check_ros2', ...)."""
    return {name[:-3] for folder in WORKSHOP[:2] for name in os.listdir(os.path.join(ROOT, folder))
            if name.endswith('.py')}


def workshop_files(paths):
    """The entries of `paths` ('/'-separated, relative to site-packages or the wheel's root) that belong
    to the workshop: under one of its folders, or a module named like one of its modules."""
    modules = workshop_modules()
    return sorted(p for p in paths if p.split('/')[0] in WORKSHOP
                  or (p.endswith('.py') and p.rsplit('/', 1)[-1][:-3] in modules))


def python_lines(files):
    """Lines of the .py files among {path: bytes}."""
    return sum(data.count(b'\n') for path, data in files.items() if path.endswith('.py'))
