// AVX-512 VNNI twin of plMatVecInt8_Scalar (mlp_int8.c): 64 columns per vpdpbusd, the same int32 row sums as the
// scalar kernel (integer addition, any order), so its bits. The sign trick of mlp_int8_avx2.c in 512-bit form, where
// there is no vpsignb: the weights are negated under the mask of the negative inputs (|q| · (w · sign q) = q · w;
// with the weight in [−127, 127] the negation cannot overflow, and a held input of −128 is 128 as the unsigned
// operand). The last partial step loads under a byte mask (masked-off bytes are neither read nor faulted on) and adds
// zeros for the columns past the end, so there is no scalar tail. The window is quantised and the rows are walked by
// the AVX2 frame (plMatVecInt8Rows_Avx2), which also takes FIRST inputs (int16) itself.
#include "kernels/kernels.h"

#include <immintrin.h>

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

// ---- the crowd's form (plMatMatInt8Fn): four rows × four instances per step, each weight vector loaded once ----
// Without the sign trick where it can be left out: a HIDDEN input's true q (0..255) is its held q − 128 with the top
// bit flipped, and vpdpbusd takes it unsigned as it is (its four products go straight into 32 bits, nothing
// saturates), so the sum is Σ w · q with no offset to add; a FIRST input's int16 meets the weights widened to int16 in
// vpdpwssd. Only a SYMMETRIC input still moves its sign onto the weight, per row and instance.

#define PLEAT_VNNI_ROWS 4
#define PLEAT_VNNI_INSTANCES 4

// The sums of the 4 × 4 accumulators, acc[k][i] for row k and instance i.
__attribute__( ( target( "avx512f,avx512bw,avx512vl,avx512vnni" ) ) ) static void
plReduce4x4( __m512i a[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES], int32_t acc[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES] )
{
	for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
	{
		__m256i h[PLEAT_VNNI_INSTANCES];
		for ( int i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
		{
			h[i] = _mm256_add_epi32( _mm512_castsi512_si256( a[k][i] ), _mm512_extracti64x4_epi64( a[k][i], 1 ) );
		}
		__m256i t = _mm256_hadd_epi32( _mm256_hadd_epi32( h[0], h[1] ), _mm256_hadd_epi32( h[2], h[3] ) );
		_mm_storeu_si128( (__m128i*)acc[k],
						  _mm_add_epi32( _mm256_castsi256_si128( t ), _mm256_extracti128_si256( t, 1 ) ) );
	}
}

// Rows rows[0..3] against instances q[0..3] (repeats of the last where fewer), held bytes; `hidden`: unsigned q.
__attribute__( ( target( "avx512f,avx512bw,avx512vl,avx512vnni" ) ) ) static void
plDotBlockBytes( const int8_t* const rows[PLEAT_VNNI_ROWS], const int8_t* const q[PLEAT_VNNI_INSTANCES], uint32_t columns,
				 int hidden, int32_t acc[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES] )
{
	__m512i a[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES];
	for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
	{
		for ( int i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
		{
			a[k][i] = _mm512_setzero_si512();
		}
	}
	const __m512i flip = _mm512_set1_epi8( (char)0x80 ), zero = _mm512_setzero_si512();
	for ( uint32_t c = 0; c < columns; c += 64 )
	{
		__mmask64 in = columns - c >= 64 ? ~(__mmask64)0 : ( (__mmask64)1 << ( columns - c ) ) - 1;
		__m512i w[PLEAT_VNNI_ROWS];
		for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
		{
			w[k] = _mm512_maskz_loadu_epi8( in, rows[k] + c );
		}
		for ( int i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
		{
			__m512i qc = _mm512_maskz_loadu_epi8( in, q[i] + c );
			if ( hidden )
			{
				// q − 128 back to q, unsigned (a masked-off column becomes 128 against a weight of 0)
				__m512i u = _mm512_xor_si512( qc, flip );
				for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
				{
					a[k][i] = _mm512_dpbusd_epi32( a[k][i], u, w[k] );
				}
			}
			else
			{
				__mmask64 negative = _mm512_movepi8_mask( qc );
				__m512i magnitude = _mm512_abs_epi8( qc );
				for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
				{
					a[k][i] = _mm512_dpbusd_epi32( a[k][i], magnitude, _mm512_mask_sub_epi8( w[k], negative, zero, w[k] ) );
				}
			}
		}
	}
	plReduce4x4( a, acc );
}

// The same for int16 (FIRST) inputs: 32 columns a step, the weights widened once per step.
__attribute__( ( target( "avx512f,avx512bw,avx512vl,avx512vnni" ) ) ) static void
plDotBlockWords( const int8_t* const rows[PLEAT_VNNI_ROWS], const int16_t* const q[PLEAT_VNNI_INSTANCES], uint32_t columns,
				 int32_t acc[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES] )
{
	__m512i a[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES];
	for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
	{
		for ( int i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
		{
			a[k][i] = _mm512_setzero_si512();
		}
	}
	for ( uint32_t c = 0; c < columns; c += 32 )
	{
		__mmask32 in = columns - c >= 32 ? ~(__mmask32)0 : ( (__mmask32)1 << ( columns - c ) ) - 1;
		__m512i w[PLEAT_VNNI_ROWS];
		for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
		{
			w[k] = _mm512_cvtepi8_epi16( _mm256_maskz_loadu_epi8( in, rows[k] + c ) );
		}
		for ( int i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
		{
			__m512i qc = _mm512_maskz_loadu_epi16( in, q[i] + c );
			for ( int k = 0; k < PLEAT_VNNI_ROWS; ++k )
			{
				a[k][i] = _mm512_dpwssd_epi32( a[k][i], qc, w[k] );
			}
		}
	}
	plReduce4x4( a, acc );
}

void plMatMatInt8_Avx512Vnni( float* const* out, const void* const* held, uint32_t batch_count, const plLayer* layer,
							  const int8_t* weight, uint32_t stride, uint32_t columns, uint32_t row_begin,
							  uint32_t row_end )
{
	int wide = layer->int8_input == PLEAT_INT8_INPUT_FIRST, hidden = layer->int8_input == PLEAT_INT8_INPUT_HIDDEN;
	for ( uint32_t r0 = row_begin; r0 < row_end; r0 += PLEAT_VNNI_ROWS )
	{
		uint32_t rows[PLEAT_VNNI_ROWS];
		const int8_t* w[PLEAT_VNNI_ROWS];
		for ( uint32_t k = 0; k < PLEAT_VNNI_ROWS; ++k )
		{
			rows[k] = r0 + k < row_end ? r0 + k : row_end - 1; // past the end: the last row again
			w[k] = weight + (size_t)rows[k] * stride;
		}
		for ( uint32_t b0 = 0; b0 < batch_count; b0 += PLEAT_VNNI_INSTANCES )
		{
			uint32_t inst[PLEAT_VNNI_INSTANCES];
			const void* q[PLEAT_VNNI_INSTANCES];
			for ( uint32_t i = 0; i < PLEAT_VNNI_INSTANCES; ++i )
			{
				inst[i] = b0 + i < batch_count ? b0 + i : batch_count - 1;
				q[i] = held[inst[i]];
			}
			int32_t acc[PLEAT_VNNI_ROWS][PLEAT_VNNI_INSTANCES];
			if ( wide )
			{
				plDotBlockWords( w, (const int16_t* const*)q, columns, acc );
			}
			else
			{
				plDotBlockBytes( w, (const int8_t* const*)q, columns, hidden, acc );
			}
			for ( uint32_t k = 0; k < PLEAT_VNNI_ROWS && r0 + k < row_end; ++k )
			{
				// a SYMMETRIC or FIRST sum is complete; a HIDDEN one was taken unsigned, so its offset is in it
				for ( uint32_t i = 0; i < PLEAT_VNNI_INSTANCES && b0 + i < batch_count; ++i )
				{
					uint32_t r = rows[k];
					out[inst[i]][r] = plDequantise( acc[k][i], layer->weight_scale[r], layer->input_scale[0],
													layer->bias[r] );
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
