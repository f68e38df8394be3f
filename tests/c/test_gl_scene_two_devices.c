// A scene on two devices (plSceneDef.gpu_mode, docs/scene-budget.md "Two devices"): every tier also as a GPU detail,
// the policy placing each character on the CPU or the GPU within both budgets. On two tiers of the test asset builder
// with given costs (tier 0: 100 µs on the CPU, 30 µs of GPU and 5 µs of CPU on the GPU; tier 1: 40 / 15 / 5; LBS-only
// 10 µs), ten characters:
// - an ample CPU budget and an unlimited GPU: everyone on the GPU's best tier (its CPU share is the cheapest);
// - an unlimited CPU and a limited GPU: everyone on the CPU's best tier;
// - both limited, neither enough for all ten at tier 0: the crowd splits over the two devices, each plan within its
//   budget, everyone on tier 0, a lower weighted error than the CPU alone with the same CPU budget;
// - a character overridden onto tier 0 on the GPU shows what the CPU's tier 0 shows (within the GL tolerance, 2e-5 m),
//   and a switch from one device to the other (a cross-fade between the two instances) moves the character no further
//   in a frame than its neighbour's motion moves it (within 1.5x);
// - the def and API refusals: a GPU mode without GPU costs, SetGpuBudget and a GPU override on a CPU scene.
// Skips (exit 77) without a GL 4.3 context.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "pleat/pleat.h"
#include "test_asset_builder.h"
#include "test_common.h"
#include "test_gl_support.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLEAT_TEST_CHARACTERS 10

typedef struct plTwoDevicesFixture
{
	plContext context;
	plAsset tiers[2];
	uint8_t* bytes[2];
	plTestEglContext engine;
} plTwoDevicesFixture;

static int plSetup( void** state )
{
	plTwoDevicesFixture* f = calloc( 1, sizeof( *f ) );
	plContextDef cdef = plDefaultContextDef();
	assert_int_equal( plCreateContext( &cdef, &f->context ), PLEAT_RESULT_OK );
	for ( int t = 0; t < 2; ++t )
	{
		plTestAssetParams p = plTestAsset_DefaultParams();
		p.grid_x = 13;
		p.grid_y = 11;
		p.lp_hidden[0] = t == 0 ? 64 : 24;
		p.lp_hidden[1] = 0;
		p.dec_hidden[0] = t == 0 ? 48 : 16;
		p.dec_hidden[1] = 0;
		p.seed = 71u + (uint32_t)t;
		plTestAsset* model = plTestAsset_Create( &p );
		assert_non_null( model );
		size_t size = 0;
		f->bytes[t] = plTestAsset_Write( model, &size );
		plTestAsset_Destroy( model );
		plAssetDef adef = plDefaultAssetDef();
		adef.data = f->bytes[t];
		adef.size = size;
		assert_int_equal( plLoadAsset( f->context, &adef, &f->tiers[t] ), PLEAT_RESULT_OK );
	}
	plTestEgl_Create( &f->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = f;
	return 0;
}

static int plTeardown( void** state )
{
	plTwoDevicesFixture* f = *state;
	plTestEgl_Destroy( &f->engine );
	plDestroyContext( f->context );
	plTestAsset_FreeBytes( f->bytes[0] );
	plTestAsset_FreeBytes( f->bytes[1] );
	free( f );
	return 0;
}

static const float k_cpu_cost[2] = { 100.0f, 40.0f }, k_skin_cost[2] = { 20.0f, 10.0f };
static const float k_stream_cost[2] = { 0.0f, 0.0f }, k_error[2] = { 10.0f, 20.0f };
static const float k_gpu_cost[2] = { 30.0f, 15.0f }, k_gpu_cpu_cost[2] = { 5.0f, 5.0f };

static plScene plMakeScene( plTwoDevicesFixture* f, plGpuMode mode, float budget_us, float gpu_budget_us )
{
	plSceneDef def = plDefaultSceneDef();
	def.tiers = f->tiers;
	def.tier_count = 2;
	def.tier_cost_us = k_cpu_cost;
	def.tier_skin_cost_us = k_skin_cost;
	def.tier_stream_cost_us = k_stream_cost;
	def.tier_error_mm = k_error;
	def.lbs_cost_us = 10.0f;
	def.lbs_error_mm = 30.0f;
	def.budget_us = budget_us;
	def.gpu_mode = mode;
	def.tier_gpu_cost_us = mode != PLEAT_GPU_MODE_NONE ? k_gpu_cost : NULL;
	def.tier_gpu_cpu_cost_us = mode != PLEAT_GPU_MODE_NONE ? k_gpu_cpu_cost : NULL;
	def.gpu_budget_us = gpu_budget_us;
	def.character_capacity = PLEAT_TEST_CHARACTERS;
	def.min_frames_between_switches = 1;
	plScene scene;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_OK );
	for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
	{
		plCharacterDef cdef = plDefaultCharacterDef();
		cdef.importance = 1.0f + 0.1f * (float)c;
		uint32_t id;
		assert_true( plScene_AddCharacter( scene, &cdef, &id ) >= 0 );
		assert_int_equal( id, c );
	}
	return scene;
}

// Frame f of a swinging pose, character c at its own phase.
static void plPose( uint32_t frame, uint32_t c, uint32_t joints, float* rotations, plFrameInput* input )
{
	double t = ( frame + 5.0 * c ) / 60.0;
	for ( uint32_t j = 0; j < joints; ++j )
	{
		double angle = 0.5 * sin( 2.0 * t + 0.5 * j );
		rotations[4 * j] = (float)sin( 0.5 * angle );
		rotations[4 * j + 1] = 0.0f;
		rotations[4 * j + 2] = 0.0f;
		rotations[4 * j + 3] = (float)cos( 0.5 * angle );
	}
	memset( input, 0, sizeof( *input ) );
	input->joint_rotations = rotations;
	input->joint_count = joints;
	input->root_translation = ( plVec3 ){ 0.0f, 0.0f, (float)( 1.0 * t ) };
	input->root_rotation = ( plQuat ){ 0.0f, 0.0f, 0.0f, 1.0f };
	input->dt_s = 1.0f / 60.0f;
}

// Steps the scene `frames` times; returns its plan after the last.
static plScenePlan plRun( plTwoDevicesFixture* f, plScene scene, uint32_t frames )
{
	plAssetInfo info;
	plAsset_GetInfo( f->tiers[0], &info );
	float* rotations = malloc( sizeof( float ) * 4 * info.joint_count * PLEAT_TEST_CHARACTERS );
	plFrameInput inputs[PLEAT_TEST_CHARACTERS];
	plResult results[PLEAT_TEST_CHARACTERS];
	for ( uint32_t frame = 0; frame < frames; ++frame )
	{
		for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
			plPose( frame, c, info.joint_count, rotations + 4 * (size_t)info.joint_count * c, &inputs[c] );
		assert_true( plScene_Step( scene, inputs, NULL, results, PLEAT_TEST_CHARACTERS ) >= 0 );
	}
	free( rotations );
	plScenePlan plan;
	assert_int_equal( plScene_GetPlan( scene, &plan ), PLEAT_RESULT_OK );
	return plan;
}

static void plCountDetails( plScene scene, uint32_t* on_gpu, uint32_t* on_tier0 )
{
	*on_gpu = 0;
	*on_tier0 = 0;
	for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
	{
		plDetail d;
		assert_int_equal( plScene_GetDetail( scene, c, &d, NULL, NULL ), PLEAT_RESULT_OK );
		*on_gpu += d.gpu != 0;
		*on_tier0 += d.tier == 0 && d.network_rate_hz == 0.0f;
	}
}

static void test_the_policy_places_characters_on_either_device( void** state )
{
	plTwoDevicesFixture* f = *state;
	plTestEgl_Require( &f->engine );
	uint32_t on_gpu, on_tier0;

	// An unlimited GPU: everyone on its best tier there (5 µs of CPU each against 100 on the CPU).
	plScene scene = plMakeScene( f, PLEAT_GPU_MODE_HEADLESS, 1000.0f, 0.0f );
	plScenePlan plan = plRun( f, scene, 3 );
	plCountDetails( scene, &on_gpu, &on_tier0 );
	print_message( "unlimited GPU: %u on the GPU, %u on tier 0, plan %.1f µs CPU, %.1f µs GPU\n", on_gpu, on_tier0,
				   (double)plan.cost_us, (double)plan.gpu_cost_us );
	assert_int_equal( on_gpu, PLEAT_TEST_CHARACTERS );
	assert_int_equal( on_tier0, PLEAT_TEST_CHARACTERS );
	assert_int_equal( plan.on_gpu, PLEAT_TEST_CHARACTERS );
	assert_true( fabsf( plan.gpu_cost_us - PLEAT_TEST_CHARACTERS * k_gpu_cost[0] ) < 1e-3f );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );

	// An unlimited CPU and a tight GPU: everyone on the CPU's best tier.
	scene = plMakeScene( f, PLEAT_GPU_MODE_HEADLESS, 0.0f, 100.0f );
	plan = plRun( f, scene, 3 );
	plCountDetails( scene, &on_gpu, &on_tier0 );
	assert_int_equal( on_gpu, 0 );
	assert_int_equal( on_tier0, PLEAT_TEST_CHARACTERS );
	assert_true( plan.gpu_cost_us == 0.0f );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );

	// Both limited (the plans may fill 90 %: 630 µs of CPU, 180 of GPU): neither device holds all ten at tier 0
	// (1,000 µs of CPU or 300 of GPU), the two together do (five on each: 525 µs of CPU, 150 of GPU).
	scene = plMakeScene( f, PLEAT_GPU_MODE_HEADLESS, 700.0f, 200.0f );
	plan = plRun( f, scene, 3 );
	plCountDetails( scene, &on_gpu, &on_tier0 );
	print_message( "both limited: %u on the GPU, %u on tier 0, plan %.1f / %.1f µs CPU, %.1f / %.1f µs GPU, weighted "
				   "error %.2f mm\n",
				   on_gpu, on_tier0, (double)plan.cost_us, 700.0, (double)plan.gpu_cost_us, 200.0,
				   (double)plan.weighted_error_mm );
	assert_true( on_gpu > 0 && on_gpu < PLEAT_TEST_CHARACTERS );
	assert_int_equal( on_tier0, PLEAT_TEST_CHARACTERS );
	assert_true( plan.cost_us <= 700.0f && plan.gpu_cost_us <= 200.0f );
	float both_error = plan.weighted_error_mm;
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );

	scene = plMakeScene( f, PLEAT_GPU_MODE_NONE, 700.0f, 0.0f );
	plan = plRun( f, scene, 3 );
	print_message( "the CPU alone: weighted error %.2f mm\n", (double)plan.weighted_error_mm );
	assert_true( both_error < plan.weighted_error_mm );
	assert_int_equal( plan.on_gpu, 0 );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );
}

static void test_a_gpu_detail_shows_what_the_cpu_detail_shows( void** state )
{
	plTwoDevicesFixture* f = *state;
	plTestEgl_Require( &f->engine );
	plScene gpu = plMakeScene( f, PLEAT_GPU_MODE_HEADLESS, 0.0f, 0.0f );
	plScene cpu = plMakeScene( f, PLEAT_GPU_MODE_NONE, 0.0f, 0.0f );
	const plDetail on_gpu = { 0, 0.0f, 1 }, on_cpu = { 0, 0.0f, 0 };
	for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
	{
		assert_int_equal( plScene_SetOverride( gpu, c, &on_gpu ), PLEAT_RESULT_OK );
		assert_int_equal( plScene_SetOverride( cpu, c, &on_cpu ), PLEAT_RESULT_OK );
	}
	plAssetInfo info;
	plAsset_GetInfo( f->tiers[0], &info );
	uint32_t n = info.vertex_count;
	float* rotations = malloc( sizeof( float ) * 4 * info.joint_count * PLEAT_TEST_CHARACTERS );
	double worst = 0.0, worst_jump = 0.0, ordinary_jump = 0.0;
	float* last = malloc( sizeof( float ) * 6 * n ); // characters 0 and 1's last positions
	for ( uint32_t frame = 0; frame < 24; ++frame )
	{
		if ( frame == 12 )
		{
			// Character 0 moves to the CPU: a switch between the two instances of tier 0, cross-faded.
			assert_int_equal( plScene_SetOverride( gpu, 0, &on_cpu ), PLEAT_RESULT_OK );
		}
		plFrameInput inputs[PLEAT_TEST_CHARACTERS];
		plResult results[PLEAT_TEST_CHARACTERS];
		for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
			plPose( frame, c, info.joint_count, rotations + 4 * (size_t)info.joint_count * c, &inputs[c] );
		assert_true( plScene_Step( gpu, inputs, NULL, results, PLEAT_TEST_CHARACTERS ) >= 0 );
		assert_true( plScene_Step( cpu, inputs, NULL, results, PLEAT_TEST_CHARACTERS ) >= 0 );
		for ( uint32_t c = 0; c < PLEAT_TEST_CHARACTERS; ++c )
		{
			const float *a, *b;
			assert_int_equal( plScene_GetPositions( gpu, c, &a, NULL ), PLEAT_RESULT_OK );
			assert_int_equal( plScene_GetPositions( cpu, c, &b, NULL ), PLEAT_RESULT_OK );
			for ( size_t e = 0; e < 3u * n; ++e )
			{
				assert_true( isfinite( a[e] ) );
				if ( c != 0 || frame < 12 ) // the switched character restarts its latent: compared for jumps below
					worst = fmax( worst, fabs( (double)a[e] - b[e] ) );
				if ( c == 0 && frame > 0 )
					worst_jump = fmax( worst_jump, fabs( (double)a[e] - last[e] ) );
				if ( c == 1 && frame > 0 )
					ordinary_jump = fmax( ordinary_jump, fabs( (double)a[e] - last[3 * n + e] ) );
			}
			if ( c < 2 )
				memcpy( last + 3 * (size_t)n * c, a, sizeof( float ) * 3 * n );
		}
		plDetail d;
		assert_int_equal( plScene_GetDetail( gpu, 1, &d, NULL, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( d.gpu, 1 );
	}
	print_message( "GPU detail against CPU detail: %.3g m; largest frame-to-frame move of character 0 (switched) %.3g m, "
				   "of character 1 %.3g m\n",
				   worst, worst_jump, ordinary_jump );
	assert_true( worst <= 2e-5 );
	assert_true( worst_jump <= 1.5 * ordinary_jump ); // no pop at the device switch
	free( rotations );
	free( last );
	assert_int_equal( plDestroyScene( gpu ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyScene( cpu ), PLEAT_RESULT_OK );
}

static void test_two_device_refusals( void** state )
{
	plTwoDevicesFixture* f = *state;
	plSceneDef def = plDefaultSceneDef();
	def.tiers = f->tiers;
	def.tier_count = 2;
	def.gpu_mode = PLEAT_GPU_MODE_HEADLESS; // no tier_gpu_cost_us
	plScene scene;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_INVALID_DEF );
	def.tier_gpu_cost_us = k_gpu_cost;
	def.gpu_budget_us = -1.0f;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_INVALID_DEF );
	def.gpu_budget_us = 0.0f;
	def.gpu_mode = (plGpuMode)7;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_INVALID_DEF );
	// A GPU scene (no characters yet: no GL needed) takes a GPU budget >= 0 and finite, and only while it lives.
	def.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_OK );
	assert_int_equal( plScene_SetGpuBudget( scene, NAN ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_SetGpuBudget( scene, -1.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_SetGpuBudget( scene, INFINITY ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_SetGpuBudget( scene, 50.0f ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );
	assert_int_equal( plScene_SetGpuBudget( scene, 50.0f ), PLEAT_RESULT_INVALID_HANDLE );
	def.gpu_mode = PLEAT_GPU_MODE_NONE;
	assert_int_equal( plCreateScene( f->context, &def, &scene ), PLEAT_RESULT_OK );
	assert_int_equal( plScene_SetGpuBudget( scene, 100.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
	uint32_t id;
	plCharacterDef cdef = plDefaultCharacterDef();
	assert_true( plScene_AddCharacter( scene, &cdef, &id ) >= 0 );
	const plDetail on_gpu = { 0, 0.0f, 1 };
	assert_int_equal( plScene_SetOverride( scene, id, &on_gpu ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_two_device_refusals ),
		cmocka_unit_test( test_the_policy_places_characters_on_either_device ),
		cmocka_unit_test( test_a_gpu_detail_shows_what_the_cpu_detail_shows ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
