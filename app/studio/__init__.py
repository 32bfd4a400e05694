"""The desktop studio: its main window, docks, panels, dialogs and file actions.

Imports the shared app modules and :mod:`app.view`, never :mod:`app.kiosk`.
"""
