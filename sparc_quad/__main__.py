import os
import sys

try:  # Ctrl-C before the CLI has imported (before main() can catch it): exit 130 without a traceback
    from sparc_quad.cli import entry
except KeyboardInterrupt:
    print("sparc-quad: interrupted", file=sys.stderr)
    sys.stderr.flush()
    os._exit(130)

entry()
