"""Sheer's data files: shaders (``shaders/*.glsl``), the default material library (``materials/``), the
built-in looks (``looks/``), head sidecars (``heads/``), the project schema and icons.

Data only: no code lives here. Find a file with :func:`core.assets.resource_path`.
"""
