"""The open SMPL-style body (docs/body.md): `BodyModel.load()` reads assets/body.npz with numpy alone."""
from pleat.body.model import (BodyCollider, BodyModel, SMPL_JOINT_NAMES, SMPL_PARENTS, default_body_path,
                              vertex_normals)

__all__ = ["BodyModel", "BodyCollider", "SMPL_JOINT_NAMES", "SMPL_PARENTS", "default_body_path", "vertex_normals"]
