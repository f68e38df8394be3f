// AVX2 + FMA twin of plSkinning_Scalar. Per vertex the blended matrix Σ_k w_k M_{j_k} is two registers (rows 0–1 in
// one 8-wide, row 2 in one 4-wide) built with 2 FMAs per influence; the three row · (x, y, z, 1) dot products are
// then two multiplies and three horizontal adds. Only the 3 floats of each output vertex are written (strided spans
// may interleave other attributes).
#include "kernels.h"

#include <immintrin.h>

void plSkinning_Avx2( float* out, uint32_t out_stride_bytes, const float* in, uint32_t in_stride_bytes,
					  const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
					  const float* skin_matrices, uint32_t joint_count, uint32_t v_begin, uint32_t v_end )
{
	uint32_t K = influence_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		__m256 m01 = _mm256_setzero_ps();
		__m128 m2 = _mm_setzero_ps();
		for ( uint32_t k = 0; k < K; ++k )
		{
			uint32_t joint = skin_indices[(size_t)v * K + k];
			float w = skin_weights[(size_t)v * K + k];
			if ( joint >= joint_count )
			{
				joint = 0; // the asset loader rejects this; never read out of bounds even so
				w = 0.0f;
			}
			const float* mj = skin_matrices + (size_t)joint * 12;
			__m256 wv = _mm256_set1_ps( w );
			m01 = _mm256_fmadd_ps( wv, _mm256_loadu_ps( mj ), m01 );
			m2 = _mm_fmadd_ps( _mm256_castps256_ps128( wv ), _mm_loadu_ps( mj + 8 ), m2 );
		}
		const float* p = (const float*)( (const uint8_t*)in + (size_t)v * in_stride_bytes );
		__m128 point = _mm_setr_ps( p[0], p[1], p[2], 1.0f );
		__m256 t01 = _mm256_mul_ps( m01, _mm256_set_m128( point, point ) );
		__m128 t2 = _mm_mul_ps( m2, point );
		__m128 h01 = _mm_hadd_ps( _mm256_castps256_ps128( t01 ), _mm256_extractf128_ps( t01, 1 ) );
		__m128 result = _mm_hadd_ps( h01, _mm_hadd_ps( t2, t2 ) ); // (row 0, row 1, row 2, row 2)
		float* q = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
		float r[4];
		_mm_storeu_ps( r, result );
		q[0] = r[0];
		q[1] = r[1];
		q[2] = r[2];
	}
}
