"""``python -m prezence`` is the ``prezence`` command."""

import sys

from prezence.cli import main

sys.exit(main())
