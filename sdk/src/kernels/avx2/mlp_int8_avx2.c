// AVX2 and AVX-VNNI twins of plMatVecInt8_Scalar (mlp_int8.c). Both form the same int32 row sums by other means, so
// they give the scalar kernel's bits: integer addition does not depend on its order, and the float ends
// (plQuantise's rounding, plDequantise) are the same operations.
//
// The products are int8 × int8, but the instructions multiply unsigned by signed bytes (vpmaddubsw, vpdpbusd). The
// sign moves from the input to the weight: |q| · (w · sign q) = q · w. With w in [−127, 127] (the loader refuses a
// −128 weight) and the held input in [−128, 127] (a SYMMETRIC input within ±127, a HIDDEN one as q − 128), |q| ≤ 128
// fits the unsigned operand and w · sign q the signed one, and vpmaddubsw's two products per 16-bit lane sum to at
// most 2 · 128 · 127 = 32512 < 32767: the saturating add never saturates. (The other usual scheme, q + 128 as the
// unsigned operand and 128 · Σw taken off afterwards, overflows vpmaddubsw.) A FIRST input (12 bits) is held as int16
// and multiplied by the weights widened to int16 (vpmaddwd), 16 columns a step.
//
// As in plMatVec_Avx2, four rows from four contiguous row blocks share each input load: four sequential streams.
#include "kernels/kernels.h"

#include <cpuid.h>
#include <immintrin.h>

// q[c] = plQuantiseInput( x[c], inv_scale, input ) for c < n, 32 at a time (SYMMETRIC or HIDDEN inputs, held in
// bytes): vcvtps2dq rounds to nearest even under the default MXCSR as the 1.5 · 2²³ trick does, and _mm256_max_ps
// returns its second operand (the bound) for a NaN as fmaxf does; the held offset comes off in int32, then the four
// vectors are packed to bytes (values within [−128, 127], so no saturation) and the 128-bit lanes that the packs
// interleave are put back in order.
static void plQuantiseWindow( int8_t* q, const float* x, uint32_t n, float inv_scale, uint32_t input )
{
	const __m256 scale = _mm256_set1_ps( inv_scale ), lo = _mm256_set1_ps( plInt8InputLow( input ) ),
				 hi = _mm256_set1_ps( plInt8InputHigh( input ) );
	const __m256i held = _mm256_set1_epi32( plInt8InputHeldOffset( input ) );
	const __m256i order = _mm256_setr_epi32( 0, 4, 1, 5, 2, 6, 3, 7 );
	uint32_t c = 0;
	for ( ; c + 32 <= n; c += 32 )
	{
		__m256i v[4];
		for ( int k = 0; k < 4; ++k )
		{
			__m256 t = _mm256_mul_ps( _mm256_loadu_ps( x + c + 8 * k ), scale );
			v[k] = _mm256_sub_epi32( _mm256_cvtps_epi32( _mm256_min_ps( _mm256_max_ps( t, lo ), hi ) ), held );
		}
		__m256i bytes = _mm256_packs_epi16( _mm256_packs_epi32( v[0], v[1] ), _mm256_packs_epi32( v[2], v[3] ) );
		_mm256_storeu_si256( (__m256i*)( q + c ), _mm256_permutevar8x32_epi32( bytes, order ) );
	}
	for ( ; c < n; ++c )
	{
		q[c] = (int8_t)plQuantiseInput( x[c], inv_scale, input );
	}
}

// The same for a FIRST input, held in int16, 16 at a time (the pack interleaves 64-bit quarters: put back in order).
static void plQuantiseWindowWide( int16_t* q, const float* x, uint32_t n, float inv_scale )
{
	const __m256 scale = _mm256_set1_ps( inv_scale ), lo = _mm256_set1_ps( plInt8InputLow( PLEAT_INT8_INPUT_FIRST ) ),
				 hi = _mm256_set1_ps( plInt8InputHigh( PLEAT_INT8_INPUT_FIRST ) );
	uint32_t c = 0;
	for ( ; c + 16 <= n; c += 16 )
	{
		__m256i v[2];
		for ( int k = 0; k < 2; ++k )
		{
			__m256 t = _mm256_mul_ps( _mm256_loadu_ps( x + c + 8 * k ), scale );
			v[k] = _mm256_cvtps_epi32( _mm256_min_ps( _mm256_max_ps( t, lo ), hi ) );
		}
		__m256i words = _mm256_permute4x64_epi64( _mm256_packs_epi32( v[0], v[1] ), 0xD8 );
		_mm256_storeu_si256( (__m256i*)( q + c ), words );
	}
	for ( ; c < n; ++c )
	{
		q[c] = (int16_t)plQuantiseInput( x[c], inv_scale, PLEAT_INT8_INPUT_FIRST );
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

// A FIRST input's four rows: the weights widened to int16 (vpmovsxbw) times the int16 inputs, pairs summed into int32
// (vpmaddwd: two products of at most 127 · 2047, no overflow), 16 columns a step; the rest scalar.
static void plDotQuadWide_Avx2( const int16_t* q, const int8_t* const rows[4], uint32_t columns, int32_t acc[4] )
{
	__m256i a[4] = { _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256() };
	uint32_t c = 0;
	for ( ; c + 16 <= columns; c += 16 )
	{
		__m256i qc = _mm256_loadu_si256( (const __m256i*)( q + c ) );
		for ( int k = 0; k < 4; ++k )
		{
			__m256i w = _mm256_cvtepi8_epi16( _mm_loadu_si128( (const __m128i*)( rows[k] + c ) ) );
			a[k] = _mm256_add_epi32( a[k], _mm256_madd_epi16( w, qc ) );
		}
	}
	plHorizontalSums4( a, acc );
	for ( ; c < columns; ++c )
	{
		for ( int k = 0; k < 4; ++k )
		{
			acc[k] += (int32_t)rows[k][c] * (int32_t)q[c];
		}
	}
}

void plMatVecInt8Rows_Avx2( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
							uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end,
							plInt8DotQuadFn* quad )
{
	_Alignas( 64 ) int16_t held[PLEAT_MAX_INT8_COLUMNS]; // int16 for a FIRST input, else its first bytes as int8
	int8_t* q = (int8_t*)held;                          // (a char type: may alias the int16 buffer)
	uint32_t columns = col_end - col_begin, n = row_end - row_begin, blocks = ( n + 3 ) / 4;
	int wide = layer->int8_input == PLEAT_INT8_INPUT_FIRST;
	plQuantiseHeld_Avx2( held, x + col_begin, columns, layer );
	// Four contiguous row blocks of `blocks` rows; the fourth may be short, and its missing rows repeat its last.
	for ( uint32_t i = 0; i < blocks; ++i )
	{
		uint32_t rows[4];
		const int8_t* w[4];
		for ( uint32_t k = 0; k < 4; ++k )
		{
			uint32_t r = row_begin + k * blocks + i;
			rows[k] = r < row_end ? r : row_end - 1;
			w[k] = weight + (size_t)rows[k] * stride + col_begin;
		}
		int32_t acc[4];
		if ( wide )
		{
			plDotQuadWide_Avx2( held, w, columns, acc );
		}
		else
		{
			quad( q, w, columns, acc );
		}
		for ( uint32_t k = 0; k < 4; ++k )
		{
			out[rows[k]] = plDequantise( acc[k] + plInt8RowOffset( layer, rows[k] ), layer->weight_scale[rows[k]],
										 layer->input_scale[0], layer->bias[rows[k]] );
		}
	}
}

void plMatVecInt8_Avx2( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
						uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	plMatVecInt8Rows_Avx2( out, x, layer, weight, stride, col_begin, col_end, row_begin, row_end, plDotQuad_Avx2 );
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

void plMatVecInt8_AvxVnni( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
						   uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end )
{
	plMatVecInt8Rows_Avx2( out, x, layer, weight, stride, col_begin, col_end, row_begin, row_end, plDotQuad_AvxVnni );
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

// One instance's input quantised as the single kernel does (plQuantiseInput's values; int16 for a FIRST input, else
// int8), for the crowd's layouts (mlp_int8_avx512.c).
void plQuantiseHeld_Avx2( void* held, const float* x, uint32_t count, const plLayer* layer )
{
	if ( layer->int8_input == PLEAT_INT8_INPUT_FIRST )
	{
		plQuantiseWindowWide( (int16_t*)held, x, count, layer->input_inv_scale );
	}
	else
	{
		plQuantiseWindow( (int8_t*)held, x, count, layer->input_inv_scale, layer->int8_input );
	}
}
