"""Cloth material (m, μ, λ, k): the paper's parameters and training ranges (section 4.1, from HOOD).

m is the areal density in kg/m² (HOOD's `density`; the paper calls it the per-vertex mass because every vertex mass
is m times the vertex's share of rest area). μ, λ are 2D Lamé parameters (N/m, "Pa" in the paper), k the bending
coefficient (J). The default is HOOD's cotton-like material, inside the ranges.
"""
from dataclasses import astuple, dataclass

MATERIAL_MIN = (4.34e-2, 15909.0, 3535.41, 6.37e-8)
MATERIAL_MAX = (7.0e-1, 63636.0, 93333.73, 1.31e-3)
MATERIAL_DEFAULT = (0.20022, 23600.0, 44400.0, 3.9625e-5)


@dataclass(frozen=True)
class Material:
    density_kg_m2: float = MATERIAL_DEFAULT[0]
    mu: float = MATERIAL_DEFAULT[1]
    lam: float = MATERIAL_DEFAULT[2]
    bending: float = MATERIAL_DEFAULT[3]

    @classmethod
    def parse(cls, text):
        """'m,mu,lambda,k' → Material; raises ValueError if malformed or outside the paper's ranges."""
        parts = [float(p) for p in str(text).split(",")]
        if len(parts) != 4:
            raise ValueError(f"material needs 4 comma-separated values m,mu,lambda,k, got {text!r}")
        mat = cls(*parts)
        mat.check()
        return mat

    def check(self):
        for name, v, lo, hi in zip(("m", "mu", "lambda", "k"), astuple(self), MATERIAL_MIN, MATERIAL_MAX):
            if not (lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)):
                raise ValueError(f"material {name}={v} outside the paper's range [{lo}, {hi}]")
        return self

    def as_tuple(self):
        return astuple(self)
