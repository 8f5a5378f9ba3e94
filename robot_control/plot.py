"""`python -m robot_control.plot BAG [-o PNG]`: the tracking figure of a bag, robot_control.tools.plot."""
import sys

from robot_control.tools.plot import main

if __name__ == '__main__':
    sys.exit(main())
