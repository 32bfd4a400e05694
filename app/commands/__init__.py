"""The ``sheer`` sub-commands, one module each with ``register(subparsers)`` (see :mod:`app.cli`).

A command module imports only the standard library at import time (heavy imports go inside its run
function), so ``sheer --help`` is instant and headless commands never load Qt. May import what
:mod:`app` may (never ``bench``).
"""
