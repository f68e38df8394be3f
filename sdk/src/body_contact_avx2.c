// AVX2 + FMA twin of plBodyContact_Scalar, in two passes over blocks of 8 vertices.
// Pass 1, per vertex, laid out like plSkinning_Avx2: the J skinning matrices rearranged into columns once per call,
// two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0); the anchor's blended matrix is
// 2 FMAs per influence, and the posed anchor c0·r_x + c1·r_y + c2·r_z + c3 and the unnormalised normal
// c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. They go to 8-lane rows.
// Pass 2, 8 vertices at once: the normalisation, plane distance and push of plPushOutOfAnchorPlane as
// plPushOutOfAnchorPlane8 (shared with plBodyContactBatch_Avx2, whose lanes are instances), masks instead of
// branches, and only the moved vertices written back. Against the one-pass version (the whole test per vertex, with
// its branches) the skinning phase of the 1k shirt, body contact included, went from 17.05 to 13.95 µs
// (pleat_bench_phases, alternated A/B). Agrees with the scalar kernel to rounding (the sums are grouped differently),
// which test_simd_matches_scalar bounds.
#include "simd_avx2.h"

// Pass 1 for one anchored vertex: its posed anchor and unnormalised normal into lane i of the rows.
static inline void plPoseAnchor( float* rows, uint32_t i, const float* r, const float* rn, const uint16_t* indices,
								 const float* weights, uint32_t K, uint32_t J, const float* columns )
{
	__m256 a, b;
	plBlendSkinColumns( &a, &b, indices, weights, K, J, columns );
	__m256 rxy = _mm256_set_m128( _mm_broadcast_ss( r + 1 ), _mm_broadcast_ss( r + 0 ) );
	__m256 rz1 = _mm256_set_m128( _mm_set1_ps( 1.0f ), _mm_broadcast_ss( r + 2 ) );
	__m256 sa = _mm256_fmadd_ps( b, rz1, _mm256_mul_ps( a, rxy ) );
	__m256 nxy = _mm256_set_m128( _mm_broadcast_ss( rn + 1 ), _mm_broadcast_ss( rn + 0 ) );
	__m256 nz0 = _mm256_set_m128( _mm_setzero_ps(), _mm_broadcast_ss( rn + 2 ) );
	__m256 sn = _mm256_fmadd_ps( b, nz0, _mm256_mul_ps( a, nxy ) );
	_Alignas( 16 ) float anchor[4], normal[4];
	_mm_store_ps( anchor, _mm_add_ps( _mm256_castps256_ps128( sa ), _mm256_extractf128_ps( sa, 1 ) ) );
	_mm_store_ps( normal, _mm_add_ps( _mm256_castps256_ps128( sn ), _mm256_extractf128_ps( sn, 1 ) ) );
	for ( int c = 0; c < 3; ++c )
	{
		rows[c * 8 + i] = anchor[c];
		rows[( 3 + c ) * 8 + i] = normal[c];
	}
}

void plBodyContact_Avx2( float* positions, uint32_t position_stride_bytes, const float* shaped_anchors,
						 const float* anchor_normals, const uint16_t* anchor_skin_indices,
						 const float* anchor_skin_weights, uint32_t influence_count, const float* skin_matrices,
						 uint32_t joint_count, float offset_m, uint32_t v_begin, uint32_t v_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	const __m256 offset = _mm256_set1_ps( offset_m );
	for ( uint32_t v0 = v_begin; v0 < v_end; v0 += 8 )
	{
		uint32_t count = v_end - v0 < 8 ? v_end - v0 : 8;
		// rows: anchor x, y, z, normal x, y, z, position x, y, z; a lane without an anchor (or past the end) gets
		// zeros, and its zero normal fails the length test below, as the scalar kernel returns early
		_Alignas( 32 ) float rows[9 * 8];
		int any = 0;
		for ( uint32_t i = 0; i < 8; ++i )
		{
			uint32_t v = v0 + i;
			const float* rn = i < count ? anchor_normals + (size_t)v * 3 : NULL;
			if ( rn == NULL || ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f ) )
			{
				for ( int c = 0; c < 9; ++c )
				{
					rows[c * 8 + i] = 0.0f;
				}
				continue;
			}
			any = 1;
			const float* x = (const float*)( (const uint8_t*)positions + (size_t)v * position_stride_bytes );
			rows[6 * 8 + i] = x[0];
			rows[7 * 8 + i] = x[1];
			rows[8 * 8 + i] = x[2];
			const float* r = shaped_anchors + (size_t)v * 3;
			if ( K == 4 ) // the common case: a constant trip count, fully unrolled
			{
				plPoseAnchor( rows, i, r, rn, anchor_skin_indices + (size_t)v * 4, anchor_skin_weights + (size_t)v * 4,
							  4, J, columns );
			}
			else
			{
				plPoseAnchor( rows, i, r, rn, anchor_skin_indices + (size_t)v * K, anchor_skin_weights + (size_t)v * K,
							  K, J, columns );
			}
		}
		if ( !any )
		{
			continue;
		}
		__m256 x = _mm256_load_ps( rows + 48 ), y = _mm256_load_ps( rows + 56 ), z = _mm256_load_ps( rows + 64 );
		int moves = _mm256_movemask_ps( plPushOutOfAnchorPlane8(
			&x, &y, &z, _mm256_load_ps( rows ), _mm256_load_ps( rows + 8 ), _mm256_load_ps( rows + 16 ),
			_mm256_load_ps( rows + 24 ), _mm256_load_ps( rows + 32 ), _mm256_load_ps( rows + 40 ), offset ) );
		if ( moves == 0 )
		{
			continue;
		}
		_mm256_store_ps( rows + 48, x );
		_mm256_store_ps( rows + 56, y );
		_mm256_store_ps( rows + 64, z );
		for ( uint32_t i = 0; i < count; ++i )
		{
			if ( moves & ( 1 << i ) )
			{
				float* p = (float*)( (uint8_t*)positions + (size_t)( v0 + i ) * position_stride_bytes );
				p[0] = rows[48 + i];
				p[1] = rows[56 + i];
				p[2] = rows[64 + i];
			}
		}
	}
}
