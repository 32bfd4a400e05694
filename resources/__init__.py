"""Sheer's data files; data only: no code lives here, and it imports nothing.

Shaders (``shaders/*.glsl``), the default material library (``materials/``), the built-in looks
(``looks/``), head sidecars (``heads/``), the project schema and icons. Find a file with
:func:`core.assets.resource_path`.
"""
