"""``python -m sim.virtual_nao``: serve a virtual NAO (see :func:`sim.virtual_nao.main`)."""

import sys

from sim.virtual_nao import main

sys.exit(main())
