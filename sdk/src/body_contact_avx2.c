// AVX2 + FMA twin of plBodyContact_Scalar, laid out like plSkinning_Avx2: the J skinning matrices rearranged into
// columns once per call, two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0). Per vertex
// the anchor's blended matrix is 2 FMAs per influence; the posed anchor c0·r_x + c1·r_y + c2·r_z + c3 and the
// unnormalised normal c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. The plane
// test and the push are the scalar kernel's float expressions. Agrees with the scalar kernel to rounding (the sums
// are grouped differently), which test_simd_matches_scalar bounds.
#include "simd_avx2.h"

void plBodyContact_Avx2( float* positions, uint32_t position_stride_bytes, const float* shaped_anchors,
						 const float* anchor_normals, const uint16_t* anchor_skin_indices,
						 const float* anchor_skin_weights, uint32_t influence_count, const float* skin_matrices,
						 uint32_t joint_count, float offset_m, uint32_t v_begin, uint32_t v_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		const float* rn = anchor_normals + (size_t)v * 3;
		if ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f )
		{
			continue; // no anchor
		}
		__m256 a, b;
		plBlendSkinColumns( &a, &b, anchor_skin_indices + (size_t)v * K, anchor_skin_weights + (size_t)v * K, K, J,
							columns );
		const float* r = shaped_anchors + (size_t)v * 3;
		__m256 rxy = _mm256_set_m128( _mm_broadcast_ss( r + 1 ), _mm_broadcast_ss( r + 0 ) );
		__m256 rz1 = _mm256_set_m128( _mm_set1_ps( 1.0f ), _mm_broadcast_ss( r + 2 ) );
		__m256 sa = _mm256_fmadd_ps( b, rz1, _mm256_mul_ps( a, rxy ) );
		__m256 nxy = _mm256_set_m128( _mm_broadcast_ss( rn + 1 ), _mm_broadcast_ss( rn + 0 ) );
		__m256 nz0 = _mm256_set_m128( _mm_setzero_ps(), _mm_broadcast_ss( rn + 2 ) );
		__m256 sn = _mm256_fmadd_ps( b, nz0, _mm256_mul_ps( a, nxy ) );
		_Alignas( 16 ) float anchor[4], normal[4];
		_mm_store_ps( anchor, _mm_add_ps( _mm256_castps256_ps128( sa ), _mm256_extractf128_ps( sa, 1 ) ) );
		_mm_store_ps( normal, _mm_add_ps( _mm256_castps256_ps128( sn ), _mm256_extractf128_ps( sn, 1 ) ) );
		float* x = (float*)( (uint8_t*)positions + (size_t)v * position_stride_bytes );
		plPushOutOfAnchorPlane( x, anchor[0], anchor[1], anchor[2], normal[0], normal[1], normal[2], offset_m );
	}
}
