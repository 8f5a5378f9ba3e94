"""`python -m robot_control.sweep run SPEC.yaml | replay RUN K`: Monte Carlo sweeps, robot_control.tools.sweep."""
import sys

from robot_control.tools.sweep import main

if __name__ == '__main__':
    sys.exit(main())
