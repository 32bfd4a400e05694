"""The Sheer application: the desktop studio, the in-store kiosk and the ``sheer`` command line.

The only package that imports Qt (PySide6). It holds the windows and their widgets, the session a window
works on (:mod:`app.session`: the material library and the painting document), the file and export
actions, the settings, and one module per ``sheer`` sub-command under :mod:`app.commands`.

May import every package below it — ``render``, ``capture``, ``project``, ``painting``, ``km``, ``core``
and ``resources`` — and never ``bench`` (``sheer bench`` is found by name at run time, see
:data:`app.cli.COMMAND_MODULES`, so a build without the benchmarks still runs).
"""
