"""The studio's and the kiosk's 3D view: the viewport, its input, the GL surface and the orbit camera's Qt side."""
