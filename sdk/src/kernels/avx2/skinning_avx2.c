// AVX2 + FMA twin of plSkinning_Scalar. The J skinning matrices are first rearranged into columns, two registers per
// joint: (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0) — J · 64 bytes, in L1, built once per call. Per vertex the
// blended matrix Σ_k w_k M_{j_k} is then 2 FMAs per influence with whole-register loads, and the transform
// c0·x + c1·y + c2·z + c3 is one multiply, one FMA and one 4-wide add on broadcast coordinates (no horizontal adds):
// about a third of the instructions of a row-wise dot-product formulation. A joint index ≥ joint_count reads an
// all-zero extra column block (weight × 0), as the scalar kernel counts it with weight 0. Only the 3 floats of each
// output vertex are written, except that packed (12-byte stride) output writes 16 bytes when the next vertex is in
// the same range (its first float is rewritten right after).
#include "simd_avx2.h"

// offsets: the vertex's column-block offsets (plSkinColumnOffsets)
static inline void plSkinVertex( float* q, int store16, const float* p, const uint32_t* offsets, const float* wt,
								 uint32_t K, const float* columns )
{
	__m256 a, b;
	plBlendSkinOffsets( &a, &b, offsets, wt, K, columns );
	__m256 xy = _mm256_set_m128( _mm_broadcast_ss( p + 1 ), _mm_broadcast_ss( p + 0 ) );
	__m256 z1 = _mm256_set_m128( _mm_set1_ps( 1.0f ), _mm_broadcast_ss( p + 2 ) );
	__m256 s = _mm256_fmadd_ps( b, z1, _mm256_mul_ps( a, xy ) );
	__m128 r = _mm_add_ps( _mm256_castps256_ps128( s ), _mm256_extractf128_ps( s, 1 ) ); // (x', y', z', 0)
	if ( store16 )
	{
		_mm_storeu_ps( q, r );
	}
	else
	{
		_mm_storel_pi( (__m64*)q, r );
		_mm_store_ss( q + 2, _mm_movehl_ps( r, r ) );
	}
}

void plSkinning_Avx2( float* out, uint32_t out_stride_bytes, const float* in, uint32_t in_stride_bytes,
					  const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
					  const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
					  uint32_t v_begin, uint32_t v_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	int packed = out_stride_bytes == 12;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		const float* p = (const float*)( (const uint8_t*)in + (size_t)v * in_stride_bytes );
		float* q = (float*)( (uint8_t*)out + (size_t)v * out_stride_bytes );
		int store16 = packed && v + 1 < v_end;
		// the vertex's column blocks: from the table, or worked out from its indices (the same offsets)
		uint32_t own[PLEAT_MAX_INFLUENCES];
		const uint32_t* offsets = column_offsets != NULL ? column_offsets + (size_t)v * K : own;
		if ( column_offsets == NULL )
		{
			plSkinColumnOffsetsOf( own, skin_indices + (size_t)v * K, K, J );
		}
		if ( K == 4 ) // the common case: a constant trip count, fully unrolled
		{
			plSkinVertex( q, store16, p, offsets, skin_weights + (size_t)v * 4, 4, columns );
		}
		else
		{
			plSkinVertex( q, store16, p, offsets, skin_weights + (size_t)v * K, K, columns );
		}
	}
}
