// The batched blend-shape job: T_def = (T + G_S(β)) + Σ_j w_j D_j for many instances of one asset over a vertex range,
// the blend shapes read once for the whole batch. plBlendShapesBatch_Scalar is the specification: per element exactly
// plBlendShapes_Scalar's sum (the base, then += w_j · D_j in ascending j, product and sum rounded separately).
#include "jobs_batch.h"

// Elements per tile: the tile's slice of every blend shape (D · 256 · 4 bytes, 128 KB at D = 128) stays in L2 while
// each instance of the batch runs its sums over it.
#define PLEAT_BLEND_BATCH_TILE 256

void plBlendShapesBatch_Scalar( float* const* out, const float* const* base, const float* const* weights,
								uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
								uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	size_t plane = (size_t)vertex_count * 3;
	size_t start = (size_t)v_begin * 3, end = (size_t)v_end * 3;
	for ( size_t t0 = start; t0 < end; t0 += PLEAT_BLEND_BATCH_TILE )
	{
		size_t t1 = t0 + PLEAT_BLEND_BATCH_TILE < end ? t0 + PLEAT_BLEND_BATCH_TILE : end;
		for ( uint32_t b = 0; b < batch_count; ++b )
		{
			float* o = out[b];
			const float* w = weights[b];
			for ( size_t i = t0; i < t1; ++i )
			{
				o[i] = base[b][i];
			}
			// The running sum lives in out (a float, as the single kernel's sum): storing it rounds nothing.
			for ( uint32_t j = 0; j < blend_count; ++j )
			{
				for ( size_t i = t0; i < t1; ++i )
				{
					o[i] += w[j] * plShapeElement( shapes, j * plane + i );
				}
			}
		}
	}
}

int plBlendShapesBatchJob_Validate( const plBlendShapesBatchJob* job )
{
	if ( job == NULL || job->blend_shapes.data == NULL || job->kernels == NULL ||
		 job->kernels->blend_shapes_batch == NULL ||
		 job->blend_shapes.type < PLEAT_SHAPES_F32 || job->blend_shapes.type > PLEAT_SHAPES_I8 ||
		 job->batch_count == 0 || job->batch_count > PLEAT_BATCH_MAX || job->shaped_templates == NULL ||
		 job->weights == NULL || job->outputs == NULL )
	{
		return 0;
	}
	uint32_t n = job->vertex_count, d = job->weights[0].count;
	if ( !( job->vertex_begin <= job->vertex_end && job->vertex_end <= n ) || d == 0 )
	{
		return 0;
	}
	for ( uint32_t b = 0; b < job->batch_count; ++b )
	{
		if ( job->shaped_templates[b].stride_bytes != 12 || !PLEAT_SPAN_HOLDS( job->shaped_templates[b], 12, n ) ||
			 job->outputs[b].stride_bytes != 12 || !PLEAT_SPAN_HOLDS( job->outputs[b], 12, n ) ||
			 job->weights[b].count != d || job->weights[b].stride_bytes != 4 ||
			 !PLEAT_SPAN_HOLDS( job->weights[b], 4, d ) || job->outputs[b].ptr == job->shaped_templates[b].ptr )
		{
			return 0;
		}
	}
	return 1;
}

plResult plBlendShapesBatchJob_Run( const plBlendShapesBatchJob* job )
{
	if ( !plBlendShapesBatchJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	float* out[PLEAT_BATCH_MAX];
	const float* base[PLEAT_BATCH_MAX];
	const float* weights[PLEAT_BATCH_MAX];
	for ( uint32_t b = 0; b < job->batch_count; ++b )
	{
		out[b] = (float*)job->outputs[b].ptr;
		base[b] = (const float*)job->shaped_templates[b].ptr;
		weights[b] = (const float*)job->weights[b].ptr;
	}
	job->kernels->blend_shapes_batch( out, base, weights, job->batch_count, &job->blend_shapes, job->weights[0].count,
									  job->vertex_count, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}
