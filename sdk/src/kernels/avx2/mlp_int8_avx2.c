// AVX2 and AVX-VNNI twins of plMatVecInt8_Scalar (mlp_int8.c). Both form the same int32 row sums by other means, so
// they give the scalar kernel's bits: integer addition does not depend on its order, and the float ends
// (plQuantise's rounding, plDequantise) are the same operations.
//
// The products are int8 × int8, but the instructions multiply unsigned by signed bytes (vpmaddubsw, vpdpbusd). The
// sign moves from the input to the weight: |q| · (w · sign q) = q · w. With q and w in [−127, 127] (the loader refuses
// a −128 weight; plQuantise clamps) |q| fits the unsigned operand and w · sign q the signed one, and vpmaddubsw's two
// products per 16-bit lane sum to at most 2 · 127² = 32258 < 32767: the saturating add never saturates.
// (The other usual scheme, q + 128 as the unsigned operand and 128 · Σw taken off afterwards, overflows vpmaddubsw.)
//
// As in plMatVec_Avx2, four rows from four contiguous row blocks share each input load: four sequential streams.
#include "kernels/kernels.h"

#include <cpuid.h>
#include <immintrin.h>

// q[c] = plQuantise( x[c], inv_scale ) for c < n, 32 at a time: vcvtps2dq rounds to nearest even under the default
// MXCSR as plQuantise's 1.5 · 2²³ trick does, and _mm256_max_ps returns its second operand (the bound) for a NaN as
// fmaxf does; then the four vectors of int32 are packed to bytes (values within ±127, so no saturation) and the
// 128-bit lanes that the packs interleave are put back in order.
static void plQuantiseWindow( int8_t* q, const float* x, uint32_t n, float inv_scale )
{
	const __m256 scale = _mm256_set1_ps( inv_scale ), lo = _mm256_set1_ps( -127.0f ), hi = _mm256_set1_ps( 127.0f );
	const __m256i order = _mm256_setr_epi32( 0, 4, 1, 5, 2, 6, 3, 7 );
	uint32_t c = 0;
	for ( ; c + 32 <= n; c += 32 )
	{
		__m256i v[4];
		for ( int k = 0; k < 4; ++k )
		{
			__m256 t = _mm256_mul_ps( _mm256_loadu_ps( x + c + 8 * k ), scale );
			v[k] = _mm256_cvtps_epi32( _mm256_min_ps( _mm256_max_ps( t, lo ), hi ) );
		}
		__m256i bytes = _mm256_packs_epi16( _mm256_packs_epi32( v[0], v[1] ), _mm256_packs_epi32( v[2], v[3] ) );
		_mm256_storeu_si256( (__m256i*)( q + c ), _mm256_permutevar8x32_epi32( bytes, order ) );
	}
	for ( ; c < n; ++c )
	{
		q[c] = plQuantise( x[c], inv_scale );
	}
}

// The four rows' lane sums at once (three horizontal adds and one 128-bit add instead of four reductions: with 128
// inputs, the decoder's first layer, a row has only four vector steps to share them).
static inline void plHorizontalSums4( const __m256i a[4], int32_t acc[4] )
{
	__m256i h = _mm256_hadd_epi32( _mm256_hadd_epi32( a[0], a[1] ), _mm256_hadd_epi32( a[2], a[3] ) );
	_mm_storeu_si128( (__m128i*)acc, _mm_add_epi32( _mm256_castsi256_si128( h ), _mm256_extracti128_si256( h, 1 ) ) );
}

// The columns past the last full 32, c of them done. With at least 32 columns, one more step over the last 32
// columns (overlapping the done ones) with the done ones' inputs zeroed: a zero input makes a zero product in both
// schemes (|0| = 0), so the sum gains exactly the missing products. A scalar tail of 9 columns (the t-shirt's 681
// inputs) cost as much as a quarter of the row's vector steps. Narrower windows take the scalar products.
static inline __m256i plTailInputs( const int8_t* q, uint32_t c, uint32_t columns )
{
	const __m256i lane = _mm256_setr_epi8( 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20,
										   21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31 );
	__m256i done = _mm256_set1_epi8( (char)( c - ( columns - 32 ) - 1 ) ); // lanes up to this one are counted
	__m256i keep = _mm256_cmpgt_epi8( lane, done );
	return _mm256_and_si256( _mm256_loadu_si256( (const __m256i*)( q + columns - 32 ) ), keep );
}

static inline void plDotTail( const int8_t* q, const int8_t* const rows[4], uint32_t c, uint32_t columns,
							  int32_t acc[4] )
{
	for ( ; c < columns; ++c )
	{
		for ( int k = 0; k < 4; ++k )
		{
			acc[k] += (int32_t)rows[k][c] * (int32_t)q[c];
		}
	}
}

// vpmaddubsw: 16-bit sums of two products, widened to 32 bits by vpmaddwd with ones.
static void plDotQuad_Avx2( const int8_t* q, const int8_t* const rows[4], uint32_t columns, int32_t acc[4] )
{
	const __m256i ones = _mm256_set1_epi16( 1 );
	__m256i a[4] = { _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256() };
	uint32_t c = 0;
	for ( ; c + 32 <= columns; c += 32 )
	{
		__m256i qc = _mm256_loadu_si256( (const __m256i*)( q + c ) );
		__m256i magnitude = _mm256_abs_epi8( qc );
		for ( int k = 0; k < 4; ++k )
		{
			__m256i w = _mm256_sign_epi8( _mm256_loadu_si256( (const __m256i*)( rows[k] + c ) ), qc );
			a[k] = _mm256_add_epi32( a[k], _mm256_madd_epi16( _mm256_maddubs_epi16( magnitude, w ), ones ) );
		}
	}
	if ( c < columns && columns >= 32 )
	{
		__m256i qc = plTailInputs( q, c, columns );
		__m256i magnitude = _mm256_abs_epi8( qc );
		for ( int k = 0; k < 4; ++k )
		{
			__m256i w = _mm256_sign_epi8( _mm256_loadu_si256( (const __m256i*)( rows[k] + columns - 32 ) ), qc );
			a[k] = _mm256_add_epi32( a[k], _mm256_madd_epi16( _mm256_maddubs_epi16( magnitude, w ), ones ) );
		}
		c = columns;
	}
	plHorizontalSums4( a, acc );
	plDotTail( q, rows, c, columns, acc );
}

void plMatVecInt8Rows_Avx2( float* out, const float* x, const int8_t* weight, const float* weight_scale,
							float input_scale, float input_inv_scale, const float* bias, uint32_t in_count,
							uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end,
							plInt8DotQuadFn* quad )
{
	_Alignas( 64 ) int8_t q[PLEAT_MAX_INT8_COLUMNS];
	uint32_t columns = col_end - col_begin, n = row_end - row_begin, blocks = ( n + 3 ) / 4;
	plQuantiseWindow( q, x + col_begin, columns, input_inv_scale );
	// Four contiguous row blocks of `blocks` rows; the fourth may be short, and its missing rows repeat its last.
	for ( uint32_t i = 0; i < blocks; ++i )
	{
		uint32_t rows[4];
		const int8_t* w[4];
		for ( uint32_t k = 0; k < 4; ++k )
		{
			uint32_t r = row_begin + k * blocks + i;
			rows[k] = r < row_end ? r : row_end - 1;
			w[k] = weight + (size_t)rows[k] * in_count + col_begin;
		}
		int32_t acc[4];
		quad( q, w, columns, acc );
		for ( uint32_t k = 0; k < 4; ++k )
		{
			out[rows[k]] = plDequantise( acc[k], weight_scale[rows[k]], input_scale, bias[rows[k]] );
		}
	}
}

void plMatVecInt8_Avx2( float* out, const float* x, const int8_t* weight, const float* weight_scale,
						float input_scale, float input_inv_scale, const float* bias, uint32_t in_count,
						uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	plMatVecInt8Rows_Avx2( out, x, weight, weight_scale, input_scale, input_inv_scale, bias, in_count, col_begin,
						   col_end, row_begin, row_end, plDotQuad_Avx2 );
}

#if defined( PLEAT_HAVE_AVXVNNI )
// AVX-VNNI (VEX vpdpbusd, Alder Lake and later): four u8 × s8 products summed into each int32 lane in one
// instruction, with no 16-bit intermediate to saturate.
__attribute__( ( target( "avx2,avxvnni" ) ) ) static void plDotQuad_AvxVnni( const int8_t* q, const int8_t* const rows[4],
																		  uint32_t columns, int32_t acc[4] )
{
	__m256i a[4] = { _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256() };
	uint32_t c = 0;
	for ( ; c + 32 <= columns; c += 32 )
	{
		__m256i qc = _mm256_loadu_si256( (const __m256i*)( q + c ) );
		__m256i magnitude = _mm256_abs_epi8( qc );
		for ( int k = 0; k < 4; ++k )
		{
			__m256i w = _mm256_sign_epi8( _mm256_loadu_si256( (const __m256i*)( rows[k] + c ) ), qc );
			a[k] = _mm256_dpbusd_avx_epi32( a[k], magnitude, w );
		}
	}
	if ( c < columns && columns >= 32 )
	{
		__m256i qc = plTailInputs( q, c, columns );
		__m256i magnitude = _mm256_abs_epi8( qc );
		for ( int k = 0; k < 4; ++k )
		{
			__m256i w = _mm256_sign_epi8( _mm256_loadu_si256( (const __m256i*)( rows[k] + columns - 32 ) ), qc );
			a[k] = _mm256_dpbusd_avx_epi32( a[k], magnitude, w );
		}
		c = columns;
	}
	plHorizontalSums4( a, acc );
	plDotTail( q, rows, c, columns, acc );
}

void plMatVecInt8_AvxVnni( float* out, const float* x, const int8_t* weight, const float* weight_scale,
						   float input_scale, float input_inv_scale, const float* bias, uint32_t in_count,
						   uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	plMatVecInt8Rows_Avx2( out, x, weight, weight_scale, input_scale, input_inv_scale, bias, in_count, col_begin,
						   col_end, row_begin, row_end, plDotQuad_AvxVnni );
}

// AVX-VNNI is CPUID leaf 7, sub-leaf 1, EAX bit 4. Read it directly: clang 14 (Debian 12's) has no "avxvnni" name
// for __builtin_cpu_supports. AVX2 being usable (checked by the builtin) already means the OS saves the YMM state.
int plCpuHasAvxVnni( void )
{
	__builtin_cpu_init();
	if ( !__builtin_cpu_supports( "avx2" ) )
	{
		return 0;
	}
	unsigned int eax = 0, ebx = 0, ecx = 0, edx = 0;
	if ( !__get_cpuid_count( 7, 1, &eax, &ebx, &ecx, &edx ) )
	{
		return 0;
	}
	return ( eax >> 4 ) & 1u;
}
#endif
