// AVX2 + FMA (+ F16C for fp16 weights) twin of plMatVec_Scalar. Compiled with -mavx2 -mfma -mf16c; only called when
// CPUID says so. A batch-1 mat-vec reads every weight once, so it is bound by how fast the weights stream in. The row
// range is cut into four contiguous blocks and one row of each block is computed at a time: four sequential streams,
// each walking its block strictly in address order (the pattern of the fastest pure read measured on the benchmark
// machine, several concurrent sequential streams), with the x loads shared by the four rows. This measured
// ×0.68–0.77 per fp32 step against one row at a time (one stream) and ×0.91 per fp16 step (docs/benchmarks.md);
// interleaving *adjacent* rows (streams that skip over each other's rows) had measured slower. Each row's
// arithmetic (plDotRow2) does not depend on the block split, so a row's result is the same for any worker split.
#include "kernels/kernels.h"
#include "simd_avx2.h"

// Four rows from four contiguous row blocks at once (four sequential streams, each walking its block in address
// order, like eight-stream reads that measured fastest), sharing the x loads; per row exactly plDotRow2.
static inline void plDotRowQuad( const float* x, const void* weight, int weight_fp16, const size_t base[4],
								 uint32_t in_count, float sum[4] )
{
	__m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), b0 = _mm256_setzero_ps(), b1 = _mm256_setzero_ps();
	__m256 c0 = _mm256_setzero_ps(), c1 = _mm256_setzero_ps(), d0 = _mm256_setzero_ps(), d1 = _mm256_setzero_ps();
	uint32_t c = 0;
	for ( ; c + 16 <= in_count; c += 16 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c ), x1 = _mm256_loadu_ps( x + c + 8 );
		a0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[0] + c ), x0, a0 );
		a1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[0] + c + 8 ), x1, a1 );
		b0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[1] + c ), x0, b0 );
		b1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[1] + c + 8 ), x1, b1 );
		c0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[2] + c ), x0, c0 );
		c1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[2] + c + 8 ), x1, c1 );
		d0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[3] + c ), x0, d0 );
		d1 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[3] + c + 8 ), x1, d1 );
	}
	for ( ; c + 8 <= in_count; c += 8 )
	{
		__m256 x0 = _mm256_loadu_ps( x + c );
		a0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[0] + c ), x0, a0 );
		b0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[1] + c ), x0, b0 );
		c0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[2] + c ), x0, c0 );
		d0 = _mm256_fmadd_ps( plLoad8( weight, weight_fp16, base[3] + c ), x0, d0 );
	}
	sum[0] = plHorizontalSum( _mm256_add_ps( a0, a1 ) );
	sum[1] = plHorizontalSum( _mm256_add_ps( b0, b1 ) );
	sum[2] = plHorizontalSum( _mm256_add_ps( c0, c1 ) );
	sum[3] = plHorizontalSum( _mm256_add_ps( d0, d1 ) );
	for ( ; c < in_count; ++c )
	{
		float xc = x[c];
		for ( int k = 0; k < 4; ++k )
		{
			sum[k] = fmaf( plLoad1( weight, weight_fp16, base[k] + c ), xc, sum[k] );
		}
	}
}

void plMatVec_Avx2( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
					uint32_t in_count, uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	uint32_t n = row_end - row_begin, q = n / 4, columns = col_end - col_begin;
	x += col_begin;
	for ( uint32_t i = 0; i < q; ++i )
	{
		uint32_t rows[4] = { row_begin + i, row_begin + q + i, row_begin + 2 * q + i, row_begin + 3 * q + i };
		size_t base[4];
		for ( int k = 0; k < 4; ++k )
		{
			base[k] = (size_t)rows[k] * in_count + col_begin;
		}
		float sum[4];
		plDotRowQuad( x, weight, weight_fp16, base, columns, sum );
		for ( int k = 0; k < 4; ++k )
		{
			out[rows[k]] = sum[k] + bias[rows[k]];
		}
	}
	for ( uint32_t r = row_begin + 4 * q; r < row_end; ++r )
	{
		out[r] = plDotRow2( x, weight, weight_fp16, (size_t)r * in_count + col_begin, columns ) + bias[r];
	}
}
