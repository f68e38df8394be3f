// An instance in PLEAT_GPU_MODE_HEADLESS mode (blend shapes, skinning and normals in GL compute, Mesa llvmpipe here) gives
// the CPU instance's output when the step asks for read-backs. Skips (exit 77) when no GL 4.3 context can be made or
// the SDK was built without PLEAT_GL.
//
// With a network rate (plInstanceDef.network_rate_hz) the steps between network updates skin the held deformation:
// the GPU re-blends it, the CPU reuses its T_def; both must still agree.
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

static void plCompareGpuWithCpu( float network_rate_hz )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 17;
	p.grid_y = 19;
	plTestRig rig;
	assert_int_equal( plTestRig_Create( &rig, &p, NULL ), PLEAT_RESULT_OK );
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
	float q[64 * 4];
	double worst_p = 0, worst_n = 0;
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
		for ( uint32_t i = 0; i < model->N * 3; ++i )
		{
			double ep = fabs( (double)positions[i] - cp[i] ), en = fabs( (double)normals[i] - cn[i] );
			worst_p = ep > worst_p ? ep : worst_p;
			worst_n = en > worst_n ? en : worst_n;
		}
	}
	print_message( "GPU vs CPU instance, network rate %g Hz: max position error %.3g m, max normal error %.3g\n",
				   network_rate_hz, worst_p, worst_n );
	assert_true( worst_p <= 1e-5 );
	assert_true( worst_n <= 1e-3 );
	free( positions );
	free( normals );
	plTestRig_Free( &rig );
}

static void test_headless_gpu_instance_matches_cpu_instance( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 0.0f );
}

static void test_headless_gpu_instance_matches_cpu_instance_between_network_updates( void** state )
{
	(void)state;
	plCompareGpuWithCpu( 12.0f ); // steps of 1/30 s: the networks run on every third step
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance ),
		cmocka_unit_test( test_headless_gpu_instance_matches_cpu_instance_between_network_updates ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
