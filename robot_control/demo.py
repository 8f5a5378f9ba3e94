"""`python -m robot_control.demo`: the demo tool, robot_control.tools.demo."""
import sys

from robot_control.tools.demo import main

if __name__ == '__main__':
    sys.exit(main())
