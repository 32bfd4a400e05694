"""The in-store kiosk: its window, the shopper's capture and try-on, shades, the PIN, its configuration.

Imports the shared app modules and :mod:`app.view`, never :mod:`app.studio`.
"""
