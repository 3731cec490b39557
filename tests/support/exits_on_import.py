"""A method module that calls ``sys.exit(0)`` when imported (a careless script's last line):
``tests.support.exits_on_import:Planner`` must be refused, never read as a run that succeeded."""

import sys

sys.exit(0)


class Planner:  # never reached
    interface_version = 1
