// Every SIMD kernel against its scalar specification, on shapes that exercise the vector body, the 16/8-wide steps,
// the scalar tails and the leftover rows, with fp32 and fp16 weights; then the whole pipeline (AVX2 context vs
// force_scalar context) on one motion.
//
// Tolerance: both compute the same fp32 sums in a different order (and FMA vs separate rounding). The rounding error
// of a sum is bounded by ~n · 2^-24 · Σ|terms|, so we assert |simd − scalar| ≤ 4 · n · 6e-8 · Σ|w·x| + 1e-30 per output
// — a wrong index or a skipped tail gives errors of the size of one term, far above this bound.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "jobs.h"
#include "test_blend_shapes.h"
#include "test_common.h"

static uint32_t s_rng = 777;

static float plRand( void )
{
	return plTestRandom( &s_rng );
}

// The next number of the LCG that picks indices (faces, adjacency, joints).
static uint32_t plRandIndex( void )
{
	s_rng = s_rng * 1103515245u + 12345u;
	return s_rng >> 16;
}

static int plHaveAvx2( void )
{
	plKernels k;
	return plChooseKernels( &k, PLEAT_KERNEL_SET_AVX512 ) != PLEAT_KERNEL_SET_SCALAR;
}

// cmocka setup: *state = the AVX2 kernels (where this build and CPU have them) and the scalar specification.
typedef struct plKernelPair
{
	plKernels simd, scalar;
	int has_simd;
} plKernelPair;

static int plKernelPair_Setup( void** state )
{
	static plKernelPair pair;
	// The single-instance SIMD kernels: AVX2's, which the AVX-512 set keeps too.
	pair.has_simd = plChooseKernels( &pair.simd, PLEAT_KERNEL_SET_AVX512 ) != PLEAT_KERNEL_SET_SCALAR;
	plChooseKernels( &pair.scalar, PLEAT_KERNEL_SET_SCALAR );
	*state = &pair;
	return 0;
}
#define PLEAT_TEST_WITH_PAIR( test ) cmocka_unit_test_setup( test, plKernelPair_Setup )

// The pair of the fixture; skips the test where there is no AVX2 set.
static const plKernelPair* plRequireAvx2Kernels( void** state )
{
	const plKernelPair* pair = (const plKernelPair*)*state;
	if ( !pair->has_simd )
	{
		skip();
	}
	return pair;
}

// count weights scale · U(−1, 1) and their fp16 encodings; with fp16 the fp32 copy holds the decoded halves, so that
// the magnitudes of the bound are those of the numbers the kernels read.
static void plRandomWeights( float* w, uint16_t* w16, size_t count, float scale, int fp16 )
{
	for ( size_t i = 0; i < count; ++i )
	{
		w[i] = scale * plRand();
		w16[i] = plFloatToHalf( w[i] );
		if ( fp16 )
		{
			w[i] = plHalfToFloat( w16[i] );
		}
	}
}

// count influences: joints in [0, joint_count] (joint_count itself out of range), weights in [0, 1).
static void plRandomInfluences( uint16_t* indices, float* weights, uint32_t count, uint32_t joint_count )
{
	for ( uint32_t i = 0; i < count; ++i )
	{
		indices[i] = (uint16_t)plRandIndex() % ( joint_count + 1 );
		weights[i] = 0.5f * ( plRand() + 1.0f );
	}
}

// The bound on |simd − scalar| for an fp32 sum of `terms` terms whose absolute values add up to magnitude (see top).
static double plSumBound( uint32_t terms, double magnitude )
{
	return 4.0 * terms * 6e-8 * magnitude + 1e-30;
}

// Fails, naming the element (a printf format and its arguments), when |simd − scalar| exceeds plSumBound.
static void plExpectWithinSumBound( float scalar, float simd, uint32_t terms, double magnitude, const char* format,
									... )
{
	if ( fabs( (double)scalar - simd ) <= plSumBound( terms, magnitude ) )
	{
		return;
	}
	char where[160];
	va_list args;
	va_start( args, format );
	vsnprintf( where, sizeof( where ), format, args );
	va_end( args );
	fail_msg( "%s: scalar %.9g simd %.9g", where, scalar, simd );
}

// n random points, `stride` bytes apart; the block ends at the last point's z.
static float* plRandomPositions( uint32_t n, uint32_t stride )
{
	float* positions = (float*)malloc( (size_t)( n - 1 ) * stride + 12 );
	for ( uint32_t v = 0; v < n; ++v )
	{
		float* p = (float*)( (uint8_t*)positions + (size_t)v * stride );
		p[0] = plRand();
		p[1] = plRand();
		p[2] = plRand();
	}
	return positions;
}

static void test_mat_vec_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t ins[] = { 1, 7, 8, 9, 15, 16, 17, 31, 33, 681 };
	const uint32_t outs[] = { 1, 2, 3, 4, 5, 7, 13, 512 };
	for ( int fp16 = 0; fp16 < 2; ++fp16 )
	{
		for ( size_t a = 0; a < sizeof( ins ) / sizeof( ins[0] ); ++a )
		{
			for ( size_t b = 0; b < sizeof( outs ) / sizeof( outs[0] ); ++b )
			{
				uint32_t in = ins[a], out = outs[b];
				float* w = (float*)malloc( ( (size_t)in * out + in + 3 * (size_t)out ) * sizeof( float ) );
				float *x = w + (size_t)in * out, *bias = x + in, *ys = bias + out, *yv = ys + out;
				uint16_t* w16 = (uint16_t*)malloc( (size_t)in * out * sizeof( uint16_t ) );
				plRandomWeights( w, w16, (size_t)in * out, 1.0f, fp16 );
				for ( uint32_t i = 0; i < in; ++i )
				{
					x[i] = plRand() * 3.0f;
				}
				for ( uint32_t i = 0; i < out; ++i )
				{
					bias[i] = plRand();
				}
				const void* weights = fp16 ? (const void*)w16 : (const void*)w;
				// Also a sub-range of rows starting at an odd row, as a worker would get.
				uint32_t begin = out > 3 ? 1 : 0;
				pair->scalar.mat_vec( ys, x, weights, fp16, bias, in, 0, in, begin, out );
				pair->simd.mat_vec( yv, x, weights, fp16, bias, in, 0, in, begin, out );
				for ( uint32_t r = begin; r < out; ++r )
				{
					double magnitude = fabs( bias[r] );
					for ( uint32_t c = 0; c < in; ++c )
					{
						magnitude += fabs( (double)w[(size_t)r * in + c] * x[c] );
					}
					plExpectWithinSumBound( ys[r], yv[r], in + 1, magnitude, "fp16=%d in=%u out=%u row %u", fp16, in,
											out, r );
				}
				free( w );
				free( w16 );
			}
		}
	}
}

static void test_blend_shapes_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t ns[] = { 1, 3, 5, 256, 257, 1000 };
	const uint32_t ds[] = { 1, 2, 3, 128 };
	for ( int type = PLEAT_SHAPES_F32; type <= PLEAT_SHAPES_I8; ++type )
	{
		for ( size_t a = 0; a < sizeof( ns ) / sizeof( ns[0] ); ++a )
		{
			for ( size_t b = 0; b < sizeof( ds ) / sizeof( ds[0] ); ++b )
			{
				uint32_t n = ns[a], d = ds[b];
				size_t plane = (size_t)n * 3;
				plTestShapes shapes = plTestShapes_Make( type, d, plane, 0.01f, plRand );
				float* base = (float*)calloc( 3 * plane + d, sizeof( float ) ); // outputs zeroed
				float *os = base + plane, *ov = os + plane, *w = ov + plane;
				for ( size_t i = 0; i < plane; ++i )
				{
					base[i] = plRand();
				}
				for ( uint32_t j = 0; j < d; ++j )
				{
					w[j] = 2.0f * plRand();
				}
				uint32_t begin = n > 2 ? 1 : 0, end = n > 2 ? n - 1 : n;
				pair->scalar.blend_shapes( os, base, &shapes.shapes, w, d, n, begin, end );
				pair->simd.blend_shapes( ov, base, &shapes.shapes, w, d, n, begin, end );
				for ( size_t i = 0; i < plane; ++i )
				{
					if ( i < (size_t)begin * 3 || i >= (size_t)end * 3 )
					{
						assert_true( ov[i] == 0.0f ); // outside the range: untouched
						continue;
					}
					double magnitude = fabs( base[i] );
					for ( uint32_t j = 0; j < d; ++j )
					{
						magnitude += fabs( (double)w[j] * shapes.elements[j * plane + i] );
					}
					plExpectWithinSumBound( os[i], ov[i], d + 1, magnitude, "type=%d n=%u d=%u float %zu", type, n, d,
											i );
				}
				plTestShapes_Free( &shapes );
				free( base );
			}
		}
	}
}

// Posing the body points: random points, normals and K = 1..8 influences, every fourth point without a normal, a joint
// index out of range, a point sub-range (rows outside it untouched). The blended matrix is summed in another
// grouping, so the rows agree to rounding: |Δ| ≤ 1e-5 (the inputs are O(1); a wrong column or sign gives O(0.1)),
// the usable flags exactly.
static void test_pose_body_points_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t joint_count = 7, n = 41;
	float matrices[7 * 12];
	for ( uint32_t i = 0; i < joint_count * 12; ++i )
	{
		matrices[i] = ( i % 4 == 3 ? 0.3f : 1.0f ) * plRand() + ( i % 5 == 0 ? 1.0f : 0.0f );
	}
	float points[41 * 3], normals[41 * 3];
	for ( uint32_t p = 0; p < n; ++p )
	{
		float nx = plRand(), ny = plRand(), nz = plRand() + 0.1f;
		float len = sqrtf( nx * nx + ny * ny + nz * nz );
		normals[3 * p] = p % 4 == 0 ? 0.0f : nx / len;
		normals[3 * p + 1] = p % 4 == 0 ? 0.0f : ny / len;
		normals[3 * p + 2] = p % 4 == 0 ? 0.0f : nz / len;
		for ( int e = 0; e < 3; ++e )
		{
			points[3 * p + e] = plRand();
		}
	}
	for ( uint32_t K = 1; K <= PLEAT_MAX_INFLUENCES; ++K )
	{
		uint16_t indices[41 * 8];
		float weights[41 * 8];
		plRandomInfluences( indices, weights, n * K, joint_count );
		float os[41 * PLEAT_POSED_POINT_FLOATS], ov[41 * PLEAT_POSED_POINT_FLOATS];
		for ( uint32_t i = 0; i < n * PLEAT_POSED_POINT_FLOATS; ++i )
		{
			os[i] = ov[i] = -77.0f;
		}
		pair->scalar.pose_body_points( os, points, normals, indices, weights, K, NULL, matrices, joint_count, NULL, 0, n,
									   1, n - 2 );
		pair->simd.pose_body_points( ov, points, normals, indices, weights, K, NULL, matrices, joint_count, NULL, 0, n, 1,
									 n - 2 );
		// with the column offsets the asset gives it: the same bits as without
		uint32_t offsets[41 * 8];
		plSkinColumnOffsets( offsets, indices, n * K, joint_count );
		float oo[41 * PLEAT_POSED_POINT_FLOATS];
		memcpy( oo, os, sizeof( oo ) ); // (the rows outside the range as the others')
		pair->simd.pose_body_points( oo, points, normals, indices, weights, K, offsets, matrices, joint_count, NULL, 0,
									 n, 1, n - 2 );
		for ( uint32_t p = 1; p < n - 2; ++p )
		{
			assert_memory_equal( oo + p * PLEAT_POSED_POINT_FLOATS, ov + p * PLEAT_POSED_POINT_FLOATS,
								 PLEAT_POSED_POINT_FLOATS * sizeof( float ) );
		}
		// With rings: every third point has one (its first slot < n); the others' are empty or past n. Those points,
		// when anchorable, get usable and the normal 0 (the ring normals set them) and the rest of their row as
		// without rings; every other row is the same as without rings, bit for bit (the same kernel).
		enum { R = 3 };
		uint16_t rings[41 * R];
		for ( uint32_t p = 0; p < n; ++p )
		{
			rings[p * R] = p % 3 == 0 ? (uint16_t)( ( p + 1 ) % n ) : p % 3 == 1 ? 0xFFFFu : (uint16_t)( n + p );
			rings[p * R + 1] = (uint16_t)( ( p + 2 ) % n );
			rings[p * R + 2] = (uint16_t)( ( p + 3 ) % n );
		}
		for ( int simd = 0; simd < 2; ++simd )
		{
			float with[41 * PLEAT_POSED_POINT_FLOATS];
			const float* without = simd ? ov : os;
			for ( uint32_t i = 0; i < n * PLEAT_POSED_POINT_FLOATS; ++i )
			{
				with[i] = -77.0f;
			}
			( simd ? pair->simd : pair->scalar )
				.pose_body_points( with, points, normals, indices, weights, K, simd ? offsets : NULL, matrices,
								   joint_count, rings, R, n, 1, n - 2 );
			uint32_t skipped = 0;
			for ( uint32_t p = 0; p < n; ++p )
			{
				const float* w = with + p * PLEAT_POSED_POINT_FLOATS;
				const float* o = without + p * PLEAT_POSED_POINT_FLOATS;
				int ring_point = p >= 1 && p < n - 2 && p % 3 == 0 && p % 4 != 0; // p % 4 == 0: not an anchor
				if ( ring_point )
				{
					assert_memory_equal( w, o, 4 * sizeof( float ) ); // (a, anchorable) as without rings
					assert_true( w[3] == 1.0f && w[4] == 0.0f && w[5] == 0.0f && w[6] == 0.0f && w[7] == 0.0f );
					skipped++;
				}
				else
				{
					assert_memory_equal( w, o, PLEAT_POSED_POINT_FLOATS * sizeof( float ) );
				}
			}
			assert_true( skipped > 0 );
		}
		uint32_t usable = 0;
		for ( uint32_t p = 0; p < n; ++p )
		{
			for ( uint32_t e = 0; e < PLEAT_POSED_POINT_FLOATS; ++e )
			{
				float a = os[p * PLEAT_POSED_POINT_FLOATS + e], b = ov[p * PLEAT_POSED_POINT_FLOATS + e];
				if ( p < 1 || p >= n - 2 )
				{
					assert_true( a == -77.0f && b == -77.0f ); // outside the range: untouched
					continue;
				}
				if ( e == 7 ) // usable: never without a normal (a zero blend, all weight on bad joints, is not either)
				{
					assert_true( a == b && ( a == 0.0f || ( a == 1.0f && p % 4 != 0 ) ) );
					usable += a == 1.0f;
				}
				if ( fabsf( a - b ) > 1e-5f )
				{
					fail_msg( "K=%u point %u float %u: scalar %.9g simd %.9g", K, p, e, a, b );
				}
			}
		}
		assert_true( usable > 0 );
	}
}

// The posed body's normals from rings: random posed positions, rings of 3..R points (R = 8, the fast path, and R = 5,
// the general one) or none, points that are not anchors, a point range with a tail of fewer than 8. The AVX2 kernel
// performs the scalar one's operations lane by lane, so the rows must be equal bit for bit.
static void test_body_point_normals_avx2_are_bit_identical_to_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	enum { P = 45 };
	for ( uint32_t R = 5; R <= 8; R += 3 )
	{
		float start[P * PLEAT_POSED_POINT_FLOATS];
		uint16_t rings[P * 8];
		for ( uint32_t p = 0; p < P; ++p )
		{
			float* r = start + p * PLEAT_POSED_POINT_FLOATS;
			float row[8] = { plRand(), plRand(), plRand(), p % 6 == 4 ? 0.0f : 1.0f, 0.0f, 1.0f, 0.0f, 1.0f };
			memcpy( r, row, sizeof( row ) );
			uint32_t m = p % 7 == 2 ? 0 : 3 + p % ( R - 2 ); // 0 or 3..R
			for ( uint32_t s = 0; s < R; ++s )
			{
				rings[p * R + s] = s < m ? (uint16_t)( ( p * 7 + s * 11 + 1 ) % P ) : PLEAT_NO_CONTACT_CANDIDATE;
			}
		}
		float os[P * PLEAT_POSED_POINT_FLOATS], ov[P * PLEAT_POSED_POINT_FLOATS];
		memcpy( os, start, sizeof( os ) );
		pair->scalar.body_point_normals( os, P, rings, R, NULL, 2, P - 3 );
		// the SIMD kernel with the rings in lanes (as the asset gives them), over the whole range and over two ranges
		// split inside a block of eight, as two workers may get them; and without them (its scalar fallback)
		_Alignas( 32 ) int32_t lanes[( P + 7 ) / 8 * 8 * 8];
		assert_true( plRingLanesCount( P, R ) <= sizeof( lanes ) / sizeof( lanes[0] ) );
		plRingLanes( lanes, rings, R, P );
		for ( int form = 0; form < 3; ++form )
		{
			memcpy( ov, start, sizeof( ov ) );
			if ( form == 0 )
			{
				pair->simd.body_point_normals( ov, P, rings, R, lanes, 2, P - 3 );
			}
			else if ( form == 1 )
			{
				pair->simd.body_point_normals( ov, P, rings, R, lanes, 2, 21 );
				pair->simd.body_point_normals( ov, P, rings, R, lanes, 21, P - 3 );
			}
			else
			{
				pair->simd.body_point_normals( ov, P, rings, R, NULL, 2, P - 3 );
			}
			assert_memory_equal( os, ov, sizeof( os ) );
		}
		uint32_t changed = 0;
		for ( uint32_t p = 0; p < P; ++p )
		{
			changed += memcmp( os + p * PLEAT_POSED_POINT_FLOATS, start + p * PLEAT_POSED_POINT_FLOATS, 32 ) != 0;
			if ( p < 2 || p >= P - 3 || p % 6 == 4 || p % 7 == 2 )
			{
				assert_memory_equal( os + p * PLEAT_POSED_POINT_FLOATS, start + p * PLEAT_POSED_POINT_FLOATS, 32 );
			}
		}
		assert_true( changed > P / 2 );
	}
}

// The body-contact twins' outputs os (scalar) and ov (SIMD) from the same start, five floats a vertex (x, y, z, then two
// that no kernel may touch) over the vertex range [1, n − 2): outside it, in the two extra floats and (without_anchor)
// at every fourth vertex, both are the start's bits; inside, they agree within `tolerance`. Returns how many floats
// moved, so that a test can require that the contact did something.
static uint32_t plExpectContactTwins( const float* os, const float* ov, const float* start, uint32_t n,
									  int without_anchor, float tolerance, const char* what, uint32_t which )
{
	uint32_t moved = 0;
	for ( uint32_t v = 0; v < n; ++v )
	{
		for ( uint32_t e = 0; e < 5; ++e )
		{
			float a = os[v * 5 + e], b = ov[v * 5 + e];
			if ( v < 1 || v >= n - 2 || e >= 3 || ( without_anchor && v % 4 == 0 ) )
			{
				assert_true( a == start[v * 5 + e] && b == start[v * 5 + e] ); // untouched
				continue;
			}
			moved += a != start[v * 5 + e];
			if ( fabsf( a - b ) > tolerance )
			{
				fail_msg( "%s=%u vertex %u float %u: scalar %.9g simd %.9g", what, which, v, e, a, b );
			}
		}
	}
	return moved;
}

// The push: random posed points (every fifth unusable), C = 1..16 candidates per vertex with empty slots (0xFFFF and
// indices past P), a vertex without any, near ties (pairs of points equally far from a vertex), strided positions
// (other floats untouched) and a vertex sub-range. Points and vertices lie within a few centimetres of each other, so
// with the candidate table vertices get the whole push, a share of it or none (plContactReach: 3–5 cm). The blend's
// sums run in another order in the SIMD kernel, so the two agree to rounding: |Δ| ≤ 1e-6 m (a wrong weight, reach or
// lane gives 1e-4 and more).
static void test_body_contact_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	enum { n = 37, P = 53, stride = 20 };
	float posed[( P + 1 ) * PLEAT_POSED_POINT_FLOATS] = { 0 }; // and the zero row P, the empty slots' (row offsets)
	for ( uint32_t p = 0; p < P; ++p )
	{
		float* r = posed + p * PLEAT_POSED_POINT_FLOATS;
		float nx = plRand(), ny = plRand(), nz = plRand() + 0.1f;
		float len = sqrtf( nx * nx + ny * ny + nz * nz );
		int usable = p % 5 != 2;
		float row[8] = { 0.03f * plRand(), 0.03f * plRand(), 0.03f * plRand(), 1.0f, usable ? nx / len : 0.0f,
						 usable ? ny / len : 0.0f,         usable ? nz / len : 0.0f,  usable ? 1.0f : 0.0f };
		memcpy( r, row, sizeof( row ) );
	}
	float start[n * 5];
	for ( uint32_t v = 0; v < n; ++v )
	{
		for ( int e = 0; e < 5; ++e )
		{
			start[5 * v + e] = e < 3 ? 0.03f * plRand() : -77.0f;
		}
	}
	// vertex 4 halfway between points 0 and 1: a tie inside the margin
	for ( int e = 0; e < 3; ++e )
	{
		start[5 * 4 + e] = 0.5f * ( posed[e] + posed[PLEAT_POSED_POINT_FLOATS + e] );
	}
	uint32_t reach_kinds[3] = { 0, 0, 0 }; // vertices with the whole push, a share of it, none (of the table passes)
	for ( uint32_t C = 1; C <= PLEAT_MAX_CONTACT_CANDIDATES; ++C )
	{
		uint16_t candidates[n * PLEAT_MAX_CONTACT_CANDIDATES];
		for ( uint32_t v = 0; v < n; ++v )
		{
			for ( uint32_t c = 0; c < C; ++c )
			{
				uint32_t k = v * C + c, r = (uint32_t)( ( plRand() + 1.0f ) * 0.5f * P ) % P;
				candidates[k] = v == 7 || c % 6 == 5 ? 0xFFFFu : c % 7 == 6 ? (uint16_t)( P + c ) : (uint16_t)r;
			}
			if ( v == 4 && C >= 2 )
			{
				candidates[v * C] = 0;
				candidates[v * C + 1] = 1;
			}
		}
		for ( uint32_t v = 1; v < n - 2; ++v )
		{
			float nearest = INFINITY;
			for ( uint32_t c = 0; c < C; ++c )
			{
				uint32_t p = candidates[v * C + c];
				const float* a = posed + (size_t)p * PLEAT_POSED_POINT_FLOATS;
				if ( p < P && a[7] != 0.0f )
				{
					float dx = start[5 * v] - a[0], dy = start[5 * v + 1] - a[1], dz = start[5 * v + 2] - a[2];
					nearest = fminf( nearest, dx * dx + dy * dy + dz * dz );
				}
			}
			if ( nearest < INFINITY )
			{
				reach_kinds[nearest <= 0.03f * 0.03f ? 0 : nearest < 0.05f * 0.05f ? 1 : 2] += 1;
			}
		}
		// the SIMD kernel with the row offsets (as the asset gives them): over the range, and over it split inside a
		// block of eight as two workers may get it; and without them (its scalar fallback)
		uint32_t offsets[2][( n + 7 ) / 8 * PLEAT_MAX_CONTACT_CANDIDATES * 8];
		assert_true( plContactRowOffsetsCount( n, C ) <= sizeof( offsets[0] ) / sizeof( offsets[0][0] ) );
		plContactRowOffsets( offsets[0], candidates, C, n, P );
		plContactRowOffsets( offsets[1], NULL, 1, n, P );
		for ( int form = 0; form < 3; ++form )
		{
			float os[n * 5], ov[n * 5];
			memcpy( os, start, sizeof( os ) );
			memcpy( ov, start, sizeof( ov ) );
			for ( int pass = 0; pass < 2; ++pass ) // pass 1: the identity table (C = 1, vertex v's point is v)
			{
				const uint16_t* table = pass == 0 ? candidates : NULL;
				uint32_t count = pass == 0 ? C : 1;
				const uint32_t* rows = form == 2 ? NULL : offsets[pass];
				pair->scalar.body_contact( os, stride, posed, P, table, count, NULL, 0.05f, 1, n - 2 );
				if ( form == 1 )
				{
					pair->simd.body_contact( ov, stride, posed, P, table, count, rows, 0.05f, 1, 13 );
					pair->simd.body_contact( ov, stride, posed, P, table, count, rows, 0.05f, 13, n - 2 );
				}
				else
				{
					pair->simd.body_contact( ov, stride, posed, P, table, count, rows, 0.05f, 1, n - 2 );
				}
			}
			assert_true( plExpectContactTwins( os, ov, start, n, 0, 1e-6f, "C", C ) > 0 );
		}
	}
	assert_true( reach_kinds[0] > 0 && reach_kinds[1] > 0 && reach_kinds[2] > 0 ); // every reach was compared
}

// The fast body contact: random anchors around the vertices (so about half are behind their planes and move), every fourth
// without an anchor, strided positions (other floats untouched), K = 1..8, a joint index out of range, a vertex
// sub-range. Both kernels compute the same plane test in float; the blended matrix is summed in another grouping,
// so they agree to rounding: |Δ| ≤ 1e-5 (the inputs are O(1); a wrong column or sign gives O(0.1)).
static void test_fast_body_contact_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t joint_count = 7, n = 41, stride = 20; // bytes
	float matrices[7 * 12];
	for ( uint32_t i = 0; i < joint_count * 12; ++i )
	{
		matrices[i] = ( i % 4 == 3 ? 0.3f : 1.0f ) * plRand() + ( i % 5 == 0 ? 1.0f : 0.0f );
	}
	float anchors[41 * 3], normals[41 * 3], start[41 * 5];
	for ( uint32_t v = 0; v < n; ++v )
	{
		float nx = plRand(), ny = plRand(), nz = plRand() + 0.1f;
		float len = sqrtf( nx * nx + ny * ny + nz * nz );
		normals[3 * v] = v % 4 == 0 ? 0.0f : nx / len;
		normals[3 * v + 1] = v % 4 == 0 ? 0.0f : ny / len;
		normals[3 * v + 2] = v % 4 == 0 ? 0.0f : nz / len;
		for ( int e = 0; e < 3; ++e )
		{
			anchors[3 * v + e] = plRand();
		}
		for ( int e = 0; e < 5; ++e )
		{
			start[5 * v + e] = e < 3 ? anchors[3 * v + e] + 0.2f * plRand() : -77.0f;
		}
	}
	for ( uint32_t K = 1; K <= PLEAT_MAX_INFLUENCES; ++K )
	{
		uint16_t indices[41 * 8];
		float weights[41 * 8];
		plRandomInfluences( indices, weights, n * K, joint_count );
		float os[41 * 5], ov[41 * 5];
		memcpy( os, start, sizeof( os ) );
		memcpy( ov, start, sizeof( ov ) );
		const plKernels *scalar = &pair->scalar, *simd = &pair->simd;
		scalar->body_contact_fast( os, stride, anchors, normals, indices, weights, K, NULL, matrices, joint_count, 0.01f,
								   1, n - 2 );
		simd->body_contact_fast( ov, stride, anchors, normals, indices, weights, K, NULL, matrices, joint_count, 0.01f, 1,
								 n - 2 );
		assert_true( plExpectContactTwins( os, ov, start, n, 1, 1e-5f, "K", K ) > 0 );
		// with the column offsets the asset gives it: the same bits as without
		uint32_t offsets[41 * 8];
		plSkinColumnOffsets( offsets, indices, n * K, joint_count );
		float oo[41 * 5];
		memcpy( oo, start, sizeof( oo ) );
		simd->body_contact_fast( oo, stride, anchors, normals, indices, weights, K, offsets, matrices, joint_count, 0.01f,
								 1, n - 2 );
		assert_memory_equal( oo, ov, sizeof( oo ) );
	}
}

// Skinning: strided input and output (other floats between vertices stay untouched), K = 1..8 influences, a joint
// index out of range (weight 0 in both), vertex sub-ranges.
static void test_skinning_avx2_matches_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t joint_count = 7, n = 37, in_stride = 16, out_stride = 28; // bytes
	float matrices[7 * 12];
	for ( uint32_t i = 0; i < joint_count * 12; ++i )
	{
		matrices[i] = 2.0f * plRand();
	}
	float in[37 * 4];
	for ( uint32_t i = 0; i < n * 4; ++i )
	{
		in[i] = plRand();
	}
	for ( uint32_t K = 1; K <= PLEAT_MAX_INFLUENCES; ++K )
	{
		uint16_t indices[37 * 8];
		float weights[37 * 8];
		plRandomInfluences( indices, weights, n * K, joint_count );
		float os[37 * 7], ov[37 * 7];
		for ( uint32_t i = 0; i < n * 7; ++i )
		{
			os[i] = ov[i] = -77.0f;
		}
		pair->scalar.skinning( os, out_stride, in, in_stride, indices, weights, K, NULL, matrices, joint_count, 2, n - 1 );
		pair->simd.skinning( ov, out_stride, in, in_stride, indices, weights, K, NULL, matrices, joint_count, 2, n - 1 );
		// with the column offsets the asset gives it: the same bits as without
		uint32_t offsets[37 * 8];
		plSkinColumnOffsets( offsets, indices, n * K, joint_count );
		float oo[37 * 7];
		for ( uint32_t i = 0; i < n * 7; ++i )
		{
			oo[i] = -77.0f;
		}
		pair->simd.skinning( oo, out_stride, in, in_stride, indices, weights, K, offsets, matrices, joint_count, 2, n - 1 );
		assert_memory_equal( oo, ov, sizeof( oo ) );
		for ( uint32_t v = 0; v < n; ++v )
		{
			for ( uint32_t e = 0; e < 7; ++e )
			{
				float a = os[v * 7 + e], b = ov[v * 7 + e];
				if ( v < 2 || v >= n - 1 || e >= 3 )
				{
					assert_true( a == -77.0f && b == -77.0f ); // outside the range or between vertices: untouched
					continue;
				}
				const float p[4] = { in[v * 4], in[v * 4 + 1], in[v * 4 + 2], 1.0f };
				double magnitude = 0.0;
				for ( uint32_t k = 0; k < K; ++k )
				{
					uint32_t j = indices[v * K + k];
					if ( j < joint_count )
					{
						for ( int c = 0; c < 4; ++c )
						{
							magnitude += fabs( (double)weights[v * K + k] * matrices[j * 12 + e * 4 + c] * p[c] );
						}
					}
				}
				plExpectWithinSumBound( a, b, K + 4, magnitude, "K=%u vertex %u row %u", K, v, e );
			}
		}
	}
}

// Normals: face normals and the adjacency gather are bit-identical to scalar (same operations in the same order), on a
// random mesh with out-of-range face and adjacency entries, packed and strided positions; the positions buffer ends at
// the last vertex's z (a 16-byte load there would be caught by ASan in the sanitizer build).
static void test_normals_avx2_are_bit_identical_to_scalar( void** state )
{
	const plKernelPair* pair = plRequireAvx2Kernels( state );
	const uint32_t n = 53, f = 97;
	for ( uint32_t stride = 12; stride <= 20; stride += 8 )
	{
		float* positions = plRandomPositions( n, stride );
		uint32_t faces[97 * 3];
		for ( uint32_t i = 0; i < f * 3; ++i )
		{
			faces[i] = plRandIndex();
			faces[i] %= i % 41 == 0 ? n + 3 : n; // a few out of range
		}
		faces[( f - 1 ) * 3] = n - 1; // the last vertex is read
		uint32_t offsets[53 + 1], adjacency[97 * 3];
		for ( uint32_t v = 0; v <= n; ++v )
		{
			offsets[v] = v * 5 < f * 3 ? v * 5 : f * 3;
		}
		for ( uint32_t e = 0; e < f * 3; ++e )
		{
			adjacency[e] = plRandIndex() % ( f + 2 );
		}
		float fs[97 * 4], fv[97 * 4];
		memset( fs, 0xAB, sizeof( fs ) );
		memset( fv, 0xCD, sizeof( fv ) );
		pair->scalar.face_normals( fs, positions, stride, n, faces, 0, f );
		pair->simd.face_normals( fv, positions, stride, n, faces, 0, f );
		assert_memory_equal( fs, fv, sizeof( fs ) );
		float os[53 * 4], ov[53 * 4];
		memset( os, 0, sizeof( os ) );
		memset( ov, 0, sizeof( ov ) );
		pair->scalar.normals_gather( os, 16, fs, f, offsets, adjacency, 1, n );
		pair->simd.normals_gather( ov, 16, fs, f, offsets, adjacency, 1, n );
		assert_memory_equal( os, ov, sizeof( os ) );
		float length = sqrtf( os[4] * os[4] + os[5] * os[5] + os[6] * os[6] );
		assert_true( fabsf( length - 1.0f ) < 1e-5f ); // vertex 1 has faces: a unit normal
		free( positions );
	}
}

// Normals scatter (one pass over the faces, one thread): on a valid mesh (distinct in-range corners, adjacency = each
// vertex's faces in ascending order, as the asset loader requires) the scalar scatter is bit-identical to face normals
// + gather, and the AVX2 scatter to the scalar one; packed and strided positions and output, the positions buffer
// ending at the last vertex's z.
static void test_normals_scatter_is_bit_identical_to_gather( void** state )
{
	(void)state;
	plKernels simd, scalar;
	plChooseKernels( &simd, PLEAT_KERNEL_SET_AVX512 );
	plChooseKernels( &scalar, PLEAT_KERNEL_SET_SCALAR );
	const uint32_t n = 61, f = 113;
	uint32_t faces[113 * 3];
	for ( uint32_t t = 0; t < f; ++t )
	{
		uint32_t a = plRandIndex() % n, b, c;
		b = ( a + 1 + plRandIndex() % ( n - 1 ) ) % n;
		do
		{
			c = plRandIndex() % n;
		} while ( c == a || c == b );
		faces[t * 3 + 0] = a;
		faces[t * 3 + 1] = b;
		faces[t * 3 + 2] = c;
	}
	faces[( f - 1 ) * 3 + 2] = n - 1; // the last vertex is read
	if ( faces[( f - 1 ) * 3] == n - 1 || faces[( f - 1 ) * 3 + 1] == n - 1 )
	{
		faces[( f - 1 ) * 3] = 0;
		faces[( f - 1 ) * 3 + 1] = 1;
	}
	uint32_t offsets[61 + 1], adjacency[113 * 3], fill[61];
	memset( offsets, 0, sizeof( offsets ) );
	for ( uint32_t i = 0; i < f * 3; ++i )
	{
		offsets[faces[i] + 1] += 1;
	}
	for ( uint32_t v = 0; v < n; ++v )
	{
		offsets[v + 1] += offsets[v];
		fill[v] = offsets[v];
	}
	for ( uint32_t t = 0; t < f; ++t )
	{
		for ( int k = 0; k < 3; ++k )
		{
			adjacency[fill[faces[t * 3 + k]]++] = t; // ascending t per vertex
		}
	}
	for ( uint32_t stride = 12; stride <= 20; stride += 8 )
	{
		float* positions = plRandomPositions( n, stride );
		float face_normals[113 * 4], sums_scalar[61 * 4], sums_simd[61 * 4];
		float gathered[61 * 5], scattered[61 * 5], scattered_simd[61 * 5];
		memset( gathered, 0, sizeof( gathered ) );
		memset( scattered, 0, sizeof( scattered ) );
		memset( scattered_simd, 0, sizeof( scattered_simd ) );
		scalar.face_normals( face_normals, positions, stride, n, faces, 0, f );
		scalar.normals_gather( gathered, stride, face_normals, f, offsets, adjacency, 0, n );
		scalar.normals_scatter( scattered, stride, positions, stride, n, faces, f, sums_scalar );
		assert_memory_equal( gathered, scattered, sizeof( gathered ) );
		if ( plHaveAvx2() )
		{
			simd.normals_scatter( scattered_simd, stride, positions, stride, n, faces, f, sums_simd );
			assert_memory_equal( scattered, scattered_simd, sizeof( scattered ) );
		}
		free( positions );
	}
}

// fp16 conversion: exact on every half value (round trip), round-to-nearest-even on floats.
static void test_half_conversion_round_trips( void** state )
{
	(void)state;
	for ( uint32_t h = 0; h < 0x10000u; ++h )
	{
		if ( ( h & 0x7C00u ) == 0x7C00u && ( h & 0x3FFu ) != 0 )
		{
			continue; // NaN payloads need not round-trip
		}
		assert_int_equal( plFloatToHalf( plHalfToFloat( (uint16_t)h ) ), h );
	}
	assert_float_equal( plHalfToFloat( 0x3C00 ), 1.0f, 0 );
	assert_float_equal( plHalfToFloat( 0xC000 ), -2.0f, 0 );
	assert_float_equal( plHalfToFloat( 0x0001 ), 5.9604645e-8f, 0 ); // smallest subnormal 2^-24
	assert_int_equal( plFloatToHalf( 1.0f + 1.0f / 2048.0f ), 0x3C00 ); // tie → even
	assert_int_equal( plFloatToHalf( 1e6f ), 0x7C00 );                // overflow → inf
}

// One SIMD set's whole step vs a scalar context's on one motion: positions within 1e-5 m.
static void plPipelineMatchesScalar( plKernelSet set, int fp16 )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 20;
	p.grid_y = 21;
	p.lp_hidden[0] = 67;
	p.dec_hidden[0] = 45;
	p.latent_count = 13;
	p.blend_count = 11;
	p.fp16 = fp16;
	plTestAsset* model = plTestAsset_Create( &p );
	plContextDef simd_def = plDefaultContextDef();
	simd_def.max_isa = set;
	plContextDef scalar_def = plDefaultContextDef();
	scalar_def.max_isa = PLEAT_KERNEL_SET_SCALAR;
	plTestRig fast, slow;
	assert_int_equal( plTestRig_Init( &fast, model, &simd_def ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Init( &slow, model, &scalar_def ), PLEAT_RESULT_OK );
	plKernelSet kernel_set;
	assert_int_equal( plContext_GetKernelSet( fast.context, &kernel_set ), PLEAT_RESULT_OK );
	assert_int_equal( kernel_set, set );
	assert_int_equal( plContext_GetKernelSet( slow.context, &kernel_set ), PLEAT_RESULT_OK );
	assert_int_equal( kernel_set, PLEAT_KERNEL_SET_SCALAR );
	assert_int_equal( fast.info.weights_fp16, fp16 );
	plInstance a, b;
	assert_int_equal( plTestRig_Instance( &fast, &a ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &slow, &b ), PLEAT_RESULT_OK );
	float q[64 * 4];
	for ( uint32_t t = 0; t < 20; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( a, &in, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( b, &in, NULL ), PLEAT_RESULT_OK );
		const float *pa, *pb;
		plInstance_GetPositions( a, &pa, NULL );
		plInstance_GetPositions( b, &pb, NULL );
		for ( uint32_t i = 0; i < model->N * 3; ++i )
		{
			assert_float_equal( pa[i], pb[i], 1e-5 );
		}
	}
	plTestRig_Free( &fast );
	plTestRig_Free( &slow );
	plTestAsset_Destroy( model );
}

// The whole step, each SIMD set this build and CPU run (AVX2, AVX-512) vs a scalar context, fp32 and fp16 assets:
// positions within 1e-5 m.
static void test_pipeline_avx2_matches_scalar( void** state )
{
	(void)state;
	if ( !plHaveAvx2() )
	{
		skip();
	}
	for ( int set = PLEAT_KERNEL_SET_AVX2; set <= PLEAT_KERNEL_SET_AVX512; ++set )
	{
		plKernels probe;
		if ( plChooseKernels( &probe, (plKernelSet)set ) != (plKernelSet)set )
		{
			break; // a set this build or CPU lacks
		}
		plPipelineMatchesScalar( (plKernelSet)set, 0 );
		plPipelineMatchesScalar( (plKernelSet)set, 1 );
	}
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		PLEAT_TEST_WITH_PAIR( test_mat_vec_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_blend_shapes_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_skinning_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_pose_body_points_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_body_contact_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_fast_body_contact_avx2_matches_scalar ),
		PLEAT_TEST_WITH_PAIR( test_body_point_normals_avx2_are_bit_identical_to_scalar ),
		PLEAT_TEST_WITH_PAIR( test_normals_avx2_are_bit_identical_to_scalar ),
		cmocka_unit_test( test_normals_scatter_is_bit_identical_to_gather ),
		cmocka_unit_test( test_half_conversion_round_trips ),
		cmocka_unit_test( test_pipeline_avx2_matches_scalar ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
