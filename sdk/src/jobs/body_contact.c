// The body-contact job (pleat.h, BODY CONTACT): after skinning, each vertex closer than offset_m to the posed tangent
// plane of its anchor moves out along the anchor's normal to that distance. The anchor is made from the vertex's
// candidate body points nearest to it in this pose: the cloth slides over the body and the arms come down beside the
// chest, so the body point nearest a garment vertex changes with the pose (asset 1.2; 1.1 has one point per vertex).
//     posing, per point p:  M_p = Σ_k w_pk M_{j_pk},  a_p = M_p · (r_p, 1),
//                           n_p = normalize(Σ_i (a_{r_i} − a_p) × (a_{r_i+1} − a_p)) over p's ring (asset 1.2, BARG)
//                           or, without a ring, normalize(M_p[:, :3] · n_rest)
//     per vertex:           m = min over usable candidates |x − a_c|²,
//                           w_c = max(0, (1 + PLEAT_CONTACT_BLEND_SHARE)·m + PLEAT_CONTACT_BLEND_M² − |x − a_c|²),
//                           a = Σ w_c a_c / Σ w_c,  n = normalize(Σ w_c n_c),  d = (x − a) · n,
//                           x ← x + max(0, offset − d) · n
// Why a blend of the nearest few and not the nearest alone: the nearest jumps from one point to the next as the vertex
// moves, and the push would jump with it (a visible pop, and a choice that two paths rounding differently could make
// differently); the weights are continuous in x, and the narrow margin keeps nearly all that the nearest alone gains
// (docs/accuracy.md "Body contact"). The points are skinned with the body's own weights (not the garment's diffused
// ones), so a is where the body surface is; its normal is the posed body's own (the blended matrix turns the rest
// normal by the joints' rotations only, which near the shoulders, armpits and waist tilts it off the surface, and
// there the candidates could not help: docs/accuracy.md "Body contact"). Same loops as shaders/body_contact.comp and
// tools/pleat/reference/body_contact.py.
#include "jobs.h"

#include <math.h>

int plBodyPointsJob_Validate( const plBodyPointsJob* job )
{
	return job != NULL && job->shaped_points != NULL && job->point_normals != NULL && job->skin_indices != NULL &&
		   job->skin_weights != NULL && job->skin_matrices != NULL && job->posed != NULL && job->influence_count >= 1 &&
		   job->influence_count <= PLEAT_MAX_INFLUENCES && job->joint_count > 0 &&
		   job->point_begin <= job->point_end && job->point_end <= job->point_count &&
		   ( job->rings == NULL || ( job->ring_count >= 1 && job->ring_count <= PLEAT_MAX_POINT_RING ) );
}

int plBodyContactJob_Validate( const plBodyContactJob* job )
{
	if ( job == NULL || job->posed == NULL || job->point_count == 0 ||
		 ( job->candidates == NULL ? job->candidate_count != 1 || job->point_count < job->positions.count
								   : job->candidate_count < 1 || job->candidate_count > PLEAT_MAX_CONTACT_CANDIDATES ) ||
		 !( job->offset_m >= 0.0f && job->offset_m <= PLEAT_BODY_CONTACT_MAX_OFFSET_M ) )
	{
		return 0;
	}
	uint32_t n = job->positions.count;
	return job->vertex_begin <= job->vertex_end && job->vertex_end <= n && PLEAT_SPAN_HOLDS( job->positions, 12, n );
}

void plPoseBodyPoints_Scalar( float* posed, const float* shaped_points, const float* point_normals,
							  const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
							  const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
							  const uint16_t* rings, uint32_t ring_count, uint32_t point_count, uint32_t p_begin,
							  uint32_t p_end )
{
	(void)column_offsets;
	uint32_t K = influence_count;
	for ( uint32_t p = p_begin; p < p_end; ++p )
	{
		float* out = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
		float m[12];
		plBlendJointMatrices( m, skin_indices + (size_t)p * K, skin_weights + (size_t)p * K, K, skin_matrices,
							  joint_count );
		const float* r = shaped_points + (size_t)p * 3;
		const float* rn = point_normals + (size_t)p * 3;
		// Every point's position: a face corner that never anchors still gives its neighbours their normals.
		out[0] = m[0] * r[0] + m[1] * r[1] + m[2] * r[2] + m[3];
		out[1] = m[4] * r[0] + m[5] * r[1] + m[6] * r[2] + m[7];
		out[2] = m[8] * r[0] + m[9] * r[1] + m[10] * r[2] + m[11];
		int anchorable = rn[0] != 0.0f || rn[1] != 0.0f || rn[2] != 0.0f;
		out[3] = anchorable ? 1.0f : 0.0f;
		if ( anchorable && rings != NULL && rings[(size_t)p * ring_count] < point_count )
		{
			out[4] = out[5] = out[6] = out[7] = 0.0f; // the ring normals set them
			continue;
		}
		float nx = m[0] * rn[0] + m[1] * rn[1] + m[2] * rn[2];
		float ny = m[4] * rn[0] + m[5] * rn[1] + m[6] * rn[2];
		float nz = m[8] * rn[0] + m[9] * rn[1] + m[10] * rn[2];
		float length = sqrtf( nx * nx + ny * ny + nz * nz );
		int usable = anchorable && length > 1e-12f; // a degenerate blend: no plane to keep the vertex out of
		out[4] = usable ? nx / length : 0.0f;
		out[5] = usable ? ny / length : 0.0f;
		out[6] = usable ? nz / length : 0.0f;
		out[7] = usable ? 1.0f : 0.0f;
	}
}

size_t plContactRowOffsetsCount( uint32_t vertex_count, uint32_t candidate_count )
{
	return (size_t)( ( vertex_count + 7 ) / 8 ) * candidate_count * 8;
}

void plContactRowOffsets( uint32_t* dst, const uint16_t* candidates, uint32_t candidate_count, uint32_t vertex_count,
						  uint32_t point_count )
{
	uint32_t C = candidate_count;
	for ( uint32_t b = 0; b < ( vertex_count + 7 ) / 8; ++b )
	{
		for ( uint32_t c = 0; c < C; ++c )
		{
			for ( uint32_t i = 0; i < 8; ++i )
			{
				uint32_t v = 8 * b + i;
				uint32_t p = v >= vertex_count ? point_count : candidates != NULL ? candidates[(size_t)v * C + c] : v;
				p = p < point_count ? p : point_count;
				dst[( (size_t)b * C + c ) * 8 + i] = p * PLEAT_POSED_POINT_FLOATS * (uint32_t)sizeof( float );
			}
		}
	}
}

size_t plRingLanesCount( uint32_t point_count, uint32_t ring_count )
{
	return (size_t)( ( point_count + 7 ) / 8 ) * ring_count * 8;
}

void plRingLanes( int32_t* dst, const uint16_t* rings, uint32_t ring_count, uint32_t point_count )
{
	uint32_t R = ring_count;
	for ( uint32_t b = 0; b < ( point_count + 7 ) / 8; ++b )
	{
		for ( uint32_t s = 0; s < R; ++s )
		{
			for ( uint32_t i = 0; i < 8; ++i )
			{
				uint32_t p = 8 * b + i;
				uint32_t q = p < point_count ? rings[(size_t)p * R + s] : point_count;
				dst[( (size_t)b * R + s ) * 8 + i] = q < point_count ? (int32_t)q : INT32_MIN;
			}
		}
	}
}

void plBodyPointNormals_Scalar( float* posed, uint32_t point_count, const uint16_t* rings, uint32_t ring_count,
								const int32_t* ring_lanes, uint32_t p_begin, uint32_t p_end )
{
	(void)ring_lanes;
	uint32_t R = ring_count;
	for ( uint32_t p = p_begin; p < p_end; ++p )
	{
		float* out = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
		const uint16_t* ring = rings + (size_t)p * R;
		if ( out[3] == 0.0f || ring[0] >= point_count )
		{
			continue; // not an anchor, or no ring: the row stands
		}
		// d_i = a_{r_i} − a_p around the fan; n = Σ d_i × d_{i+1}, the last one closing on d_0
		float d[PLEAT_MAX_POINT_RING][3];
		uint32_t m = 0;
		while ( m < R && ring[m] < point_count )
		{
			const float* q = posed + (size_t)ring[m] * PLEAT_POSED_POINT_FLOATS;
			d[m][0] = q[0] - out[0];
			d[m][1] = q[1] - out[1];
			d[m][2] = q[2] - out[2];
			m++;
		}
		float nx = 0.0f, ny = 0.0f, nz = 0.0f;
		for ( uint32_t i = 0; i < m; ++i )
		{
			const float* u = d[i];
			const float* v = d[i + 1 < m ? i + 1 : 0];
			nx += u[1] * v[2] - u[2] * v[1];
			ny += u[2] * v[0] - u[0] * v[2];
			nz += u[0] * v[1] - u[1] * v[0];
		}
		float length = sqrtf( nx * nx + ny * ny + nz * nz );
		int usable = length > 1e-12f;
		out[4] = usable ? nx / length : 0.0f;
		out[5] = usable ? ny / length : 0.0f;
		out[6] = usable ? nz / length : 0.0f;
		out[7] = usable ? 1.0f : 0.0f;
	}
}

void plBodyContact_Scalar( float* positions, uint32_t position_stride_bytes, const float* posed, uint32_t point_count,
						   const uint16_t* candidates, uint32_t candidate_count, const uint32_t* row_offsets,
						   float offset_m, uint32_t v_begin, uint32_t v_end )
{
	(void)row_offsets;
	uint32_t C = candidate_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		float* x = (float*)( (uint8_t*)positions + (size_t)v * position_stride_bytes );
		// The usable candidates and their squared distances, then the nearest.
		const float* rows[PLEAT_MAX_CONTACT_CANDIDATES];
		float d2[PLEAT_MAX_CONTACT_CANDIDATES];
		uint32_t count = 0;
		float nearest = 0.0f;
		for ( uint32_t c = 0; c < C; ++c )
		{
			uint32_t p = candidates != NULL ? candidates[(size_t)v * C + c] : v;
			if ( p >= point_count )
			{
				continue; // an empty slot (PLEAT_NO_CONTACT_CANDIDATE)
			}
			const float* a = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
			if ( a[7] == 0.0f )
			{
				continue; // not usable in this pose
			}
			float dx = x[0] - a[0], dy = x[1] - a[1], dz = x[2] - a[2];
			rows[count] = a;
			d2[count] = dx * dx + dy * dy + dz * dz;
			nearest = count == 0 || d2[count] < nearest ? d2[count] : nearest;
			count++;
		}
		if ( count == 0 )
		{
			continue; // no candidate: the vertex is far from the rest body
		}
		float limit = ( 1.0f + PLEAT_CONTACT_BLEND_SHARE ) * nearest + PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M;
		float total = 0.0f, ax = 0.0f, ay = 0.0f, az = 0.0f, nx = 0.0f, ny = 0.0f, nz = 0.0f;
		for ( uint32_t i = 0; i < count; ++i )
		{
			float w = limit - d2[i];
			if ( w > 0.0f )
			{
				const float* a = rows[i];
				total += w;
				ax += w * a[0];
				ay += w * a[1];
				az += w * a[2];
				nx += w * a[4];
				ny += w * a[5];
				nz += w * a[6];
			}
		}
		float reach = candidates != NULL ? plContactReach( nearest ) : 1.0f; // a 1.1 table: the whole push
		if ( !( total > 0.0f ) || !( reach > 0.0f ) )
		{
			continue; // no weight, or the nearest candidate too far for its plane to say where the body is
		}
		// the blended plane: normals that cancel (a thin body part seen from its edge) leave no direction to push
		// along, and plPushOutOfAnchorPlane leaves the vertex as it is
		plPushOutOfAnchorPlane( x, ax / total, ay / total, az / total, nx, ny, nz, offset_m, reach );
	}
}

plResult plBodyPointsJob_Run( const plBodyPointsJob* job )
{
	if ( !plBodyPointsJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plPoseBodyPointsFn* kernel = job->kernels != NULL && job->kernels->pose_body_points != NULL
									 ? job->kernels->pose_body_points
									 : plPoseBodyPoints_Scalar;
	kernel( job->posed, job->shaped_points, job->point_normals, job->skin_indices, job->skin_weights,
			job->influence_count, job->column_offsets, job->skin_matrices, job->joint_count, job->rings, job->ring_count,
			job->point_count, job->point_begin, job->point_end );
	return PLEAT_RESULT_OK;
}

plResult plBodyPointNormalsJob_Run( const plBodyPointNormalsJob* job )
{
	if ( job == NULL || job->posed == NULL || job->rings == NULL || job->ring_count < 3 ||
		 job->ring_count > PLEAT_MAX_POINT_RING || job->point_begin > job->point_end ||
		 job->point_end > job->point_count )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plBodyPointNormalsFn* kernel = job->kernels != NULL && job->kernels->body_point_normals != NULL
									   ? job->kernels->body_point_normals
									   : plBodyPointNormals_Scalar;
	kernel( job->posed, job->point_count, job->rings, job->ring_count, job->ring_lanes, job->point_begin,
			job->point_end );
	return PLEAT_RESULT_OK;
}

plResult plBodyContactJob_Run( const plBodyContactJob* job )
{
	if ( !plBodyContactJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plBodyContactFn* kernel = job->kernels != NULL && job->kernels->body_contact != NULL ? job->kernels->body_contact
																						  : plBodyContact_Scalar;
	kernel( (float*)job->positions.ptr, job->positions.stride_bytes, job->posed, job->point_count, job->candidates,
			job->candidate_count, job->row_offsets, job->offset_m, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}
