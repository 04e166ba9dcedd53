"""``python -m sim.virtual_nao``: serve a virtual NAO (see :func:`sim.virtual_nao.main`)."""

import logging
import os
import sys

from sim.virtual_nao import main

code = main()
# libqi's threads make the interpreter's own exit abort once a client has connected (SIGABRT
# after a clean close): end here, output flushed.
logging.shutdown()
sys.stdout.flush()
sys.stderr.flush()
os._exit(code)
