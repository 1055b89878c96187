"""``python -m redservo ...``: the same command line as the ``redservo`` script (for an
environment whose scripts directory is not on ``PATH``)."""

import sys

from redservo.cli import main

if __name__ == "__main__":
    sys.exit(main())
