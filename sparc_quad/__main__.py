import sys

from sparc_quad.cli import main

sys.exit(main())
