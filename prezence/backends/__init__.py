"""Robot backends behind one small interface (see :mod:`prezence.backends.base`)."""
