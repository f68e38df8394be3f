// Sample code (not part of the SDK; copy it into an engine and adapt): retargeting an engine skeleton whose bind pose
// is not the asset's rest pose — a T-pose, or joint frames that are not world-aligned — to the rotations Pleat takes.
//
// Pleat's joint rotations are local rotations measured from the asset's rest pose (an A-pose for the shipped body;
// pleat.h, "SKELETON AND REST POSE"). An engine has its own bind pose and measures from that. For one physical pose
// the world rotation of every bone must match, bone directions included, so per asset joint k driven by engine joint
// e (all rotations world-space, quaternions):
//
//     Δ_e = G_e · B_e⁻¹            the engine joint's world rotation G_e relative to its bind world rotation B_e
//     O_k                          the rest offset: the rotation taking the asset's rest bone directions at k onto
//                                  the engine's bind bone directions (both from joint positions: plRestJoint and the
//                                  engine's bind pose), built once
//     W_k = Δ_e · O_k              the asset joint's world rotation relative to the asset's rest pose
//     R_k = W_parent(k)⁻¹ · W_k    the local rotation Pleat takes (W_parent of the root: the engine joint above the
//                                  one that drives the root, whose motion the engine passes as root motion)
//
// With both skeletons at their bind poses Δ = identity and R_k = O_parent⁻¹ · O_k: for a T-pose engine the shoulders
// get the 25° that lowers the arms into the asset's A-pose, and everything else identity.
// Asset joints the engine lacks keep their rest relation to their parent (R = identity, as a joint map entry of -1).
#ifndef PLEAT_SAMPLE_RETARGET_H
#define PLEAT_SAMPLE_RETARGET_H
#include <pleat/pleat.h>

#include <stdint.h>

#define RETARGET_MAX_ENGINE_JOINTS 256

/// The engine's skeleton: what an engine keeps for its bind (reference) pose. Model space, metres, +Y up, facing +Z
/// (convert an engine with other axes at this boundary).
typedef struct EngineSkeleton
{
	uint32_t joint_count;               ///< E (count, <= RETARGET_MAX_ENGINE_JOINTS)
	const char* const* names;           ///< [E] joint names, matched exactly against the asset's joint names
	const int32_t* parents;             ///< [E] parent index (< the joint's own index), -1 for roots
	const float* bind_positions;        ///< [E][3] bind-pose joint positions in model space (metres)
	const float* bind_local_rotations;  ///< [E][4] (x, y, z, w) bind-pose local rotations; NULL = all identity
	                                    ///< (joint frames aligned with the model axes, as in BVH / mocap skeletons)
} EngineSkeleton;

/// A built retarget: the joint map for plInstanceDef and the per-joint rest offsets. Plain data, no allocation.
typedef struct Retarget
{
	uint32_t asset_joint_count;
	uint32_t engine_joint_count;
	int32_t joint_map[PLEAT_MAX_JOINTS];        ///< asset joint → engine joint, -1 = none (plInstanceDef.joint_map)
	int32_t asset_parents[PLEAT_MAX_JOINTS];
	float rest_offsets[PLEAT_MAX_JOINTS][4];    ///< O_k (x, y, z, w), world space
	int32_t engine_parents[RETARGET_MAX_ENGINE_JOINTS];
	float engine_bind_world[RETARGET_MAX_ENGINE_JOINTS][4]; ///< B_e (x, y, z, w)
	float engine_bind_positions[RETARGET_MAX_ENGINE_JOINTS][3];
} Retarget;

/// Maps joints by name (asset joint → engine joint) and builds the rest offsets from the asset's β = 0 rest pose
/// (plAsset_GetRestPose). Returns PLEAT_RESULT_OK, INVALID_ARGUMENT (bad skeleton: parent order, counts, two asset
/// joints on one engine joint) or the SDK's error.
plResult retargetInit( Retarget* retarget, const EngineSkeleton* engine, plAsset asset );

/// Rebuilds the rest offsets from another rest pose of the same asset, e.g. plInstance_GetRestPose for the
/// instance's β (the bone directions move a little with β). rest: [asset_joint_count].
plResult retargetSetRestPose( Retarget* retarget, const plRestJoint* rest );

/// One frame: engine_local_rotations [E][4] (x, y, z, w, the engine's own local rotations, bind included) →
/// out_rotations [E][4] in engine joint order: what plFrameInput.joint_rotations takes with the joint map above
/// (entries of engine joints no asset joint uses are set to identity and not read by the SDK).
void retargetPose( const Retarget* retarget, const float* engine_local_rotations, float* out_rotations );

#endif
