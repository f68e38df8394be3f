// The blend shape job: T_def[v] = (T + G_S(β))[v] + Σ_j w_j D_j[v] (paper eq. for the displacement), over a vertex
// range so the host's workers can split it. plBlendShapes_Scalar is the specification.
#include "jobs.h"

void plBlendShapes_Scalar( float* out, const float* base, const plBlendShapes* shapes, const float* weights,
						   uint32_t blend_count, uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	size_t plane = (size_t)vertex_count * 3;
	for ( size_t i = (size_t)v_begin * 3; i < (size_t)v_end * 3; ++i )
	{
		float sum = base[i];
		for ( uint32_t j = 0; j < blend_count; ++j )
		{
			sum += weights[j] * plShapeElement( shapes, j * plane + i );
		}
		out[i] = sum;
	}
}

int plBlendShapesJob_Validate( const plBlendShapesJob* job )
{
	if ( job == NULL || job->blend_shapes.data == NULL || job->kernels == NULL || job->kernels->blend_shapes == NULL ||
		 job->blend_shapes.type < PLEAT_SHAPES_F32 || job->blend_shapes.type > PLEAT_SHAPES_I8 )
	{
		return 0;
	}
	uint32_t n = job->shaped_template.count;
	return job->vertex_begin <= job->vertex_end && job->vertex_end <= n && job->shaped_template.stride_bytes == 12 &&
		   PLEAT_SPAN_HOLDS( job->shaped_template, 12, n ) && PLEAT_SPAN_HOLDS( job->output, 12, n ) &&
		   job->output.stride_bytes == 12 && job->weights.count > 0 && job->weights.stride_bytes == 4 &&
		   PLEAT_SPAN_HOLDS( job->weights, 4, job->weights.count );
}

plResult plBlendShapesJob_Run( const plBlendShapesJob* job )
{
	if ( !plBlendShapesJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	job->kernels->blend_shapes( (float*)job->output.ptr, (const float*)job->shaped_template.ptr, &job->blend_shapes,
								(const float*)job->weights.ptr, job->weights.count,
								job->shaped_template.count, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}
