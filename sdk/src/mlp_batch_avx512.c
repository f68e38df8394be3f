// AVX-512 twin of plMatMat_Avx2, and so the batched twin of plMatVec_Avx2: for every (instance, row) it performs
// plDotRow2's arithmetic exactly. plDotRow2 keeps two 8-wide FMA chains over each 16-column step — the even 8-block
// into one, the odd into the other — so one 16-wide accumulator holds both: its low half is the even chain and its
// high half the odd chain, and one 16-wide FMA per step does what the two 8-wide FMAs did, lane for lane. The final
// 8-wide step goes into the low half alone, then the halves are added, summed horizontally (plHorizontalSum), the
// scalar fmaf tail follows and the bias is added last — each as in plDotRow2.
//
// With 32 vector registers the register tile is 4 rows × 6 instances (24 accumulators, 4 weight vectors, 1 input
// vector): per 16 columns 10 loads feed 24 FMAs, against 6 loads for 9 FMAs in the AVX2 tile, and half the
// instructions per multiply-add. The tile's rows (4 · in_count · 4 bytes, 11 KB at 681 inputs) stay in L1 while every
// instance of the batch passes over them, so each weight is read from memory once per call. fp16 rows are widened
// once per row tile (exact) into a stack buffer.
#include "kernels_batch.h"
#include "simd_avx2.h"

#include <immintrin.h>

#define PLEAT_MM512_ROWS 4
#define PLEAT_MM512_INSTANCES 6
// fp16 rows up to this many columns are widened per row tile (4 · 1024 floats, 16 KB on the stack); wider fp16 layers
// (none in the shipped sizes) take the AVX2 kernel, which is the same arithmetic.
#define PLEAT_MM512_WIDEN_COLUMNS 1024

#if defined( __GNUC__ ) || defined( __clang__ )
#define PLEAT_ALWAYS_INLINE inline __attribute__( ( always_inline ) )
#else
#define PLEAT_ALWAYS_INLINE inline
#endif

// sum[r][b] = plDotRow2( x[b], w, 0, r · in_count, in_count ) for r < R, b < NB (R, NB compile-time after inlining).
static PLEAT_ALWAYS_INLINE void plTile512( const int R, const int NB, const float* const* x, const float* w,
										   uint32_t in_count, float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES] )
{
	__m512 acc[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES];
	const float* xb[PLEAT_MM512_INSTANCES];
	for ( int b = 0; b < NB; ++b )
	{
		xb[b] = x[b];
		for ( int r = 0; r < R; ++r )
		{
			acc[r][b] = _mm512_setzero_ps();
		}
	}
	uint32_t steps = in_count / 16;
	for ( uint32_t k = 0, c = 0; k < steps; ++k, c += 16 )
	{
		__m512 wv[PLEAT_MM512_ROWS];
		for ( int r = 0; r < R; ++r )
		{
			wv[r] = _mm512_loadu_ps( w + (size_t)r * in_count + c );
		}
		for ( int b = 0; b < NB; ++b )
		{
			__m512 xv = _mm512_loadu_ps( xb[b] + c );
			for ( int r = 0; r < R; ++r )
			{
				acc[r][b] = _mm512_fmadd_ps( wv[r], xv, acc[r][b] );
			}
		}
	}
	uint32_t c = steps * 16;
	int step8 = in_count - c >= 8;
	for ( int r = 0; r < R; ++r )
	{
		const float* wr = w + (size_t)r * in_count;
		for ( int b = 0; b < NB; ++b )
		{
			__m256 even = _mm512_castps512_ps256( acc[r][b] );
			__m256 odd = _mm512_extractf32x8_ps( acc[r][b], 1 );
			uint32_t t = c;
			if ( step8 )
			{
				even = _mm256_fmadd_ps( _mm256_loadu_ps( wr + t ), _mm256_loadu_ps( xb[b] + t ), even );
				t += 8;
			}
			float s = plHorizontalSum( _mm256_add_ps( even, odd ) );
			for ( ; t < in_count; ++t )
			{
				s = fmaf( wr[t], xb[b][t], s );
			}
			sum[r][b] = s;
		}
	}
}

// Rows [r, r + R) of instances [b, b + NB) with the tile's (fp32) rows at w.
static void plTileRows( int R, int NB, const float* const* x, const float* w, uint32_t in_count,
						float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES] )
{
#define PLEAT_TILE_CASE( rows, n )                                                                                     \
	case n:                                                                                                            \
		plTile512( rows, n, x, w, in_count, sum );                                                                     \
		return;
	if ( R == PLEAT_MM512_ROWS )
	{
		switch ( NB )
		{
			PLEAT_TILE_CASE( 4, 1 )
			PLEAT_TILE_CASE( 4, 2 )
			PLEAT_TILE_CASE( 4, 3 )
			PLEAT_TILE_CASE( 4, 4 )
			PLEAT_TILE_CASE( 4, 5 )
			PLEAT_TILE_CASE( 4, 6 )
		default:
			return;
		}
	}
	switch ( NB ) // one row (the rows left after the 4-row tiles)
	{
		PLEAT_TILE_CASE( 1, 1 )
		PLEAT_TILE_CASE( 1, 2 )
		PLEAT_TILE_CASE( 1, 3 )
		PLEAT_TILE_CASE( 1, 4 )
		PLEAT_TILE_CASE( 1, 5 )
		PLEAT_TILE_CASE( 1, 6 )
	default:
		return;
	}
#undef PLEAT_TILE_CASE
}

void plMatMat_Avx512( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					  int weight_fp16, const float* bias, uint32_t in_count, uint32_t row_begin, uint32_t row_end )
{
	if ( weight_fp16 && in_count > PLEAT_MM512_WIDEN_COLUMNS )
	{
		plMatMat_Avx2( out, x, batch_count, weight, weight_fp16, bias, in_count, row_begin, row_end );
		return;
	}
	_Alignas( 64 ) float widened[PLEAT_MM512_ROWS * PLEAT_MM512_WIDEN_COLUMNS];
	for ( uint32_t r = row_begin; r < row_end; )
	{
		int rows = row_end - r >= PLEAT_MM512_ROWS ? PLEAT_MM512_ROWS : 1;
		const float* w = (const float*)weight + (size_t)r * in_count;
		if ( weight_fp16 )
		{
			// The tile's rows widened once (exact) for every instance of the batch.
			const uint16_t* w16 = (const uint16_t*)weight + (size_t)r * in_count;
			size_t count = (size_t)rows * in_count, e = 0;
			for ( ; e + 16 <= count; e += 16 )
			{
				_mm512_store_ps( widened + e, _mm512_cvtph_ps( _mm256_loadu_si256( (const __m256i*)( w16 + e ) ) ) );
			}
			for ( ; e < count; ++e )
			{
				widened[e] = plHalfToFloat( w16[e] );
			}
			w = widened;
		}
		for ( uint32_t b = 0; b < batch_count; b += PLEAT_MM512_INSTANCES )
		{
			int n = batch_count - b >= PLEAT_MM512_INSTANCES ? PLEAT_MM512_INSTANCES : (int)( batch_count - b );
			float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES];
			plTileRows( rows, n, x + b, w, in_count, sum );
			for ( int i = 0; i < rows; ++i )
			{
				for ( int k = 0; k < n; ++k )
				{
					out[b + (uint32_t)k][r + (uint32_t)i] = sum[i][k] + bias[r + (uint32_t)i];
				}
			}
		}
		r += (uint32_t)rows;
	}
}
