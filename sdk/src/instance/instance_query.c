// What an instance lends and copies out: its posed positions and normals, skin matrices, latent, blend weights,
// shape, asset, user data and rest pose (the plInstance_Get* functions of pleat.h).
#include "instance.h"
#include "asset/skeleton.h"
#include "core/step_phases.h"
#include <math.h>
#include <string.h>

// The two getters that lend the instance's last per-vertex output ([N][3], valid until the next step or destroy):
// which picks positions (0) or normals (1).
static plResult plLendVertexArray( plInstance handle, int which, const float** out_array, uint32_t* out_count,
								   const char* function )
{
	const plInstanceData* inst = plLookupInstance( handle, function );
	plResult r = plCheckArgumentsThenHandle( out_array != NULL, inst );
	if ( r != PLEAT_RESULT_INVALID_ARGUMENT )
	{
		*out_array = inst == NULL ? NULL : ( which == 0 ? inst->positions : inst->normals );
	}
	if ( r == PLEAT_RESULT_OK && out_count != NULL )
	{
		*out_count = inst->asset->vertex_count;
	}
	return r;
}

plResult plInstance_GetPositions( plInstance handle, const float** out_positions, uint32_t* out_count )
{
	return plLendVertexArray( handle, 0, out_positions, out_count, __func__ );
}

plResult plInstance_GetNormals( plInstance handle, const float** out_normals, uint32_t* out_count )
{
	return plLendVertexArray( handle, 1, out_normals, out_count, __func__ );
}

// The getters that copy one of the instance's float arrays out: the caller's capacity must hold all of it.
static plResult plCopyFloatsOut( const float* source, size_t count, float* out, size_t capacity )
{
	if ( out == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( capacity < count )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	memcpy( out, source, count * sizeof( float ) );
	return PLEAT_RESULT_OK;
}

plResult plInstance_GetSkinMatrices( plInstance handle, float* out, uint32_t joint_count )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	// counts are of 3x4 matrices
	return plCopyFloatsOut( inst->skin_matrices, (size_t)inst->asset->joint_count * 12, out, (size_t)joint_count * 12 );
}

plResult plInstance_GetLatent( plInstance handle, float* out, uint32_t latent_count )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	return plCopyFloatsOut( inst->latent, inst->asset->latent_count, out, latent_count );
}

plResult plInstance_GetBlendWeights( plInstance handle, float* out, uint32_t blend_count )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	return plCopyFloatsOut( inst->blend_weights, inst->asset->blend_count, out, blend_count );
}

plResult plInstance_GetShape( plInstance handle, float* out_beta, uint32_t beta_count, float out_material[4] )
{
	const plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r =
		plCheckHandleThenArguments( inst, ( out_beta != NULL || beta_count == 0 ) && beta_count <= PLEAT_MAX_BETAS );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	for ( uint32_t b = 0; b < beta_count; ++b )
	{
		out_beta[b] = b < inst->asset->beta_count ? inst->beta[b] : 0.0f;
	}
	if ( out_material != NULL )
	{
		memcpy( out_material, inst->material, sizeof( inst->material ) );
	}
	return PLEAT_RESULT_OK;
}

plResult plInstance_GetAsset( plInstance handle, plAsset* out_asset )
{
	const plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r = plCheckArgumentsThenHandle( out_asset != NULL, inst );
	if ( r == PLEAT_RESULT_OK )
	{
		*out_asset = inst->asset_handle;
	}
	else if ( r == PLEAT_RESULT_INVALID_HANDLE )
	{
		memset( out_asset, 0, sizeof( *out_asset ) );
	}
	return r;
}

plResult plInstance_GetUserData( plInstance handle, void** out_user_data )
{
	const plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( out_user_data != NULL )
	{
		*out_user_data = inst != NULL ? inst->user_data : NULL;
	}
	return plCheckArgumentsThenHandle( out_user_data != NULL, inst );
}

plResult plInstance_GetRestPose( plInstance handle, plRestJoint* out_joints, uint32_t joint_capacity )
{
	const plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r = plCheckArgumentsThenHandle( out_joints != NULL, inst );
	if ( r == PLEAT_RESULT_OK && joint_capacity < inst->asset->joint_count )
	{
		r = PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	// rest_joints is the J(β) forward kinematics uses (plApplyShape), so a retarget sees exactly those joints.
	plFillRestPose( inst->asset->parents, inst->rest_joints, inst->asset->joint_count, out_joints );
	return PLEAT_RESULT_OK;
}
