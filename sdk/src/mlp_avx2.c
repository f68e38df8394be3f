// AVX2 + FMA (+ F16C for fp16 weights) twin of plMatVec_Scalar. Compiled with -mavx2 -mfma -mf16c; only called when
// CPUID says so. A batch-1 mat-vec reads every weight once, so it is bound by memory bandwidth, not arithmetic: the
// kernel walks the [rows][in] matrix strictly in address order, one row at a time (one sequential stream the
// hardware prefetcher follows from DRAM), with four independent 8-wide accumulators per row. x (≤ a few KB) stays in
// L1. Interleaving four rows (four streams 2 KB apart) measured ~20 % slower inside a step (docs/benchmarks.md).
// fp16 weights only: two rows per pass sharing the x loads (plDotRows2, per row the same arithmetic as plDotRow, so
// bit-identical): the fp16 conversions make that kernel less purely bandwidth-bound, −6 to −13 % per fp16 step;
// for fp32 weights the same measured +11 % (round 2, docs/benchmarks.md).
#include "kernels.h"

#include <immintrin.h>
#include <math.h>

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

static inline float plHorizontalSum( __m256 v )
{
	__m128 s = _mm_add_ps( _mm256_castps256_ps128( v ), _mm256_extractf128_ps( v, 1 ) );
	s = _mm_add_ps( s, _mm_movehl_ps( s, s ) );
	s = _mm_add_ss( s, _mm_movehdup_ps( s ) );
	return _mm_cvtss_f32( s );
}

// One row's dot product; the result depends only on the row (not on how rows were split over workers).
static inline float plDotRow( const float* x, const void* weight, int weight_fp16, size_t base, uint32_t in_count )
{
	__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), a2 = _mm256_setzero_ps(), a3 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 32 <= in_count; c += 32 )
	{
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), a0 );
		a1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 8 ), _mm256_loadu_ps( x + c + 8 ), a1 );
		a2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 16 ), _mm256_loadu_ps( x + c + 16 ), a2 );
		a3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 24 ), _mm256_loadu_ps( x + c + 24 ), a3 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), a0 );
	}
	float sum = plHorizontalSum( _mm256_add_ps( _mm256_add_ps( a0, a1 ), _mm256_add_ps( a2, a3 ) ) );
	for ( ; c < in_count; ++c )
	{
		sum = fmaf( plLoadWeight1( weight, weight_fp16, base + c ), x[c], sum );
	}
	return sum;
}

// Two rows at once with the same per-row arithmetic as plDotRow (so bit-identical to it), sharing the x loads.
static inline void plDotRows2( const float* x, const void* weight, int weight_fp16, size_t base, uint32_t in_count,
							   float* out0, float* out1 )
{
	__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), a2 = _mm256_setzero_ps(), a3 = _mm256_setzero_ps();
	__m256 b0 = _mm256_setzero_ps(), b1 = _mm256_setzero_ps(), b2 = _mm256_setzero_ps(), b3 = _mm256_setzero_ps();
	size_t base1 = base + in_count;
	uint32_t c = 0;
	for ( ; c + 32 <= in_count; c += 32 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c ), x1 = _mm256_loadu_ps( x + c + 8 );
		__m256 x2 = _mm256_loadu_ps( x + c + 16 ), x3 = _mm256_loadu_ps( x + c + 24 );
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), x0, a0 );
		a1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 8 ), x1, a1 );
		a2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 16 ), x2, a2 );
		a3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 24 ), x3, a3 );
		b0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c ), x0, b0 );
		b1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c + 8 ), x1, b1 );
		b2 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c + 16 ), x2, b2 );
		b3 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c + 24 ), x3, b3 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c );
		a0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), x0, a0 );
		b0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c ), x0, b0 );
	}
	float sum0 = plHorizontalSum( _mm256_add_ps( _mm256_add_ps( a0, a1 ), _mm256_add_ps( a2, a3 ) ) );
	float sum1 = plHorizontalSum( _mm256_add_ps( _mm256_add_ps( b0, b1 ), _mm256_add_ps( b2, b3 ) ) );
	for ( ; c < in_count; ++c )
	{
		sum0 = fmaf( plLoadWeight1( weight, weight_fp16, base + c ), x[c], sum0 );
		sum1 = fmaf( plLoadWeight1( weight, weight_fp16, base1 + c ), x[c], sum1 );
	}
	*out0 = sum0;
	*out1 = sum1;
}

void plMatVec_Avx2( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
					uint32_t in_count, uint32_t row_begin, uint32_t row_end )
{
	uint32_t r = row_begin;
	for ( ; weight_fp16 && r + 2 <= row_end; r += 2 )
	{
		float s0, s1;
		plDotRows2( x, weight, weight_fp16, (size_t)r * in_count, in_count, &s0, &s1 );
		out[r] = s0 + bias[r];
		out[r + 1] = s1 + bias[r + 1];
	}
	for ( ; r < row_end; ++r )
	{
		out[r] = plDotRow( x, weight, weight_fp16, (size_t)r * in_count, in_count ) + bias[r];
	}
}
