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
