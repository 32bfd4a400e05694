"""Sheer: capture package."""
