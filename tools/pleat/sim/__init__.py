"""Reference cloth simulator: implicit Euler, Newton on the incremental potential of `pleat.physics` (docs/simulator.md)."""
from .collider import BodyCollider, vertex_normals
from .solver import ClothSolver, SolverSettings, StepStats

__all__ = ["BodyCollider", "ClothSolver", "SolverSettings", "StepStats", "vertex_normals"]
