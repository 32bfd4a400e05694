"""The PySide6 studio, the kiosk and the ``sheer`` command line. The only package that imports Qt."""
