// The asset's skeleton as a reference pose (pleat.h, "Skeleton and rest pose"): what an engine reads to retarget from
// its own bind pose. The instance's version (current β) is plInstance_GetRestPose in instance.c, which owns J(β).
#include "asset.h"
#include "skeleton.h"

void plFillRestPose( const int32_t* parents, const double* positions, uint32_t joint_count, plRestJoint* out_joints )
{
	for ( uint32_t k = 0; k < joint_count; ++k )
	{
		const double* p = positions + (size_t)k * 3;
		int32_t parent = parents[k];
		// The loader guarantees parent[0] = -1 and parent[k] < k for k > 0 (docs/asset-format.md).
		double origin[3] = { 0.0, 0.0, 0.0 };
		if ( parent >= 0 )
		{
			const double* q = positions + (size_t)parent * 3;
			origin[0] = q[0], origin[1] = q[1], origin[2] = q[2];
		}
		plRestJoint* joint = out_joints + k;
		joint->parent = parent;
		joint->position = ( plVec3 ){ (float)p[0], (float)p[1], (float)p[2] };
		joint->local_translation = ( plVec3 ){ (float)( p[0] - origin[0] ), (float)( p[1] - origin[1] ),
											   (float)( p[2] - origin[2] ) };
		joint->local_rotation = ( plQuat ){ 0.0f, 0.0f, 0.0f, 1.0f };
	}
}

plResult plAsset_GetRestPose( plAsset asset, plRestJoint* out_joints, uint32_t joint_capacity )
{
	if ( out_joints == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const plAssetData* a = plGetAssetData( asset );
	if ( a == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( joint_capacity < a->joint_count )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	// β = 0: J(0) = J_template, widened to double so the translations are formed exactly as the instance's are.
	double positions[PLEAT_MAX_JOINTS * 3];
	for ( uint32_t i = 0; i < a->joint_count * 3; ++i )
	{
		positions[i] = a->joint_template[i];
	}
	plFillRestPose( a->parents, positions, a->joint_count, out_joints );
	return PLEAT_RESULT_OK;
}
