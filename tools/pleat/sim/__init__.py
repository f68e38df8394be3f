"""Reference cloth simulator: implicit Euler, Newton on the incremental potential of `pleat.physics` (docs/simulator.md)."""
from pleat.body.model import BodyCollider, vertex_normals  # one collider for every tool (the simulator contact included)
from .solver import ClothSolver, SolverSettings, StepStats

__all__ = ["BodyCollider", "ClothSolver", "SolverSettings", "StepStats", "vertex_normals"]
