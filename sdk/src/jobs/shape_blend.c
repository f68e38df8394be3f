// The shape blend jobs: the shaped template T + G_S(β) = T + Σ_b β_b G_S[b] and the rest joints
// J(β) = J_template + Σ_b β_b J_shapedirs[b] (docs/inputs.md). Both run once per β and are cached by the instance, so
// they accumulate in double, in b order, for a result that does not depend on how the sum is split.
#include "jobs.h"

// out[i] = base[i] + Σ_b beta[b] · dirs[b][i] for i < count, in double; exactly one of out_f32 / out_f64 is set.
static void plShapeSum( const float* base, const float* dirs, const float* beta, uint32_t beta_count, size_t count,
						float* out_f32, double* out_f64 )
{
	for ( size_t i = 0; i < count; ++i )
	{
		double v = base[i];
		for ( uint32_t b = 0; b < beta_count; ++b )
		{
			v += (double)beta[b] * dirs[b * count + i];
		}
		if ( out_f32 != NULL )
		{
			out_f32[i] = (float)v;
		}
		else
		{
			out_f64[i] = v;
		}
	}
}

int plShapeBlendJob_Validate( const plShapeBlendJob* job )
{
	if ( job == NULL || ( job->shape_blend_shapes == NULL && job->beta.count > 0 ) || job->beta.stride_bytes != 4 ||
		 !PLEAT_SPAN_HOLDS( job->beta, 4, job->beta.count ) )
	{
		return 0;
	}
	uint32_t n = job->template_positions.count;
	return n > 0 && job->output.count == n && job->template_positions.stride_bytes == 12 &&
		   job->output.stride_bytes == 12 && PLEAT_SPAN_HOLDS( job->template_positions, 12, n ) &&
		   PLEAT_SPAN_HOLDS( job->output, 12, n );
}

plResult plShapeBlendJob_Run( const plShapeBlendJob* job )
{
	if ( !plShapeBlendJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plShapeSum( (const float*)job->template_positions.ptr, job->shape_blend_shapes, (const float*)job->beta.ptr,
				job->beta.count, (size_t)job->template_positions.count * 3, (float*)job->output.ptr, NULL );
	return PLEAT_RESULT_OK;
}

int plShapedJointsJob_Validate( const plShapedJointsJob* job )
{
	return job != NULL && job->joint_template != NULL && job->output != NULL && job->joint_count > 0 &&
		   job->joint_count <= PLEAT_MAX_JOINTS && ( job->joint_shapedirs != NULL || job->beta.count == 0 ) &&
		   job->beta.stride_bytes == 4 && PLEAT_SPAN_HOLDS( job->beta, 4, job->beta.count );
}

plResult plShapedJointsJob_Run( const plShapedJointsJob* job )
{
	if ( !plShapedJointsJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plShapeSum( job->joint_template, job->joint_shapedirs, (const float*)job->beta.ptr, job->beta.count,
				(size_t)job->joint_count * 3, NULL, job->output );
	return PLEAT_RESULT_OK;
}
