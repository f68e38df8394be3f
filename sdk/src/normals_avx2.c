// AVX2 twin of plFaceNormals_Scalar and plNormalsGather_Scalar, bit-identical to them: a face normal is one 4-wide
// (x, y, z, 0) cross product with separate multiplies and subtractions in the scalar order, and the gather adds one
// 16-byte row per adjacent face (per component the same additions in the same order as the scalar x/y/z sums), then
// normalises with the scalar expression — eight vertices at a time (one 8-wide sqrt and divide instead of eight scalar
// ones). A vertex other than the last is loaded with one 16-byte load (its fourth float, the next vertex's x or
// padding, only reaches lane 3, which is masked to 0); packed (12-byte stride) output is stored 16 bytes at a time
// when the next vertex is in the same range (its first float is rewritten right after). Contraction into FMA would
// change the bits, so it is switched off here (GCC does not contract in ISO C mode; clang needs the pragma).
#include "kernels.h"

#include <immintrin.h>
#include <math.h>

#if defined( __clang__ )
#pragma STDC FP_CONTRACT OFF
#endif

// (x, y, z, 0) without reading past the vertex's third float (the last vertex may end the buffer).
static inline __m128 plLoadPointSafe( const uint8_t* base, size_t index, uint32_t stride_bytes )
{
	const float* p = (const float*)( base + index * stride_bytes );
	return _mm_setr_ps( p[0], p[1], p[2], 0.0f );
}

// (e1y e2z − e1z e2y, e1z e2x − e1x e2z, e1x e2y − e1y e2x, 0), lane 3 forced to 0.
static inline __m128 plCross( __m128 a, __m128 b, __m128 c, __m128 xyz_mask )
{
	__m128 e1 = _mm_sub_ps( b, a );
	__m128 e2 = _mm_sub_ps( c, a );
	__m128 e1_yzx = _mm_shuffle_ps( e1, e1, _MM_SHUFFLE( 3, 0, 2, 1 ) );
	__m128 e1_zxy = _mm_shuffle_ps( e1, e1, _MM_SHUFFLE( 3, 1, 0, 2 ) );
	__m128 e2_yzx = _mm_shuffle_ps( e2, e2, _MM_SHUFFLE( 3, 0, 2, 1 ) );
	__m128 e2_zxy = _mm_shuffle_ps( e2, e2, _MM_SHUFFLE( 3, 1, 0, 2 ) );
	return _mm_and_ps( _mm_sub_ps( _mm_mul_ps( e1_yzx, e2_zxy ), _mm_mul_ps( e1_zxy, e2_yzx ) ), xyz_mask );
}

void plFaceNormals_Avx2( float* out4, const float* positions, uint32_t position_stride_bytes, uint32_t vertex_count,
						 const uint32_t* faces, uint32_t f_begin, uint32_t f_end )
{
	const uint8_t* in = (const uint8_t*)positions;
	const __m128 xyz_mask = _mm_castsi128_ps( _mm_setr_epi32( -1, -1, -1, 0 ) );
	uint32_t last = vertex_count > 0 ? vertex_count - 1 : 0; // indices below it may be loaded 16 bytes wide
	for ( uint32_t f = f_begin; f < f_end; ++f )
	{
		const uint32_t* tri = faces + (size_t)f * 3;
		uint32_t i0 = tri[0], i1 = tri[1], i2 = tri[2];
		uint32_t top = i0 > i1 ? i0 : i1;
		top = top > i2 ? top : i2;
		__m128 normal;
		if ( top < last )
		{
			normal = plCross( _mm_loadu_ps( (const float*)( in + (size_t)i0 * position_stride_bytes ) ),
							  _mm_loadu_ps( (const float*)( in + (size_t)i1 * position_stride_bytes ) ),
							  _mm_loadu_ps( (const float*)( in + (size_t)i2 * position_stride_bytes ) ), xyz_mask );
		}
		else if ( top < vertex_count )
		{
			normal = plCross( plLoadPointSafe( in, i0, position_stride_bytes ),
							  plLoadPointSafe( in, i1, position_stride_bytes ),
							  plLoadPointSafe( in, i2, position_stride_bytes ), xyz_mask );
		}
		else
		{
			normal = _mm_setzero_ps();
		}
		_mm_storeu_ps( out4 + (size_t)f * 4, normal );
	}
}

// Σ of the vertex's adjacent face normals, (x, y, z, 0), in ascending adjacency order.
static inline __m128 plGatherSum( const float* face_normals4, uint32_t face_count, const uint32_t* adjacency_offsets,
								  const uint32_t* adjacency_faces, uint32_t limit, uint32_t v )
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
	return sum;
}

static inline void plStoreNormal( float* o, __m128 n, int store16 )
{
	if ( store16 )
	{
		_mm_storeu_ps( o, n );
	}
	else
	{
		_mm_storel_pi( (__m64*)o, n );
		_mm_store_ss( o + 2, _mm_movehl_ps( n, n ) );
	}
}

void plNormalsGather_Avx2( float* out, uint32_t out_stride_bytes, const float* face_normals4, uint32_t face_count,
						   const uint32_t* adjacency_offsets, const uint32_t* adjacency_faces, uint32_t v_begin,
						   uint32_t v_end )
{
	uint32_t limit = 3u * face_count;
	int packed = out_stride_bytes == 12;
	uint32_t v = v_begin;
	for ( ; v + 8 <= v_end; v += 8 )
	{
		__m128 s[8];
		for ( int i = 0; i < 8; ++i )
		{
			s[i] = plGatherSum( face_normals4, face_count, adjacency_offsets, adjacency_faces, limit, v + (uint32_t)i );
		}
		// Transpose to x, y, z of eight vertices; length = sqrt((x·x + y·y) + z·z) and the scale as in the scalar kernel.
		__m128 a0 = s[0], a1 = s[1], a2 = s[2], a3 = s[3], b0 = s[4], b1 = s[5], b2 = s[6], b3 = s[7];
		_MM_TRANSPOSE4_PS( a0, a1, a2, a3 );
		_MM_TRANSPOSE4_PS( b0, b1, b2, b3 );
		__m256 x = _mm256_set_m128( b0, a0 ), y = _mm256_set_m128( b1, a1 ), z = _mm256_set_m128( b2, a2 );
		__m256 length2 = _mm256_add_ps( _mm256_add_ps( _mm256_mul_ps( x, x ), _mm256_mul_ps( y, y ) ), _mm256_mul_ps( z, z ) );
		__m256 length = _mm256_sqrt_ps( length2 );
		__m256 scale = _mm256_and_ps( _mm256_div_ps( _mm256_set1_ps( 1.0f ), length ),
									  _mm256_cmp_ps( length, _mm256_setzero_ps(), _CMP_GT_OQ ) );
		float scales[8];
		_mm256_storeu_ps( scales, scale );
		for ( int i = 0; i < 8; ++i )
		{
			uint32_t u = v + (uint32_t)i;
			float* o = (float*)( (uint8_t*)out + (size_t)u * out_stride_bytes );
			plStoreNormal( o, _mm_mul_ps( s[i], _mm_set1_ps( scales[i] ) ), packed && u + 1 < v_end );
		}
	}
	for ( ; v < v_end; ++v )
	{
		__m128 sum = plGatherSum( face_normals4, face_count, adjacency_offsets, adjacency_faces, limit, v );
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

void plNormalsScatter_Avx2( float* out, uint32_t out_stride_bytes, const float* positions,
							uint32_t position_stride_bytes, uint32_t vertex_count, const uint32_t* faces,
							uint32_t face_count, float* sums4 )
{
	const uint8_t* in = (const uint8_t*)positions;
	const __m128 xyz_mask = _mm_castsi128_ps( _mm_setr_epi32( -1, -1, -1, 0 ) );
	uint32_t n = vertex_count;
	uint32_t last = n > 0 ? n - 1 : 0;
	for ( uint32_t v = 0; v < n; ++v )
	{
		_mm_store_ps( sums4 + (size_t)v * 4, _mm_setzero_ps() );
	}
	for ( uint32_t f = 0; f < face_count; ++f )
	{
		const uint32_t* tri = faces + (size_t)f * 3;
		uint32_t i0 = tri[0], i1 = tri[1], i2 = tri[2];
		uint32_t top = i0 > i1 ? i0 : i1;
		top = top > i2 ? top : i2;
		__m128 normal;
		if ( top < last )
		{
			normal = plCross( _mm_loadu_ps( (const float*)( in + (size_t)i0 * position_stride_bytes ) ),
							  _mm_loadu_ps( (const float*)( in + (size_t)i1 * position_stride_bytes ) ),
							  _mm_loadu_ps( (const float*)( in + (size_t)i2 * position_stride_bytes ) ), xyz_mask );
		}
		else if ( top < n )
		{
			normal = plCross( plLoadPointSafe( in, i0, position_stride_bytes ),
							  plLoadPointSafe( in, i1, position_stride_bytes ),
							  plLoadPointSafe( in, i2, position_stride_bytes ), xyz_mask );
		}
		else
		{
			normal = _mm_setzero_ps(); // the scalar kernel adds (0, 0, 0) to the in-range vertices
			if ( i0 < n )
				_mm_store_ps( sums4 + (size_t)i0 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i0 * 4 ), normal ) );
			if ( i1 < n )
				_mm_store_ps( sums4 + (size_t)i1 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i1 * 4 ), normal ) );
			if ( i2 < n )
				_mm_store_ps( sums4 + (size_t)i2 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i2 * 4 ), normal ) );
			continue;
		}
		_mm_store_ps( sums4 + (size_t)i0 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i0 * 4 ), normal ) );
		_mm_store_ps( sums4 + (size_t)i1 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i1 * 4 ), normal ) );
		_mm_store_ps( sums4 + (size_t)i2 * 4, _mm_add_ps( _mm_load_ps( sums4 + (size_t)i2 * 4 ), normal ) );
	}
	int packed = out_stride_bytes == 12;
	uint32_t v = 0;
	for ( ; v + 8 <= n; v += 8 )
	{
		__m128 s[8];
		for ( int i = 0; i < 8; ++i )
		{
			s[i] = _mm_load_ps( sums4 + (size_t)( v + (uint32_t)i ) * 4 );
		}
		__m128 a0 = s[0], a1 = s[1], a2 = s[2], a3 = s[3], b0 = s[4], b1 = s[5], b2 = s[6], b3 = s[7];
		_MM_TRANSPOSE4_PS( a0, a1, a2, a3 );
		_MM_TRANSPOSE4_PS( b0, b1, b2, b3 );
		__m256 x = _mm256_set_m128( b0, a0 ), y = _mm256_set_m128( b1, a1 ), z = _mm256_set_m128( b2, a2 );
		__m256 length2 = _mm256_add_ps( _mm256_add_ps( _mm256_mul_ps( x, x ), _mm256_mul_ps( y, y ) ), _mm256_mul_ps( z, z ) );
		__m256 length = _mm256_sqrt_ps( length2 );
		__m256 scale = _mm256_and_ps( _mm256_div_ps( _mm256_set1_ps( 1.0f ), length ),
									  _mm256_cmp_ps( length, _mm256_setzero_ps(), _CMP_GT_OQ ) );
		float scales[8];
		_mm256_storeu_ps( scales, scale );
		for ( int i = 0; i < 8; ++i )
		{
			uint32_t u = v + (uint32_t)i;
			float* o = (float*)( (uint8_t*)out + (size_t)u * out_stride_bytes );
			plStoreNormal( o, _mm_mul_ps( s[i], _mm_set1_ps( scales[i] ) ), packed && u + 1 < n );
		}
	}
	for ( ; v < n; ++v )
	{
		const float* s = sums4 + (size_t)v * 4;
		float nx = s[0], ny = s[1], nz = s[2];
		float length = sqrtf( nx * nx + ny * ny + nz * nz );
		float scale = length > 0.0f ? 1.0f / length : 0.0f;
		float* o = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
		o[0] = nx * scale;
		o[1] = ny * scale;
		o[2] = nz * scale;
	}
}
