"""Sub-commands of ``sheer``; each module has ``register(subparsers)`` (see :mod:`app.cli`)."""
