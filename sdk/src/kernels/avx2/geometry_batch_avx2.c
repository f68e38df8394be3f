// AVX2 twins of plSkinning_Avx2 and plNormalsScatter_Avx2 over a batch: 8 instances of one mesh per vector, one lane
// each, for plStepInstances (batch.c) on AVX2 and on AVX-512 CPUs alike (on the AVX-512 machine measured, an AMD
// EPYC that executes 512-bit operations as two 256-bit halves, 16-lane versions were slower: twice the shuffles in the
// transposes for the same load bandwidth).
//
// A single-instance kernel spends its vector lanes on one instance's vertex (x, y, z, 0 in four lanes, or one 3×4
// matrix spread over eight) and then shuffles, broadcasts and sums across them. With many instances of one mesh the
// lanes can be instances instead: every instance of a lane group reads the same skin indices and weights, the same
// faces and adjacency, so one vector operation does one scalar operation of the single kernel for 8 instances at once
// and nothing crosses lanes. Per lane the operations, operands and their order are exactly those of the single kernel,
// so every instance gets the single kernel's bits:
//   skinning  (plSkinning_Avx2)       per matrix element an FMA chain over the influences from 0, then per output
//                                      component fma(m_i2, z, m_i0 · x) + fma(m_i3, 1, m_i1 · y)
//   normals   (plNormalsScatter_Avx2) per face cross(x_b − x_a, x_c − x_a) as (e1y e2z − e1z e2y, ...) with separate
//                                      roundings, added to its in-range vertices' sums in face order from 0; per
//                                      vertex length = sqrt((x² + y²) + z²), scale = length > 0 ? 1 / length : 0
// The instances' own buffers are [N][3] (AoS); blocks of 8 vertices are transposed into lanes and back (8×8
// transposes in registers), through zero-padded copies at a ragged end. Contraction into FMA would change the bits of
// the normals, so it is off here as in normals_avx2.c (GCC does not contract in ISO C mode; clang needs the pragma).
#include "kernels/kernels_batch.h"
#include "simd_avx2.h"

#include <immintrin.h>
#include <string.h>

#if defined( __clang__ )
#pragma STDC FP_CONTRACT OFF
#endif

#define PL_LANES 8
typedef __m256 plVec;
#define plVecZero() _mm256_setzero_ps()
#define plVecSet1( f ) _mm256_set1_ps( f )
#define plVecLoad( p ) _mm256_load_ps( p )
#define plVecStore( p, v ) _mm256_store_ps( p, v )
#define plVecLoadU( p ) _mm256_loadu_ps( p )
#define plVecStoreU( p, v ) _mm256_storeu_ps( p, v )
#define plVecAdd( a, b ) _mm256_add_ps( a, b )
#define plVecSub( a, b ) _mm256_sub_ps( a, b )
#define plVecMul( a, b ) _mm256_mul_ps( a, b )
#define plVecFma( a, b, c ) _mm256_fmadd_ps( a, b, c )
#define plVecSqrt( a ) _mm256_sqrt_ps( a )
// length > 0 ? 1 / length : 0, as plNormalsScatter_Avx2 (a division, then the lanes whose length is not > 0 zeroed)
#define plVecUnitScale( length )                                                                                       \
	_mm256_and_ps( _mm256_div_ps( _mm256_set1_ps( 1.0f ), length ),                                                    \
				   _mm256_cmp_ps( length, _mm256_setzero_ps(), _CMP_GT_OQ ) )

// Lanes of a group beyond batch_count read this (zeros) and are never written back.
static const float s_plZeroBlock[3 * PL_LANES] = { 0 };

// Vertices [v0, v0 + count) of instances src[0..n) (AoS, packed) → dst[3 · PL_LANES][PL_LANES]: row 3i + c holds
// component c of vertex v0 + i of every instance (zero rows past count, zero lanes past n).
static inline void plToLanes( const float* const* src, uint32_t n, uint32_t v0, uint32_t count, float* dst )
{
	for ( int q = 0; q < 3; ++q )
	{
		plVec r[PL_LANES];
		for ( uint32_t b = 0; b < PL_LANES; ++b )
		{
			const float* s = b < n ? src[b] + (size_t)v0 * 3 : s_plZeroBlock;
			if ( count == PL_LANES || b >= n )
			{
				r[b] = plVecLoadU( s + q * PL_LANES );
			}
			else
			{
				float padded[3 * PL_LANES] = { 0 };
				memcpy( padded, s, (size_t)count * 3 * sizeof( float ) );
				r[b] = plVecLoadU( padded + q * PL_LANES );
			}
		}
		plTranspose8x8( r );
		for ( int t = 0; t < PL_LANES; ++t )
		{
			plVecStore( dst + (size_t)( q * PL_LANES + t ) * PL_LANES, r[t] );
		}
	}
}

// The lines of vertices [v, v + PL_LANES) of instances p[0..n) (AoS), for reading (write = 0) or writing. Each lane's
// buffer is its own stream, more streams than the hardware prefetchers follow, and the buffers were last touched by an
// earlier stage of the step (out in L3 by now).
static inline void plPrefetchLanes( const float* const* p, uint32_t n, size_t v, size_t v_end, int write )
{
	if ( v >= v_end )
	{
		return;
	}
	for ( uint32_t b = 0; b < n; ++b )
	{
		const char* line = (const char*)( p[b] + v * 3 );
		for ( int k = 0; k < 3 * PL_LANES * 4; k += 64 )
		{
			if ( write )
			{
				__builtin_prefetch( line + k, 1, 3 );
			}
			else
			{
				__builtin_prefetch( line + k, 0, 3 );
			}
		}
	}
}

// The way back: src[3 · PL_LANES][PL_LANES] → vertices [v0, v0 + count) of instances dst[0..n) (AoS, packed).
static inline void plFromLanes( const float* src, float* const* dst, uint32_t n, uint32_t v0, uint32_t count )
{
	for ( int q = 0; q < 3; ++q )
	{
		plVec r[PL_LANES];
		for ( int t = 0; t < PL_LANES; ++t )
		{
			r[t] = plVecLoad( src + (size_t)( q * PL_LANES + t ) * PL_LANES );
		}
		plTranspose8x8( r );
		for ( uint32_t b = 0; b < n; ++b )
		{
			float* d = dst[b] + (size_t)v0 * 3;
			if ( count == PL_LANES )
			{
				plVecStoreU( d + q * PL_LANES, r[b] );
			}
			else
			{
				// A ragged end: only the floats of vertices below count, which may end inside this vector or before it.
				float full[PL_LANES];
				plVecStoreU( full, r[b] );
				uint32_t first = (uint32_t)q * PL_LANES, total = count * 3;
				if ( first < total )
				{
					uint32_t floats = total - first < PL_LANES ? total - first : PL_LANES;
					memcpy( d + first, full, floats * sizeof( float ) );
				}
			}
		}
	}
}

// skin_matrices[0..n) (each [J][12]) → lanes[J + 1][12][PL_LANES]: element e of joint j's matrix for every lane, the
// extra joint and the lanes past n all zero.
static inline void plSkinMatricesToLanes( const float* const* skin_matrices, uint32_t n, uint32_t J, float* lanes )
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

// Σ_k w_k M_{j_k} per lane, as plSkinning_Avx2 blends: per matrix element an FMA chain over the influences from 0;
// a0..a3[r] = columns 0..3 of row r. indices, weights: the vertex's K influences; an index ≥ J reads the zero joint.
static inline void plBlendMatrixLanes( plVec a0[3], plVec a1[3], plVec a2[3], plVec a3[3], const uint16_t* indices,
									   const float* weights, uint32_t K, uint32_t J, const float* lanes )
{
	for ( int r = 0; r < 3; ++r )
	{
		a0[r] = a1[r] = a2[r] = a3[r] = plVecZero();
	}
	for ( uint32_t k = 0; k < K; ++k )
	{
		uint32_t joint = indices[k] < J ? indices[k] : J;
		const float* m = lanes + (size_t)joint * 12 * PL_LANES;
		plVec w = plVecSet1( weights[k] );
		for ( int r = 0; r < 3; ++r )
		{
			a0[r] = plVecFma( w, plVecLoad( m + ( 4 * r + 0 ) * PL_LANES ), a0[r] );
			a1[r] = plVecFma( w, plVecLoad( m + ( 4 * r + 1 ) * PL_LANES ), a1[r] );
			a2[r] = plVecFma( w, plVecLoad( m + ( 4 * r + 2 ) * PL_LANES ), a2[r] );
			a3[r] = plVecFma( w, plVecLoad( m + ( 4 * r + 3 ) * PL_LANES ), a3[r] );
		}
	}
}

void plSkinningBatch_Avx2( float* const* out, const float* const* in, uint32_t batch_count,
						   const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
						   const float* const* skin_matrices, uint32_t joint_count, uint32_t v_begin, uint32_t v_end )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	// [J + 1][12][PL_LANES]: element e of joint j's matrix for every lane; the extra joint is all zero (an index out of
	// range blends a zero matrix, as plSkinning_Avx2 does). Sized by J (a VLA: the SIMD files build with GCC and clang
	// only): 9.6 KB of a worker's stack for 24 joints, 25 KB for the most.
	_Alignas( 64 ) float lanes[( J + 1 ) * 12 * PL_LANES];
	_Alignas( 64 ) float block_in[3 * PL_LANES * PL_LANES];
	_Alignas( 64 ) float block_out[3 * PL_LANES * PL_LANES];
	uint32_t K = influence_count;
	const plVec one = plVecSet1( 1.0f );
	for ( uint32_t b0 = 0; b0 < batch_count; b0 += PL_LANES )
	{
		uint32_t n = batch_count - b0 < PL_LANES ? batch_count - b0 : PL_LANES;
		plSkinMatricesToLanes( skin_matrices + b0, n, J, lanes );
		for ( uint32_t v0 = v_begin; v0 < v_end; v0 += PL_LANES )
		{
			uint32_t count = v_end - v0 < PL_LANES ? v_end - v0 : PL_LANES;
			plPrefetchLanes( in + b0, n, (size_t)v0 + 4 * PL_LANES, v_end, 0 );
			plPrefetchLanes( (const float* const*)( out + b0 ), n, (size_t)v0 + 4 * PL_LANES, v_end, 1 );
			plToLanes( in + b0, n, v0, count, block_in );
			for ( uint32_t i = 0; i < count; ++i )
			{
				uint32_t v = v0 + i;
				plVec a0[3], a1[3], a2[3], a3[3]; // the blended matrix: columns 0..3 of rows 0..2
				plBlendMatrixLanes( a0, a1, a2, a3, skin_indices + (size_t)v * K, skin_weights + (size_t)v * K, K, J,
									lanes );
				const float* p = block_in + (size_t)i * 3 * PL_LANES;
				plVec x = plVecLoad( p ), y = plVecLoad( p + PL_LANES ), z = plVecLoad( p + 2 * PL_LANES );
				float* q = block_out + (size_t)i * 3 * PL_LANES;
				for ( int r = 0; r < 3; ++r )
				{
					plVec even = plVecFma( a2[r], z, plVecMul( a0[r], x ) );
					plVec odd = plVecFma( a3[r], one, plVecMul( a1[r], y ) );
					plVecStore( q + r * PL_LANES, plVecAdd( even, odd ) );
				}
			}
			plFromLanes( block_out, out + b0, n, v0, count );
		}
	}
}

void plNormalsBatch_Avx2( float* const* normals, const float* const* positions, uint32_t batch_count,
					   uint32_t vertex_count, const uint32_t* faces, uint32_t face_count, float* scratch )
{
	uint32_t N = vertex_count;
	// [N'][3][PL_LANES] each, N' = N rounded up to whole PL_LANES-vertex blocks: plToLanes and plFromLanes move whole
	// blocks (plNormalsBatchScratchFloats sizes the scratch the same way)
	size_t plane = ( ( ( (size_t)N + PL_LANES - 1 ) / PL_LANES * PL_LANES ) * 3 * PL_LANES + 15 ) & ~(size_t)15;
	float* P = scratch;          // positions
	float* S = scratch + plane;  // sums, then unit normals
	for ( uint32_t b0 = 0; b0 < batch_count; b0 += PL_LANES )
	{
		uint32_t n = batch_count - b0 < PL_LANES ? batch_count - b0 : PL_LANES;
		for ( uint32_t v0 = 0; v0 < N; v0 += PL_LANES )
		{
			plPrefetchLanes( positions + b0, n, (size_t)v0 + 4 * PL_LANES, N, 0 );
			plToLanes( positions + b0, n, v0, N - v0 < PL_LANES ? N - v0 : PL_LANES, P + (size_t)v0 * 3 * PL_LANES );
		}
		memset( S, 0, (size_t)N * 3 * PL_LANES * sizeof( float ) );
		for ( uint32_t f = 0; f < face_count; ++f )
		{
			const uint32_t* tri = faces + (size_t)f * 3;
			plVec nx = plVecZero(), ny = plVecZero(), nz = plVecZero();
			if ( tri[0] < N && tri[1] < N && tri[2] < N )
			{
				const float* a = P + (size_t)tri[0] * 3 * PL_LANES;
				const float* b = P + (size_t)tri[1] * 3 * PL_LANES;
				const float* c = P + (size_t)tri[2] * 3 * PL_LANES;
				plVec ax = plVecLoad( a ), ay = plVecLoad( a + PL_LANES ), az = plVecLoad( a + 2 * PL_LANES );
				plVec e1x = plVecSub( plVecLoad( b ), ax ), e1y = plVecSub( plVecLoad( b + PL_LANES ), ay );
				plVec e1z = plVecSub( plVecLoad( b + 2 * PL_LANES ), az );
				plVec e2x = plVecSub( plVecLoad( c ), ax ), e2y = plVecSub( plVecLoad( c + PL_LANES ), ay );
				plVec e2z = plVecSub( plVecLoad( c + 2 * PL_LANES ), az );
				nx = plVecSub( plVecMul( e1y, e2z ), plVecMul( e1z, e2y ) );
				ny = plVecSub( plVecMul( e1z, e2x ), plVecMul( e1x, e2z ) );
				nz = plVecSub( plVecMul( e1x, e2y ), plVecMul( e1y, e2x ) );
			}
			for ( int k = 0; k < 3; ++k )
			{
				if ( tri[k] < N )
				{
					float* s = S + (size_t)tri[k] * 3 * PL_LANES;
					plVecStore( s, plVecAdd( plVecLoad( s ), nx ) );
					plVecStore( s + PL_LANES, plVecAdd( plVecLoad( s + PL_LANES ), ny ) );
					plVecStore( s + 2 * PL_LANES, plVecAdd( plVecLoad( s + 2 * PL_LANES ), nz ) );
				}
			}
		}
		for ( uint32_t v = 0; v < N; ++v )
		{
			float* s = S + (size_t)v * 3 * PL_LANES;
			plVec x = plVecLoad( s ), y = plVecLoad( s + PL_LANES ), z = plVecLoad( s + 2 * PL_LANES );
			plVec length = plVecSqrt( plVecAdd( plVecAdd( plVecMul( x, x ), plVecMul( y, y ) ), plVecMul( z, z ) ) );
			plVec scale = plVecUnitScale( length );
			plVecStore( s, plVecMul( x, scale ) );
			plVecStore( s + PL_LANES, plVecMul( y, scale ) );
			plVecStore( s + 2 * PL_LANES, plVecMul( z, scale ) );
		}
		for ( uint32_t v0 = 0; v0 < N; v0 += PL_LANES )
		{
			plPrefetchLanes( (const float* const*)( normals + b0 ), n, (size_t)v0 + 4 * PL_LANES, N, 1 );
			plFromLanes( S + (size_t)v0 * 3 * PL_LANES, normals + b0, n, v0, N - v0 < PL_LANES ? N - v0 : PL_LANES );
		}
	}
}

// A body point posed in the lanes from its blended matrix (plBlendMatrixLanes) and rest position (per lane) and rest
// normal (shared): the posed point fma(m_i2, r_z, m_i0 r_x) + fma(m_i3, 1, m_i1 r_y) and the unnormalised normal
// fma(m_i2, n_z, m_i0 n_x) + fma(m_i3, 0, m_i1 n_y) per component, plPoseAnchor's operations per lane. Both contacts'
// lanes kernels pose with it.
static inline void plPosePointLanes( plVec point[3], plVec normal[3], const plVec a0[3], const plVec a1[3],
									 const plVec a2[3], const plVec a3[3], plVec rx, plVec ry, plVec rz,
									 const float* rest_normal )
{
	const plVec one = plVecSet1( 1.0f ), zero = plVecZero();
	plVec nx0 = plVecSet1( rest_normal[0] ), ny0 = plVecSet1( rest_normal[1] ), nz0 = plVecSet1( rest_normal[2] );
	for ( int r = 0; r < 3; ++r )
	{
		point[r] = plVecAdd( plVecFma( a2[r], rz, plVecMul( a0[r], rx ) ), plVecFma( a3[r], one, plVecMul( a1[r], ry ) ) );
		normal[r] =
			plVecAdd( plVecFma( a2[r], nz0, plVecMul( a0[r], nx0 ) ), plVecFma( a3[r], zero, plVecMul( a1[r], ny0 ) ) );
	}
}

// Body contact (twin of plBodyContactFast_Avx2), 8 instances per vector: the anchor's blended matrix as skinning's, the
// posed anchor fma(m_i2, r_z, m_i0 r_x) + fma(m_i3, 1, m_i1 r_y) and the normal fma(m_i2, n_z, m_i0 n_x) +
// fma(m_i3, 0, m_i1 n_y) per component, then the scalar kernel's length, divisions, plane distance and push
// (plPushOutOfAnchorPlane8, shared with plBodyContactFast_Avx2) — per lane, each instance with its own anchors (its β)
// and clearance. A lane whose normal is degenerate, or whose vertex lies beyond the clearance, keeps its position bit
// for bit.
void plBodyContactFastBatch_Avx2( float* const* positions, const float* const* shaped_anchors, const float* offsets_m,
							  uint32_t batch_count, const float* anchor_normals, const uint16_t* anchor_skin_indices,
							  const float* anchor_skin_weights, uint32_t influence_count,
							  const float* const* skin_matrices, uint32_t joint_count, uint32_t v_begin,
							  uint32_t v_end )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	_Alignas( 64 ) float lanes[( J + 1 ) * 12 * PL_LANES];
	_Alignas( 64 ) float block_x[3 * PL_LANES * PL_LANES];
	_Alignas( 64 ) float block_r[3 * PL_LANES * PL_LANES];
	uint32_t K = influence_count;
	for ( uint32_t b0 = 0; b0 < batch_count; b0 += PL_LANES )
	{
		uint32_t n = batch_count - b0 < PL_LANES ? batch_count - b0 : PL_LANES;
		_Alignas( 32 ) float offset_lanes[PL_LANES] = { 0 };
		for ( uint32_t l = 0; l < n; ++l )
		{
			offset_lanes[l] = offsets_m[b0 + l];
		}
		const plVec offset = plVecLoad( offset_lanes );
		plSkinMatricesToLanes( skin_matrices + b0, n, J, lanes );
		for ( uint32_t v0 = v_begin; v0 < v_end; v0 += PL_LANES )
		{
			uint32_t count = v_end - v0 < PL_LANES ? v_end - v0 : PL_LANES;
			int any = 0;
			for ( uint32_t i = 0; i < count && !any; ++i )
			{
				const float* rn = anchor_normals + (size_t)( v0 + i ) * 3;
				any = !( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f );
			}
			if ( !any )
			{
				continue; // no anchor in the block: nothing moves
			}
			plPrefetchLanes( (const float* const*)( positions + b0 ), n, (size_t)v0 + 4 * PL_LANES, v_end, 1 );
			plPrefetchLanes( shaped_anchors + b0, n, (size_t)v0 + 4 * PL_LANES, v_end, 0 );
			plToLanes( (const float* const*)( positions + b0 ), n, v0, count, block_x );
			plToLanes( shaped_anchors + b0, n, v0, count, block_r );
			for ( uint32_t i = 0; i < count; ++i )
			{
				uint32_t v = v0 + i;
				const float* rn = anchor_normals + (size_t)v * 3;
				if ( rn[0] == 0.0f && rn[1] == 0.0f && rn[2] == 0.0f )
				{
					continue; // no anchor
				}
				plVec a0[3], a1[3], a2[3], a3[3];
				const uint16_t* indices = anchor_skin_indices + (size_t)v * K;
				plBlendMatrixLanes( a0, a1, a2, a3, indices, anchor_skin_weights + (size_t)v * K, K, J, lanes );
				const float* pr = block_r + (size_t)i * 3 * PL_LANES;
				plVec anchor[3], normal[3];
				plPosePointLanes( anchor, normal, a0, a1, a2, a3, plVecLoad( pr ), plVecLoad( pr + PL_LANES ),
								  plVecLoad( pr + 2 * PL_LANES ), rn );
				float* px = block_x + (size_t)i * 3 * PL_LANES;
				plVec x = plVecLoad( px ), y = plVecLoad( px + PL_LANES ), z = plVecLoad( px + 2 * PL_LANES );
				plPushOutOfAnchorPlane8( &x, &y, &z, anchor[0], anchor[1], anchor[2], normal[0], normal[1], normal[2],
										 offset, plVecSet1( 1.0f ) );
				plVecStore( px, x );
				plVecStore( px + PL_LANES, y );
				plVecStore( px + 2 * PL_LANES, z );
			}
			plFromLanes( block_x, positions + b0, n, v0, count );
		}
	}
}

// The full body contact (twin of plPoseBodyPoints_Avx2, plBodyPointNormals_Avx2 and plBodyContact_Avx2) of up to 8
// instances of one asset, the instances in the lanes: the posed points go to scratch as [P][8 rows][8 lanes] (a_x, a_y,
// a_z, penalty, n_x, n_y, n_z, unused; penalty = +0 where the point is usable, +inf where not, so that a distance plus
// its penalty is the kernels' "usable ? d : inf" with one addition), so that a ring point's or a candidate's row is
// one aligned 8-lane load for all instances at once instead of a gather per instance. Per lane the operations of the single kernels in their order
// (the posing's blend and FMAs as plPoseAnchor, as plBodyContactFastBatch_Avx2 does; the ring sums and the push as the
// scalar kernels, which the single AVX2 twins match), so every instance gets its lone step's bits (what
// plStepInstances promises). Why: the full contact runs per instance and a crowd step could not batch it (60 µs an
// instance on the 1k shirt, docs/benchmarks.md "Body contact"); in lanes the points' rows are shared loads.
void plBodyContactBatch_Avx2( float* const* positions, const float* const* shaped_points, const float* offsets_m,
							  uint32_t batch_count, const float* point_normals, const uint16_t* skin_indices,
							  const float* skin_weights, uint32_t influence_count, const float* const* skin_matrices,
							  uint32_t joint_count, uint32_t point_count, const uint16_t* candidates,
							  uint32_t candidate_count, const uint16_t* rings, uint32_t ring_count, uint32_t vertex_count,
							  float* scratch )
{
	uint32_t J = joint_count < PLEAT_SKIN_COLUMN_JOINTS ? joint_count : PLEAT_SKIN_COLUMN_JOINTS;
	_Alignas( 64 ) float lanes[( J + 1 ) * 12 * PL_LANES];
	_Alignas( 64 ) float block[3 * PL_LANES * PL_LANES];
	uint32_t K = influence_count, n = batch_count < PL_LANES ? batch_count : PL_LANES;
	const plVec zero = plVecZero(), infinity = plVecSet1( INFINITY );
	const plVec tiny = plVecSet1( 1e-12f );
	plSkinMatricesToLanes( skin_matrices, n, J, lanes );
#define PL_ROW( p, e ) ( scratch + ( (size_t)( p ) * 8 + ( e ) ) * PL_LANES )
	// 1. the points posed, eight points at a time through the lanes transpose of their shaped rows
	for ( uint32_t p0 = 0; p0 < point_count; p0 += PL_LANES )
	{
		uint32_t count = point_count - p0 < PL_LANES ? point_count - p0 : PL_LANES;
		plToLanes( shaped_points, n, p0, count, block );
		for ( uint32_t i = 0; i < count; ++i )
		{
			uint32_t p = p0 + i;
			const float* rn = point_normals + (size_t)p * 3;
			plVec a0[3], a1[3], a2[3], a3[3];
			plBlendMatrixLanes( a0, a1, a2, a3, skin_indices + (size_t)p * K, skin_weights + (size_t)p * K, K, J, lanes );
			const float* pr = block + (size_t)i * 3 * PL_LANES;
			plVec point[3], normal[3];
			plPosePointLanes( point, normal, a0, a1, a2, a3, plVecLoad( pr ), plVecLoad( pr + PL_LANES ),
							  plVecLoad( pr + 2 * PL_LANES ), rn );
			for ( int r = 0; r < 3; ++r )
			{
				plVecStore( PL_ROW( p, r ), point[r] );
			}
			int anchorable = rn[0] != 0.0f || rn[1] != 0.0f || rn[2] != 0.0f;
			if ( anchorable && rings != NULL && rings[(size_t)p * ring_count] < point_count )
			{
				continue; // the ring pass below writes rows 3-6 (penalty, normal): a square root and three divisions
			}
			plVec length = plVecSqrt( plVecAdd( plVecAdd( plVecMul( normal[0], normal[0] ), plVecMul( normal[1], normal[1] ) ),
												plVecMul( normal[2], normal[2] ) ) );
			plVec usable = anchorable ? _mm256_cmp_ps( length, tiny, _CMP_GT_OQ ) : zero;
			plVecStore( PL_ROW( p, 3 ), _mm256_andnot_ps( usable, infinity ) );
			for ( int r = 0; r < 3; ++r )
			{
				plVecStore( PL_ROW( p, 4 + r ), _mm256_and_ps( _mm256_div_ps( normal[r], length ), usable ) );
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
		plVec ox = plVecLoad( PL_ROW( p, 0 ) ), oy = plVecLoad( PL_ROW( p, 1 ) ), oz = plVecLoad( PL_ROW( p, 2 ) );
		plVec dx[PLEAT_MAX_POINT_RING], dy[PLEAT_MAX_POINT_RING], dz[PLEAT_MAX_POINT_RING];
		uint32_t m = 0;
		while ( m < ring_count && ring[m] < point_count )
		{
			dx[m] = plVecSub( plVecLoad( PL_ROW( ring[m], 0 ) ), ox );
			dy[m] = plVecSub( plVecLoad( PL_ROW( ring[m], 1 ) ), oy );
			dz[m] = plVecSub( plVecLoad( PL_ROW( ring[m], 2 ) ), oz );
			m++;
		}
		plVec nx = zero, ny = zero, nz = zero;
		for ( uint32_t i = 0; i < m; ++i )
		{
			uint32_t j = i + 1 < m ? i + 1 : 0;
			nx = plVecAdd( nx, plVecSub( plVecMul( dy[i], dz[j] ), plVecMul( dz[i], dy[j] ) ) );
			ny = plVecAdd( ny, plVecSub( plVecMul( dz[i], dx[j] ), plVecMul( dx[i], dz[j] ) ) );
			nz = plVecAdd( nz, plVecSub( plVecMul( dx[i], dy[j] ), plVecMul( dy[i], dx[j] ) ) );
		}
		plVec length = plVecSqrt( plVecAdd( plVecAdd( plVecMul( nx, nx ), plVecMul( ny, ny ) ), plVecMul( nz, nz ) ) );
		plVec usable = _mm256_cmp_ps( length, tiny, _CMP_GT_OQ );
		plVecStore( PL_ROW( p, 3 ), _mm256_andnot_ps( usable, infinity ) );
		plVecStore( PL_ROW( p, 4 ), _mm256_and_ps( _mm256_div_ps( nx, length ), usable ) );
		plVecStore( PL_ROW( p, 5 ), _mm256_and_ps( _mm256_div_ps( ny, length ), usable ) );
		plVecStore( PL_ROW( p, 6 ), _mm256_and_ps( _mm256_div_ps( nz, length ), usable ) );
	}
	// 3. the push, eight vertices at a time through the lanes transpose of the instances' positions
	_Alignas( 32 ) float offset_lanes[PL_LANES] = { 0 };
	for ( uint32_t l = 0; l < n; ++l )
	{
		offset_lanes[l] = offsets_m[l];
	}
	const plVec offset = plVecLoad( offset_lanes );
	const plVec margin = plVecSet1( PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M );
	const plVec share = plVecSet1( 1.0f + PLEAT_CONTACT_BLEND_SHARE );
	uint32_t C = candidate_count;
	// the squared distance at which plContactReach8 reaches 0 (the whole push without candidates: 1.1's fast contact)
	const plVec beyond_reach = candidates != NULL ? plVecSet1( PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M )
												  : infinity;
	for ( uint32_t v0 = 0; v0 < vertex_count; v0 += PL_LANES )
	{
		uint32_t count = vertex_count - v0 < PL_LANES ? vertex_count - v0 : PL_LANES;
		plToLanes( (const float* const*)positions, n, v0, count, block );
		int moved = 0;
		for ( uint32_t i = 0; i < count; ++i )
		{
			uint32_t v = v0 + i;
			float* px = block + (size_t)i * 3 * PL_LANES;
			plVec x = plVecLoad( px ), y = plVecLoad( px + PL_LANES ), z = plVecLoad( px + 2 * PL_LANES );
			plVec d2[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t slot[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t used = 0;
			plVec nearest = infinity;
			for ( uint32_t c = 0; c < C; ++c )
			{
				uint32_t p = candidates != NULL ? candidates[(size_t)v * C + c] : v;
				if ( p >= point_count )
				{
					continue; // an empty slot, for every instance
				}
				plVec dx = plVecSub( x, plVecLoad( PL_ROW( p, 0 ) ) ), dy = plVecSub( y, plVecLoad( PL_ROW( p, 1 ) ) );
				plVec dz = plVecSub( z, plVecLoad( PL_ROW( p, 2 ) ) );
				plVec d = plVecAdd( plVecAdd( plVecMul( dx, dx ), plVecMul( dy, dy ) ), plVecMul( dz, dz ) );
				d2[used] = plVecAdd( d, plVecLoad( PL_ROW( p, 3 ) ) ); // d + 0 = d (d >= +0), d + inf = inf
				slot[used++] = p;
				nearest = _mm256_min_ps( nearest, d2[used - 1] );
			}
			plVec anchored = _mm256_cmp_ps( nearest, infinity, _CMP_LT_OQ );
			if ( _mm256_movemask_ps( _mm256_and_ps( anchored, _mm256_cmp_ps( nearest, beyond_reach, _CMP_LT_OQ ) ) ) ==
				 0 )
			{
				continue; // no lane has a usable candidate within the reach: the push below would leave every lane
			}
			plVec limit = plVecAdd( plVecMul( share, nearest ), margin );
			plVec total = zero, sx = zero, sy = zero, sz = zero, nx = zero, ny = zero, nz = zero;
			// The weights first, and a bit per candidate that some instance weighs; the sums then visit only those, in
			// candidate order. A lane without weight has w = +0, and sums that start at +0 never hold -0, so adding
			// its w · row (±0) leaves them as the single kernels' skip does: skipping a candidate no lane weighs is
			// exact. (A branch per candidate mispredicted often; the list is built without one.)
			uint32_t weighed_k[PLEAT_MAX_CONTACT_CANDIDATES];
			uint32_t weighed_count = 0;
			for ( uint32_t k = 0; k < used; ++k )
			{
				plVec w = plVecSub( limit, d2[k] );
				plVec positive = _mm256_cmp_ps( w, zero, _CMP_GT_OQ );
				d2[k] = _mm256_and_ps( w, positive );
				weighed_k[weighed_count] = k;
				weighed_count += _mm256_movemask_ps( positive ) != 0;
			}
			for ( uint32_t j = 0; j < weighed_count; ++j )
			{
				uint32_t k = weighed_k[j];
				plVec w = d2[k];
				uint32_t p = slot[k];
				total = plVecAdd( total, w );
				sx = plVecAdd( sx, plVecMul( w, plVecLoad( PL_ROW( p, 0 ) ) ) );
				sy = plVecAdd( sy, plVecMul( w, plVecLoad( PL_ROW( p, 1 ) ) ) );
				sz = plVecAdd( sz, plVecMul( w, plVecLoad( PL_ROW( p, 2 ) ) ) );
				nx = plVecAdd( nx, plVecMul( w, plVecLoad( PL_ROW( p, 4 ) ) ) );
				ny = plVecAdd( ny, plVecMul( w, plVecLoad( PL_ROW( p, 5 ) ) ) );
				nz = plVecAdd( nz, plVecMul( w, plVecLoad( PL_ROW( p, 6 ) ) ) );
			}
			// the blended plane through plPushOutOfAnchorPlane8 (a lane without a usable candidate or weight: a zero
			// normal, which it leaves where it is)
			// and, as the single kernels, none where the nearest candidate is beyond the reach (plContactReach8)
			plVec reach = candidates != NULL ? plContactReach8( nearest ) : plVecSet1( 1.0f );
			plVec weighed = _mm256_and_ps( _mm256_and_ps( anchored, _mm256_cmp_ps( total, zero, _CMP_GT_OQ ) ),
										   _mm256_cmp_ps( reach, zero, _CMP_GT_OQ ) );
			if ( _mm256_movemask_ps( plPushOutOfAnchorPlane8( &x, &y, &z, _mm256_div_ps( sx, total ),
															  _mm256_div_ps( sy, total ), _mm256_div_ps( sz, total ),
															  _mm256_and_ps( nx, weighed ), _mm256_and_ps( ny, weighed ),
															  _mm256_and_ps( nz, weighed ), offset, reach ) ) == 0 )
			{
				continue;
			}
			plVecStore( px, x );
			plVecStore( px + PL_LANES, y );
			plVecStore( px + 2 * PL_LANES, z );
			moved = 1;
		}
		if ( moved )
		{
			plFromLanes( block, positions, n, v0, count );
		}
	}
#undef PL_ROW
}
