"""Physics energies shared by the reference simulator (numpy) and training (torch): the paper's equation (4)."""
from .energies import (GRAVITY_M_S2, ClothRest, bending_energy, bending_grad_hess, cloth_rest, collision_energy,
                       collision_grad_hess, dihedral_angles, friction_energy, friction_grad_hess, gravity_energy,
                       hinges_of, inertia_energy, stretching_energy, stretching_grad_hess, stretching_grad_hess_gn,
                       unique_edges)
from .materials import MATERIAL_DEFAULT, MATERIAL_MAX, MATERIAL_MIN, Material

__all__ = ["GRAVITY_M_S2", "ClothRest", "Material", "MATERIAL_DEFAULT", "MATERIAL_MIN", "MATERIAL_MAX",
           "bending_energy", "bending_grad_hess", "cloth_rest", "collision_energy", "collision_grad_hess",
           "dihedral_angles", "friction_energy", "friction_grad_hess", "gravity_energy", "hinges_of",
           "inertia_energy", "stretching_energy", "stretching_grad_hess", "stretching_grad_hess_gn", "unique_edges"]
