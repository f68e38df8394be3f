// AVX2 + FMA twin of plPoseBodyPoints_Scalar, laid out like plSkinning_Avx2: the J skinning matrices rearranged into
// columns once per call, two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0); a point's
// blended matrix is 2 FMAs per influence, and the posed point c0·r_x + c1·r_y + c2·r_z + c3 and the unnormalised
// normal c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. The length test and the
// division are the scalar kernel's. Agrees with it to rounding (the sums are grouped differently), which
// test_simd_matches_scalar bounds. The push (plBodyContact_Scalar) stays scalar: per vertex it reads 16 scattered
// 32-byte rows, and the loads, not the arithmetic, are its cost.
#include "simd_avx2.h"

#include <math.h>

// One point: its posed position and unnormalised normal, each (x, y, z, 0).
static inline void plPoseAnchor( __m128* anchor, __m128* normal, const float* r, const float* rn,
								 const uint16_t* indices, const float* weights, uint32_t K, uint32_t J,
								 const float* columns )
{
	__m256 a, b;
	plBlendSkinColumns( &a, &b, indices, weights, K, J, columns );
	__m256 rxy = _mm256_set_m128( _mm_broadcast_ss( r + 1 ), _mm_broadcast_ss( r + 0 ) );
	__m256 rz1 = _mm256_set_m128( _mm_set1_ps( 1.0f ), _mm_broadcast_ss( r + 2 ) );
	__m256 sa = _mm256_fmadd_ps( b, rz1, _mm256_mul_ps( a, rxy ) );
	__m256 nxy = _mm256_set_m128( _mm_broadcast_ss( rn + 1 ), _mm_broadcast_ss( rn + 0 ) );
	__m256 nz0 = _mm256_set_m128( _mm_setzero_ps(), _mm_broadcast_ss( rn + 2 ) );
	__m256 sn = _mm256_fmadd_ps( b, nz0, _mm256_mul_ps( a, nxy ) );
	*anchor = _mm_add_ps( _mm256_castps256_ps128( sa ), _mm256_extractf128_ps( sa, 1 ) );
	*normal = _mm_add_ps( _mm256_castps256_ps128( sn ), _mm256_extractf128_ps( sn, 1 ) );
}

void plPoseBodyPoints_Avx2( float* posed, const float* shaped_points, const float* point_normals,
							const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
							const float* skin_matrices, uint32_t joint_count, uint32_t p_begin, uint32_t p_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	for ( uint32_t p = p_begin; p < p_end; ++p )
	{
		float* out = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
		const float* rn = point_normals + (size_t)p * 3;
		if ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f )
		{
			_mm256_storeu_ps( out, _mm256_setzero_ps() );
			continue;
		}
		__m128 point, normal;
		const float* r = shaped_points + (size_t)p * 3;
		if ( K == 4 ) // the common case: a constant trip count, fully unrolled
		{
			plPoseAnchor( &point, &normal, r, rn, skin_indices + (size_t)p * 4, skin_weights + (size_t)p * 4, 4, J,
						  columns );
		}
		else
		{
			plPoseAnchor( &point, &normal, r, rn, skin_indices + (size_t)p * K, skin_weights + (size_t)p * K, K, J,
						  columns );
		}
		_Alignas( 16 ) float n[4];
		_mm_store_ps( n, normal );
		float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		if ( !( length > 1e-12f ) )
		{
			_mm256_storeu_ps( out, _mm256_setzero_ps() );
			continue;
		}
		_mm_storeu_ps( out, _mm_insert_ps( point, _mm_set_ss( 1.0f ), 0x30 ) ); // (a_x, a_y, a_z, usable = 1)
		_mm_storeu_ps( out + 4, _mm_div_ps( normal, _mm_set1_ps( length ) ) );  // lane 3: 0 / length = 0
	}
}
