// The skinning job (linear blend skinning): x'_v = (Σ_k w_vk M_{j_vk}) · (x_v, 1), M = [J][3][4] row-major rest → output
// space, the same matrices the GL path (skinning.comp) takes. Strided spans so interleaved vertex buffers work.
#include "jobs.h"

int plSkinningJob_Validate( const plSkinningJob* job )
{
	if ( job == NULL || job->skin_indices == NULL || job->skin_weights == NULL || job->skin_matrices == NULL ||
		 job->influence_count < 1 || job->influence_count > PLEAT_MAX_INFLUENCES || job->joint_count == 0 )
	{
		return 0;
	}
	uint32_t n = job->positions.count;
	return job->vertex_begin <= job->vertex_end && job->vertex_end <= n && PLEAT_SPAN_HOLDS( job->positions, 12, n ) &&
		   PLEAT_SPAN_HOLDS( job->output, 12, n ) && job->positions.ptr != job->output.ptr;
}

void plSkinColumnOffsets( uint32_t* dst, const uint16_t* indices, size_t count, uint32_t joint_count )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	for ( size_t e = 0; e < count; ++e )
	{
		dst[e] = ( indices[e] < J ? indices[e] : J ) * 16u * (uint32_t)sizeof( float );
	}
}

void plSkinning_Scalar( float* out, uint32_t out_stride_bytes, const float* in, uint32_t in_stride_bytes,
						const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
						const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
						uint32_t v_begin, uint32_t v_end )
{
	(void)column_offsets;
	uint32_t K = influence_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		float m[12];
		plBlendJointMatrices( m, skin_indices + (size_t)v * K, skin_weights + (size_t)v * K, K, skin_matrices,
							  joint_count );
		const float* p = (const float*)( (const uint8_t*)in + (size_t)v * in_stride_bytes );
		float* q = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
		float x = p[0], y = p[1], z = p[2];
		q[0] = m[0] * x + m[1] * y + m[2] * z + m[3];
		q[1] = m[4] * x + m[5] * y + m[6] * z + m[7];
		q[2] = m[8] * x + m[9] * y + m[10] * z + m[11];
	}
}

plResult plSkinningJob_Run( const plSkinningJob* job )
{
	if ( !plSkinningJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plSkinningFn* kernel = job->kernels != NULL && job->kernels->skinning != NULL ? job->kernels->skinning
																				  : plSkinning_Scalar;
	kernel( (float*)job->output.ptr, job->output.stride_bytes, (const float*)job->positions.ptr,
			job->positions.stride_bytes, job->skin_indices, job->skin_weights, job->influence_count,
			job->column_offsets, job->skin_matrices, job->joint_count, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}
