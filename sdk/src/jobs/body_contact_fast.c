// The fast body contact (pleat.h PLEAT_BODY_CONTACT_FAST; asset 1.1's only contact): each vertex's anchor is its own
// point, the body vertex nearest to it at rest, posed alone with its rest normal turned by its blended matrix:
//     M_a = Σ_k w_ak M_{j_ak},  a = M_a · (anchor, 1),  n = normalize(M_a[:, :3] · n_rest),  d = (x − a) · n
//     x ← x + max(0, offset − d) · n
// What it costs is one blended matrix per vertex; what it gives up against the full contact (body_contact.c) is the
// posed body's normal and the candidates, so it leaves more of the cloth inside the body near the joints
// (docs/accuracy.md "Body contact"). A scene's LBS-only characters use it. Same loop as the GL path's one-candidate,
// no-ring case and tools/pleat/reference/body_contact.py with one candidate and no rings.
#include "jobs.h"

#include <math.h>

int plBodyContactFastJob_Validate( const plBodyContactFastJob* job )
{
	if ( job == NULL || job->shaped_anchors == NULL || job->anchor_normals == NULL ||
		 job->anchor_skin_indices == NULL || job->anchor_skin_weights == NULL || job->skin_matrices == NULL ||
		 job->influence_count < 1 || job->influence_count > PLEAT_MAX_INFLUENCES || job->joint_count == 0 ||
		 !( job->offset_m >= 0.0f && job->offset_m <= PLEAT_BODY_CONTACT_MAX_OFFSET_M ) )
	{
		return 0;
	}
	uint32_t n = job->positions.count;
	return job->vertex_begin <= job->vertex_end && job->vertex_end <= n && PLEAT_SPAN_HOLDS( job->positions, 12, n );
}

void plBodyContactFast_Scalar( float* positions, uint32_t position_stride_bytes, const float* shaped_anchors,
						   const float* anchor_normals, const uint16_t* anchor_skin_indices,
						   const float* anchor_skin_weights, uint32_t influence_count,
						   const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
						   float offset_m, uint32_t v_begin, uint32_t v_end )
{
	(void)column_offsets;
	uint32_t K = influence_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		const float* rest_normal = anchor_normals + (size_t)v * 3;
		if ( rest_normal[0] == 0.0f && rest_normal[1] == 0.0f && rest_normal[2] == 0.0f )
		{
			continue; // no anchor: the vertex is far from the rest body
		}
		float m[12];
		plBlendJointMatrices( m, anchor_skin_indices + (size_t)v * K, anchor_skin_weights + (size_t)v * K, K,
							  skin_matrices, joint_count );
		const float* r = shaped_anchors + (size_t)v * 3;
		float ax = m[0] * r[0] + m[1] * r[1] + m[2] * r[2] + m[3];
		float ay = m[4] * r[0] + m[5] * r[1] + m[6] * r[2] + m[7];
		float az = m[8] * r[0] + m[9] * r[1] + m[10] * r[2] + m[11];
		float nx = m[0] * rest_normal[0] + m[1] * rest_normal[1] + m[2] * rest_normal[2];
		float ny = m[4] * rest_normal[0] + m[5] * rest_normal[1] + m[6] * rest_normal[2];
		float nz = m[8] * rest_normal[0] + m[9] * rest_normal[1] + m[10] * rest_normal[2];
		float* x = (float*)( (uint8_t*)positions + (size_t)v * position_stride_bytes );
		plPushOutOfAnchorPlane( x, ax, ay, az, nx, ny, nz, offset_m, 1.0f );
	}
}

plResult plBodyContactFastJob_Run( const plBodyContactFastJob* job )
{
	if ( !plBodyContactFastJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plBodyContactFastFn* kernel = job->kernels != NULL && job->kernels->body_contact_fast != NULL ? job->kernels->body_contact_fast
																						  : plBodyContactFast_Scalar;
	kernel( (float*)job->positions.ptr, job->positions.stride_bytes, job->shaped_anchors, job->anchor_normals,
			job->anchor_skin_indices, job->anchor_skin_weights, job->influence_count, job->column_offsets,
			job->skin_matrices, job->joint_count, job->offset_m, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}
