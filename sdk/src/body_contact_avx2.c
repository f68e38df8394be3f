// AVX2 + FMA twin of plBodyContact_Scalar, in two passes over blocks of 8 vertices.
// Pass 1, per vertex, laid out like plSkinning_Avx2: the J skinning matrices rearranged into columns once per call,
// two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0); the anchor's blended matrix is
// 2 FMAs per influence, and the posed anchor c0·r_x + c1·r_y + c2·r_z + c3 and the unnormalised normal
// c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. The eight vertices' anchors,
// normals and positions become 8-lane rows by register shuffles (plRowsOf8).
// Pass 2, 8 vertices at once: the normalisation, plane distance and push of plPushOutOfAnchorPlane as
// plPushOutOfAnchorPlane8 (shared with plBodyContactBatch_Avx2, whose lanes are instances), masks instead of
// branches, and only the moved vertices written back. Measured on the 1k shirt's skinning phase, body contact
// included (pleat_bench_phases, alternated A/B): the one-pass version (the whole test per vertex, with its branches)
// 17.05 µs; two passes with rows built by scalar stores 14.1 µs; rows by shuffles 13.1 µs. Agrees with the scalar
// kernel to rounding (the sums are grouped differently), which test_simd_matches_scalar bounds; the shuffles move
// bits only, so the batch kernel's lanes still agree with this one bit for bit.
#include "simd_avx2.h"

// Pass 1 for one anchored vertex: its posed anchor and unnormalised normal, each (x, y, z, 0).
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

// Eight (x, y, z, ·) vectors, vertex i in v[i], as three 8-lane rows x, y, z (lane i = vertex i): register shuffles, so
// the rows are never read back from eight narrow stores (a load that spans several stores cannot be forwarded and
// waits for them to retire; building the rows in memory cost more than the arithmetic).
static inline void plRowsOf8( __m256* x, __m256* y, __m256* z, const __m128* v )
{
	__m256 t0 = _mm256_set_m128( v[4], v[0] ), t1 = _mm256_set_m128( v[5], v[1] );
	__m256 t2 = _mm256_set_m128( v[6], v[2] ), t3 = _mm256_set_m128( v[7], v[3] );
	__m256 lo01 = _mm256_unpacklo_ps( t0, t1 ), hi01 = _mm256_unpackhi_ps( t0, t1 ); // (x0 x1 y0 y1), (z0 z1 · ·)
	__m256 lo23 = _mm256_unpacklo_ps( t2, t3 ), hi23 = _mm256_unpackhi_ps( t2, t3 );
	*x = _mm256_shuffle_ps( lo01, lo23, _MM_SHUFFLE( 1, 0, 1, 0 ) );
	*y = _mm256_shuffle_ps( lo01, lo23, _MM_SHUFFLE( 3, 2, 3, 2 ) );
	*z = _mm256_shuffle_ps( hi01, hi23, _MM_SHUFFLE( 1, 0, 1, 0 ) );
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
		// per lane: anchor, normal and position; a lane without an anchor (or past the end) gets zeros, and its
		// zero normal fails the length test below, as the scalar kernel returns early
		__m128 anchor[8], normal[8], position[8];
		int any = 0;
		for ( uint32_t i = 0; i < 8; ++i )
		{
			uint32_t v = v0 + i;
			const float* rn = i < count ? anchor_normals + (size_t)v * 3 : NULL;
			if ( rn == NULL || ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f ) )
			{
				anchor[i] = normal[i] = position[i] = _mm_setzero_ps();
				continue;
			}
			any = 1;
			const float* x = (const float*)( (const uint8_t*)positions + (size_t)v * position_stride_bytes );
			// (x, y) by an unaligned 8-byte load (positions are only 4-byte aligned), z alone: no read past the vertex
			position[i] = _mm_movelh_ps( _mm_castsi128_ps( _mm_loadl_epi64( (const __m128i*)x ) ), _mm_load_ss( x + 2 ) );
			const float* r = shaped_anchors + (size_t)v * 3;
			if ( K == 4 ) // the common case: a constant trip count, fully unrolled
			{
				plPoseAnchor( anchor + i, normal + i, r, rn, anchor_skin_indices + (size_t)v * 4,
							  anchor_skin_weights + (size_t)v * 4, 4, J, columns );
			}
			else
			{
				plPoseAnchor( anchor + i, normal + i, r, rn, anchor_skin_indices + (size_t)v * K,
							  anchor_skin_weights + (size_t)v * K, K, J, columns );
			}
		}
		if ( !any )
		{
			continue;
		}
		__m256 ax, ay, az, nx, ny, nz, x, y, z;
		plRowsOf8( &ax, &ay, &az, anchor );
		plRowsOf8( &nx, &ny, &nz, normal );
		plRowsOf8( &x, &y, &z, position );
		int moves = _mm256_movemask_ps( plPushOutOfAnchorPlane8( &x, &y, &z, ax, ay, az, nx, ny, nz, offset ) );
		if ( moves == 0 )
		{
			continue;
		}
		_Alignas( 32 ) float rows[3 * 8];
		_mm256_store_ps( rows, x );
		_mm256_store_ps( rows + 8, y );
		_mm256_store_ps( rows + 16, z );
		for ( uint32_t i = 0; i < count; ++i )
		{
			if ( moves & ( 1 << i ) )
			{
				float* p = (float*)( (uint8_t*)positions + (size_t)( v0 + i ) * position_stride_bytes );
				p[0] = rows[i];
				p[1] = rows[8 + i];
				p[2] = rows[16 + i];
			}
		}
	}
}
