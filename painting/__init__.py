"""Sheer: painting package."""
