"""Procedural garments fitted to the template body, with diffused skinning and shape blend shapes (docs/garments.md)."""
from .garment import Garment
from .generate import DEFAULT_VERTICES, GARMENT_NAMES, diffuse_from_body, garment_from_obj, make_garment

__all__ = ["Garment", "DEFAULT_VERTICES", "GARMENT_NAMES", "diffuse_from_body", "garment_from_obj", "make_garment"]
