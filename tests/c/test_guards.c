// The runtime's guards, each provoked on purpose: the latent clamp to [ZMIN, ZMAX], the reset after a non-finite value
// inside a step (PLEAT_RESULT_NUMERIC_RESET), and the dt clamp to [dt_min_s, dt_max_s] (PLEAT_RESULT_CLAMPED).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"

static void plExpectSameOutput( plInstance a, plInstance b, uint32_t n )
{
	const float *pa, *pb, *na, *nb;
	plInstance_GetPositions( a, &pa, NULL );
	plInstance_GetPositions( b, &pb, NULL );
	plInstance_GetNormals( a, &na, NULL );
	plInstance_GetNormals( b, &nb, NULL );
	assert_memory_equal( pa, pb, n * 3 * sizeof( float ) );
	assert_memory_equal( na, nb, n * 3 * sizeof( float ) );
}

// The last LP bias is far outside the latent range: the de-normalised latent is clamped to exactly ZMIN / ZMAX.
static void test_latent_is_clamped_to_training_range( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	plTestLayer* last = &model->lp[model->lp_count - 1];
	for ( uint32_t i = 0; i < model->L; ++i )
	{
		last->bias[i] = ( i & 1u ) ? 1000.0f : -1000.0f;
		model->z_min[i] = -0.25f - 0.01f * (float)i;
		model->z_max[i] = 0.5f + 0.01f * (float)i;
	}
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	plInstance inst;
	assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	float q[64 * 4];
	for ( uint32_t t = 0; t < 5; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_OK );
		float latent[64];
		assert_int_equal( plInstance_GetLatent( inst, latent, 64 ), PLEAT_RESULT_OK );
		for ( uint32_t i = 0; i < model->L; ++i )
		{
			assert_float_equal( latent[i], ( i & 1u ) ? model->z_max[i] : model->z_min[i], 0.0 );
		}
	}
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

// X_c[L] (root velocity x) has x_std 1e-30, and the first LP layer weighs it with ±1e30 (both signs, so ReLU keeps some): any root motion along x
// overflows f_LP to ±inf. Standing still is fine (0 · 1e30 = 0). The step that moves must return NUMERIC_RESET with
// the output recomputed from the reset state, i.e. equal to a fresh instance's first step on that pose.
static void test_non_finite_inside_step_resets_history_and_latent( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	model->x_std[model->L] = 1e-30f;
	for ( uint32_t r = 0; r < model->lp[0].out_count; ++r )
	{
		model->lp[0].weight[(size_t)r * model->lp[0].in_count + model->L] = ( r & 1u ) ? 1e30f : -1e30f;
	}
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	plInstance inst, fresh;
	assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &rig, &fresh ), PLEAT_RESULT_OK );
	float q[64 * 4];
	plFrameInput in = plTestMotion( 0, model->J, q );
	in.root_translation = ( plVec3 ){ 0, 0, 0 };
	in.root_rotation = ( plQuat ){ 0, 0, 0, 1 };
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_OK );
	in.root_translation.x = 0.05f; // moving along x: velocity 1.5 m/s → 1.5e30 · 1e30 = inf
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_NUMERIC_RESET );
	assert_int_equal( plInstance_Step( fresh, &in, NULL ), PLEAT_RESULT_OK );
	plExpectSameOutput( inst, fresh, model->N );
	float la[64], lb[64];
	plInstance_GetLatent( inst, la, 64 );
	plInstance_GetLatent( fresh, lb, 64 );
	assert_memory_equal( la, lb, model->L * sizeof( float ) );
	const float* positions;
	plInstance_GetPositions( inst, &positions, NULL );
	for ( uint32_t i = 0; i < model->N * 3; ++i )
	{
		assert_true( isfinite( positions[i] ) );
	}
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

// X_c[L + 8], the first 6D component of input joint 1's rotation, is about 1 on every frame, first frames included; with
// x_std 1e-30 and LP weights ±1e30 on it, f_LP overflows even from the reset state. The step must then dress the body
// without the learned deformation — zero latent, zero blend weights, the shaped template skinned with the pose — and
// still return NUMERIC_RESET: bit for bit what a twin whose decoder outputs zero gives (tools/pleat/reference
// instance.py does the same, tests/python/test_failed_reset_twins.py).
static void test_non_finite_even_from_reset_dresses_the_body_without_learned_deformation( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* overflowing = plTestAsset_Create( &p );
	plTestAsset* zero_decoder = plTestAsset_Create( &p );
	uint32_t column = overflowing->L + 8;
	overflowing->x_mean[column] = 0.0f;
	overflowing->x_std[column] = 1e-30f;
	for ( uint32_t r = 0; r < overflowing->lp[0].out_count; ++r )
	{
		overflowing->lp[0].weight[(size_t)r * overflowing->lp[0].in_count + column] = ( r & 1u ) ? 1e30f : -1e30f;
	}
	for ( uint32_t i = 0; i < zero_decoder->dec_count; ++i )
	{
		plTestLayer* layer = &zero_decoder->dec[i];
		memset( layer->weight, 0, (size_t)layer->out_count * layer->in_count * sizeof( float ) );
		memset( layer->bias, 0, layer->out_count * sizeof( float ) );
	}
	plTestRig a_rig, b_rig;
	assert_int_equal( plTestRig_Init( &a_rig, overflowing, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Init( &b_rig, zero_decoder, NULL ), PLEAT_RESULT_OK );
	plInstance a, b;
	assert_int_equal( plTestRig_Instance( &a_rig, &a ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &b_rig, &b ), PLEAT_RESULT_OK );
	float q[64 * 4];
	for ( uint32_t t = 0; t < 3; ++t ) // a first frame, then steps with a history: each resets and falls back
	{
		plFrameInput in = plTestMotion( t, overflowing->J, q );
		assert_int_equal( plInstance_Step( a, &in, NULL ), PLEAT_RESULT_NUMERIC_RESET );
		assert_int_equal( plInstance_Step( b, &in, NULL ), PLEAT_RESULT_OK );
		plExpectSameOutput( a, b, overflowing->N );
		float latent[64], weights[64];
		assert_int_equal( plInstance_GetLatent( a, latent, 64 ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_GetBlendWeights( a, weights, 64 ), PLEAT_RESULT_OK );
		for ( uint32_t i = 0; i < overflowing->L; ++i )
		{
			assert_true( latent[i] == 0.0f );
		}
		for ( uint32_t i = 0; i < overflowing->D; ++i )
		{
			assert_true( weights[i] == 0.0f );
		}
	}
	plTestRig_Free( &a_rig );
	plTestRig_Free( &b_rig );
	plTestAsset_Destroy( overflowing );
	plTestAsset_Destroy( zero_decoder );
}

// dt below dt_min_s or above dt_max_s (but inside (0, 1]) is clamped: CLAMPED, and the output equals a twin given the
// clamped dt directly. Reset forgets the history: a reset instance equals a fresh one.
static void test_dt_is_clamped_to_asset_range( void** state )
{
	plTestRig* rig = *state;
	plInstance a, b;
	assert_int_equal( plTestRig_Instance( rig, &a ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( rig, &b ), PLEAT_RESULT_OK );
	float q[64 * 4];
	const float requested[4] = { 1e-5f, 0.5f, 1.0f, 1.0f / 60.0f };
	const float effective[4] = { rig->model->dt_min_s, rig->model->dt_max_s, rig->model->dt_max_s, 1.0f / 60.0f };
	const plResult expected[4] = { PLEAT_RESULT_CLAMPED, PLEAT_RESULT_CLAMPED, PLEAT_RESULT_CLAMPED, PLEAT_RESULT_OK };
	for ( int i = 0; i < 4; ++i )
	{
		plFrameInput in = plTestMotion( (uint32_t)i, rig->model->J, q );
		in.dt_s = requested[i];
		assert_int_equal( plInstance_Step( a, &in, NULL ), expected[i] );
		in.dt_s = effective[i];
		assert_int_equal( plInstance_Step( b, &in, NULL ), PLEAT_RESULT_OK );
		plExpectSameOutput( a, b, rig->model->N );
	}
	plInstance c;
	assert_int_equal( plTestRig_Instance( rig, &c ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Reset( a ), PLEAT_RESULT_OK );
	plFrameInput in = plTestMotion( 9, rig->model->J, q );
	assert_int_equal( plInstance_Step( a, &in, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Step( c, &in, NULL ), PLEAT_RESULT_OK );
	plExpectSameOutput( a, c, rig->model->N );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_latent_is_clamped_to_training_range ),
		cmocka_unit_test( test_non_finite_inside_step_resets_history_and_latent ),
		cmocka_unit_test( test_non_finite_even_from_reset_dresses_the_body_without_learned_deformation ),
		PLEAT_TEST_WITH_RIG( test_dt_is_clamped_to_asset_range ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
