// The GL compute path (sdk/src/backends/gl/, shaders/) against a double-precision reference of the same equations, on Mesa
// llvmpipe: host-context mode (the test plays the engine: its own EGL context and output buffers, and GL state that
// must come back unchanged), headless mode (the automatic choice, the EGL device platform forced, OSMesa forced), fp16
// blend shapes, bad descriptions.
//
// Tolerances: positions within 2e-5 m (fp32 accumulation of D = 32 shapes of a few cm and a 3×4 transform on
// coordinates up to ~1.5 m gives errors of a few 1e-7 m; 2e-5 m leaves room for GPU FMA contraction and is still far
// below the 1 mm scale of anything visible); normals within 1e-3 per component (a normal is a cross product of ~2 cm
// edge differences, so the fp32 position rounding of ~1e-7 m becomes a relative error of ~1e-5, amplified where
// adjacent faces nearly cancel).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "gl/gl_internal.h"
#include "test_gl_support.h"
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLEAT_TEST_FRAMES 40
#define PLEAT_TEST_POSITION_TOLERANCE_M 2e-5
#define PLEAT_TEST_NORMAL_TOLERANCE 1e-3

typedef struct plTestFixture
{
	plTestMesh mesh;
	plTestAllocatorState allocator_state;
	plAllocator allocator;
	plTestEglContext engine; // the "engine" context; only made current by host-context tests
	float* blend_weights;
	float* skin_matrices;
	float* positions;
	float* normals;
	double* expected_positions;
	double* expected_normals;
} plTestFixture;

static int plSetup( void** state )
{
	plTestFixture* fixture = calloc( 1, sizeof( *fixture ) );
	plTestMesh_Build( &fixture->mesh, 79, 56, 32, 7 ); // 4,424 vertices
	fixture->allocator = plTestAllocator( &fixture->allocator_state );
	size_t n = fixture->mesh.vertex_count;
	fixture->blend_weights = malloc( sizeof( float ) * fixture->mesh.blend_count );
	fixture->skin_matrices = malloc( sizeof( float ) * 12 * fixture->mesh.joint_count );
	fixture->positions = malloc( sizeof( float ) * 3 * n );
	fixture->normals = malloc( sizeof( float ) * 3 * n );
	fixture->expected_positions = malloc( sizeof( double ) * 3 * n );
	fixture->expected_normals = malloc( sizeof( double ) * 3 * n );
	plTestEgl_Create( &fixture->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = fixture;
	return 0;
}

static int plTeardown( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Destroy( &fixture->engine );
	plTestMesh_Free( &fixture->mesh );
	free( fixture->blend_weights );
	free( fixture->skin_matrices );
	free( fixture->positions );
	free( fixture->normals );
	free( fixture->expected_positions );
	free( fixture->expected_normals );
	free( fixture );
	return 0;
}

static plGlDeformerDesc plDescFor( const plTestMesh* mesh, plGlDeformerMode mode, int fp16 )
{
	plGlDeformerDesc desc;
	memset( &desc, 0, sizeof( desc ) );
	desc.mode = mode;
	desc.vertex_count = mesh->vertex_count;
	desc.face_count = mesh->face_count;
	desc.blend_count = mesh->blend_count;
	desc.influence_count = mesh->influence_count;
	desc.joint_count = mesh->joint_count;
	desc.shaped_template = mesh->shaped_template;
	desc.blend_shapes = fp16 ? ( plBlendShapes ){ mesh->blend_shapes_fp16, PLEAT_SHAPES_F16, NULL }
							 : ( plBlendShapes ){ mesh->blend_shapes, PLEAT_SHAPES_F32, NULL };
	desc.skin_indices = mesh->skin_indices;
	desc.skin_weights = mesh->skin_weights;
	desc.faces = mesh->faces;
	desc.adjacency_offsets = mesh->adjacency_offsets;
	desc.adjacency_faces = mesh->adjacency_faces;
	return desc;
}

// Runs the motion for frame_count frames and checks every frame against the reference; returns the worst errors.
static void plRunMotion( plTestFixture* fixture, plGlDeformer* deformer, int fp16, uint32_t frame_count,
						 double* worst_position, double* worst_normal )
{
	const plTestMesh* mesh = &fixture->mesh;
	size_t values = (size_t)3 * mesh->vertex_count;
	*worst_position = 0.0;
	*worst_normal = 0.0;
	for ( uint32_t frame = 0; frame < frame_count; ++frame )
	{
		plTestMotion_Frame( mesh, frame, fixture->blend_weights, fixture->skin_matrices );
		memset( fixture->positions, 0xff, sizeof( float ) * values ); // NaN: a frame that writes nothing fails
		memset( fixture->normals, 0xff, sizeof( float ) * values );
		assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices,
											fixture->positions, fixture->normals ),
						  PLEAT_RESULT_OK );
		plTestReference_Deform( mesh, fp16 ? mesh->blend_shapes_rounded : mesh->blend_shapes, fixture->blend_weights,
								fixture->skin_matrices, fixture->expected_positions, fixture->expected_normals );
		double position_error = plTestMaxAbsDiff( fixture->positions, fixture->expected_positions, values );
		double normal_error = plTestMaxAbsDiff( fixture->normals, fixture->expected_normals, values );
		*worst_position = fmax( *worst_position, position_error );
		*worst_normal = fmax( *worst_normal, normal_error );
	}
	assert_true( *worst_position <= PLEAT_TEST_POSITION_TOLERANCE_M );
	assert_true( *worst_normal <= PLEAT_TEST_NORMAL_TOLERANCE );
}

static void plExpectNoLeak( const plTestFixture* fixture )
{
	assert_int_equal( fixture->allocator_state.live_bytes, 0 );
	assert_false( fixture->allocator_state.size_mismatch );
}

static void test_headless_matches_reference_over_motion( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_EGL );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT ); // nothing current before → nothing after
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, PLEAT_TEST_FRAMES, &position_error, &normal_error );
	print_message( "headless EGL: max position error %.3g m, max normal error %.3g over %d frames\n", position_error,
				   normal_error, PLEAT_TEST_FRAMES );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_headless_restores_the_callers_current_context( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 2, &position_error, &normal_error );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	assert_int_equal( eglQueryAPI(), EGL_OPENGL_API );
	plGlDeformer_Destroy( deformer );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_headless_osmesa_fallback_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	plResult result = plGlDeformer_CreateHeadless( &desc, &fixture->allocator, PLEAT_GL_HEADLESS_OSMESA, &deformer );
	if ( result == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		print_message( "SKIP: OSMesa (libOSMesa.so.8 with GL 4.3 core) is not available here\n" );
		skip();
	}
	assert_int_equal( result, PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_OSMESA );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 3, &position_error, &normal_error );
	print_message( "headless OSMesa: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

// The EGL device platform route itself (EGL_EXT_platform_device), forced with software devices allowed so that it
// runs here on Mesa's llvmpipe device too: same results as the reference, and the report names the route.
static void test_headless_egl_device_platform_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	char report[448] = { 0 };
	desc.report = report;
	desc.report_size = sizeof( report );
	plGlDeformer* deformer = NULL;
	plResult result = plGlDeformer_CreateHeadless( &desc, &fixture->allocator, PLEAT_GL_HEADLESS_EGL_DEVICE, &deformer );
	if ( result == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		print_message( "SKIP: no EGL device gives a GL 4.3 core context here: %s\n", report );
		skip();
	}
	assert_int_equal( result, PLEAT_RESULT_OK );
	print_message( "report: %s\n", report );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_EGL );
	assert_int_equal( plGlDeformer_Platform( deformer ), PLEAT_GL_PLATFORM_EGL_DEVICE );
	assert_true( strncmp( report, "EGL device platform (EGL_EXT_platform_device), device ", 54 ) == 0 );
	assert_non_null( strstr( report, "GL_RENDERER '" ) );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 5, &position_error, &normal_error );
	print_message( "headless EGL device: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_fp16_blend_shapes_match_rounded_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 1 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 1, 5, &position_error, &normal_error );
	print_message( "fp16 blend shapes: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_set_shaped_template_moves_the_output( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plTestMesh* mesh = &fixture->mesh;
	plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	// A new shape: the template scaled radially by 1.1 (what a β change does, conceptually).
	size_t values = (size_t)3 * mesh->vertex_count;
	float* original = malloc( sizeof( float ) * values );
	memcpy( original, mesh->shaped_template, sizeof( float ) * values );
	for ( uint32_t i = 0; i < mesh->vertex_count; ++i )
	{
		mesh->shaped_template[3 * i] *= 1.1f;
		mesh->shaped_template[3 * i + 2] *= 1.1f;
	}
	assert_int_equal( plGlDeformer_SetShapedTemplate( deformer, mesh->shaped_template, NULL ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 2, &position_error, &normal_error );
	memcpy( mesh->shaped_template, original, sizeof( float ) * values );
	free( original );
	assert_int_equal( plGlDeformer_SetShapedTemplate( deformer, NULL, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

// --- body contact with candidate points (asset 1.2) ----------------------------------------------------------------

// A stand-in body inside the tube: P = 30 × 20 points on a coarser cylinder of radius 0.12 m (every 7th point without
// a normal: never an anchor) plus 20 copies of points with the same rest position and skinning but a normal tilted 30°
// up, so that a vertex listing a point and its copy blends two normals at exactly the same distance. The body is
// skinned with its own two influences (Ka = 2 ≠ K). Each vertex lists C = 8 candidates: the 4 body points around it,
// the copy (before the original for every third vertex, after it otherwise), a far point on the other side of the
// tube or the out-of-range index P, and empty slots (PLEAT_NO_CONTACT_CANDIDATE, leading for every fourth vertex);
// every 97th vertex has only empty slots and stays as skinned. The blend shapes (±3 cm each) push many vertices
// through the body.
// With rings (asset 1.2, BARG; R = 8 entries): a cylinder point whose ring + segment is 0 or 1 mod 4 lists its four
// ring and segment neighbours counter-clockwise seen from outside (up, right, down, left), one that is 2 mod 4 those
// and the four diagonal ones between them, and then empty entries (0xFFFF); on the first and last ring the missing
// neighbours are left out (rings of 3 and 5). The others (3 mod 4) and the copies have no ring and keep the blended
// rest normal. The points with a ring get a rest normal tilted 23° down, which the posed body's normal must replace;
// the points without a normal are in their neighbours' rings all the same, so their posed positions are needed (and
// some have a ring themselves, yet never anchor).
#define PLEAT_TEST_BODY_RINGS 30u
#define PLEAT_TEST_BODY_SEGMENTS 20u
#define PLEAT_TEST_BODY_COPIES 20u
#define PLEAT_TEST_BODY_POINTS ( PLEAT_TEST_BODY_RINGS * PLEAT_TEST_BODY_SEGMENTS + PLEAT_TEST_BODY_COPIES )
#define PLEAT_TEST_BODY_INFLUENCES 2u
#define PLEAT_TEST_BODY_CANDIDATES 8u
#define PLEAT_TEST_BODY_RING 8u
#define PLEAT_TEST_NO_CANDIDATE 0xFFFFu
#define PLEAT_TEST_CONTACT_OFFSET_M 0.004f
// pleat.h BODY CONTACT's blend of the candidates almost as near as the nearest (kernels.h PLEAT_CONTACT_BLEND_SHARE and
// PLEAT_CONTACT_BLEND_M; the reference keeps its own copy of the rule).
#define PLEAT_TEST_BLEND_SHARE 0.1
#define PLEAT_TEST_BLEND_M 0.001
// The push's reach (kernels.h PLEAT_CONTACT_REACH_NEAR_M / _FAR_M, plContactReach): whole within 3 cm of the nearest
// usable candidate, none beyond 5 cm, linear in the squared distance between.
#define PLEAT_TEST_REACH_NEAR_M 0.03
#define PLEAT_TEST_REACH_FAR_M 0.05

typedef struct plTestBody
{
	float points[PLEAT_TEST_BODY_POINTS * 3];  // the body points of the current β, [P][3]
	float normals[PLEAT_TEST_BODY_POINTS * 3]; // [P][3]
	uint16_t skin_indices[PLEAT_TEST_BODY_POINTS * PLEAT_TEST_BODY_INFLUENCES];
	float skin_weights[PLEAT_TEST_BODY_POINTS * PLEAT_TEST_BODY_INFLUENCES];
	uint16_t* candidates; // [N][C]
	uint16_t rings[PLEAT_TEST_BODY_POINTS * PLEAT_TEST_BODY_RING]; // [P][R]
	uint32_t ring_count;  // R, 0 = no rings (the desc gets NULL)
} plTestBody;

// How many neighbours cylinder point q (< rings × segments) lists in its ring away from the ends: 4, 8 or 0.
static uint32_t plTestBody_RingKind( uint32_t q )
{
	static const uint32_t kinds[4] = { 4, 4, 8, 0 };
	return kinds[( q / PLEAT_TEST_BODY_SEGMENTS + q % PLEAT_TEST_BODY_SEGMENTS ) % 4u];
}

static void plTestBody_BuildRings( plTestBody* body )
{
	const uint32_t base = PLEAT_TEST_BODY_RINGS * PLEAT_TEST_BODY_SEGMENTS, S = PLEAT_TEST_BODY_SEGMENTS;
	body->ring_count = PLEAT_TEST_BODY_RING;
	for ( uint32_t e = 0; e < PLEAT_TEST_BODY_POINTS * PLEAT_TEST_BODY_RING; ++e )
		body->rings[e] = PLEAT_TEST_NO_CANDIDATE;
	// Counter-clockwise seen from outside: the segment direction × the ring direction points into the cylinder, so
	// up (+1 ring) comes before right (+1 segment).
	static const int around_ring[8] = { 1, 1, 0, -1, -1, -1, 0, 1 }, around_segment[8] = { 0, 1, 1, 1, 0, -1, -1, -1 };
	for ( uint32_t p = 0; p < base; ++p )
	{
		uint32_t kind = plTestBody_RingKind( p ), m = 0;
		int ring = (int)( p / S ), segment = (int)( p % S );
		for ( uint32_t e = 0; e < 8 && kind > 0; e += 8 / kind )
		{
			int r = ring + around_ring[e], s = ( segment + around_segment[e] + (int)S ) % (int)S;
			if ( r >= 0 && r < (int)PLEAT_TEST_BODY_RINGS )
				body->rings[(size_t)p * PLEAT_TEST_BODY_RING + m++] = (uint16_t)( (uint32_t)r * S + (uint32_t)s );
		}
	}
}

static void plTestBody_Build( plTestBody* body, const plTestMesh* mesh, float radius_m, int with_rings )
{
	const float height = 1.2f; // plTestMesh_Build's tube
	const uint32_t base = PLEAT_TEST_BODY_RINGS * PLEAT_TEST_BODY_SEGMENTS;
	body->ring_count = 0;
	if ( with_rings )
		plTestBody_BuildRings( body );
	for ( uint32_t p = 0; p < PLEAT_TEST_BODY_POINTS; ++p )
	{
		uint32_t q = p < base ? p : ( p - base ) * 30u + 1u; // a copy of point q
		uint32_t ring = q / PLEAT_TEST_BODY_SEGMENTS, segment = q % PLEAT_TEST_BODY_SEGMENTS;
		float y = height * (float)ring / (float)( PLEAT_TEST_BODY_RINGS - 1 );
		float angle = 6.2831853f * (float)segment / (float)PLEAT_TEST_BODY_SEGMENTS;
		body->points[3 * p] = radius_m * cosf( angle );
		body->points[3 * p + 1] = y;
		body->points[3 * p + 2] = radius_m * sinf( angle );
		float tilt = p >= base ? 0.5235988f : with_rings && plTestBody_RingKind( p ) > 0 ? -0.4f : 0.0f;
		int without = p < base && p % 7 == 0;
		body->normals[3 * p] = without ? 0.0f : cosf( tilt ) * cosf( angle );
		body->normals[3 * p + 1] = without ? 0.0f : sinf( tilt );
		body->normals[3 * p + 2] = without ? 0.0f : cosf( tilt ) * sinf( angle );
		float t = y / height * (float)( mesh->joint_count - 1 );
		uint32_t lower = (uint32_t)floorf( t );
		lower = lower + 1 < mesh->joint_count ? lower : mesh->joint_count - 2;
		body->skin_indices[2 * p] = (uint16_t)lower;
		body->skin_indices[2 * p + 1] = (uint16_t)( lower + 1 );
		body->skin_weights[2 * p] = 1.0f - ( t - (float)lower );
		body->skin_weights[2 * p + 1] = t - (float)lower;
	}
	uint32_t rings = mesh->vertex_count / 56u, segments = 56u; // plSetup's 79 × 56
	body->candidates = malloc( sizeof( uint16_t ) * mesh->vertex_count * PLEAT_TEST_BODY_CANDIDATES );
	for ( uint32_t v = 0; v < mesh->vertex_count; ++v )
	{
		uint32_t r = v / segments, s = v % segments;
		float fr = (float)r / (float)( rings - 1 ) * (float)( PLEAT_TEST_BODY_RINGS - 1 );
		uint32_t r0 = (uint32_t)floorf( fr ) < PLEAT_TEST_BODY_RINGS - 1 ? (uint32_t)floorf( fr )
																		 : PLEAT_TEST_BODY_RINGS - 2;
		uint32_t s0 = s * PLEAT_TEST_BODY_SEGMENTS / segments, s1 = ( s0 + 1 ) % PLEAT_TEST_BODY_SEGMENTS;
		uint32_t around[4] = { r0 * PLEAT_TEST_BODY_SEGMENTS + s0, r0 * PLEAT_TEST_BODY_SEGMENTS + s1,
							   ( r0 + 1 ) * PLEAT_TEST_BODY_SEGMENTS + s0, ( r0 + 1 ) * PLEAT_TEST_BODY_SEGMENTS + s1 };
		uint32_t copy = around[0] % 30u == 1u ? base + around[0] / 30u : PLEAT_TEST_NO_CANDIDATE;
		uint32_t far = ( PLEAT_TEST_BODY_RINGS - 1 - r0 ) * PLEAT_TEST_BODY_SEGMENTS +
					   ( s0 + PLEAT_TEST_BODY_SEGMENTS / 2 ) % PLEAT_TEST_BODY_SEGMENTS;
		uint16_t* slots = body->candidates + (size_t)v * PLEAT_TEST_BODY_CANDIDATES;
		uint32_t c = 0;
		for ( uint32_t e = 0; e < PLEAT_TEST_BODY_CANDIDATES; ++e )
			slots[e] = PLEAT_TEST_NO_CANDIDATE;
		if ( v % 97u == 0 )
			continue;
		if ( v % 4u == 0 )
			slots[c++] = PLEAT_TEST_NO_CANDIDATE;
		if ( copy != PLEAT_TEST_NO_CANDIDATE && v % 3u == 0 )
			slots[c++] = (uint16_t)copy;
		for ( int e = 0; e < 4; ++e )
			slots[c++] = (uint16_t)around[e];
		if ( copy != PLEAT_TEST_NO_CANDIDATE && v % 3u != 0 )
			slots[c++] = (uint16_t)copy;
		slots[c++] = (uint16_t)( v % 2u ? PLEAT_TEST_BODY_POINTS : far );
	}
}

static void plAddBody( plGlDeformerDesc* desc, const plTestBody* body )
{
	desc->body_anchors = body->points;
	desc->body_anchor_normals = body->normals;
	desc->body_anchor_skin_indices = body->skin_indices;
	desc->body_anchor_skin_weights = body->skin_weights;
	desc->body_anchor_influence_count = PLEAT_TEST_BODY_INFLUENCES;
	desc->body_point_count = PLEAT_TEST_BODY_POINTS;
	desc->body_anchor_candidates = body->candidates;
	desc->body_anchor_candidate_count = PLEAT_TEST_BODY_CANDIDATES;
	desc->body_anchor_ring = body->ring_count > 0 ? body->rings : NULL;
	desc->body_anchor_ring_count = body->ring_count;
}

// What the contact did across a run, to show that the body exercised the rules.
typedef struct plContactCounts
{
	uint32_t pushed;        // vertices moved out
	uint32_t blended;       // of those, vertices whose plane blends two or more candidates
	uint32_t from_rings;    // of those, vertices whose plane has a normal from a posed ring in it
	uint32_t faded;         // of those, vertices pushed by a share (their nearest candidate 3–5 cm away)
	uint32_t beyond;        // vertices behind the plane left alone: their nearest candidate beyond the reach
	double ring_turn;       // largest angle (radians) between a usable point's ring normal and its blended rest normal
	double worst_position;  // largest |GPU − reference| (m)
	double worst_normal;
} plContactCounts;

// The body contact of pleat.h in double, written out from the equations (not from body_contact.c): positions [N][3]
// skinned in, pushed out of the plane blended from the candidates almost as near as the nearest; a point with a ring
// takes the posed body's normal there (tools/pleat/reference/body_contact.py pose_contact_points).
static void plReferenceBodyContact( const plTestMesh* mesh, const plTestBody* body, const float* skin_matrices,
									double offset_m, double* positions, plContactCounts* counts )
{
	static double posed[PLEAT_TEST_BODY_POINTS][3], normal[PLEAT_TEST_BODY_POINTS][3];
	static int usable[PLEAT_TEST_BODY_POINTS], from_ring[PLEAT_TEST_BODY_POINTS];
	for ( uint32_t p = 0; p < PLEAT_TEST_BODY_POINTS; ++p )
	{
		double m[12] = { 0.0 };
		for ( uint32_t k = 0; k < PLEAT_TEST_BODY_INFLUENCES; ++k )
		{
			const float* joint = skin_matrices + 12 * body->skin_indices[PLEAT_TEST_BODY_INFLUENCES * p + k];
			for ( int e = 0; e < 12; ++e )
				m[e] += (double)body->skin_weights[PLEAT_TEST_BODY_INFLUENCES * p + k] * joint[e];
		}
		const float *r = body->points + 3 * p, *n = body->normals + 3 * p;
		double length = 0.0;
		for ( int row = 0; row < 3; ++row )
		{
			posed[p][row] = m[4 * row] * r[0] + m[4 * row + 1] * r[1] + m[4 * row + 2] * r[2] + m[4 * row + 3];
			normal[p][row] = m[4 * row] * n[0] + m[4 * row + 1] * n[1] + m[4 * row + 2] * n[2];
			length += normal[p][row] * normal[p][row];
		}
		length = sqrt( length );
		usable[p] = !( n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f ) && length > 1e-12;
		for ( int row = 0; row < 3 && usable[p]; ++row )
			normal[p][row] /= length;
	}
	// Every point is posed before any normal reads its ring: the ones without a normal too. n = Σ d_i × d_{i+1 mod m}.
	for ( uint32_t p = 0; p < PLEAT_TEST_BODY_POINTS; ++p )
	{
		const uint16_t* ring = body->rings + (size_t)p * body->ring_count;
		uint32_t m = 0;
		for ( uint32_t e = 0; e < body->ring_count; ++e )
			m += ring[e] < PLEAT_TEST_BODY_POINTS;
		from_ring[p] = m >= 3;
		if ( !from_ring[p] )
			continue; // no ring: the blended rest normal stands
		double sum[3] = { 0.0, 0.0, 0.0 };
		for ( uint32_t i = 0; i < m; ++i )
		{
			double u[3], w[3];
			for ( int e = 0; e < 3; ++e )
			{
				u[e] = posed[ring[i]][e] - posed[p][e];
				w[e] = posed[ring[( i + 1 ) % m]][e] - posed[p][e];
			}
			sum[0] += u[1] * w[2] - u[2] * w[1];
			sum[1] += u[2] * w[0] - u[0] * w[2];
			sum[2] += u[0] * w[1] - u[1] * w[0];
		}
		double length = sqrt( sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2] );
		const float* n = body->normals + 3 * p;
		int was_usable = usable[p];
		usable[p] = !( n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f ) && length > 1e-12;
		if ( !usable[p] )
			continue;
		double cosine = 0.0; // with the blended rest normal, where that one is a unit normal
		for ( int e = 0; e < 3; ++e )
			cosine += normal[p][e] * sum[e] / length;
		if ( was_usable )
			counts->ring_turn = fmax( counts->ring_turn, acos( fmin( 1.0, cosine ) ) );
		for ( int e = 0; e < 3; ++e )
			normal[p][e] = sum[e] / length;
	}
	for ( uint32_t v = 0; v < mesh->vertex_count; ++v )
	{
		double* x = positions + 3 * v;
		const uint16_t* slots = body->candidates + (size_t)v * PLEAT_TEST_BODY_CANDIDATES;
		double d2[PLEAT_TEST_BODY_CANDIDATES], nearest = INFINITY;
		for ( uint32_t c = 0; c < PLEAT_TEST_BODY_CANDIDATES; ++c )
		{
			uint32_t p = slots[c];
			d2[c] = INFINITY;
			if ( p >= PLEAT_TEST_BODY_POINTS || !usable[p] )
				continue;
			d2[c] = 0.0;
			for ( int e = 0; e < 3; ++e )
				d2[c] += ( x[e] - posed[p][e] ) * ( x[e] - posed[p][e] );
			nearest = fmin( nearest, d2[c] );
		}
		if ( nearest == INFINITY )
			continue;
		double limit = ( 1.0 + PLEAT_TEST_BLEND_SHARE ) * nearest + PLEAT_TEST_BLEND_M * PLEAT_TEST_BLEND_M;
		double total = 0.0, a[3] = { 0.0, 0.0, 0.0 }, n[3] = { 0.0, 0.0, 0.0 };
		uint32_t blended = 0, rings = 0;
		for ( uint32_t c = 0; c < PLEAT_TEST_BODY_CANDIDATES; ++c )
		{
			double w = limit - d2[c]; // −∞ for empty slots and unusable points
			if ( !( w > 0.0 ) )
				continue;
			total += w;
			blended += 1;
			rings += (uint32_t)from_ring[slots[c]];
			for ( int e = 0; e < 3; ++e )
			{
				a[e] += w * posed[slots[c]][e];
				n[e] += w * normal[slots[c]][e];
			}
		}
		double length = sqrt( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		double near2 = PLEAT_TEST_REACH_NEAR_M * PLEAT_TEST_REACH_NEAR_M;
		double far2 = PLEAT_TEST_REACH_FAR_M * PLEAT_TEST_REACH_FAR_M;
		double reach = fmin( 1.0, fmax( 0.0, ( far2 - nearest ) / ( far2 - near2 ) ) );
		if ( !( length > 1e-12 ) )
			continue;
		double d = 0.0;
		for ( int e = 0; e < 3; ++e )
			d += ( x[e] - a[e] / total ) * n[e] / length;
		if ( !( reach > 0.0 ) )
		{
			counts->beyond += d < offset_m;
			continue;
		}
		if ( d < offset_m )
		{
			counts->faded += reach < 1.0;
			for ( int e = 0; e < 3; ++e )
				x[e] += ( offset_m - d ) * reach * n[e] / length;
			counts->pushed += 1;
			counts->blended += blended > 1;
			counts->from_rings += rings > 0;
		}
	}
}

// Area-weighted vertex normals over the adjacency, in double, of positions [N][3] (as plTestReference_Deform's).
static void plReferenceNormals( const plTestMesh* mesh, const double* positions, double* normals )
{
	for ( uint32_t i = 0; i < mesh->vertex_count; ++i )
	{
		double sum[3] = { 0.0, 0.0, 0.0 };
		for ( uint32_t e = mesh->adjacency_offsets[i]; e < mesh->adjacency_offsets[i + 1]; ++e )
		{
			const uint32_t* tri = mesh->faces + 3 * mesh->adjacency_faces[e];
			const double *a = positions + 3 * tri[0], *b = positions + 3 * tri[1], *c = positions + 3 * tri[2];
			double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
			double w[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
			sum[0] += u[1] * w[2] - u[2] * w[1];
			sum[1] += u[2] * w[0] - u[0] * w[2];
			sum[2] += u[0] * w[1] - u[1] * w[0];
		}
		double length = sqrt( sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2] );
		for ( int c = 0; c < 3; ++c )
			normals[3 * i + c] = length > 0.0 ? sum[c] / length : 0.0;
	}
}

// Checks one deformer's read-back of a frame against the reference with contact at offset_m (< 0: contact off).
static void plExpectContactFrame( plTestFixture* fixture, const plTestBody* body, const float* blend_weights,
								  const float* skin_matrices, const float* positions, const float* normals,
								  double offset_m, plContactCounts* counts )
{
	const plTestMesh* mesh = &fixture->mesh;
	size_t values = (size_t)3 * mesh->vertex_count;
	plTestReference_Deform( mesh, mesh->blend_shapes, blend_weights, skin_matrices, fixture->expected_positions,
							fixture->expected_normals );
	if ( offset_m >= 0.0 )
	{
		plReferenceBodyContact( mesh, body, skin_matrices, offset_m, fixture->expected_positions, counts );
		plReferenceNormals( mesh, fixture->expected_positions, fixture->expected_normals );
	}
	double position_error = plTestMaxAbsDiff( positions, fixture->expected_positions, values );
	double normal_error = plTestMaxAbsDiff( normals, fixture->expected_normals, values );
	counts->worst_position = fmax( counts->worst_position, position_error );
	counts->worst_normal = fmax( counts->worst_normal, normal_error );
	assert_true( position_error <= PLEAT_TEST_POSITION_TOLERANCE_M );
	assert_true( normal_error <= PLEAT_TEST_NORMAL_TOLERANCE );
}

// One deformer over 12 frames of motion with contact on (a new β at frame 6), then off; every frame as the reference.
static void plRunBodyContact( plTestFixture* fixture, int with_rings, plContactCounts* counts )
{
	plTestEgl_Require( &fixture->engine );
	const plTestMesh* mesh = &fixture->mesh;
	plTestBody* body = calloc( 1, sizeof( *body ) );
	plTestBody_Build( body, mesh, 0.12f, with_rings );
	plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plAddBody( &desc, body );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_SetBodyContact( deformer, 1, PLEAT_TEST_CONTACT_OFFSET_M ), PLEAT_RESULT_OK );
	for ( uint32_t frame = 0; frame < 12; ++frame )
	{
		if ( frame == 6 )
		{
			// A new β moves the body points with the template (rows N..N+P−1 of the same upload).
			free( body->candidates ); // built again, the same
			plTestBody_Build( body, mesh, 0.125f, with_rings );
			assert_int_equal( plGlDeformer_SetShapedTemplate( deformer, mesh->shaped_template, body->points ),
							  PLEAT_RESULT_OK );
		}
		plTestMotion_Frame( mesh, frame, fixture->blend_weights, fixture->skin_matrices );
		assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices,
											fixture->positions, fixture->normals ),
						  PLEAT_RESULT_OK );
		plExpectContactFrame( fixture, body, fixture->blend_weights, fixture->skin_matrices, fixture->positions,
							  fixture->normals, PLEAT_TEST_CONTACT_OFFSET_M, counts );
	}
	print_message( "body contact, P = %u, C = %u, R = %u: %u vertex pushes over 12 frames, %u of them from a blend of "
				   "candidates, %u with normals from the posed rings (turned up to %.3g rad from the blended rest "
				   "normal), %u by a share of the push, %u left beyond the reach; max position error %.3g m, max "
				   "normal error %.3g\n",
				   PLEAT_TEST_BODY_POINTS, PLEAT_TEST_BODY_CANDIDATES, body->ring_count, counts->pushed,
				   counts->blended, counts->from_rings, counts->ring_turn, counts->faded, counts->beyond,
				   counts->worst_position, counts->worst_normal );
	assert_true( counts->pushed > 1000 );
	assert_true( counts->blended > 0 );
	assert_true( counts->faded > 100 && counts->beyond > 100 ); // the reach shaped the run at both ends
	// Off: the skinned positions as they are.
	assert_int_equal( plGlDeformer_SetBodyContact( deformer, 0, PLEAT_TEST_CONTACT_OFFSET_M ), PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices, fixture->positions,
										fixture->normals ),
					  PLEAT_RESULT_OK );
	plExpectContactFrame( fixture, body, fixture->blend_weights, fixture->skin_matrices, fixture->positions,
						  fixture->normals, -1.0, counts );
	plGlDeformer_Destroy( deformer );
	free( body->candidates );
	free( body );
	plExpectNoLeak( fixture );
}

static void test_body_contact_pushes_out_of_the_nearest_candidates( void** state )
{
	plContactCounts counts = { 0 };
	plRunBodyContact( *state, 0, &counts );
	assert_int_equal( counts.from_rings, 0 );
}

// Asset 1.2 with BARG: the anchorable points with a ring take the posed body's normal (pass 2 of the posing), the
// others keep the blended rest normal; the ring points without a normal are posed for their neighbours.
static void test_body_contact_takes_the_normals_of_the_posed_rings( void** state )
{
	plContactCounts counts = { 0 };
	plRunBodyContact( *state, 1, &counts );
	assert_true( counts.from_rings > 1000 );
	assert_true( counts.from_rings < counts.pushed ); // and some from points without a ring
	assert_true( counts.ring_turn > 0.3 );            // the tilted rest normals are replaced, not kept
}

// The batch path (plGlDeformer_RunBatch, PLEAT_BATCH 1 programs): three deformers of the same mesh in one batch, each
// with its own body points (β: radius 12, 12.6 and 13.2 cm), pose and contact setting (on at 4 mm, off, on at 1 mm),
// each as the reference says; with rings, the batch runs the second posing pass too.
static void plRunBodyContactBatch( plTestFixture* fixture, int with_rings )
{
	plTestEgl_Require( &fixture->engine );
	const plTestMesh* mesh = &fixture->mesh;
	enum { members_count = 3 };
	const double offsets[members_count] = { 0.004, -1.0, 0.001 };
	plTestBody* bodies[members_count];
	plGlDeformer* deformers[members_count];
	float *weights[members_count], *matrices[members_count], *positions[members_count], *normals[members_count];
	size_t values = (size_t)3 * mesh->vertex_count;
	for ( int k = 0; k < members_count; ++k )
	{
		bodies[k] = calloc( 1, sizeof( *bodies[k] ) );
		plTestBody_Build( bodies[k], mesh, 0.12f + 0.006f * (float)k, with_rings );
		plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
		plAddBody( &desc, bodies[k] );
		assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformers[k] ), PLEAT_RESULT_OK );
		assert_int_equal( plGlDeformer_SetBodyContact( deformers[k], offsets[k] >= 0.0,
													   offsets[k] >= 0.0 ? (float)offsets[k] : 0.0f ),
						  PLEAT_RESULT_OK );
		weights[k] = malloc( sizeof( float ) * mesh->blend_count );
		matrices[k] = malloc( sizeof( float ) * 12 * mesh->joint_count );
		positions[k] = malloc( sizeof( float ) * values );
		normals[k] = malloc( sizeof( float ) * values );
	}
	plContactCounts counts = { 0 };
	for ( uint32_t frame = 0; frame < 4; ++frame )
	{
		plGlBatchMember members[members_count];
		for ( int k = 0; k < members_count; ++k )
		{
			plTestMotion_Frame( mesh, frame + 5u * (uint32_t)k, weights[k], matrices[k] );
			memset( positions[k], 0xff, sizeof( float ) * values );
			members[k] = ( plGlBatchMember ){ .deformer = deformers[k],
											  .shaped_template = mesh->shaped_template,
											  .body_anchors = bodies[k]->points,
											  .blend_weights = weights[k],
											  .skin_matrices = matrices[k],
											  .positions = positions[k],
											  .normals = normals[k] };
		}
		uint64_t before = atomic_load( &g_plGlDispatches );
		assert_int_equal( plGlDeformer_RunBatch( deformers[0], members, members_count ), PLEAT_RESULT_OK );
		// blend shapes, skinning, posing the body points (with rings: and their normals), the push, face normals,
		// normals gather
		assert_int_equal( atomic_load( &g_plGlDispatches ) - before, with_rings ? 7 : 6 );
		for ( int k = 0; k < members_count; ++k )
			plExpectContactFrame( fixture, bodies[k], weights[k], matrices[k], positions[k], normals[k], offsets[k],
								  &counts );
	}
	print_message( "body contact in a batch of %d, R = %u: %u pushes, %u with normals from the posed rings; max "
				   "position error %.3g m, max normal error %.3g\n",
				   members_count, bodies[0]->ring_count, counts.pushed, counts.from_rings, counts.worst_position,
				   counts.worst_normal );
	assert_true( counts.pushed > 1000 );
	assert_true( with_rings ? counts.from_rings > 1000 : counts.from_rings == 0 );
	for ( int k = 0; k < members_count; ++k )
	{
		plGlDeformer_Destroy( deformers[k] );
		free( weights[k] );
		free( matrices[k] );
		free( positions[k] );
		free( normals[k] );
		free( bodies[k]->candidates );
		free( bodies[k] );
	}
	plExpectNoLeak( fixture );
}

static void test_body_contact_batch_matches_reference( void** state )
{
	plRunBodyContactBatch( *state, 0 );
}

static void test_body_contact_batch_with_rings_matches_reference( void** state )
{
	plRunBodyContactBatch( *state, 1 );
}

// --- host-context mode ---------------------------------------------------------------------------------------------

// Engine-side GL objects with distinctive bindings that the deformer must leave exactly as they were.
typedef struct plEngineState
{
	GLuint program;
	GLuint buffers[4];
} plEngineState;

static GLuint plEngineProgram( void )
{
	const char* source = "#version 430 core\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
	GLuint shader = glCreateShader( GL_COMPUTE_SHADER );
	glShaderSource( shader, 1, &source, NULL );
	glCompileShader( shader );
	GLuint program = glCreateProgram();
	glAttachShader( program, shader );
	glLinkProgram( program );
	glDeleteShader( shader );
	GLint linked = 0;
	glGetProgramiv( program, GL_LINK_STATUS, &linked );
	assert_int_equal( linked, GL_TRUE );
	return program;
}

static void plEngineBind( plEngineState* engine )
{
	engine->program = plEngineProgram();
	glGenBuffers( 4, engine->buffers );
	for ( int b = 0; b < 4; ++b )
	{
		glBindBuffer( GL_SHADER_STORAGE_BUFFER, engine->buffers[b] );
		glBufferData( GL_SHADER_STORAGE_BUFFER, 4096, NULL, GL_STATIC_DRAW );
	}
	glUseProgram( engine->program );
	glBindBufferBase( GL_SHADER_STORAGE_BUFFER, 0, engine->buffers[0] );
	glBindBufferRange( GL_SHADER_STORAGE_BUFFER, 3, engine->buffers[1], 256, 512 );
	glBindBufferBase( GL_SHADER_STORAGE_BUFFER, 11, engine->buffers[2] );
	glBindBufferRange( GL_UNIFORM_BUFFER, 0, engine->buffers[3], 512, 256 );
	glBindBuffer( GL_UNIFORM_BUFFER, engine->buffers[2] );
	glBindBuffer( GL_SHADER_STORAGE_BUFFER, engine->buffers[3] ); // generic bindings last (indexed binds set them)
}

static void plExpectEngineState( const plEngineState* engine )
{
	GLint value = -1;
	GLint64 value64 = -1;
	glGetIntegerv( GL_CURRENT_PROGRAM, &value );
	assert_int_equal( value, engine->program );
	glGetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &value );
	assert_int_equal( value, engine->buffers[3] );
	glGetIntegerv( GL_UNIFORM_BUFFER_BINDING, &value );
	assert_int_equal( value, engine->buffers[2] );
	for ( GLuint i = 0; i < PLEAT_GL_BINDING_COUNT; ++i )
	{
		GLint expected = i == 0 ? (GLint)engine->buffers[0]
								: i == 3 ? (GLint)engine->buffers[1] : i == 11 ? (GLint)engine->buffers[2] : 0;
		glGetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, i, &value );
		assert_int_equal( value, expected );
		glGetInteger64i_v( GL_SHADER_STORAGE_BUFFER_START, i, &value64 );
		assert_int_equal( value64, i == 3 ? 256 : 0 );
		glGetInteger64i_v( GL_SHADER_STORAGE_BUFFER_SIZE, i, &value64 );
		assert_int_equal( value64, i == 3 ? 512 : 0 );
	}
	glGetIntegeri_v( GL_UNIFORM_BUFFER_BINDING, 0, &value );
	assert_int_equal( value, engine->buffers[3] );
	glGetInteger64i_v( GL_UNIFORM_BUFFER_START, 0, &value64 );
	assert_int_equal( value64, 512 );
	glGetInteger64i_v( GL_UNIFORM_BUFFER_SIZE, 0, &value64 );
	assert_int_equal( value64, 256 );
	assert_int_equal( glGetError(), GL_NO_ERROR );
}

static void plEngineRelease( plEngineState* engine )
{
	glUseProgram( 0 );
	glDeleteProgram( engine->program );
	glDeleteBuffers( 4, engine->buffers );
}

static void test_host_context_matches_reference_and_restores_state( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	const plTestMesh* mesh = &fixture->mesh;
	size_t n = mesh->vertex_count;

	// The engine's vertex buffers the deformer writes into (vec4 per vertex).
	GLuint outputs[2];
	glGenBuffers( 2, outputs );
	for ( int b = 0; b < 2; ++b )
	{
		glBindBuffer( GL_ARRAY_BUFFER, outputs[b] );
		glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 16 * n ), NULL, GL_DYNAMIC_DRAW );
	}
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plEngineState engine;
	plEngineBind( &engine );

	plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	desc.host_position_buffer = outputs[0];
	desc.host_normal_buffer = outputs[1];
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	plExpectEngineState( &engine );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );

	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, PLEAT_TEST_FRAMES, &position_error, &normal_error );
	print_message( "host context: max position error %.3g m, max normal error %.3g over %d frames\n",
				   position_error, normal_error, PLEAT_TEST_FRAMES );
	plExpectEngineState( &engine );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );

	// The engine's own buffers hold the last frame: xyz as read back, w = 1 for positions and 0 for normals.
	float* rows = malloc( 16 * n );
	for ( int b = 0; b < 2; ++b )
	{
		const float* expected = b == 0 ? fixture->positions : fixture->normals;
		glBindBuffer( GL_COPY_READ_BUFFER, outputs[b] );
		glGetBufferSubData( GL_COPY_READ_BUFFER, 0, (GLsizeiptr)( 16 * n ), rows );
		for ( size_t i = 0; i < n; ++i )
		{
			assert_memory_equal( rows + 4 * i, expected + 3 * i, 3 * sizeof( float ) );
			assert_true( rows[4 * i + 3] == ( b == 0 ? 1.0f : 0.0f ) );
		}
	}
	free( rows );
	glBindBuffer( GL_COPY_READ_BUFFER, 0 );

	// Running without read-back leaves the result in the engine's buffers only, and still restores state.
	assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices, NULL, NULL ),
					  PLEAT_RESULT_OK );
	plExpectEngineState( &engine );
	plGlDeformer_Destroy( deformer );
	plExpectEngineState( &engine );
	plEngineRelease( &engine );
	glDeleteBuffers( 2, outputs );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_host_context_without_output_buffers_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 1 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 1, 3, &position_error, &normal_error );
	plGlDeformer_Destroy( deformer );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_host_context_without_current_context_is_unavailable( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	plGlDeformer* deformer = (plGlDeformer*)&desc; // must be overwritten with NULL
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_GL_UNAVAILABLE );
	assert_null( deformer );
	plExpectNoLeak( fixture );
}

static void test_host_buffer_too_small_is_rejected( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	GLuint small;
	glGenBuffers( 1, &small );
	glBindBuffer( GL_ARRAY_BUFFER, small );
	glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 12 * fixture->mesh.vertex_count ), NULL, GL_DYNAMIC_DRAW ); // vec3
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	desc.host_position_buffer = small;
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	desc.host_position_buffer = small + 1000; // not a buffer name
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	GLint bound = -1;
	glGetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &bound );
	assert_int_equal( bound, 0 );
	assert_int_equal( glGetError(), GL_NO_ERROR );
	glDeleteBuffers( 1, &small );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_invalid_descriptions_are_rejected( void** state )
{
	plTestFixture* fixture = *state;
	const plTestMesh* mesh = &fixture->mesh;
	plGlDeformer* deformer = NULL;
	plGlDeformerDesc valid = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	assert_int_equal( plGlDeformer_Create( NULL, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plGlDeformer_Create( &valid, NULL, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plGlDeformer_Create( &valid, &fixture->allocator, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );

	uint16_t* bad_indices = malloc( sizeof( uint16_t ) * mesh->influence_count * mesh->vertex_count );
	memcpy( bad_indices, mesh->skin_indices, sizeof( uint16_t ) * mesh->influence_count * mesh->vertex_count );
	bad_indices[17] = (uint16_t)mesh->joint_count;
	uint32_t* bad_faces = malloc( sizeof( uint32_t ) * 3 * mesh->face_count );
	memcpy( bad_faces, mesh->faces, sizeof( uint32_t ) * 3 * mesh->face_count );
	bad_faces[3 * mesh->face_count - 1] = mesh->vertex_count;
	uint32_t* bad_offsets = malloc( sizeof( uint32_t ) * ( mesh->vertex_count + 1 ) );
	memcpy( bad_offsets, mesh->adjacency_offsets, sizeof( uint32_t ) * ( mesh->vertex_count + 1 ) );
	bad_offsets[5] = bad_offsets[6] + 1; // not monotonic
	plTestBody* body = calloc( 1, sizeof( *body ) );
	plTestBody_Build( body, mesh, 0.12f, 1 );
	plTestBody* bad_body = malloc( sizeof( *bad_body ) );
	*bad_body = *body; // shares body's candidates
	bad_body->skin_indices[PLEAT_TEST_BODY_INFLUENCES * PLEAT_TEST_BODY_POINTS - 1] = (uint16_t)mesh->joint_count;

	for ( int c = 0;; ++c )
	{
		plGlDeformerDesc desc = valid;
		switch ( c )
		{
		case 0: desc.mode = (plGlDeformerMode)0; break;
		case 1: desc.vertex_count = 0; break;
		case 2: desc.influence_count = 9; break;
		case 3: desc.influence_count = 0; break;
		case 4: desc.blend_count = 0; break;
		case 5: desc.joint_count = 0; break;
		case 6: desc.face_count = 0; break;
		case 7: desc.shaped_template = NULL; break;
		case 8: desc.blend_shapes.data = NULL; break;
		case 9: desc.skin_indices = NULL; break;
		case 10: desc.skin_weights = NULL; break;
		case 11: desc.faces = NULL; break;
		case 12: desc.adjacency_offsets = NULL; break;
		case 13: desc.adjacency_faces = NULL; break;
		case 14: desc.skin_indices = bad_indices; break;
		case 15: desc.faces = bad_faces; break;
		case 16: desc.adjacency_offsets = bad_offsets; break;
		case 17: desc.host_position_buffer = 1; break; // host buffers in headless mode
		case 18: desc.vertex_count = 0x10000000u; break; // buffers past 2 GiB
		// Body contact: plBodyContactJob_Validate's rules, and the point skinning the posing pass indexes unchecked.
		case 19: plAddBody( &desc, body ), desc.body_point_count = 0; break;
		case 20: plAddBody( &desc, body ), desc.body_anchor_candidate_count = 0; break;
		case 21: plAddBody( &desc, body ), desc.body_anchor_candidate_count = 17; break; // > the most, 16
		case 22: plAddBody( &desc, body ), desc.body_anchor_candidates = NULL, desc.body_anchor_candidate_count = 1;
			break; // no table: vertex v's point is v, but P < N
		case 23: plAddBody( &desc, body ), desc.body_anchor_normals = NULL; break;
		case 24: plAddBody( &desc, body ), desc.body_anchor_influence_count = 9; break;
		case 25: plAddBody( &desc, bad_body ); break; // a point skin index >= J
		// Rings (BARG): R in 3..PLEAT_MAX_POINT_RING with a table, 0 without.
		case 26: plAddBody( &desc, body ), desc.body_anchor_ring_count = 0; break;
		case 27: plAddBody( &desc, body ), desc.body_anchor_ring_count = 2; break; // < a triangle's
		case 28: plAddBody( &desc, body ), desc.body_anchor_ring_count = 9; break; // > the most, 8
		case 29: plAddBody( &desc, body ), desc.body_anchor_ring = NULL; break;
		default: goto done;
		}
		deformer = (plGlDeformer*)&desc;
		assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
		assert_null( deformer );
	}
done:
	free( body->candidates );
	free( body );
	free( bad_body );
	free( bad_indices );
	free( bad_faces );
	free( bad_offsets );
	assert_int_equal( plGlDeformer_Run( NULL, fixture->blend_weights, fixture->skin_matrices, NULL, NULL ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	plGlDeformer_Destroy( NULL );
	plExpectNoLeak( fixture );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_invalid_descriptions_are_rejected ),
		cmocka_unit_test( test_headless_matches_reference_over_motion ),
		cmocka_unit_test( test_headless_restores_the_callers_current_context ),
		cmocka_unit_test( test_headless_osmesa_fallback_matches_reference ),
		cmocka_unit_test( test_headless_egl_device_platform_matches_reference ),
		cmocka_unit_test( test_fp16_blend_shapes_match_rounded_reference ),
		cmocka_unit_test( test_set_shaped_template_moves_the_output ),
		cmocka_unit_test( test_body_contact_pushes_out_of_the_nearest_candidates ),
		cmocka_unit_test( test_body_contact_takes_the_normals_of_the_posed_rings ),
		cmocka_unit_test( test_body_contact_batch_matches_reference ),
		cmocka_unit_test( test_body_contact_batch_with_rings_matches_reference ),
		cmocka_unit_test( test_host_context_matches_reference_and_restores_state ),
		cmocka_unit_test( test_host_context_without_output_buffers_matches_reference ),
		cmocka_unit_test( test_host_context_without_current_context_is_unavailable ),
		cmocka_unit_test( test_host_buffer_too_small_is_rejected ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
