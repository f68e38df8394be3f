// AVX2 + FMA (+ F16C for fp16 weights) twin of plMatVec_Scalar. Compiled with -mavx2 -mfma -mf16c; only called when
// CPUID says so. Four rows at a time, two 8-wide accumulators per row (8 independent FMA chains), unaligned loads
// (rows of odd length are not 32-byte aligned).
#include "kernels.h"

#include <immintrin.h>

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

void plMatVec_Avx2( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
					uint32_t in_count, uint32_t row_begin, uint32_t row_end )
{
	uint32_t r = row_begin;
	for ( ; r + 4 <= row_end; r += 4 )
	{
		size_t b0 = (size_t)r * in_count, b1 = b0 + in_count, b2 = b1 + in_count, b3 = b2 + in_count;
		__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), a2 = _mm256_setzero_ps(),
			   a3 = _mm256_setzero_ps();
		__m256 c0 = _mm256_setzero_ps(), c1 = _mm256_setzero_ps(), c2 = _mm256_setzero_ps(),
			   c3 = _mm256_setzero_ps();
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
		for ( ; c < in_count; ++c )
		{
			s[0] += plLoadWeight1( weight, weight_fp16, b0 + c ) * x[c];
			s[1] += plLoadWeight1( weight, weight_fp16, b1 + c ) * x[c];
			s[2] += plLoadWeight1( weight, weight_fp16, b2 + c ) * x[c];
			s[3] += plLoadWeight1( weight, weight_fp16, b3 + c ) * x[c];
		}
		out[r + 0] = s[0] + bias[r + 0];
		out[r + 1] = s[1] + bias[r + 1];
		out[r + 2] = s[2] + bias[r + 2];
		out[r + 3] = s[3] + bias[r + 3];
	}
	for ( ; r < row_end; ++r )
	{
		size_t b0 = (size_t)r * in_count;
		__m256 a0 = _mm256_setzero_ps();
		uint32_t c = 0;
		for ( ; c + 8 <= in_count; c += 8 )
		{
			a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, b0 + c ), _mm256_loadu_ps( x + c ), a0 );
		}
		__m128 h = _mm_add_ps( _mm256_castps256_ps128( a0 ), _mm256_extractf128_ps( a0, 1 ) );
		h = _mm_hadd_ps( h, h );
		h = _mm_hadd_ps( h, h );
		float s = _mm_cvtss_f32( h );
		for ( ; c < in_count; ++c )
		{
			s += plLoadWeight1( weight, weight_fp16, b0 + c ) * x[c];
		}
		out[r] = s + bias[r];
	}
}
