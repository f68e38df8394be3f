// AVX2 + FMA twin of plPoseBodyPoints_Scalar, laid out like plSkinning_Avx2: the J skinning matrices rearranged into
// columns once per call, two registers per joint, (c0 | c1) and (c2 | c3) with c_i = (m0i, m1i, m2i, 0); a point's
// blended matrix is 2 FMAs per influence, and the posed point c0·r_x + c1·r_y + c2·r_z + c3 and the unnormalised
// normal c0·n_x + c1·n_y + c2·n_z come from the same two registers without horizontal adds. The length test and the
// division are the scalar kernel's. Agrees with it to rounding (the sums are grouped differently), which
// test_simd_matches_scalar bounds.
#include "simd_avx2.h"

#include <math.h>

// A point posed by its blended matrix (a, b) = ((c0 | c1), (c2 | c3)): c0·r_x + c1·r_y + c2·r_z + c3, (x, y, z, 0).
static inline __m128 plPosePoint( __m256 a, __m256 b, const float* r )
{
	__m256 rxy = _mm256_set_m128( _mm_broadcast_ss( r + 1 ), _mm_broadcast_ss( r + 0 ) );
	__m256 rz1 = _mm256_set_m128( _mm_set1_ps( 1.0f ), _mm_broadcast_ss( r + 2 ) );
	__m256 sa = _mm256_fmadd_ps( b, rz1, _mm256_mul_ps( a, rxy ) );
	return _mm_add_ps( _mm256_castps256_ps128( sa ), _mm256_extractf128_ps( sa, 1 ) );
}

// Its rest normal turned by the same matrix, unnormalised: c0·n_x + c1·n_y + c2·n_z, (x, y, z, 0).
static inline __m128 plTurnNormal( __m256 a, __m256 b, const float* rn )
{
	__m256 nxy = _mm256_set_m128( _mm_broadcast_ss( rn + 1 ), _mm_broadcast_ss( rn + 0 ) );
	__m256 nz0 = _mm256_set_m128( _mm_setzero_ps(), _mm_broadcast_ss( rn + 2 ) );
	__m256 sn = _mm256_fmadd_ps( b, nz0, _mm256_mul_ps( a, nxy ) );
	return _mm_add_ps( _mm256_castps256_ps128( sn ), _mm256_extractf128_ps( sn, 1 ) );
}

// One anchor: its posed position and unnormalised normal; offsets: its column blocks (plSkinColumnOffsets).
static inline void plPoseAnchor( __m128* anchor, __m128* normal, const float* r, const float* rn,
								 const uint32_t* offsets, const float* weights, uint32_t K, const float* columns )
{
	__m256 a, b;
	plBlendSkinOffsets( &a, &b, offsets, weights, K, columns );
	*anchor = plPosePoint( a, b, r );
	*normal = plTurnNormal( a, b, rn );
}

void plPoseBodyPoints_Avx2( float* posed, const float* shaped_points, const float* point_normals,
							const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
							const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
							const uint16_t* rings, uint32_t ring_count, uint32_t point_count, uint32_t p_begin,
							uint32_t p_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	for ( uint32_t p = p_begin; p < p_end; ++p )
	{
		float* out = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
		const float* rn = point_normals + (size_t)p * 3;
		const float* r = shaped_points + (size_t)p * 3;
		// the point's column blocks: from the table, or worked out from its indices (the same offsets)
		uint32_t own[PLEAT_MAX_INFLUENCES];
		const uint32_t* offsets = column_offsets != NULL ? column_offsets + (size_t)p * K : own;
		if ( column_offsets == NULL )
		{
			plSkinColumnOffsetsOf( own, skin_indices + (size_t)p * K, K, J );
		}
		__m256 a, b;
		if ( K == 4 ) // the common case: a constant trip count, fully unrolled
		{
			plBlendSkinOffsets( &a, &b, offsets, skin_weights + (size_t)p * 4, 4, columns );
		}
		else
		{
			plBlendSkinOffsets( &a, &b, offsets, skin_weights + (size_t)p * K, K, columns );
		}
		__m128 point = plPosePoint( a, b, r );
		int anchorable = rn[0] != 0.0f || rn[1] != 0.0f || rn[2] != 0.0f;
		if ( anchorable && rings != NULL && rings[(size_t)p * ring_count] < point_count )
		{
			// (a, 1), (0, 0, 0, 0): the ring normals set the normal and usable (3.4 % of the t-shirt's step); the
			// turned normal is not even formed
			_mm_storeu_ps( out, _mm_insert_ps( point, _mm_set_ss( 1.0f ), 0x30 ) );
			_mm_storeu_ps( out + 4, _mm_setzero_ps() );
			continue;
		}
		__m128 normal = plTurnNormal( a, b, rn );
		_Alignas( 16 ) float n[4];
		_mm_store_ps( n, normal );
		float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		int usable = anchorable && length > 1e-12f;
		// (a_x, a_y, a_z, anchorable): every point's position, a face corner's too
		_mm_storeu_ps( out, _mm_insert_ps( point, _mm_set_ss( anchorable ? 1.0f : 0.0f ), 0x30 ) );
		// (n, usable): lane 3 of the normal is 0, so 0 / length = 0 before the flag goes in
		__m128 unit = usable ? _mm_div_ps( normal, _mm_set1_ps( length ) ) : _mm_setzero_ps();
		_mm_storeu_ps( out + 4, _mm_insert_ps( unit, _mm_set_ss( usable ? 1.0f : 0.0f ), 0x30 ) );
	}
}

// A vertex's (x, y, z, 0): (x, y) by an unaligned 8-byte load (positions are only 4-byte aligned), z alone, so nothing
// past the vertex is read.
static inline __m128 plLoadPosition( const float* x )
{
	return _mm_movelh_ps( _mm_castsi128_ps( _mm_loadl_epi64( (const __m128i*)x ) ), _mm_load_ss( x + 2 ) );
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

// AVX2 twin of plBodyContact_Scalar, eight vertices per vector: slot by slot, the eight candidates' whole posed rows
// (8 floats: position, anchorable, normal, usable) loaded and transposed into their fields' lanes (plTranspose8x8);
// the nearest, the weights and the sums lane by lane in the scalar kernel's order (an unusable or empty slot, or one
// outside the margin, adds w = 0, which leaves every sum's bits as they were), so the two agree bit for bit. Why lanes
// of vertices and not of candidates: a vertex's work is one long chain (distances, nearest, weights, sums, a square
// root, three divisions), so one vertex at a time ran at its latency, ~23 ns. Why rows and a transpose: the 64-bit
// gathers of field pairs they replace cost 41 µs for the shipped t-shirt's push (16 candidates), the rows 23.5. Each
// row comes from the slots' byte offsets in lanes (plContactRowOffsets, built at load; an empty slot reads the zero row
// P): one load per lane (the t-shirt's step 94.6 -> 91.8 µs against finding the row per lane from the candidates).
// Blocks of eight are the offsets' (from a multiple of 8): a lane outside [v_begin, v_end) takes the range's first
// vertex and is never written.
void plBodyContact_Avx2( float* positions, uint32_t position_stride_bytes, const float* posed, uint32_t point_count,
						 const uint16_t* candidates, uint32_t candidate_count, const uint32_t* row_offsets,
						 float offset_m, uint32_t v_begin, uint32_t v_end )
{
	if ( row_offsets == NULL )
	{
		plBodyContact_Scalar( positions, position_stride_bytes, posed, point_count, candidates, candidate_count, NULL,
							  offset_m, v_begin, v_end );
		return;
	}
	uint32_t C = candidate_count;
	const __m256 zero = _mm256_setzero_ps(), infinity = _mm256_set1_ps( INFINITY );
	// the squared distance at which plContactReach8 reaches 0 (the whole push without candidates: 1.1)
	const __m256 beyond_reach = candidates != NULL
									? _mm256_set1_ps( PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M )
									: infinity;
	for ( uint32_t v0 = v_begin & ~7u; v0 < v_end; v0 += 8 )
	{
		const uint32_t* block = row_offsets + (size_t)( v0 / 8 ) * C * 8;
		// the eight positions turned into lanes (a lane outside the range reads the range's first vertex)
		__m128 position[8];
		for ( uint32_t i = 0; i < 8; ++i )
		{
			uint32_t v = v0 + i >= v_begin && v0 + i < v_end ? v0 + i : v_begin;
			position[i] = plLoadPosition( (const float*)( (const uint8_t*)positions + (size_t)v * position_stride_bytes ) );
		}
		__m256 x, y, z;
		plRowsOf8( &x, &y, &z, position );
		__m256 ax[PLEAT_MAX_CONTACT_CANDIDATES], ay[PLEAT_MAX_CONTACT_CANDIDATES], az[PLEAT_MAX_CONTACT_CANDIDATES];
		__m256 cnx[PLEAT_MAX_CONTACT_CANDIDATES], cny[PLEAT_MAX_CONTACT_CANDIDATES], cnz[PLEAT_MAX_CONTACT_CANDIDATES];
		__m256 d2[PLEAT_MAX_CONTACT_CANDIDATES];
		__m256 nearest = infinity;
		for ( uint32_t c = 0; c < C; ++c )
		{
			// the eight candidates' whole rows, transposed: field f of every lane's candidate in rows[f]
			const uint32_t* offsets = block + (size_t)c * 8;
			__m256 rows[8];
			for ( uint32_t i = 0; i < 8; ++i )
			{
				rows[i] = _mm256_loadu_ps( (const float*)( (const uint8_t*)posed + offsets[i] ) );
			}
			plTranspose8x8( rows );
			ax[c] = rows[0], ay[c] = rows[1], az[c] = rows[2];
			cnx[c] = rows[4], cny[c] = rows[5], cnz[c] = rows[6];
			__m256 usable = _mm256_cmp_ps( rows[7], zero, _CMP_NEQ_OQ );
			__m256 dx = _mm256_sub_ps( x, ax[c] ), dy = _mm256_sub_ps( y, ay[c] ), dz = _mm256_sub_ps( z, az[c] );
			__m256 d = _mm256_add_ps( _mm256_add_ps( _mm256_mul_ps( dx, dx ), _mm256_mul_ps( dy, dy ) ),
									  _mm256_mul_ps( dz, dz ) );
			d2[c] = _mm256_blendv_ps( infinity, d, usable );
			nearest = _mm256_min_ps( nearest, d2[c] );
		}
		__m256 anchored = _mm256_cmp_ps( nearest, infinity, _CMP_LT_OQ ); // lanes with a usable candidate
		if ( _mm256_movemask_ps( _mm256_and_ps( anchored, _mm256_cmp_ps( nearest, beyond_reach, _CMP_LT_OQ ) ) ) == 0 )
		{
			continue; // no lane has a usable candidate within the reach: the push below would leave every lane
		}
		const float margin = PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M;
		__m256 margin_limit = _mm256_add_ps( _mm256_mul_ps( _mm256_set1_ps( 1.0f + PLEAT_CONTACT_BLEND_SHARE ), nearest ),
											 _mm256_set1_ps( margin ) );
		__m256 total = zero, sx = zero, sy = zero, sz = zero, nx = zero, ny = zero, nz = zero;
		for ( uint32_t c = 0; c < C; ++c )
		{
			__m256 w = _mm256_sub_ps( margin_limit, d2[c] );
			// No branch on "no lane weighs this slot": with many candidates it mispredicted more than the loads it
			// saved cost (16 candidates: the push 49 -> 46 us, with gathers then); a lane without weight adds w = +0 to
			// every sum, which leaves its bits as the scalar kernel's skip does.
			w = _mm256_and_ps( w, _mm256_cmp_ps( w, zero, _CMP_GT_OQ ) );
			total = _mm256_add_ps( total, w );
			sx = _mm256_add_ps( sx, _mm256_mul_ps( w, ax[c] ) );
			sy = _mm256_add_ps( sy, _mm256_mul_ps( w, ay[c] ) );
			sz = _mm256_add_ps( sz, _mm256_mul_ps( w, az[c] ) );
			nx = _mm256_add_ps( nx, _mm256_mul_ps( w, cnx[c] ) );
			ny = _mm256_add_ps( ny, _mm256_mul_ps( w, cny[c] ) );
			nz = _mm256_add_ps( nz, _mm256_mul_ps( w, cnz[c] ) );
		}
		// The blended plane through plPushOutOfAnchorPlane8, the scalar push's operations lane by lane; a lane without a
		// usable candidate or weight gets a zero normal, which the helper leaves where it is.
		// A lane whose nearest candidate is beyond the reach (plContactReach) is left as it is too.
		__m256 reach = candidates != NULL ? plContactReach8( nearest ) : _mm256_set1_ps( 1.0f ); // 1.1: whole push
		__m256 weighed = _mm256_and_ps( _mm256_and_ps( anchored, _mm256_cmp_ps( total, zero, _CMP_GT_OQ ) ),
										_mm256_cmp_ps( reach, zero, _CMP_GT_OQ ) );
		nx = _mm256_and_ps( nx, weighed );
		ny = _mm256_and_ps( ny, weighed );
		nz = _mm256_and_ps( nz, weighed );
		int moves = _mm256_movemask_ps( plPushOutOfAnchorPlane8( &x, &y, &z, _mm256_div_ps( sx, total ),
																 _mm256_div_ps( sy, total ), _mm256_div_ps( sz, total ),
																 nx, ny, nz, _mm256_set1_ps( offset_m ), reach ) );
		if ( moves == 0 )
		{
			continue;
		}
		_Alignas( 32 ) float rx[8], ry[8], rz[8];
		_mm256_store_ps( rx, x );
		_mm256_store_ps( ry, y );
		_mm256_store_ps( rz, z );
		for ( uint32_t i = 0; i < 8; ++i )
		{
			if ( ( moves & ( 1 << i ) ) && v0 + i >= v_begin && v0 + i < v_end )
			{
				float* p = (float*)( (uint8_t*)positions + (size_t)( v0 + i ) * position_stride_bytes );
				p[0] = rx[i];
				p[1] = ry[i];
				p[2] = rz[i];
			}
		}
	}
}

// AVX2 twin of plBodyPointNormals_Scalar, eight points per vector: their own positions and, slot by slot, their ring
// points' positions, each from the first four floats of a posed row turned into lanes (plRowsOf8: 19 µs for the
// shipped t-shirt's rings against 27 with gathers); d_i = a_{r_i} − a_p, and the cross product of each d_i with the
// next, the last slot of each lane closing on its d_0 (a blend where the next slot is past the lane's ring). The same
// operations in the same order as the scalar kernel, lane by lane (no contraction), so the two agree bit for bit. Why
// lanes of points: a point's normal is one chain (the fan's sum, a square root, three divisions), so one point at a
// time (16-byte rows, shuffles for the cross products) ran at its latency, ~25 ns a point against ~11 here. The slots
// come from the rings in lanes (plRingLanes, built at load): one load gives a slot's eight indices and which are used.
// Built here per block of eight, from the rings, they were a quarter of the kernel's work (the t-shirt's step 100.4
// -> 93.7 µs without). A block may begin before p_begin or end past p_end: the lanes outside are computed, not written.
void plBodyPointNormals_Avx2( float* posed, uint32_t point_count, const uint16_t* rings, uint32_t ring_count,
							  const int32_t* ring_lanes, uint32_t p_begin, uint32_t p_end )
{
	if ( ring_lanes == NULL )
	{
		plBodyPointNormals_Scalar( posed, point_count, rings, ring_count, NULL, p_begin, p_end );
		return;
	}
	uint32_t R = ring_count;
	const __m256 zero = _mm256_setzero_ps();
	const __m256i none = _mm256_set1_epi32( -1 ); // an index > -1 is used; INT32_MIN (an empty slot) is not
	enum { CHUNK = 16 };
	for ( uint32_t c0 = p_begin & ~7u; c0 < p_end; c0 += 8 * CHUNK )
	{
		// Two passes over a chunk of blocks: the fans' sums, then the square roots and divisions. In one pass each
		// block ended on that chain (~40 cycles), which the next block's loads could not hide.
		__m256 sums[CHUNK][3];
		int block_changes[CHUNK];
		uint32_t blocks = 0;
		for ( uint32_t p0 = c0; p0 < p_end && blocks < CHUNK; p0 += 8, ++blocks )
		{
			const int32_t* slots = ring_lanes + (size_t)( p0 / 8 ) * R * 8;
			// the lanes that change: in the range, an anchor (float 3) and with a ring (slot 0 used)
			int changes = _mm256_movemask_ps(
				_mm256_castsi256_ps( _mm256_cmpgt_epi32( _mm256_load_si256( (const __m256i*)slots ), none ) ) );
			for ( uint32_t i = 0; i < 8; ++i )
			{
				uint32_t p = p0 + i;
				if ( p < p_begin || p >= p_end || posed[(size_t)p * PLEAT_POSED_POINT_FLOATS + 3] == 0.0f )
				{
					changes &= ~( 1 << i );
				}
			}
			block_changes[blocks] = changes;
			if ( changes == 0 )
			{
				continue;
			}
			// the eight points' own positions (a lane past P reads row 0 and changes nothing)
			__m128 v[8];
			for ( uint32_t i = 0; i < 8; ++i )
			{
				v[i] = _mm_loadu_ps( posed + (size_t)( p0 + i < point_count ? p0 + i : 0u ) * PLEAT_POSED_POINT_FLOATS );
			}
			__m256 px, py, pz;
			plRowsOf8( &px, &py, &pz, v );
			__m256 dx[PLEAT_MAX_POINT_RING], dy[PLEAT_MAX_POINT_RING], dz[PLEAT_MAX_POINT_RING];
			__m256 used[PLEAT_MAX_POINT_RING];
			for ( uint32_t s = 0; s < R; ++s )
			{
				const int32_t* slot = slots + (size_t)s * 8;
				used[s] = _mm256_castsi256_ps( _mm256_cmpgt_epi32( _mm256_load_si256( (const __m256i*)slot ), none ) );
				for ( uint32_t i = 0; i < 8; ++i )
				{
					// the index's low 16 bits (INT32_MIN's are 0: an empty slot reads row 0, which its mask leaves out)
					v[i] = _mm_loadu_ps( posed + (size_t)( (uint32_t)slot[i] & 0xFFFFu ) * PLEAT_POSED_POINT_FLOATS );
				}
				__m256 ax, ay, az;
				plRowsOf8( &ax, &ay, &az, v );
				dx[s] = _mm256_sub_ps( ax, px );
				dy[s] = _mm256_sub_ps( ay, py );
				dz[s] = _mm256_sub_ps( az, pz );
			}
			__m256 nx = zero, ny = zero, nz = zero;
			for ( uint32_t s = 0; s < R; ++s )
			{
				// the next slot, or d_0 where the next is past this lane's ring (or s is the last slot)
				__m256 next_used = s + 1 < R ? used[s + 1] : zero;
				__m256 vx = _mm256_blendv_ps( dx[0], s + 1 < R ? dx[s + 1] : dx[0], next_used );
				__m256 vy = _mm256_blendv_ps( dy[0], s + 1 < R ? dy[s + 1] : dy[0], next_used );
				__m256 vz = _mm256_blendv_ps( dz[0], s + 1 < R ? dz[s + 1] : dz[0], next_used );
				__m256 cx = _mm256_sub_ps( _mm256_mul_ps( dy[s], vz ), _mm256_mul_ps( dz[s], vy ) );
				__m256 cy = _mm256_sub_ps( _mm256_mul_ps( dz[s], vx ), _mm256_mul_ps( dx[s], vz ) );
				__m256 cz = _mm256_sub_ps( _mm256_mul_ps( dx[s], vy ), _mm256_mul_ps( dy[s], vx ) );
				nx = _mm256_blendv_ps( nx, _mm256_add_ps( nx, cx ), used[s] );
				ny = _mm256_blendv_ps( ny, _mm256_add_ps( ny, cy ), used[s] );
				nz = _mm256_blendv_ps( nz, _mm256_add_ps( nz, cz ), used[s] );
			}
			sums[blocks][0] = nx;
			sums[blocks][1] = ny;
			sums[blocks][2] = nz;
		}
		for ( uint32_t k = 0; k < blocks; ++k )
		{
			int changes = block_changes[k];
			if ( changes == 0 )
			{
				continue;
			}
			__m256 nx = sums[k][0], ny = sums[k][1], nz = sums[k][2];
			__m256 length = _mm256_sqrt_ps( _mm256_add_ps(
				_mm256_add_ps( _mm256_mul_ps( nx, nx ), _mm256_mul_ps( ny, ny ) ), _mm256_mul_ps( nz, nz ) ) );
			__m256 usable = _mm256_cmp_ps( length, _mm256_set1_ps( 1e-12f ), _CMP_GT_OQ );
			// (n, usable) per lane: the four rows turned into eight (x, y, z, u) vectors, one 16-byte store each into
			// the second half of the point's row (the half no other point's ring pass reads)
			__m256 rx = _mm256_and_ps( _mm256_div_ps( nx, length ), usable );
			__m256 ry = _mm256_and_ps( _mm256_div_ps( ny, length ), usable );
			__m256 rz = _mm256_and_ps( _mm256_div_ps( nz, length ), usable );
			__m256 ru = _mm256_and_ps( _mm256_set1_ps( 1.0f ), usable );
			__m256 xy_lo = _mm256_unpacklo_ps( rx, ry ), xy_hi = _mm256_unpackhi_ps( rx, ry ); // x0 y0 x1 y1 | x4 y4 ..
			__m256 zu_lo = _mm256_unpacklo_ps( rz, ru ), zu_hi = _mm256_unpackhi_ps( rz, ru );
			__m256 q0 = _mm256_shuffle_ps( xy_lo, zu_lo, _MM_SHUFFLE( 1, 0, 1, 0 ) ); // lanes 0 | 4
			__m256 q1 = _mm256_shuffle_ps( xy_lo, zu_lo, _MM_SHUFFLE( 3, 2, 3, 2 ) ); // lanes 1 | 5
			__m256 q2 = _mm256_shuffle_ps( xy_hi, zu_hi, _MM_SHUFFLE( 1, 0, 1, 0 ) ); // lanes 2 | 6
			__m256 q3 = _mm256_shuffle_ps( xy_hi, zu_hi, _MM_SHUFFLE( 3, 2, 3, 2 ) ); // lanes 3 | 7
			__m128 lane[8] = { _mm256_castps256_ps128( q0 ),   _mm256_castps256_ps128( q1 ),
							   _mm256_castps256_ps128( q2 ),   _mm256_castps256_ps128( q3 ),
							   _mm256_extractf128_ps( q0, 1 ), _mm256_extractf128_ps( q1, 1 ),
							   _mm256_extractf128_ps( q2, 1 ), _mm256_extractf128_ps( q3, 1 ) };
			uint32_t p0 = c0 + 8 * k;
			for ( uint32_t i = 0; i < 8; ++i )
			{
				if ( changes & ( 1 << i ) )
				{
					_mm_storeu_ps( posed + (size_t)( p0 + i ) * PLEAT_POSED_POINT_FLOATS + 4, lane[i] );
				}
			}
		}
	}
}

// AVX2 + FMA twin of plBodyContactFast_Scalar, in two passes over blocks of 8 vertices: per vertex the anchor posed as
// plPoseAnchor does, then 8 vertices at once through plPushOutOfAnchorPlane8 (shared with the batched twin, whose lanes
// are instances), masks instead of branches, only the moved vertices written back. Agrees with the scalar kernel to
// rounding (test_simd_matches_scalar).
void plBodyContactFast_Avx2( float* positions, uint32_t position_stride_bytes, const float* shaped_anchors,
						 const float* anchor_normals, const uint16_t* anchor_skin_indices,
						 const float* anchor_skin_weights, uint32_t influence_count,
						 const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
						 float offset_m, uint32_t v_begin, uint32_t v_end )
{
	_Alignas( 32 ) float columns[PLEAT_SKIN_COLUMN_FLOATS];
	uint32_t J = plSkinColumns( columns, skin_matrices, joint_count );
	uint32_t K = influence_count;
	const __m256 offset = _mm256_set1_ps( offset_m ), one = _mm256_set1_ps( 1.0f ); // the fast contact: full reach
	enum { CHUNK = 8 };
	for ( uint32_t c0 = v_begin; c0 < v_end; c0 += 8 * CHUNK )
	{
		// Two passes over a chunk of blocks: the anchors posed into lanes, then the pushes. In one pass each block
		// ended on the push's square root and divisions, which the next block's posing did not hide.
		__m256 lanes[CHUNK][9];
		int any_lane[CHUNK];
		uint32_t blocks = 0;
		for ( uint32_t v0 = c0; v0 < v_end && blocks < CHUNK; v0 += 8, ++blocks )
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
				position[i] = plLoadPosition( x );
				const float* r = shaped_anchors + (size_t)v * 3;
				uint32_t own[PLEAT_MAX_INFLUENCES];
				const uint32_t* offsets = column_offsets != NULL ? column_offsets + (size_t)v * K : own;
				if ( column_offsets == NULL )
				{
					plSkinColumnOffsetsOf( own, anchor_skin_indices + (size_t)v * K, K, J );
				}
				if ( K == 4 ) // the common case: a constant trip count, fully unrolled
				{
					plPoseAnchor( anchor + i, normal + i, r, rn, offsets, anchor_skin_weights + (size_t)v * 4, 4,
								  columns );
				}
				else
				{
					plPoseAnchor( anchor + i, normal + i, r, rn, offsets, anchor_skin_weights + (size_t)v * K, K,
								  columns );
				}
			}
			any_lane[blocks] = any;
			if ( !any )
			{
				continue;
			}
			__m256* l = lanes[blocks];
			plRowsOf8( &l[0], &l[1], &l[2], anchor );
			plRowsOf8( &l[3], &l[4], &l[5], normal );
			plRowsOf8( &l[6], &l[7], &l[8], position );
		}
		for ( uint32_t k = 0; k < blocks; ++k )
		{
			if ( !any_lane[k] )
			{
				continue;
			}
			uint32_t v0 = c0 + 8 * k, count = v_end - v0 < 8 ? v_end - v0 : 8;
			__m256* l = lanes[k];
			__m256 x = l[6], y = l[7], z = l[8];
			int moves = _mm256_movemask_ps( plPushOutOfAnchorPlane8( &x, &y, &z, l[0], l[1], l[2], l[3], l[4], l[5],
																	 offset, one ) );
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
}
