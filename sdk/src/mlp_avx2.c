// AVX2 + FMA (+ F16C for fp16 weights) twin of plMatVec_Scalar. Compiled with -mavx2 -mfma -mf16c; only called when
// CPUID says so. Four rows at a time, two 8-wide accumulators per row (8 independent FMA chains), unaligned loads
// (rows of odd length are not 32-byte aligned).
#include "kernels.h"

#include <immintrin.h>
#include <math.h>

// Sums of four accumulators, lane-reduced, as one __m128 (row r..r+3).
static inline __m128 plReduce4( __m256 a, __m256 b, __m256 c, __m256 d )
{
	__m256 ab = _mm256_hadd_ps( a, b );
	__m256 cd = _mm256_hadd_ps( c, d );
	__m256 abcd = _mm256_hadd_ps( ab, cd );
	return _mm_add_ps( _mm256_castps256_ps128( abcd ), _mm256_extractf128_ps( abcd, 1 ) );
}

static inline __m256 plLoadWeights8( const void* w, int fp16, size_t index )
{
	if ( fp16 )
	{
		return _mm256_cvtph_ps( _mm_loadu_si128( (const __m128i*)( (const uint16_t*)w + index ) ) );
	}
	return _mm256_loadu_ps( (const float*)w + index );
}

static inline float plLoadWeight1( const void* w, int fp16, size_t index )
{
	return fp16 ? plHalfToFloat( ( (const uint16_t*)w )[index] ) : ( (const float*)w )[index];
}

// Dot products of four rows (byte-identical per row whatever the other three are, so a row's result does not depend
// on how the rows were split over workers) written to out[r0..r3].
static inline void plDot4( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
						   uint32_t in_count, const uint32_t rows[4], uint32_t write_count )
{
	size_t b0 = (size_t)rows[0] * in_count, b1 = (size_t)rows[1] * in_count, b2 = (size_t)rows[2] * in_count,
		   b3 = (size_t)rows[3] * in_count;
	__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), a2 = _mm256_setzero_ps(), a3 = _mm256_setzero_ps();
	__m256 c0 = _mm256_setzero_ps(), c1 = _mm256_setzero_ps(), c2 = _mm256_setzero_ps(), c3 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c );
		__m256 x1 = _mm256_loadu_ps( x + c + 8 );
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b0 + c ), x0, a0 );
		a1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b1 + c ), x0, a1 );
		a2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b2 + c ), x0, a2 );
		a3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b3 + c ), x0, a3 );
		c0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b0 + c + 8 ), x1, c0 );
		c1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b1 + c + 8 ), x1, c1 );
		c2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b2 + c + 8 ), x1, c2 );
		c3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b3 + c + 8 ), x1, c3 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c );
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b0 + c ), x0, a0 );
		a1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b1 + c ), x0, a1 );
		a2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b2 + c ), x0, a2 );
		a3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b3 + c ), x0, a3 );
	}
	__m128 sums = plReduce4( _mm256_add_ps( a0, c0 ), _mm256_add_ps( a1, c1 ), _mm256_add_ps( a2, c2 ),
							 _mm256_add_ps( a3, c3 ) );
	float s[4];
	_mm_storeu_ps( s, sums );
	size_t base[4] = { b0, b1, b2, b3 };
	for ( uint32_t k = 0; k < write_count; ++k )
	{
		float v = s[k];
		for ( uint32_t t = c; t < in_count; ++t )
		{
			v = fmaf( plLoadWeight1( weight, weight_fp16, base[k] + t ), x[t], v );
		}
		out[rows[k]] = v + bias[rows[k]];
	}
}

void plMatVec_Avx2( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
					uint32_t in_count, uint32_t row_begin, uint32_t row_end )
{
	uint32_t r = row_begin;
	for ( ; r + 4 <= row_end; r += 4 )
	{
		const uint32_t rows[4] = { r, r + 1, r + 2, r + 3 };
		plDot4( out, x, weight, weight_fp16, bias, in_count, rows, 4 );
	}
	if ( r < row_end )
	{
		// 1..3 rows left: repeat the last one in the unused slots, write only the real ones.
		uint32_t left = row_end - r;
		const uint32_t rows[4] = { r, left > 1 ? r + 1 : r, left > 2 ? r + 2 : r, r };
		plDot4( out, x, weight, weight_fp16, bias, in_count, rows, left );
	}
}
