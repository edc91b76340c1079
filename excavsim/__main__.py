"""``python -m excavsim``: the ``excavsim`` command."""

import sys

from excavsim.cli import main

sys.exit(main())
