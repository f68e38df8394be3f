// The normals jobs: n_v = normalize(Σ_{faces f ∋ v} cross(x_b − x_a, x_c − x_a)), area weighted, as face normals
// then a gather through the asset's CSR adjacency (NADO/NADF) in ascending face order — deterministic for any split
// of the vertex range, no atomics — or, on one thread, as one scatter pass with the same sums (jobs.h names the two
// algorithms and their GLSL and numpy twins). A vertex whose faces all have zero area gets a zero normal (not NaN).
#include "jobs.h"

#include <math.h>
#include <string.h>

// cross(x_b − x_a, x_c − x_a) of the triangle `tri`, whose indices the caller has checked against the vertex count.
static inline void plTriangleCross( const uint8_t* in, uint32_t stride_bytes, const uint32_t* tri, float n[3] )
{
	const float* a = (const float*)( in + (size_t)tri[0] * stride_bytes );
	const float* b = (const float*)( in + (size_t)tri[1] * stride_bytes );
	const float* c = (const float*)( in + (size_t)tri[2] * stride_bytes );
	float e1x = b[0] - a[0], e1y = b[1] - a[1], e1z = b[2] - a[2];
	float e2x = c[0] - a[0], e2y = c[1] - a[1], e2z = c[2] - a[2];
	n[0] = e1y * e2z - e1z * e2y;
	n[1] = e1z * e2x - e1x * e2z;
	n[2] = e1x * e2y - e1y * e2x;
}

// Vertex v's normal: the sum (x, y, z) normalised, or zero when it has zero length (never NaN).
static inline void plStoreUnitNormal( float* out, uint32_t out_stride_bytes, uint32_t v, float x, float y, float z )
{
	float length = sqrtf( x * x + y * y + z * z );
	float scale = length > 0.0f ? 1.0f / length : 0.0f;
	float* o = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
	o[0] = x * scale;
	o[1] = y * scale;
	o[2] = z * scale;
}

int plNormalsGatherJob_Validate( const plNormalsGatherJob* job )
{
	if ( job == NULL || job->face_normals == NULL || job->adjacency_offsets == NULL || job->adjacency_faces == NULL ||
		 job->face_count == 0 )
	{
		return 0;
	}
	uint32_t n = job->normals.count;
	return job->vertex_begin <= job->vertex_end && job->vertex_end <= n && PLEAT_SPAN_HOLDS( job->normals, 12, n );
}

plResult plNormalsGatherJob_Run( const plNormalsGatherJob* job )
{
	if ( !plNormalsGatherJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plNormalsGatherFn* kernel = job->kernels != NULL && job->kernels->normals_gather != NULL
									? job->kernels->normals_gather
									: plNormalsGather_Scalar;
	kernel( (float*)job->normals.ptr, job->normals.stride_bytes, job->face_normals, job->face_count,
			job->adjacency_offsets, job->adjacency_faces, job->vertex_begin, job->vertex_end );
	return PLEAT_RESULT_OK;
}

void plNormalsGather_Scalar( float* normals, uint32_t normals_stride_bytes, const float* face_normals,
							 uint32_t face_count, const uint32_t* adjacency_offsets, const uint32_t* adjacency_faces,
							 uint32_t v_begin, uint32_t v_end )
{
	uint32_t limit = 3u * face_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		float nx = 0.0f, ny = 0.0f, nz = 0.0f;
		uint32_t begin = adjacency_offsets[v], end = adjacency_offsets[v + 1];
		end = end > limit ? limit : end;
		for ( uint32_t e = begin; e < end; ++e )
		{
			uint32_t f = adjacency_faces[e];
			if ( f < face_count )
			{
				nx += face_normals[(size_t)f * 4 + 0];
				ny += face_normals[(size_t)f * 4 + 1];
				nz += face_normals[(size_t)f * 4 + 2];
			}
		}
		plStoreUnitNormal( normals, normals_stride_bytes, v, nx, ny, nz );
	}
}

int plFaceNormalsJob_Validate( const plFaceNormalsJob* job )
{
	return job != NULL && job->faces != NULL && job->face_normals != NULL && job->face_begin <= job->face_end &&
		   job->face_end <= job->face_count && PLEAT_SPAN_HOLDS( job->positions, 12, job->positions.count );
}

plResult plFaceNormalsJob_Run( const plFaceNormalsJob* job )
{
	if ( !plFaceNormalsJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plFaceNormalsFn* kernel = job->kernels != NULL && job->kernels->face_normals != NULL ? job->kernels->face_normals
																						 : plFaceNormals_Scalar;
	kernel( job->face_normals, (const float*)job->positions.ptr, job->positions.stride_bytes, job->positions.count,
			job->faces, job->face_begin, job->face_end );
	return PLEAT_RESULT_OK;
}

void plFaceNormals_Scalar( float* face_normals, const float* positions, uint32_t position_stride_bytes,
						   uint32_t vertex_count, const uint32_t* faces, uint32_t f_begin, uint32_t f_end )
{
	const uint8_t* in = (const uint8_t*)positions;
	uint32_t n = vertex_count;
	for ( uint32_t f = f_begin; f < f_end; ++f )
	{
		const uint32_t* tri = faces + (size_t)f * 3;
		float* out = face_normals + (size_t)f * 4;
		out[3] = 0.0f;
		if ( tri[0] >= n || tri[1] >= n || tri[2] >= n )
		{
			out[0] = out[1] = out[2] = 0.0f;
			continue;
		}
		plTriangleCross( in, position_stride_bytes, tri, out );
	}
}

void plNormalsScatter_Scalar( float* normals, uint32_t normals_stride_bytes, const float* positions,
							  uint32_t position_stride_bytes, uint32_t vertex_count, const uint32_t* faces,
							  uint32_t face_count, float* sums4 )
{
	const uint8_t* in = (const uint8_t*)positions;
	uint32_t n = vertex_count;
	memset( sums4, 0, (size_t)n * 4 * sizeof( float ) );
	for ( uint32_t f = 0; f < face_count; ++f )
	{
		const uint32_t* tri = faces + (size_t)f * 3;
		float normal[3] = { 0.0f, 0.0f, 0.0f };
		if ( tri[0] < n && tri[1] < n && tri[2] < n )
		{
			plTriangleCross( in, position_stride_bytes, tri, normal );
		}
		for ( int k = 0; k < 3; ++k )
		{
			if ( tri[k] < n )
			{
				float* s = sums4 + (size_t)tri[k] * 4;
				s[0] += normal[0];
				s[1] += normal[1];
				s[2] += normal[2];
			}
		}
	}
	for ( uint32_t v = 0; v < n; ++v )
	{
		const float* s = sums4 + (size_t)v * 4;
		plStoreUnitNormal( normals, normals_stride_bytes, v, s[0], s[1], s[2] );
	}
}

int plNormalsScatterJob_Validate( const plNormalsScatterJob* job )
{
	if ( job == NULL || job->faces == NULL || job->sums4 == NULL || ( (uintptr_t)job->sums4 & 15u ) != 0 )
	{
		return 0;
	}
	uint32_t n = job->positions.count;
	return job->sums4_count >= n && PLEAT_SPAN_HOLDS( job->positions, 12, n ) && job->normals.count == n &&
		   PLEAT_SPAN_HOLDS( job->normals, 12, n );
}

plResult plNormalsScatterJob_Run( const plNormalsScatterJob* job )
{
	if ( !plNormalsScatterJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plNormalsScatterFn* kernel = job->kernels != NULL && job->kernels->normals_scatter != NULL
									 ? job->kernels->normals_scatter
									 : plNormalsScatter_Scalar;
	kernel( (float*)job->normals.ptr, job->normals.stride_bytes, (const float*)job->positions.ptr,
			job->positions.stride_bytes, job->positions.count, job->faces, job->face_count, job->sums4 );
	return PLEAT_RESULT_OK;
}
