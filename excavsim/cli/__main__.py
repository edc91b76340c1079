"""``python -m excavsim.cli``: the ``excavsim`` command."""

import sys

from excavsim.cli import main

sys.exit(main())
