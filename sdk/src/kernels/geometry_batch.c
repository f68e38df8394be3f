// The batched skinning and normals kernels' specification (kernels_batch.h): each instance of the batch gets exactly
// what the single-instance scalar kernel gives it — here by running that kernel per instance. The SIMD twins
// (geometry_batch_avx2.c, geometry_batch_avx512.c) put the instances in vector lanes instead and match the AVX2
// single-instance kernels bit for bit; test_batched_kernels_match_single holds every variant to both.
#include "kernels_batch.h"

void plSkinningBatch_Scalar( float* const* out, const float* const* in, uint32_t batch_count,
							 const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
							 const float* const* skin_matrices, uint32_t joint_count, uint32_t v_begin, uint32_t v_end )
{
	for ( uint32_t b = 0; b < batch_count; ++b )
	{
		plSkinning_Scalar( out[b], 12, in[b], 12, skin_indices, skin_weights, influence_count, NULL, skin_matrices[b],
						   joint_count, v_begin, v_end );
	}
}

void plBodyContactFastBatch_Scalar( float* const* positions, const float* const* shaped_anchors, const float* offsets_m,
								uint32_t batch_count, const float* anchor_normals, const uint16_t* anchor_skin_indices,
								const float* anchor_skin_weights, uint32_t influence_count,
								const float* const* skin_matrices, uint32_t joint_count, uint32_t v_begin,
								uint32_t v_end )
{
	for ( uint32_t b = 0; b < batch_count; ++b )
	{
		plBodyContactFast_Scalar( positions[b], 12, shaped_anchors[b], anchor_normals, anchor_skin_indices,
							  anchor_skin_weights, influence_count, NULL, skin_matrices[b], joint_count, offsets_m[b],
							  v_begin, v_end );
	}
}

void plNormalsBatch_Scalar( float* const* normals, const float* const* positions, uint32_t batch_count,
							uint32_t vertex_count, const uint32_t* faces, uint32_t face_count, float* scratch )
{
	for ( uint32_t b = 0; b < batch_count; ++b )
	{
		plNormalsScatter_Scalar( normals[b], 12, positions[b], 12, vertex_count, faces, face_count, scratch );
	}
}
