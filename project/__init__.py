"""The ``.sheer`` project format (see ``docs/FORMAT.md``): the model, reading and writing, the zip
container, migrations, crash recovery, export, and the one bridge to a :class:`painting.Document`.

May import: :mod:`core`, :mod:`km`, :mod:`painting` (never Qt, never GL).
"""
