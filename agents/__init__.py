"""Energy-management strategies behind one protocol (see :mod:`agents.base`)."""
