// An instance in PLEAT_GPU_MODE_HEADLESS mode (blend shapes, skinning and normals in GL compute, Mesa llvmpipe here) gives
// the CPU instance's output when the step asks for read-backs. Skips (exit 77) when no GL 4.3 context can be made or
// the SDK was built without PLEAT_GL.
//
// With a network rate (plInstanceDef.network_rate_hz) the steps between network updates skin the held deformation:
// the GPU re-blends it, the CPU reuses its T_def; both must still agree.
//
// With body contact (pleat.h BODY CONTACT) body_contact.comp's two passes run after skinning on the GPU and
// plBodyPointsJob + plBodyPointNormalsJob + plBodyContactJob on the CPU: the stand-in body is a plane 2 mm behind the
// sheet, with tilted candidate points beside some vertices (asset 1.2, P ≠ N, C > 1: plTestAsset_AddBodyAnchors) whose
// points behind the interior grid vertices take their normals from the posed ring of points around them (BARG: the
// sheet's own grid, so they turn with the sheet as it bends; every fifth point has a zero rest normal and never
// anchors, yet is in its neighbours' rings), the same without the ring table (a 1.2 asset without BARG: the blended
// rest normals), or one point per vertex (asset 1.1, no candidate or ring table: plTestAsset_DropBodyCandidates), and
// the blend shapes (±1 cm) push many vertices through it, so both paths move vertices; they must agree, and differ
// from contact off.
//
// Tolerance: 1e-5 m for positions, 1e-3 for normals — the GPU sums in a different order and with its own rounding
// (the GL engineer's test_gl_deformer measures ~1e-6 m and ~1e-4); a wrong matrix layout or weight gives centimetres.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>

#include "test_common.h"

typedef enum plTestBody
{
	PLEAT_TEST_NO_BODY,
	PLEAT_TEST_BODY_CANDIDATES,           // asset 1.2 with the points' rings (BARG)
	PLEAT_TEST_BODY_ONE_POINT_PER_VERTEX, // asset 1.1
	PLEAT_TEST_BODY_CANDIDATES_NO_RINGS,  // asset 1.2 without BARG
} plTestBody;

static void plCompareGpuWithCpu( float network_rate_hz, plTestBody body, int int8_blend_shapes )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 17;
	p.grid_y = 19;
	p.int8_blend_shapes = int8_blend_shapes;
	plTestRig rig;
	int body_anchors = body != PLEAT_TEST_NO_BODY;
	plTestAsset* built = plTestAsset_Create( &p );
	assert_non_null( built );
	if ( body_anchors )
	{
		assert_true( plTestAsset_AddBodyAnchors( built, 0.002f ) );
	}
	if ( body == PLEAT_TEST_BODY_ONE_POINT_PER_VERTEX )
	{
		plTestAsset_DropBodyCandidates( built );
	}
	if ( body == PLEAT_TEST_BODY_CANDIDATES_NO_RINGS )
	{
		free( built->body_ring );
		built->body_ring = NULL;
	}
	if ( body == PLEAT_TEST_BODY_CANDIDATES || body == PLEAT_TEST_BODY_CANDIDATES_NO_RINGS )
	{
		// What these cases are for: more body points than vertices, several candidates per vertex, and (or not) the
		// points' normals from the posed rings.
		assert_true( built->body_candidates != NULL && built->P != built->N && built->C > 1 );
		assert_true( ( built->body_ring != NULL ) == ( body == PLEAT_TEST_BODY_CANDIDATES ) );
	}
	if ( body == PLEAT_TEST_BODY_ONE_POINT_PER_VERTEX )
	{
		assert_null( built->body_ring );
	}
	assert_int_equal( plTestRig_Init( &rig, built, NULL ), PLEAT_RESULT_OK );
	rig.model = built; // freed by plTestRig_Free
	assert_int_equal( rig.info.has_body_contact, body_anchors );
	const plTestAsset* model = rig.model;
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
	idef.network_rate_hz = network_rate_hz;
	plInstance gpu, cpu;
	plResult r = plCreateInstance( rig.context, &idef, &gpu );
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		plTestRig_Free( &rig );
		skip();
	}
	assert_int_equal( r, PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &rig, &cpu ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_SetNetworkRate( cpu, network_rate_hz ), PLEAT_RESULT_OK );
	float beta[2] = { 1.0f, -0.5f };
	assert_int_equal( plInstance_SetShape( gpu, beta, 2 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_SetShape( cpu, beta, 2 ), PLEAT_RESULT_OK );
	float* positions = (float*)calloc( (size_t)model->N * 3, sizeof( float ) );
	float* normals = (float*)calloc( (size_t)model->N * 3, sizeof( float ) );
	plStepOutput out;
	memset( &out, 0, sizeof( out ) );
	out.positions = positions;
	out.normals = normals;
	out.vertex_capacity = model->N;
	plInstance plain = { 0 }; // contact off: the contact must change something for the comparison to mean anything
	plInstanceDef pdef = plDefaultInstanceDef();
	pdef.asset = rig.asset;
	pdef.body_contact = 0;
	assert_int_equal( plCreateInstance( rig.context, &pdef, &plain ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_SetNetworkRate( plain, network_rate_hz ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_SetShape( plain, beta, 2 ), PLEAT_RESULT_OK );
	float q[64 * 4];
	double worst_p = 0, worst_n = 0, contact_moved = 0;
	for ( uint32_t t = 0; t < 10; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		// at 12 Hz the network's dt (3 × 1/30 s) is beyond the test asset's dt_max (1/15 s): CLAMPED, on both
		plResult on_gpu = plInstance_Step( gpu, &in, &out );
		assert_true( on_gpu == PLEAT_RESULT_OK || ( network_rate_hz > 0.0f && on_gpu == PLEAT_RESULT_CLAMPED ) );
		assert_int_equal( plInstance_Step( cpu, &in, NULL ), on_gpu );
		const float *cp, *cn;
		plInstance_GetPositions( cpu, &cp, NULL );
		plInstance_GetNormals( cpu, &cn, NULL );
		const float* pp;
		assert_int_equal( plInstance_Step( plain, &in, NULL ), on_gpu );
		plInstance_GetPositions( plain, &pp, NULL );
		for ( uint32_t i = 0; i < model->N * 3; ++i )
		{
			double moved = fabs( (double)pp[i] - cp[i] );
			contact_moved = moved > contact_moved ? moved : contact_moved;
		}
		for ( uint32_t i = 0; i < model->N * 3; ++i )
		{
			double ep = fabs( (double)positions[i] - cp[i] ), en = fabs( (double)normals[i] - cn[i] );
			worst_p = ep > worst_p ? ep : worst_p;
			worst_n = en > worst_n ? en : worst_n;
		}
	}
	static const char* const bodies[4] = { "none", "candidate points and rings (1.2)", "one point per vertex (1.1)",
										   "candidate points without rings (1.2)" };
	print_message( "GPU vs CPU instance, network rate %g Hz, body %s: max position error %.3g m, max normal error %.3g "
				   "(body contact moved vertices by up to %.3g m)\n",
				   network_rate_hz, bodies[body], worst_p, worst_n, contact_moved );
	assert_true( worst_p <= 1e-5 );
	assert_true( worst_n <= 1e-3 );
	if ( body_anchors )
	{
		assert_true( contact_moved > 1e-3 );
	}
	else
	{
		assert_true( contact_moved == 0.0 );
	}
	free( positions );
	free( normals );
	plTestRig_Free( &rig );
}

static void test_headless_gpu_instance_matches_cpu_instance( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f, PLEAT_TEST_NO_BODY, 0 );
}

static void test_headless_gpu_instance_matches_cpu_instance_with_body_contact( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f, PLEAT_TEST_BODY_CANDIDATES, 0 );
}

static void test_headless_gpu_instance_matches_cpu_instance_with_one_body_point_per_vertex( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f, PLEAT_TEST_BODY_ONE_POINT_PER_VERTEX, 0 );
}

static void test_headless_gpu_instance_matches_cpu_instance_with_body_contact_without_rings( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f, PLEAT_TEST_BODY_CANDIDATES_NO_RINGS, 0 );
}

static void test_headless_gpu_instance_matches_cpu_instance_between_network_updates( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 12.0f, PLEAT_TEST_BODY_CANDIDATES, 0 ); // steps of 1/30 s: the networks run on every third step
}

// int8 blend shapes (asset 1.4): the GPU reads them as the fp32 values q · scale and the CPU folds the scale into the
// weight, (w · s) · q against w · (q · s), a rounding apart.
static void test_headless_gpu_instance_matches_cpu_instance_with_int8_blend_shapes( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f, PLEAT_TEST_BODY_CANDIDATES, 1 );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_with_body_contact ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_with_one_body_point_per_vertex ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_with_body_contact_without_rings ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_between_network_updates ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_with_int8_blend_shapes ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
