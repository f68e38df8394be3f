// AVX2 twin of plFaceNormals_Scalar and plNormalsGather_Scalar, bit-identical to them: a face normal is one 4-wide
// (x, y, z, 0) cross product with separate multiplies and subtractions in the scalar order, and the gather adds one
// 16-byte row per adjacent face (per component the same additions in the same order as the scalar x/y/z sums), then
// normalises with the scalar expression — eight vertices at a time (one 8-wide sqrt and divide instead of eight scalar
// ones). A vertex other than the last is loaded with one 16-byte load (its fourth float, the next vertex's x or
// padding, only reaches lane 3, which is masked to 0); packed (12-byte stride) output is stored 16 bytes at a time
// when the next vertex is in the same range (its first float is rewritten right after). Contraction into FMA would
// change the bits, so it is switched off here (GCC does not contract in ISO C mode; clang needs the pragma).
#include "kernels/kernels.h"

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

// Face normal of `tri` as (x, y, z, 0); zero when an index is out of range. Indices below `last` (= vertex_count − 1)
// are loaded 16 bytes wide, the last vertex without reading past its third float.
static inline __m128 plFaceNormal( const uint8_t* in, uint32_t stride_bytes, uint32_t vertex_count, uint32_t last,
								   const uint32_t* tri, __m128 xyz_mask )
{
	uint32_t i0 = tri[0], i1 = tri[1], i2 = tri[2];
	uint32_t top = i0 > i1 ? i0 : i1;
	top = top > i2 ? top : i2;
	if ( top < last )
	{
		return plCross( _mm_loadu_ps( (const float*)( in + (size_t)i0 * stride_bytes ) ),
						_mm_loadu_ps( (const float*)( in + (size_t)i1 * stride_bytes ) ),
						_mm_loadu_ps( (const float*)( in + (size_t)i2 * stride_bytes ) ), xyz_mask );
	}
	if ( top < vertex_count )
	{
		return plCross( plLoadPointSafe( in, i0, stride_bytes ), plLoadPointSafe( in, i1, stride_bytes ),
						plLoadPointSafe( in, i2, stride_bytes ), xyz_mask );
	}
	return _mm_setzero_ps();
}

void plFaceNormals_Avx2( float* face_normals, const float* positions, uint32_t position_stride_bytes,
						 uint32_t vertex_count, const uint32_t* faces, uint32_t f_begin, uint32_t f_end )
{
	const uint8_t* in = (const uint8_t*)positions;
	const __m128 xyz_mask = _mm_castsi128_ps( _mm_setr_epi32( -1, -1, -1, 0 ) );
	uint32_t last = vertex_count > 0 ? vertex_count - 1 : 0;
	for ( uint32_t f = f_begin; f < f_end; ++f )
	{
		_mm_storeu_ps( face_normals + (size_t)f * 4, plFaceNormal( in, position_stride_bytes, vertex_count, last,
														   faces + (size_t)f * 3, xyz_mask ) );
	}
}

// Σ of the vertex's adjacent face normals, (x, y, z, 0), in ascending adjacency order.
static inline __m128 plGatherSum( const float* face_normals, uint32_t face_count, const uint32_t* adjacency_offsets,
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
			sum = _mm_add_ps( sum, _mm_loadu_ps( face_normals + (size_t)f * 4 ) );
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

// Vertices v .. v+7 from their sums s[0..7]: length = sqrt((x·x + y·y) + z·z) and the scale as in the scalar kernel,
// one 8-wide sqrt and divide; `v_end` bounds the 16-byte stores of packed output.
static inline void plStoreUnitNormals8( float* out, uint32_t out_stride_bytes, const __m128 s[8], uint32_t v,
										uint32_t v_end )
{
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
	int packed = out_stride_bytes == 12;
	for ( int i = 0; i < 8; ++i )
	{
		uint32_t u = v + (uint32_t)i;
		float* o = (float*)( (uint8_t*)out + (size_t)u * out_stride_bytes );
		plStoreNormal( o, _mm_mul_ps( s[i], _mm_set1_ps( scales[i] ) ), packed && u + 1 < v_end );
	}
}

// One vertex from its sum (x, y, z, ·), the scalar kernel's expression.
static inline void plStoreUnitNormal1( float* out, uint32_t out_stride_bytes, uint32_t v, __m128 sum )
{
	float n[4];
	_mm_storeu_ps( n, sum );
	float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
	float scale = length > 0.0f ? 1.0f / length : 0.0f;
	float* o = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
	o[0] = n[0] * scale;
	o[1] = n[1] * scale;
	o[2] = n[2] * scale;
}

void plNormalsGather_Avx2( float* normals, uint32_t normals_stride_bytes, const float* face_normals,
						   uint32_t face_count, const uint32_t* adjacency_offsets, const uint32_t* adjacency_faces,
						   uint32_t v_begin, uint32_t v_end )
{
	uint32_t limit = 3u * face_count;
	uint32_t v = v_begin;
	for ( ; v + 8 <= v_end; v += 8 )
	{
		__m128 s[8];
		for ( int i = 0; i < 8; ++i )
		{
			s[i] = plGatherSum( face_normals, face_count, adjacency_offsets, adjacency_faces, limit, v + (uint32_t)i );
		}
		plStoreUnitNormals8( normals, normals_stride_bytes, s, v, v_end );
	}
	for ( ; v < v_end; ++v )
	{
		plStoreUnitNormal1( normals, normals_stride_bytes, v,
							plGatherSum( face_normals, face_count, adjacency_offsets, adjacency_faces, limit, v ) );
	}
}

void plNormalsScatter_Avx2( float* normals, uint32_t normals_stride_bytes, const float* positions,
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
		// zero for a face with an index out of range, added to its in-range vertices as the scalar kernel does
		const uint32_t* tri = faces + (size_t)f * 3;
		__m128 normal = plFaceNormal( in, position_stride_bytes, n, last, tri, xyz_mask );
		for ( int k = 0; k < 3; ++k )
		{
			if ( tri[k] < n )
			{
				float* sum = sums4 + (size_t)tri[k] * 4;
				_mm_store_ps( sum, _mm_add_ps( _mm_load_ps( sum ), normal ) );
			}
		}
	}
	uint32_t v = 0;
	for ( ; v + 8 <= n; v += 8 )
	{
		__m128 s[8];
		for ( int i = 0; i < 8; ++i )
		{
			s[i] = _mm_load_ps( sums4 + (size_t)( v + (uint32_t)i ) * 4 );
		}
		plStoreUnitNormals8( normals, normals_stride_bytes, s, v, n );
	}
	for ( ; v < n; ++v )
	{
		plStoreUnitNormal1( normals, normals_stride_bytes, v, _mm_load_ps( sums4 + (size_t)v * 4 ) );
	}
}
