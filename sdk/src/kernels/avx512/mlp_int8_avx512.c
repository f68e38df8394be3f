// AVX-512 VNNI twin of plMatVecInt8_Scalar (mlp_int8.c): 64 columns per vpdpbusd, the same int32 row sums as the
// scalar kernel (integer addition, any order), so its bits. The sign trick of mlp_int8_avx2.c in 512-bit form, where
// there is no vpsignb: the weights are negated under the mask of the negative inputs (|q| · (w · sign q) = q · w;
// with the weight in [−127, 127] the negation cannot overflow, and a held input of −128 is 128 as the unsigned
// operand). The last partial step loads under a byte mask (masked-off bytes are neither read nor faulted on) and adds
// zeros for the columns past the end, so there is no scalar tail. The window is quantised and the rows are walked by
// the AVX2 frame (plMatVecInt8Rows_Avx2), which also takes FIRST inputs (int16) itself.
#include "kernels/kernels.h"

#include <immintrin.h>
#include <string.h>

#if defined( PLEAT_HAVE_AVX512VNNI )
__attribute__( ( target( "avx512f,avx512bw,avx512vl,avx512vnni" ) ) ) static void
plDotQuad_Avx512Vnni( const int8_t* q, const int8_t* const rows[4], uint32_t columns, int32_t acc[4] )
{
	__m512i a[4] = { _mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512() };
	const __m512i zero = _mm512_setzero_si512();
	for ( uint32_t c = 0; c < columns; c += 64 )
	{
		__mmask64 in = columns - c >= 64 ? ~(__mmask64)0 : ( (__mmask64)1 << ( columns - c ) ) - 1;
		__m512i qc = _mm512_maskz_loadu_epi8( in, q + c );
		__mmask64 negative = _mm512_movepi8_mask( qc );
		__m512i magnitude = _mm512_abs_epi8( qc );
		for ( int k = 0; k < 4; ++k )
		{
			__m512i w = _mm512_maskz_loadu_epi8( in, rows[k] + c );
			w = _mm512_mask_sub_epi8( w, negative, zero, w );
			a[k] = _mm512_dpbusd_epi32( a[k], magnitude, w );
		}
	}
	for ( int k = 0; k < 4; ++k )
	{
		acc[k] = _mm512_reduce_add_epi32( a[k] );
	}
}

void plMatVecInt8_Avx512Vnni( float* out, const float* x, const plLayer* layer, const int8_t* weight,
							  uint32_t stride, uint32_t col_begin, uint32_t col_end, uint32_t row_begin,
							  uint32_t row_end )
{
	plMatVecInt8Rows_Avx2( out, x, layer, weight, stride, col_begin, col_end, row_begin, row_end,
						   plDotQuad_Avx512Vnni );
}

// ---- the crowd's form (plMatMatInt8Fn, plQuantiseInt8Fn): sixteen instances in the lanes of a vector ----
// The held block is sixteen-instance groups; in a group, four columns of sixteen instances fill a 64-byte line
// (instance i's four bytes at 4i), so one vpdpbusd against a weight dword broadcast to every lane adds four products
// to each of sixteen instances' sums: each weight is read once per group, and no sum needs a horizontal reduction.
// vpdpbusd takes its input unsigned, so each value is held biased, v = q + bias ≥ 0, and bias · Σ w (the row's
// weight_sums) comes off the sum: a HIDDEN q as it is (bias 0), a SYMMETRIC one + 128, a FIRST one + 2048 split into
// two planes of bytes, v = 256 · hi + lo, summed apart and joined as 256 · Σ w · hi + Σ w · lo. The int32 arithmetic
// wraps on the way but the true sum fits (plMatVecInt8Fn), so it is exact. Lanes past the batch hold zeros.

#define PLEAT_VNNI_ROWS 8

static int32_t plHeldBias( uint32_t input )
{
	return input == PLEAT_INT8_INPUT_FIRST ? 2048 : input == PLEAT_INT8_INPUT_SYMMETRIC ? 128 : 0;
}

static uint32_t plHeldPlanes( const plLayer* layer )
{
	return layer->int8_input == PLEAT_INT8_INPUT_FIRST ? 2u : 1u;
}

// Bytes of one group's block: its planes of ⌈in / 4⌉ lines.
static size_t plGroupBytes( const plLayer* layer )
{
	return (size_t)plHeldPlanes( layer ) * ( ( layer->in_count + 3u ) / 4u ) * 64u;
}

void plQuantiseInt8_Avx512Vnni( void* held, const float* const* x, uint32_t batch_count, const plLayer* layer )
{
	_Alignas( 64 ) int16_t q16[PLEAT_MAX_INT8_COLUMNS + 4];
	_Alignas( 64 ) uint8_t planes[2][PLEAT_MAX_INT8_COLUMNS + 4];
	uint32_t in = layer->in_count, lines = ( in + 3u ) / 4u, groups = ( batch_count + 15u ) / 16u;
	int first = layer->int8_input == PLEAT_INT8_INPUT_FIRST;
	memset( held, 0, groups * plGroupBytes( layer ) );
	memset( planes, 0, sizeof( planes ) ); // the columns past `in` up to a whole line: 0 (their weights are 0 too)
	for ( uint32_t b = 0; b < batch_count; ++b )
	{
		uint8_t* group = (uint8_t*)held + ( b / 16u ) * plGroupBytes( layer ) + ( b % 16u ) * 4u;
		if ( first )
		{
			// q + 2048 in 1..4095, as two bytes
			plQuantiseHeld_Avx2( q16, x[b], in, layer );
			for ( uint32_t c = 0; c < in; ++c )
			{
				uint32_t v = (uint32_t)( q16[c] + plHeldBias( PLEAT_INT8_INPUT_FIRST ) );
				planes[0][c] = (uint8_t)( v & 0xFFu );
				planes[1][c] = (uint8_t)( v >> 8 );
			}
		}
		else
		{
			// the held byte (q − 128 for a HIDDEN input, q for a SYMMETRIC one) plus 128 is its top bit flipped
			plQuantiseHeld_Avx2( planes[0], x[b], in, layer );
			for ( uint32_t c = 0; c < in; ++c )
			{
				planes[0][c] ^= 0x80u;
			}
		}
		for ( uint32_t p = 0; p < plHeldPlanes( layer ); ++p )
		{
			for ( uint32_t k = 0; k < lines; ++k ) // four columns of this instance into its lane of line k
			{
				memcpy( group + ( (size_t)p * lines + k ) * 64u, planes[p] + 4u * k, 4 );
			}
		}
	}
}

// Row r's weight dword of line k: its columns 4k..4k+3 of the window, the ones past `columns` zero (never read).
static inline int32_t plWeightDword( const int8_t* row, uint32_t k, uint32_t columns )
{
	int32_t word = 0;
	uint32_t c = 4u * k, n = columns - c < 4u ? columns - c : 4u;
	memcpy( &word, row + c, n );
	return word;
}

__attribute__( ( target( "avx512f,avx512bw,avx512vl,avx512vnni" ) ) ) void
plMatMatInt8_Avx512Vnni( float* const* out, const void* held, uint32_t batch_count, const plLayer* layer,
						 const int8_t* weight, uint32_t stride, uint32_t col_begin, uint32_t columns, uint32_t row_begin,
						 uint32_t row_end )
{
	uint32_t lines = ( columns + 3u ) / 4u, full = columns / 4u, groups = ( batch_count + 15u ) / 16u;
	uint32_t all_lines = ( layer->in_count + 3u ) / 4u;
	int first = layer->int8_input == PLEAT_INT8_INPUT_FIRST;
	int32_t bias = plHeldBias( layer->int8_input );
	float scale_in = layer->input_scale[0];
	for ( uint32_t g = 0; g < groups; ++g )
	{
		const uint8_t* lo = (const uint8_t*)held + g * plGroupBytes( layer ) + (size_t)( col_begin / 4u ) * 64u;
		const uint8_t* hi = lo + (size_t)all_lines * 64u;
		uint32_t lanes = batch_count - 16u * g < 16u ? batch_count - 16u * g : 16u;
		for ( uint32_t r0 = row_begin; r0 < row_end; r0 += PLEAT_VNNI_ROWS )
		{
			const int8_t* rows[PLEAT_VNNI_ROWS];
			for ( uint32_t j = 0; j < PLEAT_VNNI_ROWS; ++j )
			{
				uint32_t r = r0 + j < row_end ? r0 + j : row_end - 1; // past the end: the last row again
				rows[j] = weight + (size_t)r * stride;
			}
			__m512i a[PLEAT_VNNI_ROWS], h[PLEAT_VNNI_ROWS];
			for ( uint32_t j = 0; j < PLEAT_VNNI_ROWS; ++j )
			{
				a[j] = _mm512_setzero_si512();
				h[j] = _mm512_setzero_si512();
			}
			for ( uint32_t k = 0; k < lines; ++k )
			{
				__m512i v = _mm512_loadu_si512( (const void*)( lo + (size_t)k * 64u ) );
				__m512i w[PLEAT_VNNI_ROWS];
				for ( uint32_t j = 0; j < PLEAT_VNNI_ROWS; ++j )
				{
					int32_t word;
					if ( k < full )
					{
						memcpy( &word, rows[j] + 4u * k, 4 );
					}
					else
					{
						word = plWeightDword( rows[j], k, columns );
					}
					w[j] = _mm512_set1_epi32( word );
					a[j] = _mm512_dpbusd_epi32( a[j], v, w[j] );
				}
				if ( first )
				{
					__m512i vh = _mm512_loadu_si512( (const void*)( hi + (size_t)k * 64u ) );
					for ( uint32_t j = 0; j < PLEAT_VNNI_ROWS; ++j )
					{
						h[j] = _mm512_dpbusd_epi32( h[j], vh, w[j] );
					}
				}
			}
			for ( uint32_t j = 0; j < PLEAT_VNNI_ROWS && r0 + j < row_end; ++j )
			{
				uint32_t r = r0 + j;
				__m512i sum = first ? _mm512_add_epi32( _mm512_slli_epi32( h[j], 8 ), a[j] ) : a[j];
				sum = _mm512_sub_epi32( sum, _mm512_set1_epi32( (int32_t)( (uint32_t)bias * (uint32_t)layer->weight_sums[r] ) ) );
				// plDequantise in lanes: a product, then a sum, each rounded (never fused)
				float scale = layer->weight_scale[r] * scale_in;
				__m512 product = _mm512_mul_ps( _mm512_cvtepi32_ps( sum ), _mm512_set1_ps( scale ) );
				_Alignas( 64 ) float y[16];
				_mm512_store_ps( y, _mm512_add_ps( product, _mm512_set1_ps( layer->bias[r] ) ) );
				for ( uint32_t i = 0; i < lanes; ++i )
				{
					out[16u * g + i][r] = y[i];
				}
			}
		}
	}
}

int plCpuHasAvx512Vnni( void )
{
	__builtin_cpu_init();
	// libgcc reports AVX-512 only where the OS saves the ZMM state too.
	return __builtin_cpu_supports( "avx512f" ) && __builtin_cpu_supports( "avx512bw" ) &&
		   __builtin_cpu_supports( "avx512vl" ) && __builtin_cpu_supports( "avx512vnni" );
}
#else
// A translation unit must declare something (ISO C); this build's compiler has no AVX-512 VNNI.
typedef int plNoAvx512Vnni;
#endif
