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
#include "kernels/kernels_batch.h"
#include "kernels/avx2/simd_avx2.h"

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

// dst[c] = the fp16 weight w16[c] as float for c < columns (exact), 16 at a time.
static inline void plWidenRow( float* dst, const uint16_t* w16, uint32_t columns )
{
	uint32_t c = 0;
	for ( ; c + 16 <= columns; c += 16 )
	{
		_mm512_storeu_ps( dst + c, _mm512_cvtph_ps( _mm256_loadu_si256( (const __m256i*)( w16 + c ) ) ) );
	}
	for ( ; c < columns; ++c )
	{
		dst[c] = _cvtsh_ss( w16[c] );
	}
}

// sum[r][b] = plDotRow2( x[b], w, 0, r · stride, in_count ) for r < R, b < NB (R, NB compile-time after inlining).
static PLEAT_ALWAYS_INLINE void plTile512( const int R, const int NB, const float* const* x, const float* w,
										   size_t stride, uint32_t in_count,
										   float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES] )
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
			wv[r] = _mm512_loadu_ps( w + (size_t)r * stride + c );
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
		const float* wr = w + (size_t)r * stride;
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

// Rows [r, r + R) of instances [b, b + NB) with the tile's (fp32) rows at w, `stride` floats apart.
static void plTileRows( int R, int NB, const float* const* x, const float* w, size_t stride, uint32_t in_count,
						float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES] )
{
#define PLEAT_TILE_CASE( rows, n )                                                                                     \
	case n:                                                                                                            \
		plTile512( rows, n, x, w, stride, in_count, sum );                                                             \
		return;
	if ( R == PLEAT_MM512_ROWS )
	{
		switch ( NB )
		{
			PLEAT_TILE_CASES_1_TO_6( PLEAT_TILE_CASE, 4 )
		default:
			return;
		}
	}
	switch ( NB ) // one row (the rows left after the 4-row tiles)
	{
		PLEAT_TILE_CASES_1_TO_6( PLEAT_TILE_CASE, 1 )
	default:
		return;
	}
#undef PLEAT_TILE_CASE
}

void plMatMat_Avx512( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
					  int weight_fp16, const float* bias, uint32_t in_count, uint32_t col_begin, uint32_t col_end,
					  uint32_t row_begin, uint32_t row_end )
{
	uint32_t columns = col_end - col_begin;
	if ( weight_fp16 && columns > PLEAT_MM512_WIDEN_COLUMNS )
	{
		plMatMat_Avx2( out, x, batch_count, weight, weight_fp16, bias, in_count, col_begin, col_end, row_begin,
					   row_end );
		return;
	}
	_Alignas( 64 ) float widened[PLEAT_MM512_ROWS * PLEAT_MM512_WIDEN_COLUMNS];
	for ( uint32_t r = row_begin; r < row_end; )
	{
		int rows = row_end - r >= PLEAT_MM512_ROWS ? PLEAT_MM512_ROWS : 1;
		const float* w = (const float*)weight + (size_t)r * in_count + col_begin;
		size_t stride = in_count;
		if ( weight_fp16 )
		{
			// The tile's rows (their windows) widened once (exact) for every instance of the batch.
			for ( int i = 0; i < rows; ++i )
			{
				plWidenRow( widened + (size_t)i * columns,
							(const uint16_t*)weight + (size_t)( r + (uint32_t)i ) * in_count + col_begin, columns );
			}
			w = widened;
			stride = columns;
		}
		for ( uint32_t b = 0; b < batch_count; b += PLEAT_MM512_INSTANCES )
		{
			int n = batch_count - b >= PLEAT_MM512_INSTANCES ? PLEAT_MM512_INSTANCES : (int)( batch_count - b );
			const float* window[PLEAT_MM512_INSTANCES];
			for ( int k = 0; k < n; ++k )
			{
				window[k] = x[b + (uint32_t)k] + col_begin;
			}
			float sum[PLEAT_MM512_ROWS][PLEAT_MM512_INSTANCES];
			plTileRows( rows, n, window, w, stride, columns, sum );
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

// ---- the lanes form: sixteen instances per vector (plMatMatLanesFn, kernels_batch.h) ----
//
// Here a vector holds one partial sum of sixteen instances instead of sixteen partial sums of one: plDotRow2's 16
// partial sums of a (row, instance) — lanes 0-7 of its even chain, 0-7 of its odd chain — become 16 accumulators
// whose lanes are the instances, each an FMA chain over the same columns in the same order, from the transposed
// inputs x^T[c][instance] and the weight W[r][c] broadcast. Then the same additions as plDotRow2's end: even + odd
// per lane, the halves, the pairs, the last two (plHorizontalSum's order), the fmaf tail, + bias; all vertical, for
// sixteen instances at once. Per column and 3 rows: one 16-wide load and 3 FMAs with a broadcast operand, against
// 10 loads for 24 FMAs in plMatMat_Avx512's tile, and no horizontal sums; the outputs stay transposed for the next
// layer.

// Rows [r, r + R) of lane group xt ([in][16]) into yt ([out_count][16]), one half (even = 0: columns 16k + l and the
// final 8-wide step's; odd = 1: columns 16k + 8 + l) of the partial sums into acc[R][8].
static PLEAT_ALWAYS_INLINE void plLanesHalf( const int R, int odd, const float* const w[3], const float* xt,
											 uint32_t in_count, const char* const* ahead, size_t ahead_step,
											 __m512 acc[3][8] )
{
	__m512 a[3][8];
	for ( int r = 0; r < R; ++r )
	{
		for ( int l = 0; l < 8; ++l )
		{
			a[r][l] = _mm512_setzero_ps();
		}
	}
	// Pointers that step 16 columns at a time, so every operand below is a constant offset from one of four registers.
	uint32_t steps = in_count / 16, first = odd ? 8u : 0u;
	const float* x = xt + (size_t)first * 16;
	const float *w0 = w[0] + first, *w1 = w[R > 1 ? 1 : 0] + first, *w2 = w[R > 2 ? 2 : 0] + first;
	for ( uint32_t k = 0; k <= steps; ++k, x += 16 * 16, w0 += 16, w1 += 16, w2 += 16 )
	{
		if ( ahead != NULL )
		{
			// the next row tile's weights, a line per row per step (they come from memory: other stages of the step
			// have evicted the networks since the last batch)
			for ( int r = 0; r < 3; ++r )
			{
				_mm_prefetch( ahead[r] + ahead_step * k, _MM_HINT_T0 );
			}
		}
		if ( k == steps && ( odd || in_count - 16 * steps < 8 ) )
		{
			break; // the final 8-wide step belongs to the even chain only, and only when 8 columns are left
		}
		for ( int l = 0; l < 8; ++l )
		{
			__m512 xv = _mm512_load_ps( x + 16 * l );
#if defined( __GNUC__ ) || defined( __clang__ )
			// One load into a register for the R FMAs, each taking its weight as a broadcast memory operand (left
			// alone, GCC 12 folds this load into every FMA and broadcasts the weights separately: twice the loads).
			__asm__( "" : "+v"( xv ) );
#endif
			a[0][l] = _mm512_fmadd_ps( _mm512_set1_ps( w0[l] ), xv, a[0][l] );
			if ( R > 1 )
			{
				a[1][l] = _mm512_fmadd_ps( _mm512_set1_ps( w1[l] ), xv, a[1][l] );
			}
			if ( R > 2 )
			{
				a[2][l] = _mm512_fmadd_ps( _mm512_set1_ps( w2[l] ), xv, a[2][l] );
			}
		}
	}
	for ( int r = 0; r < R; ++r )
	{
		for ( int l = 0; l < 8; ++l )
		{
			acc[r][l] = a[r][l];
		}
	}
}

static PLEAT_ALWAYS_INLINE void plLanesRows( const int R, const float* const w[3], const float* bias, const float* xt,
											 uint32_t in_count, const char* const* ahead, size_t ahead_step,
											 float* yt )
{
	__m512 even[3][8], odd[3][8];
	plLanesHalf( R, 0, w, xt, in_count, ahead, ahead_step, even );
	plLanesHalf( R, 1, w, xt, in_count, NULL, 0, odd );
	uint32_t tail = in_count - in_count % 8;
	for ( int r = 0; r < R; ++r )
	{
		__m512 v[8];
		for ( int l = 0; l < 8; ++l )
		{
			v[l] = _mm512_add_ps( even[r][l], odd[r][l] );
		}
		__m512 t0 = _mm512_add_ps( v[0], v[4] ), t1 = _mm512_add_ps( v[1], v[5] );
		__m512 t2 = _mm512_add_ps( v[2], v[6] ), t3 = _mm512_add_ps( v[3], v[7] );
		__m512 s = _mm512_add_ps( _mm512_add_ps( t0, t2 ), _mm512_add_ps( t1, t3 ) );
		for ( uint32_t c = tail; c < in_count; ++c )
		{
			s = _mm512_fmadd_ps( _mm512_set1_ps( w[r][c] ), _mm512_load_ps( xt + (size_t)c * 16 ), s );
		}
		_mm512_store_ps( yt + (size_t)r * 16, _mm512_add_ps( s, _mm512_set1_ps( bias[r] ) ) );
	}
}

void plMatMatLanes_Avx512( float* yt, const float* xt, uint32_t group_count, const void* window,
						   size_t weight_stride, int weight_fp16, const float* bias, uint32_t in_count,
						   uint32_t out_count, uint32_t col_begin, uint32_t col_end, uint32_t row_begin,
						   uint32_t row_end )
{
	uint32_t columns = col_end - col_begin;
	size_t row_bytes = weight_stride * ( weight_fp16 ? 2 : 4 ), ahead_step = weight_fp16 ? 32 : 64; // 16 columns' bytes
	_Alignas( 64 ) float widened[3 * PLEAT_MM512_WIDEN_COLUMNS];
	for ( uint32_t r = row_begin; r < row_end; )
	{
		int rows = row_end - r >= 3 ? 3 : (int)( row_end - r );
		const float* w[3];
		for ( int i = 0; i < 3; ++i )
		{
			const char* row = (const char*)window + (size_t)( r + (uint32_t)( i < rows ? i : 0 ) ) * row_bytes;
			w[i] = (const float*)row;
			if ( weight_fp16 )
			{
				// widened once per row tile for every lane group (exact); the caller keeps the window within the buffer
				float* dst = widened + (size_t)i * PLEAT_MM512_WIDEN_COLUMNS;
				plWidenRow( dst, (const uint16_t*)row, columns );
				w[i] = dst;
			}
		}
		// The next tile's rows, a line per row per 16-column step of the first group (fp16 rows, half as long, take
		// each line twice): other stages of the step have evicted the networks since the last batch, and the widening
		// stalled on them (a fifth of this kernel's time with fp16 weights, measured) without.
		const char* next[3];
		int prefetch = r + 3 < row_end;
		for ( int i = 0; i < 3; ++i )
		{
			uint32_t row = r + 3 + (uint32_t)i < row_end ? r + 3 + (uint32_t)i : r + 3;
			next[i] = (const char*)window + (size_t)( prefetch ? row : 0 ) * row_bytes;
		}
		for ( uint32_t g = 0; g < group_count; ++g )
		{
			const float* x = xt + ( (size_t)g * in_count + col_begin ) * 16;
			float* y = yt + ( (size_t)g * out_count + r ) * 16;
			const char* const* ahead = prefetch && g == 0 ? next : NULL;
			if ( rows == 3 )
			{
				plLanesRows( 3, w, bias + r, x, columns, ahead, ahead_step, y );
			}
			else if ( rows == 2 )
			{
				plLanesRows( 2, w, bias + r, x, columns, ahead, ahead_step, y );
			}
			else
			{
				plLanesRows( 1, w, bias + r, x, columns, ahead, ahead_step, y );
			}
		}
		r += (uint32_t)rows;
	}
}
