// AVX2 + FMA (+ F16C) twin of plMatMat_Scalar, and the batched twin of plMatVec_Avx2: for every (instance, row) it
// performs plMatVec_Avx2's per-row arithmetic exactly (simd_avx2.h, plDotRow2: an FMA chain over the even 8-blocks of
// each 16-step plus the final 8-step, one over the odd 8-blocks, their sum, the horizontal sum, a scalar fmaf tail,
// then + bias), so a batch gives what each instance's own step gives, bit for bit.
//
// A single-instance mat-vec is bound by how fast the weights stream in (docs/benchmarks.md); with a batch each weight
// vector, once loaded, feeds several instances. The register tile is 3 rows × 3 instances, one of the two chains at a
// time (9 accumulators: with both chains, 12 or more accumulators made GCC spill one to the stack, a store and a load
// in a chain's every step): per 8 columns 3 weight loads and 3 input loads feed 9 FMAs, so the loop runs near the FMA
// units' rate rather than the memory's. The tile's rows (3 · in_count · 4 bytes) stay in L1 while every instance of
// the batch passes over them, so each weight is read from memory once per call.
#include "kernels/kernels_batch.h"
#include "simd_avx2.h"

// The end of one dot product: the two chains summed, the horizontal sum, the scalar tail from column c (the first
// column no 8-wide step covered).
static inline float plFinishDot( __m256 even, __m256 odd, const float* x, const void* weight, int weight_fp16,
								 size_t base, uint32_t c, uint32_t in_count )
{
	float sum = plHorizontalSum( _mm256_add_ps( even, odd ) );
	for ( ; c < in_count; ++c )
	{
		sum = fmaf( plLoad1( weight, weight_fp16, base + c ), x[c], sum );
	}
	return sum;
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
		e0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base0 + c ), xe, e0 );
		e1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base1 + c ), xe, e1 );
		o0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base0 + c + 8 ), xo, o0 );
		o1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base1 + c + 8 ), xo, o1 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 xe = _mm256_loadu_ps( x + c );
		e0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base0 + c ), xe, e0 );
		e1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base1 + c ), xe, e1 );
	}
	*sum0 = plFinishDot( e0, o0, x, weight, weight_fp16, base0, c, in_count );
	*sum1 = plFinishDot( e1, o1, x, weight, weight_fp16, base1, c, in_count );
}

// One of the two FMA chains of three rows × three instances (9 accumulators, so nothing spills out of the 16 vector
// registers): offset 0 = the even 8-blocks of each 16-step plus the final 8-wide step, offset 8 = the odd 8-blocks.
// The two chains of a dot product are independent, so computing one after the other changes no operation.
static inline void plChain3x3( const float* const x[3], const void* weight, int weight_fp16, const size_t base[3],
							   uint32_t in_count, uint32_t offset, __m256 acc[3][3] )
{
	__m256 a00 = _mm256_setzero_ps(), a01 = _mm256_setzero_ps(), a02 = _mm256_setzero_ps();
	__m256 a10 = _mm256_setzero_ps(), a11 = _mm256_setzero_ps(), a12 = _mm256_setzero_ps();
	__m256 a20 = _mm256_setzero_ps(), a21 = _mm256_setzero_ps(), a22 = _mm256_setzero_ps();
	const float *x0 = x[0] + offset, *x1 = x[1] + offset, *x2 = x[2] + offset;
	size_t b0 = base[0] + offset, b1 = base[1] + offset, b2 = base[2] + offset;
	uint32_t steps = in_count / 16 + ( offset == 0 && in_count % 16 >= 8 ? 1u : 0u );
	for ( uint32_t k = 0, c = 0; k < steps; ++k, c += 16 )
	{
		__m256 w0 = plLoad8( weight, weight_fp16, b0 + c );
		__m256 w1 = plLoad8( weight, weight_fp16, b1 + c );
		__m256 w2 = plLoad8( weight, weight_fp16, b2 + c );
		__m256 xv = _mm256_loadu_ps( x0 + c );
		a00 = _mm256_fmadd_ps( w0, xv, a00 );
		a10 = _mm256_fmadd_ps( w1, xv, a10 );
		a20 = _mm256_fmadd_ps( w2, xv, a20 );
		xv = _mm256_loadu_ps( x1 + c );
		a01 = _mm256_fmadd_ps( w0, xv, a01 );
		a11 = _mm256_fmadd_ps( w1, xv, a11 );
		a21 = _mm256_fmadd_ps( w2, xv, a21 );
		xv = _mm256_loadu_ps( x2 + c );
		a02 = _mm256_fmadd_ps( w0, xv, a02 );
		a12 = _mm256_fmadd_ps( w1, xv, a12 );
		a22 = _mm256_fmadd_ps( w2, xv, a22 );
	}
	acc[0][0] = a00, acc[0][1] = a01, acc[0][2] = a02;
	acc[1][0] = a10, acc[1][1] = a11, acc[1][2] = a12;
	acc[2][0] = a20, acc[2][1] = a21, acc[2][2] = a22;
}

// Three rows × three instances: the even chains, then the odd ones, then each dot product finished as plDotRow2.
static inline void plDot3x3( const float* const x[3], const void* weight, int weight_fp16, const size_t base[3],
							 uint32_t in_count, float sum[3][3] )
{
	__m256 even[3][3], odd[3][3];
	plChain3x3( x, weight, weight_fp16, base, in_count, 0, even );
	plChain3x3( x, weight, weight_fp16, base, in_count, 8, odd );
	uint32_t tail = in_count - in_count % 8;
	for ( int r = 0; r < 3; ++r )
	{
		for ( int b = 0; b < 3; ++b )
		{
			sum[r][b] = plFinishDot( even[r][b], odd[r][b], x[b], weight, weight_fp16, base[r], tail, in_count );
		}
	}
}

// fp16 rows of up to this many columns are widened to fp32 once per row triple (a 12 KB stack buffer) instead of once
// per instance triple: the same values (the conversion is exact), a third or less of the conversions.
#define PLEAT_MAT_MAT_WIDEN_COLUMNS 1024

// plMatMat_Avx2 for at most PLEAT_BATCH_MAX instances whose inputs x[b] start at the window's first column; the
// weights' rows are in_count long and `columns` of each, from column col_begin, are used.
static void plMatMatWindow( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
							int weight_fp16, const float* bias, uint32_t in_count, uint32_t col_begin,
							uint32_t columns, uint32_t row_begin, uint32_t row_end )
{
	float widened[3 * PLEAT_MAT_MAT_WIDEN_COLUMNS];
	int widen = weight_fp16 && columns <= PLEAT_MAT_MAT_WIDEN_COLUMNS && batch_count > 3;
	uint32_t r = row_begin;
	for ( ; r + 3 <= row_end; r += 3 )
	{
		size_t base[3] = { (size_t)r * in_count + col_begin, (size_t)( r + 1 ) * in_count + col_begin,
						   (size_t)( r + 2 ) * in_count + col_begin };
		const void* tile_weight = weight;
		int tile_fp16 = weight_fp16;
		size_t tile_base[3] = { base[0], base[1], base[2] };
		if ( widen )
		{
			const uint16_t* w16 = (const uint16_t*)weight;
			for ( uint32_t k = 0; k < 3; ++k )
			{
				uint32_t c = 0;
				for ( ; c + 8 <= columns; c += 8 )
				{
					_mm256_storeu_ps( widened + k * columns + c,
									  _mm256_cvtph_ps( _mm_loadu_si128( (const __m128i*)( w16 + base[k] + c ) ) ) );
				}
				for ( ; c < columns; ++c )
				{
					widened[k * columns + c] = _cvtsh_ss( w16[base[k] + c] );
				}
				tile_base[k] = (size_t)k * columns;
			}
			tile_weight = widened;
			tile_fp16 = 0;
		}
		uint32_t b = 0;
		for ( ; b + 3 <= batch_count; b += 3 )
		{
			float sum[3][3];
			plDot3x3( x + b, tile_weight, tile_fp16, tile_base, columns, sum );
			for ( uint32_t k = 0; k < 3; ++k )
			{
				out[b + k][r] = sum[0][k] + bias[r];
				out[b + k][r + 1] = sum[1][k] + bias[r + 1];
				out[b + k][r + 2] = sum[2][k] + bias[r + 2];
			}
		}
		for ( ; b < batch_count; ++b )
		{
			float sum0, sum1;
			plDot2x1( x[b], tile_weight, tile_fp16, tile_base[0], tile_base[1], columns, &sum0, &sum1 );
			out[b][r] = sum0 + bias[r];
			out[b][r + 1] = sum1 + bias[r + 1];
			out[b][r + 2] = plDotRow2( x[b], tile_weight, tile_fp16, tile_base[2], columns ) + bias[r + 2];
		}
	}
	for ( ; r < row_end; ++r )
	{
		for ( uint32_t b = 0; b < batch_count; ++b )
		{
			out[b][r] = plDotRow2( x[b], weight, weight_fp16, (size_t)r * in_count + col_begin, columns ) + bias[r];
		}
	}
}

void plMatMat_Avx2( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					int weight_fp16, const float* bias, uint32_t in_count, uint32_t col_begin, uint32_t col_end,
					uint32_t row_begin, uint32_t row_end )
{
	for ( uint32_t b = 0; b < batch_count; b += PLEAT_BATCH_MAX )
	{
		uint32_t n = batch_count - b < PLEAT_BATCH_MAX ? batch_count - b : PLEAT_BATCH_MAX;
		const float* window[PLEAT_BATCH_MAX];
		for ( uint32_t k = 0; k < n; ++k )
		{
			window[k] = x[b + k] + col_begin;
		}
		plMatMatWindow( out + b, window, n, weight, weight_fp16, bias, in_count, col_begin, col_end - col_begin,
						row_begin, row_end );
	}
}
