// The full body contact of up to 16 instances of one asset, the instances in the lanes of a 512-bit vector: the twin
// of plBodyContactBatch_Avx2 (avx2/geometry_batch_avx2.c) with twice its lanes, for plStepInstances on CPUs with
// AVX-512 (the crowd's largest stage on the t-shirt: ~40 % of a 64-instance int8 step at 8 lanes). The same three
// passes in the same order — the points posed, their normals from the posed rings, the push — and per lane the same
// operations of the single kernels, so every instance keeps its lone step's bits (test_batched_kernels_match_single).
// The posed points' scratch rows are [P][8 rows][16 lanes]: a candidate's or a ring point's row is one aligned 64-byte
// load (one cache line) for all sixteen instances. The AoS ↔ lanes transposes run as two 8×8 AVX2 transposes (the
// instances 0–7 and 8–15 into the low and high halves of each row).
#include "kernels/kernels_batch.h"
#include "kernels/avx2/simd_avx2.h"

#include <immintrin.h>
#include <string.h>

#if defined( __clang__ )
#pragma STDC FP_CONTRACT OFF
#endif

#define PL_LANES 16
#define PL_BLOCK 8 // vertices or points per transpose block
typedef __m512 plVec16;

static const float s_plZeroBlock[3 * PL_BLOCK] = { 0 };

// Vertices [v0, v0 + count) of instances src[0..n) (AoS, packed) → dst[3 · PL_BLOCK][PL_LANES]: row 3i + c holds
// component c of vertex v0 + i of every instance (zero rows past count, zero lanes past n).
static inline void plToLanes16( const float* const* src, uint32_t n, uint32_t v0, uint32_t count, float* dst )
{
	for ( int half = 0; half < 2; ++half )
	{
		for ( int q = 0; q < 3; ++q )
		{
			__m256 r[PL_BLOCK];
			for ( uint32_t b = 0; b < PL_BLOCK; ++b )
			{
				uint32_t lane = (uint32_t)half * PL_BLOCK + b;
				const float* s = lane < n ? src[lane] + (size_t)v0 * 3 : s_plZeroBlock;
				if ( count == PL_BLOCK || lane >= n )
				{
					r[b] = _mm256_loadu_ps( s + q * PL_BLOCK );
				}
				else
				{
					float padded[3 * PL_BLOCK] = { 0 };
					memcpy( padded, s, (size_t)count * 3 * sizeof( float ) );
					r[b] = _mm256_loadu_ps( padded + q * PL_BLOCK );
				}
			}
			plTranspose8x8( r );
			for ( int t = 0; t < PL_BLOCK; ++t )
			{
				_mm256_store_ps( dst + (size_t)( q * PL_BLOCK + t ) * PL_LANES + half * PL_BLOCK, r[t] );
			}
		}
	}
}

// The way back: src[3 · PL_BLOCK][PL_LANES] → vertices [v0, v0 + count) of instances dst[0..n) (AoS, packed).
static inline void plFromLanes16( const float* src, float* const* dst, uint32_t n, uint32_t v0, uint32_t count )
{
	for ( int half = 0; half < 2 && (uint32_t)half * PL_BLOCK < n; ++half )
	{
		for ( int q = 0; q < 3; ++q )
		{
			__m256 r[PL_BLOCK];
			for ( int t = 0; t < PL_BLOCK; ++t )
			{
				r[t] = _mm256_load_ps( src + (size_t)( q * PL_BLOCK + t ) * PL_LANES + half * PL_BLOCK );
			}
			plTranspose8x8( r );
			for ( uint32_t b = 0; b < PL_BLOCK && (uint32_t)half * PL_BLOCK + b < n; ++b )
			{
				float* d = dst[half * PL_BLOCK + b] + (size_t)v0 * 3;
				if ( count == PL_BLOCK )
				{
					_mm256_storeu_ps( d + q * PL_BLOCK, r[b] );
				}
				else
				{
					// A ragged end: only the floats of vertices below count.
					float full[PL_BLOCK];
					_mm256_storeu_ps( full, r[b] );
					uint32_t first = (uint32_t)q * PL_BLOCK, total = count * 3;
					if ( first < total )
					{
						uint32_t floats = total - first < PL_BLOCK ? total - first : PL_BLOCK;
						memcpy( d + first, full, floats * sizeof( float ) );
					}
				}
			}
		}
	}
}

// skin_matrices[0..n) (each [J][12]) → lanes[J + 1][12][PL_LANES]: element e of joint j's matrix for every lane, the
// extra joint and the lanes past n all zero.
static inline void plSkinMatricesToLanes16( const float* const* skin_matrices, uint32_t n, uint32_t J, float* lanes )
{
	for ( uint32_t j = 0; j <= J; ++j )
	{
		for ( uint32_t e = 0; e < 12; ++e )
		{
			float* row = lanes + ( (size_t)j * 12 + e ) * PL_LANES;
			for ( uint32_t l = 0; l < PL_LANES; ++l )
			{
				row[l] = j < J && l < n ? skin_matrices[l][(size_t)j * 12 + e] : 0.0f;
			}
		}
	}
}

// Σ_k w_k M_{j_k} per lane, the FMA chain of plBlendMatrixLanes (and plSkinning_Avx2).
static inline void plBlendMatrixLanes16( plVec16 a0[3], plVec16 a1[3], plVec16 a2[3], plVec16 a3[3],
										 const uint16_t* indices, const float* weights, uint32_t K, uint32_t J,
										 const float* lanes )
{
	for ( int r = 0; r < 3; ++r )
	{
		a0[r] = a1[r] = a2[r] = a3[r] = _mm512_setzero_ps();
	}
	for ( uint32_t k = 0; k < K; ++k )
	{
		uint32_t joint = indices[k] < J ? indices[k] : J;
		const float* m = lanes + (size_t)joint * 12 * PL_LANES;
		plVec16 w = _mm512_set1_ps( weights[k] );
		for ( int r = 0; r < 3; ++r )
		{
			a0[r] = _mm512_fmadd_ps( w, _mm512_load_ps( m + ( 4 * r + 0 ) * PL_LANES ), a0[r] );
			a1[r] = _mm512_fmadd_ps( w, _mm512_load_ps( m + ( 4 * r + 1 ) * PL_LANES ), a1[r] );
			a2[r] = _mm512_fmadd_ps( w, _mm512_load_ps( m + ( 4 * r + 2 ) * PL_LANES ), a2[r] );
			a3[r] = _mm512_fmadd_ps( w, _mm512_load_ps( m + ( 4 * r + 3 ) * PL_LANES ), a3[r] );
		}
	}
}

// plPosePointLanes in sixteen lanes: fma(m_i2, r_z, m_i0 r_x) + fma(m_i3, 1, m_i1 r_y), the normal with 0.
static inline void plPosePointLanes16( plVec16 point[3], plVec16 normal[3], const plVec16 a0[3], const plVec16 a1[3],
									   const plVec16 a2[3], const plVec16 a3[3], plVec16 rx, plVec16 ry, plVec16 rz,
									   const float* rest_normal )
{
	const plVec16 one = _mm512_set1_ps( 1.0f ), zero = _mm512_setzero_ps();
	plVec16 nx0 = _mm512_set1_ps( rest_normal[0] ), ny0 = _mm512_set1_ps( rest_normal[1] );
	plVec16 nz0 = _mm512_set1_ps( rest_normal[2] );
	for ( int r = 0; r < 3; ++r )
	{
		point[r] = _mm512_add_ps( _mm512_fmadd_ps( a2[r], rz, _mm512_mul_ps( a0[r], rx ) ),
								  _mm512_fmadd_ps( a3[r], one, _mm512_mul_ps( a1[r], ry ) ) );
		normal[r] = _mm512_add_ps( _mm512_fmadd_ps( a2[r], nz0, _mm512_mul_ps( a0[r], nx0 ) ),
								   _mm512_fmadd_ps( a3[r], zero, _mm512_mul_ps( a1[r], ny0 ) ) );
	}
}

// plContactReach8 in sixteen lanes.
static inline plVec16 plContactReach16( plVec16 nearest )
{
	const float near2 = PLEAT_CONTACT_REACH_NEAR_M * PLEAT_CONTACT_REACH_NEAR_M;
	const float far2 = PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M;
	plVec16 r = _mm512_div_ps( _mm512_sub_ps( _mm512_set1_ps( far2 ), nearest ), _mm512_set1_ps( far2 - near2 ) );
	return _mm512_min_ps( _mm512_max_ps( r, _mm512_setzero_ps() ), _mm512_set1_ps( 1.0f ) );
}

// plPushOutOfAnchorPlane8 in sixteen lanes (the same operations in the same order); returns the lanes that moved.
static inline __mmask16 plPushOutOfAnchorPlane16( plVec16* x, plVec16* y, plVec16* z, plVec16 ax, plVec16 ay,
												   plVec16 az, plVec16 nx, plVec16 ny, plVec16 nz, plVec16 offset,
												   plVec16 reach )
{
	plVec16 length = _mm512_sqrt_ps(
		_mm512_add_ps( _mm512_add_ps( _mm512_mul_ps( nx, nx ), _mm512_mul_ps( ny, ny ) ), _mm512_mul_ps( nz, nz ) ) );
	__mmask16 has_direction = _mm512_cmp_ps_mask( length, _mm512_set1_ps( 1e-12f ), _CMP_GT_OQ );
	nx = _mm512_div_ps( nx, length );
	ny = _mm512_div_ps( ny, length );
	nz = _mm512_div_ps( nz, length );
	plVec16 d = _mm512_add_ps(
		_mm512_add_ps( _mm512_mul_ps( _mm512_sub_ps( *x, ax ), nx ), _mm512_mul_ps( _mm512_sub_ps( *y, ay ), ny ) ),
		_mm512_mul_ps( _mm512_sub_ps( *z, az ), nz ) );
	__mmask16 moves = has_direction & _mm512_cmp_ps_mask( d, offset, _CMP_LT_OQ );
	plVec16 push = _mm512_mul_ps( _mm512_sub_ps( offset, d ), reach );
	*x = _mm512_mask_blend_ps( moves, *x, _mm512_add_ps( *x, _mm512_mul_ps( push, nx ) ) );
	*y = _mm512_mask_blend_ps( moves, *y, _mm512_add_ps( *y, _mm512_mul_ps( push, ny ) ) );
	*z = _mm512_mask_blend_ps( moves, *z, _mm512_add_ps( *z, _mm512_mul_ps( push, nz ) ) );
	return moves;
}

void plBodyContactBatch_Avx512( float* const* positions, const float* const* shaped_points, const float* offsets_m,
								uint32_t batch_count, const float* point_normals, const uint16_t* skin_indices,
								const float* skin_weights, uint32_t influence_count, const float* const* skin_matrices,
								uint32_t joint_count, uint32_t point_count, const uint16_t* candidates,
								uint32_t candidate_count, const uint16_t* rings, uint32_t ring_count,
								uint32_t vertex_count, float* scratch )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	_Alignas( 64 ) float lanes[( J + 1 ) * 12 * PL_LANES];
	_Alignas( 64 ) float block[3 * PL_BLOCK * PL_LANES];
	uint32_t K = influence_count, n = batch_count < PL_LANES ? batch_count : PL_LANES;
	const plVec16 zero = _mm512_setzero_ps(), infinity = _mm512_set1_ps( INFINITY );
	const plVec16 tiny = _mm512_set1_ps( 1e-12f );
	plSkinMatricesToLanes16( skin_matrices, n, J, lanes );
#define PL_ROW( p, e ) ( scratch + ( (size_t)( p ) * 8 + ( e ) ) * PL_LANES )
	// 1. the points posed, eight points at a time through the lanes transpose of their shaped rows
	for ( uint32_t p0 = 0; p0 < point_count; p0 += PL_BLOCK )
	{
		uint32_t count = point_count - p0 < PL_BLOCK ? point_count - p0 : PL_BLOCK;
		plToLanes16( shaped_points, n, p0, count, block );
		for ( uint32_t i = 0; i < count; ++i )
		{
			uint32_t p = p0 + i;
			const float* rn = point_normals + (size_t)p * 3;
			plVec16 a0[3], a1[3], a2[3], a3[3];
			plBlendMatrixLanes16( a0, a1, a2, a3, skin_indices + (size_t)p * K, skin_weights + (size_t)p * K, K, J,
								  lanes );
			const float* pr = block + (size_t)i * 3 * PL_LANES;
			plVec16 point[3], normal[3];
			plPosePointLanes16( point, normal, a0, a1, a2, a3, _mm512_load_ps( pr ), _mm512_load_ps( pr + PL_LANES ),
								_mm512_load_ps( pr + 2 * PL_LANES ), rn );
			for ( int r = 0; r < 3; ++r )
			{
				_mm512_store_ps( PL_ROW( p, r ), point[r] );
			}
			int anchorable = rn[0] != 0.0f || rn[1] != 0.0f || rn[2] != 0.0f;
			if ( anchorable && rings != NULL && rings[(size_t)p * ring_count] < point_count )
			{
				continue; // the ring pass below writes rows 3-6 (penalty, normal)
			}
			plVec16 length = _mm512_sqrt_ps( _mm512_add_ps(
				_mm512_add_ps( _mm512_mul_ps( normal[0], normal[0] ), _mm512_mul_ps( normal[1], normal[1] ) ),
				_mm512_mul_ps( normal[2], normal[2] ) ) );
			__mmask16 usable = anchorable ? _mm512_cmp_ps_mask( length, tiny, _CMP_GT_OQ ) : 0;
			_mm512_store_ps( PL_ROW( p, 3 ), _mm512_mask_blend_ps( usable, infinity, zero ) );
			for ( int r = 0; r < 3; ++r )
			{
				_mm512_store_ps( PL_ROW( p, 4 + r ), _mm512_maskz_div_ps( usable, normal[r], length ) );
			}
		}
	}
	// 2. the posed body's normals from the rings (after every point is posed: a ring reads its neighbours' rows)
	for ( uint32_t p = 0; rings != NULL && p < point_count; ++p )
	{
		const uint16_t* ring = rings + (size_t)p * ring_count;
		const float* rn = point_normals + (size_t)p * 3;
		if ( ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f ) || ring[0] >= point_count )
		{
			continue;
		}
		plVec16 ox = _mm512_load_ps( PL_ROW( p, 0 ) ), oy = _mm512_load_ps( PL_ROW( p, 1 ) );
		plVec16 oz = _mm512_load_ps( PL_ROW( p, 2 ) );
		plVec16 dx[PLEAT_MAX_POINT_RING], dy[PLEAT_MAX_POINT_RING], dz[PLEAT_MAX_POINT_RING];
		uint32_t m = 0;
		while ( m < ring_count && ring[m] < point_count )
		{
			dx[m] = _mm512_sub_ps( _mm512_load_ps( PL_ROW( ring[m], 0 ) ), ox );
			dy[m] = _mm512_sub_ps( _mm512_load_ps( PL_ROW( ring[m], 1 ) ), oy );
			dz[m] = _mm512_sub_ps( _mm512_load_ps( PL_ROW( ring[m], 2 ) ), oz );
			m++;
		}
		plVec16 nx = zero, ny = zero, nz = zero;
		for ( uint32_t i = 0; i < m; ++i )
		{
			uint32_t j = i + 1 < m ? i + 1 : 0;
			nx = _mm512_add_ps( nx, _mm512_sub_ps( _mm512_mul_ps( dy[i], dz[j] ), _mm512_mul_ps( dz[i], dy[j] ) ) );
			ny = _mm512_add_ps( ny, _mm512_sub_ps( _mm512_mul_ps( dz[i], dx[j] ), _mm512_mul_ps( dx[i], dz[j] ) ) );
			nz = _mm512_add_ps( nz, _mm512_sub_ps( _mm512_mul_ps( dx[i], dy[j] ), _mm512_mul_ps( dy[i], dx[j] ) ) );
		}
		plVec16 squares = _mm512_add_ps( _mm512_mul_ps( nx, nx ), _mm512_mul_ps( ny, ny ) );
		plVec16 length = _mm512_sqrt_ps( _mm512_add_ps( squares, _mm512_mul_ps( nz, nz ) ) );
		__mmask16 usable = _mm512_cmp_ps_mask( length, tiny, _CMP_GT_OQ );
		_mm512_store_ps( PL_ROW( p, 3 ), _mm512_mask_blend_ps( usable, infinity, zero ) );
		_mm512_store_ps( PL_ROW( p, 4 ), _mm512_maskz_div_ps( usable, nx, length ) );
		_mm512_store_ps( PL_ROW( p, 5 ), _mm512_maskz_div_ps( usable, ny, length ) );
		_mm512_store_ps( PL_ROW( p, 6 ), _mm512_maskz_div_ps( usable, nz, length ) );
	}
	// 3. the push, eight vertices at a time through the lanes transpose of the instances' positions
	_Alignas( 64 ) float offset_lanes[PL_LANES] = { 0 };
	for ( uint32_t l = 0; l < n; ++l )
	{
		offset_lanes[l] = offsets_m[l];
	}
	const plVec16 offset = _mm512_load_ps( offset_lanes );
	const plVec16 margin = _mm512_set1_ps( PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M );
	const plVec16 share = _mm512_set1_ps( 1.0f + PLEAT_CONTACT_BLEND_SHARE );
	uint32_t C = candidate_count;
	// the squared distance at which plContactReach16 reaches 0 (the whole push without candidates: 1.1's fast contact)
	const plVec16 beyond_reach =
		candidates != NULL ? _mm512_set1_ps( PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M ) : infinity;
	for ( uint32_t v0 = 0; v0 < vertex_count; v0 += PL_BLOCK )
	{
		uint32_t count = vertex_count - v0 < PL_BLOCK ? vertex_count - v0 : PL_BLOCK;
		plToLanes16( (const float* const*)positions, n, v0, count, block );
		int moved = 0;
		for ( uint32_t i = 0; i < count; ++i )
		{
			uint32_t v = v0 + i;
			float* px = block + (size_t)i * 3 * PL_LANES;
			plVec16 x = _mm512_load_ps( px ), y = _mm512_load_ps( px + PL_LANES );
			plVec16 z = _mm512_load_ps( px + 2 * PL_LANES );
			plVec16 d2[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t slot[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t used = 0;
			plVec16 nearest = infinity;
			for ( uint32_t c = 0; c < C; ++c )
			{
				uint32_t p = candidates != NULL ? candidates[(size_t)v * C + c] : v;
				if ( p >= point_count )
				{
					continue; // an empty slot, for every instance
				}
				plVec16 dx = _mm512_sub_ps( x, _mm512_load_ps( PL_ROW( p, 0 ) ) );
				plVec16 dy = _mm512_sub_ps( y, _mm512_load_ps( PL_ROW( p, 1 ) ) );
				plVec16 dz = _mm512_sub_ps( z, _mm512_load_ps( PL_ROW( p, 2 ) ) );
				plVec16 d = _mm512_add_ps( _mm512_add_ps( _mm512_mul_ps( dx, dx ), _mm512_mul_ps( dy, dy ) ),
										   _mm512_mul_ps( dz, dz ) );
				d2[used] = _mm512_add_ps( d, _mm512_load_ps( PL_ROW( p, 3 ) ) ); // d + 0 = d, d + inf = inf
				slot[used++] = p;
				nearest = _mm512_min_ps( nearest, d2[used - 1] );
			}
			__mmask16 anchored = _mm512_cmp_ps_mask( nearest, infinity, _CMP_LT_OQ );
			if ( ( anchored & _mm512_cmp_ps_mask( nearest, beyond_reach, _CMP_LT_OQ ) ) == 0 )
			{
				continue; // no lane has a usable candidate within the reach
			}
			plVec16 limit = _mm512_add_ps( _mm512_mul_ps( share, nearest ), margin );
			plVec16 total = zero, sx = zero, sy = zero, sz = zero, nx = zero, ny = zero, nz = zero;
			// The weights first, and the candidates some instance weighs; the sums then visit only those, in order (a
			// lane without weight adds w · row = ±0 to sums that never hold −0: skipping is exact).
			uint32_t weighed_k[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t weighed_count = 0;
			for ( uint32_t k = 0; k < used; ++k )
			{
				plVec16 w = _mm512_sub_ps( limit, d2[k] );
				__mmask16 positive = _mm512_cmp_ps_mask( w, zero, _CMP_GT_OQ );
				d2[k] = _mm512_maskz_mov_ps( positive, w );
				weighed_k[weighed_count] = k;
				weighed_count += positive != 0;
			}
			for ( uint32_t j = 0; j < weighed_count; ++j )
			{
				uint32_t k = weighed_k[j];
				plVec16 w = d2[k];
				uint32_t p = slot[k];
				total = _mm512_add_ps( total, w );
				sx = _mm512_add_ps( sx, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 0 ) ) ) );
				sy = _mm512_add_ps( sy, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 1 ) ) ) );
				sz = _mm512_add_ps( sz, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 2 ) ) ) );
				nx = _mm512_add_ps( nx, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 4 ) ) ) );
				ny = _mm512_add_ps( ny, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 5 ) ) ) );
				nz = _mm512_add_ps( nz, _mm512_mul_ps( w, _mm512_load_ps( PL_ROW( p, 6 ) ) ) );
			}
			// the blended plane (a lane without a usable candidate or weight: a zero normal, left where it is), none
			// where the nearest candidate is beyond the reach
			plVec16 reach = candidates != NULL ? plContactReach16( nearest ) : _mm512_set1_ps( 1.0f );
			__mmask16 weighed = anchored & _mm512_cmp_ps_mask( total, zero, _CMP_GT_OQ ) &
								_mm512_cmp_ps_mask( reach, zero, _CMP_GT_OQ );
			if ( plPushOutOfAnchorPlane16( &x, &y, &z, _mm512_div_ps( sx, total ), _mm512_div_ps( sy, total ),
										   _mm512_div_ps( sz, total ), _mm512_maskz_mov_ps( weighed, nx ),
										   _mm512_maskz_mov_ps( weighed, ny ), _mm512_maskz_mov_ps( weighed, nz ),
										   offset, reach ) == 0 )
			{
				continue;
			}
			_mm512_store_ps( px, x );
			_mm512_store_ps( px + PL_LANES, y );
			_mm512_store_ps( px + 2 * PL_LANES, z );
			moved = 1;
		}
		if ( moved )
		{
			plFromLanes16( block, positions, n, v0, count );
		}
	}
#undef PL_ROW
}
