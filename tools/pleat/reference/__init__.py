"""Numpy float64 reference of the Pleat runtime: the same jobs, names and steps as sdk/src (input_assembly, mlp,
blend_shapes, skinning, normals, forward_kinematics) plus `Instance`, the twin of plInstance. Golden vectors for the
C/SIMD/GLSL paths come from here (`python -m pleat.reference.golden`)."""
from pleat.reference.blend_shapes import blend_shapes, shape_blend
from pleat.reference.forward_kinematics import forward_kinematics, shaped_joints
from pleat.reference.input_assembly import assemble_inputs, input_assembly, pose_features
from pleat.reference.instance import Instance, StepError
from pleat.reference.mlp import mlp
from pleat.reference.normals import normals
from pleat.reference.skinning import skinning

__all__ = ["Instance", "StepError", "assemble_inputs", "blend_shapes", "forward_kinematics", "input_assembly", "mlp",
           "normals", "pose_features", "shape_blend", "shaped_joints", "skinning"]
