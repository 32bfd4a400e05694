"""Sheer: render package."""
