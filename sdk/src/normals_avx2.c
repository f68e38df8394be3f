// AVX2 twin of plFaceNormals_Scalar and plNormalsGather_Scalar, bit-identical to them: a face normal is one 4-wide
// (x, y, z, 0) cross product with separate multiplies and subtractions in the scalar order, and the gather adds one
// 16-byte row per adjacent face (per component the same additions in the same order as the scalar x/y/z sums), then
// normalises with the scalar expression. Contraction into FMA would change the bits, so it is switched off here
// (GCC does not contract in ISO C mode; clang needs the pragma).
#include "kernels.h"

#include <immintrin.h>
#include <math.h>

#if defined( __clang__ )
#pragma STDC FP_CONTRACT OFF
#endif

// (x, y, z, 0) without reading past the vertex's third float (the last vertex may end the buffer).
static inline __m128 plLoadPoint( const uint8_t* base, size_t index, uint32_t stride_bytes )
{
	const float* p = (const float*)( base + index * stride_bytes );
	return _mm_setr_ps( p[0], p[1], p[2], 0.0f );
}

void plFaceNormals_Avx2( float* out4, const float* positions, uint32_t position_stride_bytes, uint32_t vertex_count,
						 const uint32_t* faces, uint32_t f_begin, uint32_t f_end )
{
	const uint8_t* in = (const uint8_t*)positions;
	for ( uint32_t f = f_begin; f < f_end; ++f )
	{
		const uint32_t* tri = faces + (size_t)f * 3;
		if ( tri[0] >= vertex_count || tri[1] >= vertex_count || tri[2] >= vertex_count )
		{
			_mm_storeu_ps( out4 + (size_t)f * 4, _mm_setzero_ps() );
			continue;
		}
		__m128 a = plLoadPoint( in, tri[0], position_stride_bytes );
		__m128 e1 = _mm_sub_ps( plLoadPoint( in, tri[1], position_stride_bytes ), a );
		__m128 e2 = _mm_sub_ps( plLoadPoint( in, tri[2], position_stride_bytes ), a );
		// (e1y e2z − e1z e2y, e1z e2x − e1x e2z, e1x e2y − e1y e2x, 0)
		__m128 e1_yzx = _mm_shuffle_ps( e1, e1, _MM_SHUFFLE( 3, 0, 2, 1 ) );
		__m128 e1_zxy = _mm_shuffle_ps( e1, e1, _MM_SHUFFLE( 3, 1, 0, 2 ) );
		__m128 e2_yzx = _mm_shuffle_ps( e2, e2, _MM_SHUFFLE( 3, 0, 2, 1 ) );
		__m128 e2_zxy = _mm_shuffle_ps( e2, e2, _MM_SHUFFLE( 3, 1, 0, 2 ) );
		__m128 left = _mm_mul_ps( e1_yzx, e2_zxy );
		__m128 right = _mm_mul_ps( e1_zxy, e2_yzx );
		_mm_storeu_ps( out4 + (size_t)f * 4, _mm_sub_ps( left, right ) );
	}
}

void plNormalsGather_Avx2( float* out, uint32_t out_stride_bytes, const float* face_normals4, uint32_t face_count,
						   const uint32_t* adjacency_offsets, const uint32_t* adjacency_faces, uint32_t v_begin,
						   uint32_t v_end )
{
	uint32_t limit = 3u * face_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		__m128 sum = _mm_setzero_ps();
		uint32_t begin = adjacency_offsets[v], end = adjacency_offsets[v + 1];
		end = end > limit ? limit : end;
		for ( uint32_t e = begin; e < end; ++e )
		{
			uint32_t f = adjacency_faces[e];
			if ( f < face_count )
			{
				sum = _mm_add_ps( sum, _mm_loadu_ps( face_normals4 + (size_t)f * 4 ) );
			}
		}
		float n[4];
		_mm_storeu_ps( n, sum );
		float nx = n[0], ny = n[1], nz = n[2];
		float length = sqrtf( nx * nx + ny * ny + nz * nz );
		float scale = length > 0.0f ? 1.0f / length : 0.0f;
		float* o = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
		o[0] = nx * scale;
		o[1] = ny * scale;
		o[2] = nz * scale;
	}
}
