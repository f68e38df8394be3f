// Internal: the AVX2 + FMA (+ F16C) helpers that the single-instance kernels and their batched twins share
// (mlp_avx2.c / mlp_batch_avx2.c, blend_shapes_avx2.c / blend_shapes_batch_avx2.c, skinning_avx2.c /
// body_contact_avx2.c / geometry_batch_avx2.c). One definition each, so a batched
// kernel performs its single-instance twin's per-element arithmetic by construction (kernels_batch.h). Include only
// from sources compiled with -mavx2 -mfma -mf16c.
#ifndef PLEAT_SIMD_AVX2_H
#define PLEAT_SIMD_AVX2_H
#include "kernels/kernels.h"
#include "pleat/pleat.h" // PLEAT_MAX_INFLUENCES

#include <immintrin.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

// Eight consecutive elements from index of an fp32 or fp16 (F16C-converted) array.
static inline __m256 plLoad8( const void* p, int fp16, size_t index )
{
	if ( fp16 )
	{
		return _mm256_cvtph_ps( _mm_loadu_si128( (const __m128i*)( (const uint16_t*)p + index ) ) );
	}
	return _mm256_loadu_ps( (const float*)p + index );
}

// One element of an fp32 or fp16 array (the scalar tail of the 8-wide loops; F16C's conversion, exact like
// plHalfToFloat, one instruction instead of a call: the t-shirt's first layers end on one such column a row).
static inline float plLoad1( const void* p, int fp16, size_t index )
{
	return fp16 ? _cvtsh_ss( ( (const uint16_t*)p )[index] ) : ( (const float*)p )[index];
}

// Eight consecutive elements of blend shapes from index, as plShapeElement reads them (int8: widened and converted,
// exact; the shape's scale is in the weight).
static inline __m256 plLoadShape8( const plBlendShapes* shapes, size_t index )
{
	if ( shapes->type == PLEAT_SHAPES_I8 )
	{
		__m128i q = _mm_loadl_epi64( (const __m128i*)( (const int8_t*)shapes->data + index ) );
		return _mm256_cvtepi32_ps( _mm256_cvtepi8_epi32( q ) );
	}
	return plLoad8( shapes->data, shapes->type == PLEAT_SHAPES_F16, index );
}

// One element (the scalar tails).
static inline float plLoadShape1( const plBlendShapes* shapes, size_t index )
{
	if ( shapes->type == PLEAT_SHAPES_I8 )
	{
		return (float)( (const int8_t*)shapes->data )[index];
	}
	return plLoad1( shapes->data, shapes->type == PLEAT_SHAPES_F16, index );
}

// The sum of the eight lanes: halves added, then pairs, then the last two (one fixed order).
static inline float plHorizontalSum( __m256 v )
{
	__m128 s = _mm_add_ps( _mm256_castps256_ps128( v ), _mm256_extractf128_ps( v, 1 ) );
	s = _mm_add_ps( s, _mm_movehl_ps( s, s ) );
	s = _mm_add_ss( s, _mm_movehdup_ps( s ) );
	return _mm_cvtss_f32( s );
}

// The per-row arithmetic of plMatVec_Avx2 (one row, one input vector): two 8-wide accumulators over 16-element steps,
// then an 8-wide tail step into the first, their sum, the horizontal sum, a scalar fmaf tail. The blocked and batched
// kernels compute exactly this for each of their rows.
static inline float plDotRow2( const float* x, const void* weight, int weight_fp16, size_t base, uint32_t in_count )
{
	__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		a0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), a0 );
		a1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base + c + 8 ), _mm256_loadu_ps( x + c + 8 ), a1 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		a0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), a0 );
	}
	float sum = plHorizontalSum( _mm256_add_ps( a0, a1 ) );
	for ( ; c < in_count; ++c )
	{
		sum = fmaf( plLoad1( weight, weight_fp16, base + c ), x[c], sum );
	}
	return sum;
}

// The skinning matrices as columns, two registers per joint: (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0),
// joints at 16-float strides, plus an all-zero block after the last (an out-of-range index reads it: weight × 0).
// columns: 32-byte aligned, PLEAT_SKIN_COLUMN_FLOATS floats. Returns the joints laid out (joint_count capped at 64).
#define PLEAT_SKIN_COLUMN_FLOATS ( ( PLEAT_SKIN_COLUMN_JOINTS + 1 ) * 16 )
static inline uint32_t plSkinColumns( float* columns, const float* skin_matrices, uint32_t joint_count )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	for ( uint32_t j = 0; j < J; ++j )
	{
		const float* m = skin_matrices + (size_t)j * 12;
		float* c = columns + (size_t)j * 16;
		for ( int col = 0; col < 4; ++col )
		{
			c[col * 4 + 0] = m[col];
			c[col * 4 + 1] = m[4 + col];
			c[col * 4 + 2] = m[8 + col];
			c[col * 4 + 3] = 0.0f;
		}
	}
	for ( int e = 0; e < 16; ++e )
	{
		columns[(size_t)J * 16 + e] = 0.0f;
	}
	return J;
}

// Σ_k w_k M_{j_k} in column form: *a = (c0 | c1), *b = (c2 | c3) of the blended matrix, 2 FMAs per influence, k in
// order; offsets: the joints' column blocks in bytes (plSkinColumnOffsets).
static inline void plBlendSkinOffsets( __m256* a, __m256* b, const uint32_t* offsets, const float* weights, uint32_t K,
									   const float* columns )
{
	__m256 sa = _mm256_setzero_ps(), sb = _mm256_setzero_ps();
	for ( uint32_t k = 0; k < K; ++k )
	{
		const float* c = (const float*)( (const uint8_t*)columns + offsets[k] );
		__m256 w = _mm256_broadcast_ss( weights + k );
		sa = _mm256_fmadd_ps( w, _mm256_load_ps( c ), sa );
		sb = _mm256_fmadd_ps( w, _mm256_load_ps( c + 8 ), sb );
	}
	*a = sa;
	*b = sb;
}

// One vertex's or point's offsets from its K indices, where the kernel has no table (plSkinColumnOffsets' values): J is
// what plSkinColumns returned, and an index past it reads the zero block.
static inline void plSkinColumnOffsetsOf( uint32_t* offsets, const uint16_t* indices, uint32_t K, uint32_t J )
{
	for ( uint32_t k = 0; k < K; ++k )
	{
		offsets[k] = ( indices[k] < J ? indices[k] : J ) * 16u * (uint32_t)sizeof( float );
	}
}

// Eight lanes of plContactReach (the same operations).
static inline __m256 plContactReach8( __m256 nearest )
{
	const float near2 = PLEAT_CONTACT_REACH_NEAR_M * PLEAT_CONTACT_REACH_NEAR_M;
	const float far2 = PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M;
	__m256 r = _mm256_div_ps( _mm256_sub_ps( _mm256_set1_ps( far2 ), nearest ), _mm256_set1_ps( far2 - near2 ) );
	return _mm256_min_ps( _mm256_max_ps( r, _mm256_setzero_ps() ), _mm256_set1_ps( 1.0f ) );
}

// r[i][j] <-> r[j][i] for an 8x8 block of floats in 8 registers: eight instances' blocks into lanes and back
// (geometry_batch_avx2.c), eight 8-float rows into their fields' lanes (body_contact_avx2.c; cheaper than gathers).
static inline void plTranspose8x8( __m256 r[8] )
{
	__m256 t[8], s[8];
	for ( int i = 0; i < 4; ++i )
	{
		t[2 * i] = _mm256_unpacklo_ps( r[2 * i], r[2 * i + 1] );
		t[2 * i + 1] = _mm256_unpackhi_ps( r[2 * i], r[2 * i + 1] );
	}
	for ( int g = 0; g < 2; ++g )
	{
		s[4 * g] = _mm256_shuffle_ps( t[4 * g], t[4 * g + 2], 0x44 );
		s[4 * g + 1] = _mm256_shuffle_ps( t[4 * g], t[4 * g + 2], 0xEE );
		s[4 * g + 2] = _mm256_shuffle_ps( t[4 * g + 1], t[4 * g + 3], 0x44 );
		s[4 * g + 3] = _mm256_shuffle_ps( t[4 * g + 1], t[4 * g + 3], 0xEE );
	}
	for ( int c = 0; c < 4; ++c )
	{
		r[c] = _mm256_permute2f128_ps( s[c], s[4 + c], 0x20 );
		r[4 + c] = _mm256_permute2f128_ps( s[c], s[4 + c], 0x31 );
	}
}

// Eight lanes of plPushOutOfAnchorPlane, the end of the body-contact test: n = (nx, ny, nz) / length with
// length = sqrt((nx² + ny²) + nz²), d = ((x − ax)·nx + (y − ay)·ny) + (z − az)·nz, and where length > 1e-12 and
// d < offset, x ← x + reach·(offset − d)·n (other lanes keep their bits; reach is each lane's share of its push,
// plContactReach8, 1 for the fast contact). Returns the mask of the lanes that moved. The lanes are vertices in
// plBodyContactFast_Avx2 and plBodyContact_Avx2, instances in plBodyContactFastBatch_Avx2 and plBodyContactBatch_Avx2
// (the full contacts with their blended plane): one definition, so they agree bit for bit by construction, and with
// plPushOutOfAnchorPlane, which the scalar kernels share.
static inline __m256 plPushOutOfAnchorPlane8( __m256* x, __m256* y, __m256* z, __m256 ax, __m256 ay, __m256 az,
											  __m256 nx, __m256 ny, __m256 nz, __m256 offset, __m256 reach )
{
	__m256 length = _mm256_sqrt_ps(
		_mm256_add_ps( _mm256_add_ps( _mm256_mul_ps( nx, nx ), _mm256_mul_ps( ny, ny ) ), _mm256_mul_ps( nz, nz ) ) );
	__m256 has_direction = _mm256_cmp_ps( length, _mm256_set1_ps( 1e-12f ), _CMP_GT_OQ );
	nx = _mm256_div_ps( nx, length );
	ny = _mm256_div_ps( ny, length );
	nz = _mm256_div_ps( nz, length );
	__m256 d = _mm256_add_ps(
		_mm256_add_ps( _mm256_mul_ps( _mm256_sub_ps( *x, ax ), nx ), _mm256_mul_ps( _mm256_sub_ps( *y, ay ), ny ) ),
		_mm256_mul_ps( _mm256_sub_ps( *z, az ), nz ) );
	__m256 moves = _mm256_and_ps( has_direction, _mm256_cmp_ps( d, offset, _CMP_LT_OQ ) );
	__m256 push = _mm256_mul_ps( _mm256_sub_ps( offset, d ), reach );
	*x = _mm256_blendv_ps( *x, _mm256_add_ps( *x, _mm256_mul_ps( push, nx ) ), moves );
	*y = _mm256_blendv_ps( *y, _mm256_add_ps( *y, _mm256_mul_ps( push, ny ) ), moves );
	*z = _mm256_blendv_ps( *z, _mm256_add_ps( *z, _mm256_mul_ps( push, nz ) ), moves );
	return moves;
}

#endif
