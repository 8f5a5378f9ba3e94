"""`python -m robot_control.record`: the record tool, robot_control.tools.record."""
import sys

from robot_control.tools.record import main

if __name__ == '__main__':
    sys.exit(main())
