"""Numpy float64 reference of the Pleat runtime: one module per C job with the same names and steps as sdk/src
(shape_blend, forward_kinematics, input_assembly, input_normalisation, mlp, latent_guard, blend_shapes, skinning,
normals, body_contact), the network rate decision (network_rate) and `Instance`, the twin of plInstance (instance_step.c). Golden
vectors for the C/SIMD/GLSL paths come from here (`python -m pleat.reference.golden`)."""
from pleat.reference.blend_shapes import blend_shapes
from pleat.reference.body_contact import body_contact
from pleat.reference.forward_kinematics import forward_kinematics
from pleat.reference.input_assembly import assemble_inputs, input_assembly, pose_features
from pleat.reference.input_normalisation import input_normalisation
from pleat.reference.instance import Instance, StepError
from pleat.reference.latent_guard import latent_guard
from pleat.reference.mlp import mlp
from pleat.reference.network_rate import decide_network_update
from pleat.reference.normals import normals
from pleat.reference.shape_blend import shape_blend, shaped_joints
from pleat.reference.skinning import skinning

__all__ = ["Instance", "StepError", "assemble_inputs", "blend_shapes", "body_contact", "decide_network_update", "forward_kinematics",
           "input_assembly", "input_normalisation", "latent_guard", "mlp", "normals", "pose_features", "shape_blend",
           "shaped_joints", "skinning"]
