"""Lights for shading volumes."""

from .light import Light, LightError

__all__ = ["Light", "LightError"]
