// AVX2 + FMA twin of plPoseBodyPoints_Scalar, laid out like plSkinning_Avx2: the J skinning matrices rearranged into
// columns once per call, two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0); a point's
// blended matrix is 2 FMAs per influence, and the posed point c0·r_x + c1·r_y + c2·r_z + c3 and the unnormalised
// normal c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. The length test and the
// division are the scalar kernel's. Agrees with it to rounding (the sums are grouped differently), which
// test_simd_matches_scalar bounds.
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

// AVX twin of plBodyContact_Scalar, four candidates per vector and no branch per candidate: their rows are read with
// one 16-byte load per half ((a_x, a_y, a_z, usable), then the unit normal) and transposed in registers; pass 1 gives
// the squared distances (an empty slot or an unusable point: +∞) and the nearest; pass 2 the weights
// max(0, margin − d²), which are zero outside the margin, and the weighted sums, lane by lane, then across lanes. Why:
// the scalar kernel branched on every candidate, twice, and the branch on the weight mispredicted (a vertex has 1–3 of
// its 16 inside the margin): ~60 ns a vertex against ~15 here. The sums run in another order than the scalar
// kernel's, so the two agree to rounding (test_simd_matches_scalar).
void plBodyContact_Avx2( float* positions, uint32_t position_stride_bytes, const float* posed, uint32_t point_count,
						 const uint16_t* candidates, uint32_t candidate_count, float offset_m, uint32_t v_begin,
						 uint32_t v_end )
{
	uint32_t C = candidate_count, groups = ( C + 3 ) / 4;
	const __m128 infinity = _mm_set1_ps( INFINITY ), zero = _mm_setzero_ps();
	for ( uint32_t v = v_begin; v < v_end; ++v )
	{
		float* x = (float*)( (uint8_t*)positions + (size_t)v * position_stride_bytes );
		const __m128 px = _mm_set1_ps( x[0] ), py = _mm_set1_ps( x[1] ), pz = _mm_set1_ps( x[2] );
		const float* rows[PLEAT_MAX_CONTACT_CANDIDATES];
		__m128 ax[PLEAT_MAX_CONTACT_CANDIDATES / 4], ay[PLEAT_MAX_CONTACT_CANDIDATES / 4];
		__m128 az[PLEAT_MAX_CONTACT_CANDIDATES / 4], d2[PLEAT_MAX_CONTACT_CANDIDATES / 4];
		__m128 nearest4 = infinity;
		for ( uint32_t g = 0; g < groups; ++g )
		{
			__m128 r[4];
			for ( uint32_t i = 0; i < 4; ++i )
			{
				uint32_t c = 4 * g + i;
				uint32_t p = c >= C ? point_count : candidates != NULL ? candidates[(size_t)v * C + c] : v;
				rows[c] = p < point_count ? posed + (size_t)p * PLEAT_POSED_POINT_FLOATS : NULL;
				r[i] = rows[c] != NULL ? _mm_loadu_ps( rows[c] ) : zero; // a zero row is never usable
			}
			_MM_TRANSPOSE4_PS( r[0], r[1], r[2], r[3] ); // a_x of the four, a_y, a_z, usable
			__m128 dx = _mm_sub_ps( px, r[0] ), dy = _mm_sub_ps( py, r[1] ), dz = _mm_sub_ps( pz, r[2] );
			__m128 d = _mm_add_ps( _mm_add_ps( _mm_mul_ps( dx, dx ), _mm_mul_ps( dy, dy ) ), _mm_mul_ps( dz, dz ) );
			d2[g] = _mm_blendv_ps( infinity, d, _mm_cmpneq_ps( r[3], zero ) );
			ax[g] = r[0];
			ay[g] = r[1];
			az[g] = r[2];
			nearest4 = _mm_min_ps( nearest4, d2[g] );
		}
		nearest4 = _mm_min_ps( nearest4, _mm_movehl_ps( nearest4, nearest4 ) );
		nearest4 = _mm_min_ss( nearest4, _mm_shuffle_ps( nearest4, nearest4, 1 ) );
		float nearest = _mm_cvtss_f32( nearest4 );
		if ( nearest == INFINITY )
		{
			continue; // no usable candidate
		}
		const __m128 limit = _mm_set1_ps( ( 1.0f + PLEAT_CONTACT_BLEND_SHARE ) * nearest +
										  PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M );
		__m128 sw = zero, sax = zero, say = zero, saz = zero, snx = zero, sny = zero, snz = zero;
		for ( uint32_t g = 0; g < groups; ++g )
		{
			__m128 w = _mm_max_ps( zero, _mm_sub_ps( limit, d2[g] ) ); // +∞ distances: max(0, −∞) = 0
			__m128 n[4];
			for ( uint32_t i = 0; i < 4; ++i )
			{
				n[i] = rows[4 * g + i] != NULL ? _mm_loadu_ps( rows[4 * g + i] + 4 ) : zero;
			}
			_MM_TRANSPOSE4_PS( n[0], n[1], n[2], n[3] );
			sw = _mm_add_ps( sw, w );
			sax = _mm_add_ps( sax, _mm_mul_ps( w, ax[g] ) );
			say = _mm_add_ps( say, _mm_mul_ps( w, ay[g] ) );
			saz = _mm_add_ps( saz, _mm_mul_ps( w, az[g] ) );
			snx = _mm_add_ps( snx, _mm_mul_ps( w, n[0] ) );
			sny = _mm_add_ps( sny, _mm_mul_ps( w, n[1] ) );
			snz = _mm_add_ps( snz, _mm_mul_ps( w, n[2] ) );
		}
		// Across the lanes: (total, a_x, a_y, a_z) from one transpose, then the normal's three.
		_MM_TRANSPOSE4_PS( sw, sax, say, saz );
		__m128 sums = _mm_add_ps( _mm_add_ps( sw, sax ), _mm_add_ps( say, saz ) );
		__m128 unused = zero;
		_MM_TRANSPOSE4_PS( snx, sny, snz, unused );
		__m128 normal = _mm_add_ps( _mm_add_ps( snx, sny ), _mm_add_ps( snz, unused ) );
		_Alignas( 16 ) float s4[4], n4[4];
		_mm_store_ps( s4, sums );
		_mm_store_ps( n4, normal );
		float total = s4[0], nx = n4[0], ny = n4[1], nz = n4[2];
		float length = sqrtf( nx * nx + ny * ny + nz * nz );
		if ( !( total > 0.0f ) || !( length > 1e-12f ) )
		{
			continue; // normals that cancel: no direction to push along
		}
		float bx = s4[1] / total, by = s4[2] / total, bz = s4[3] / total;
		nx /= length;
		ny /= length;
		nz /= length;
		float d = ( x[0] - bx ) * nx + ( x[1] - by ) * ny + ( x[2] - bz ) * nz;
		if ( d < offset_m )
		{
			float push = offset_m - d;
			x[0] += push * nx;
			x[1] += push * ny;
			x[2] += push * nz;
		}
	}
}
