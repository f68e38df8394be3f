// AVX2 + FMA (+ F16C) twin of plMatMat_Scalar, and the batched twin of plMatVec_Avx2: for every (instance, row) it
// performs plMatVec_Avx2's per-row arithmetic exactly (mlp_avx2.c, plDotRow2: an FMA chain over the even 8-blocks of
// each 16-step plus the final 8-step, one over the odd 8-blocks, their sum, the horizontal sum, a scalar fmaf tail,
// then + bias), so a batch gives what each instance's own step gives, bit for bit.
//
// A single-instance mat-vec is bound by how fast the weights stream in (docs/benchmarks.md); with a batch each weight
// vector, once loaded, feeds several instances. The register tile is 2 rows × 3 instances: per 16 columns 4 weight
// loads and 6 input loads feed 12 FMAs into 12 accumulators (the two chains of 6 dot products), so the loop runs near
// the FMA units' rate rather than the memory's. A row's weights (in_count · 4 bytes) stay in L1 while every instance
// of the batch passes over them, so each weight is read from memory once per call.
#include "kernels_batch.h"

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

// The same reduction as mlp_avx2.c's plHorizontalSum.
static inline float plHorizontalSum( __m256 v )
{
	__m128 s = _mm_add_ps( _mm256_castps256_ps128( v ), _mm256_extractf128_ps( v, 1 ) );
	s = _mm_add_ps( s, _mm_movehl_ps( s, s ) );
	s = _mm_add_ss( s, _mm_movehdup_ps( s ) );
	return _mm_cvtss_f32( s );
}

// The end of one dot product: the two chains summed, the horizontal sum, the scalar tail from column c.
static inline float plFinishDot( __m256 even, __m256 odd, const float* x, const void* weight, int weight_fp16,
								 size_t base, uint32_t c, uint32_t in_count )
{
	float sum = plHorizontalSum( _mm256_add_ps( even, odd ) );
	for ( ; c < in_count; ++c )
	{
		sum = fmaf( plLoadWeight1( weight, weight_fp16, base + c ), x[c], sum );
	}
	return sum;
}

// One row, one instance: plDotRow2 itself.
static inline float plDot1x1( const float* x, const void* weight, int weight_fp16, size_t base, uint32_t in_count )
{
	__m256 e = _mm256_setzero_ps(), o = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		e = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), e );
		o = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c + 8 ), _mm256_loadu_ps( x + c + 8 ), o );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		e = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base + c ), _mm256_loadu_ps( x + c ), e );
	}
	return plFinishDot( e, o, x, weight, weight_fp16, base, c, in_count );
}

// Two rows (base0, base1), one instance.
static inline void plDot2x1( const float* x, const void* weight, int weight_fp16, size_t base0, size_t base1,
							 uint32_t in_count, float* sum0, float* sum1 )
{
	__m256 e0 = _mm256_setzero_ps(), o0 = _mm256_setzero_ps(), e1 = _mm256_setzero_ps(), o1 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		__m256 xe = _mm256_loadu_ps( x + c ), xo = _mm256_loadu_ps( x + c + 8 );
		e0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base0 + c ), xe, e0 );
		e1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c ), xe, e1 );
		o0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base0 + c + 8 ), xo, o0 );
		o1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c + 8 ), xo, o1 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 xe = _mm256_loadu_ps( x + c );
		e0 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base0 + c ), xe, e0 );
		e1 = _mm256_fmadd_ps( plLoadWeights8( weight, weight_fp16, base1 + c ), xe, e1 );
	}
	*sum0 = plFinishDot( e0, o0, x, weight, weight_fp16, base0, c, in_count );
	*sum1 = plFinishDot( e1, o1, x, weight, weight_fp16, base1, c, in_count );
}

// Two rows × three instances: 12 accumulators (rows r, instances 0..2, even/odd chains).
static inline void plDot2x3( const float* x0, const float* x1, const float* x2, const void* weight, int weight_fp16,
							 size_t base0, size_t base1, uint32_t in_count, float sum[2][3] )
{
	__m256 e00 = _mm256_setzero_ps(), e01 = _mm256_setzero_ps(), e02 = _mm256_setzero_ps();
	__m256 e10 = _mm256_setzero_ps(), e11 = _mm256_setzero_ps(), e12 = _mm256_setzero_ps();
	__m256 o00 = _mm256_setzero_ps(), o01 = _mm256_setzero_ps(), o02 = _mm256_setzero_ps();
	__m256 o10 = _mm256_setzero_ps(), o11 = _mm256_setzero_ps(), o12 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		__m256 w0 = plLoadWeights8( weight, weight_fp16, base0 + c );
		__m256 w1 = plLoadWeights8( weight, weight_fp16, base1 + c );
		__m256 xv = _mm256_loadu_ps( x0 + c );
		e00 = _mm256_fmadd_ps( w0, xv, e00 );
		e10 = _mm256_fmadd_ps( w1, xv, e10 );
		xv = _mm256_loadu_ps( x1 + c );
		e01 = _mm256_fmadd_ps( w0, xv, e01 );
		e11 = _mm256_fmadd_ps( w1, xv, e11 );
		xv = _mm256_loadu_ps( x2 + c );
		e02 = _mm256_fmadd_ps( w0, xv, e02 );
		e12 = _mm256_fmadd_ps( w1, xv, e12 );
		w0 = plLoadWeights8( weight, weight_fp16, base0 + c + 8 );
		w1 = plLoadWeights8( weight, weight_fp16, base1 + c + 8 );
		xv = _mm256_loadu_ps( x0 + c + 8 );
		o00 = _mm256_fmadd_ps( w0, xv, o00 );
		o10 = _mm256_fmadd_ps( w1, xv, o10 );
		xv = _mm256_loadu_ps( x1 + c + 8 );
		o01 = _mm256_fmadd_ps( w0, xv, o01 );
		o11 = _mm256_fmadd_ps( w1, xv, o11 );
		xv = _mm256_loadu_ps( x2 + c + 8 );
		o02 = _mm256_fmadd_ps( w0, xv, o02 );
		o12 = _mm256_fmadd_ps( w1, xv, o12 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 w0 = plLoadWeights8( weight, weight_fp16, base0 + c );
		__m256 w1 = plLoadWeights8( weight, weight_fp16, base1 + c );
		__m256 xv = _mm256_loadu_ps( x0 + c );
		e00 = _mm256_fmadd_ps( w0, xv, e00 );
		e10 = _mm256_fmadd_ps( w1, xv, e10 );
		xv = _mm256_loadu_ps( x1 + c );
		e01 = _mm256_fmadd_ps( w0, xv, e01 );
		e11 = _mm256_fmadd_ps( w1, xv, e11 );
		xv = _mm256_loadu_ps( x2 + c );
		e02 = _mm256_fmadd_ps( w0, xv, e02 );
		e12 = _mm256_fmadd_ps( w1, xv, e12 );
	}
	sum[0][0] = plFinishDot( e00, o00, x0, weight, weight_fp16, base0, c, in_count );
	sum[0][1] = plFinishDot( e01, o01, x1, weight, weight_fp16, base0, c, in_count );
	sum[0][2] = plFinishDot( e02, o02, x2, weight, weight_fp16, base0, c, in_count );
	sum[1][0] = plFinishDot( e10, o10, x0, weight, weight_fp16, base1, c, in_count );
	sum[1][1] = plFinishDot( e11, o11, x1, weight, weight_fp16, base1, c, in_count );
	sum[1][2] = plFinishDot( e12, o12, x2, weight, weight_fp16, base1, c, in_count );
}

void plMatMat_Avx2( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					int weight_fp16, const float* bias, uint32_t in_count, uint32_t row_begin, uint32_t row_end )
{
	uint32_t r = row_begin;
	for ( ; r + 2 <= row_end; r += 2 )
	{
		size_t base0 = (size_t)r * in_count, base1 = base0 + in_count;
		uint32_t b = 0;
		for ( ; b + 3 <= batch_count; b += 3 )
		{
			float sum[2][3];
			plDot2x3( x[b], x[b + 1], x[b + 2], weight, weight_fp16, base0, base1, in_count, sum );
			for ( uint32_t k = 0; k < 3; ++k )
			{
				out[b + k][r] = sum[0][k] + bias[r];
				out[b + k][r + 1] = sum[1][k] + bias[r + 1];
			}
		}
		for ( ; b < batch_count; ++b )
		{
			float sum0, sum1;
			plDot2x1( x[b], weight, weight_fp16, base0, base1, in_count, &sum0, &sum1 );
			out[b][r] = sum0 + bias[r];
			out[b][r + 1] = sum1 + bias[r + 1];
		}
	}
	for ( ; r < row_end; ++r )
	{
		for ( uint32_t b = 0; b < batch_count; ++b )
		{
			out[b][r] = plDot1x1( x[b], weight, weight_fp16, (size_t)r * in_count, in_count ) + bias[r];
		}
	}
}
