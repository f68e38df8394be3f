// AVX2 + FMA (+ F16C) twin of plBlendShapes_Scalar. The vertex range is cut into chunks whose accumulators stay in
// L1; each blend shape is then streamed contiguously through the chunk, two shapes per pass.
#include "kernels.h"

#include <immintrin.h>
#include <math.h>

#define PLEAT_BLEND_CHUNK 768 // floats (256 vertices), multiple of 8

static inline __m256 plLoad8( const void* p, int fp16, size_t index )
{
	if ( fp16 )
	{
		return _mm256_cvtph_ps( _mm_loadu_si128( (const __m128i*)( (const uint16_t*)p + index ) ) );
	}
	return _mm256_loadu_ps( (const float*)p + index );
}

static inline float plLoad1( const void* p, int fp16, size_t index )
{
	return fp16 ? plHalfToFloat( ( (const uint16_t*)p )[index] ) : ( (const float*)p )[index];
}

void plBlendShapes_Avx2( float* out, const float* base, const void* shapes, int shapes_fp16, const float* weights,
						 uint32_t blend_count, uint32_t vertex_count, uint32_t v_begin, uint32_t v_end )
{
	size_t plane = (size_t)vertex_count * 3;
	size_t end = (size_t)v_end * 3;
	for ( size_t start = (size_t)v_begin * 3; start < end; start += PLEAT_BLEND_CHUNK )
	{
		size_t count = end - start < PLEAT_BLEND_CHUNK ? end - start : PLEAT_BLEND_CHUNK;
		size_t vec_count = count & ~(size_t)7;
		float* acc = out + start;
		for ( size_t i = 0; i < count; ++i )
		{
			acc[i] = base[start + i];
		}
		uint32_t j = 0;
		for ( ; j + 2 <= blend_count; j += 2 )
		{
			__m256 w0 = _mm256_set1_ps( weights[j] );
			__m256 w1 = _mm256_set1_ps( weights[j + 1] );
			size_t o0 = j * plane + start, o1 = o0 + plane;
			for ( size_t i = 0; i < vec_count; i += 8 )
			{
				__m256 a = _mm256_loadu_ps( acc + i );
				a = _mm256_fmadd_ps( w0, plLoad8( shapes, shapes_fp16, o0 + i ), a );
				a = _mm256_fmadd_ps( w1, plLoad8( shapes, shapes_fp16, o1 + i ), a );
				_mm256_storeu_ps( acc + i, a );
			}
			for ( size_t i = vec_count; i < count; ++i )
			{
				// fmaf: the same single rounding as the vector lanes, so a vertex's result does not depend on where
				// the range split put it.
				acc[i] = fmaf( weights[j], plLoad1( shapes, shapes_fp16, o0 + i ), acc[i] );
				acc[i] = fmaf( weights[j + 1], plLoad1( shapes, shapes_fp16, o1 + i ), acc[i] );
			}
		}
		for ( ; j < blend_count; ++j )
		{
			__m256 w0 = _mm256_set1_ps( weights[j] );
			size_t o0 = j * plane + start;
			for ( size_t i = 0; i < vec_count; i += 8 )
			{
				_mm256_storeu_ps( acc + i,
								  _mm256_fmadd_ps( w0, plLoad8( shapes, shapes_fp16, o0 + i ), _mm256_loadu_ps( acc + i ) ) );
			}
			for ( size_t i = vec_count; i < count; ++i )
			{
				acc[i] = fmaf( weights[j], plLoad1( shapes, shapes_fp16, o0 + i ), acc[i] );
			}
		}
	}
}
