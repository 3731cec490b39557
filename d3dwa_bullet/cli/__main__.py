import sys

from d3dwa_bullet.cli.app import main

sys.exit(main())
