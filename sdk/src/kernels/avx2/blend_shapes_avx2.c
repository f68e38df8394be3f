// AVX2 + FMA (+ F16C) twin of plBlendShapes_Scalar. Four blend shapes per pass over the whole vertex range: four long
// sequential streams that the hardware prefetchers follow (the [N][3] accumulator, 53 KB at N = 4,424, stays in L2).
// Short per-chunk streams (128 shapes × a few KB) measured ~30 % slower stand-alone and ~15 % per step
// (docs/benchmarks.md). Per element the FMAs run in ascending j, as in the scalar kernel and for any vertex split.
#include "kernels/kernels.h"
#include "simd_avx2.h"

void plBlendShapes_Avx2( float* out, const float* base, const plBlendShapes* shapes, const float* weights,
						 uint32_t blend_count, uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	const plBlendShapes sh = *shapes; // a local copy: stores to out cannot alias it, so its type stays in a register
	size_t plane = (size_t)vertex_count * 3;
	size_t start = (size_t)v_begin * 3, end = (size_t)v_end * 3;
	size_t vec_end = start + ( ( end - start ) & ~(size_t)7 );
	if ( blend_count < 4 )
	{
		for ( size_t i = start; i < end; ++i )
		{
			out[i] = base[i];
		}
	}
	uint32_t j = 0;
	for ( ; j + 4 <= blend_count; j += 4 )
	{
		__m256 w0 = _mm256_set1_ps( weights[j] ), w1 = _mm256_set1_ps( weights[j + 1] );
		__m256 w2 = _mm256_set1_ps( weights[j + 2] ), w3 = _mm256_set1_ps( weights[j + 3] );
		size_t o0 = j * plane, o1 = o0 + plane, o2 = o1 + plane, o3 = o2 + plane;
		const float* acc = j == 0 ? base : out; // the first pass starts from T + G_S(β): no separate copy pass
		for ( size_t i = start; i < vec_end; i += 8 )
		{
			__m256 a = _mm256_loadu_ps( acc + i );
			a = _mm256_fmadd_ps( w0, plLoadShape8( &sh, o0 + i ), a );
			a = _mm256_fmadd_ps( w1, plLoadShape8( &sh, o1 + i ), a );
			a = _mm256_fmadd_ps( w2, plLoadShape8( &sh, o2 + i ), a );
			a = _mm256_fmadd_ps( w3, plLoadShape8( &sh, o3 + i ), a );
			_mm256_storeu_ps( out + i, a );
		}
		for ( size_t i = vec_end; i < end; ++i )
		{
			// fmaf: the same single rounding as the vector lanes, so a vertex's result does not depend on where the
			// range split put it.
			out[i] = fmaf( weights[j], plLoadShape1( &sh, o0 + i ), acc[i] );
			out[i] = fmaf( weights[j + 1], plLoadShape1( &sh, o1 + i ), out[i] );
			out[i] = fmaf( weights[j + 2], plLoadShape1( &sh, o2 + i ), out[i] );
			out[i] = fmaf( weights[j + 3], plLoadShape1( &sh, o3 + i ), out[i] );
		}
	}
	for ( ; j < blend_count; ++j )
	{
		__m256 w0 = _mm256_set1_ps( weights[j] );
		size_t o0 = j * plane;
		for ( size_t i = start; i < vec_end; i += 8 )
		{
			_mm256_storeu_ps( out + i,
							  _mm256_fmadd_ps( w0, plLoadShape8( &sh, o0 + i ), _mm256_loadu_ps( out + i ) ) );
		}
		for ( size_t i = vec_end; i < end; ++i )
		{
			out[i] = fmaf( weights[j], plLoadShape1( &sh, o0 + i ), out[i] );
		}
	}
}
