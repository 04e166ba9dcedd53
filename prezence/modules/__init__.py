"""Input modules: separate processes that measure the presenter and write metric streams.

Each runs as ``python -m prezence.modules.<name> --out SESSION …`` and only appends
``<t> <value>`` lines to ``SESSION/streams/<metric>.txt`` (see :mod:`prezence.modules.common`).
Their heavy dependencies (pocketsphinx, PyAV, mediapipe, OpenCV) are imported by the module
that needs them, never by this package.
"""
