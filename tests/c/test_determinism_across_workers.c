// Determinism: the same motion gives the same output hash (positions, normals, latent over every frame) whether the
// host task system runs 1, 2, 3 or 4 workers — the SDK splits MLP rows, blend shapes, skinning and normals into
// ranges whose results do not depend on the split (no atomics, fixed summation order). The same holds for a scene,
// whose characters are finished (LBS-only details, tier transfer, cross-fades, copies out) by the workers in turn.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"
#include "test_task_system.h"

static uint64_t plRunMotion( uint32_t workers, int force_scalar, uint32_t* parallel_tasks )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 40;
	p.grid_y = 30; // N = 1200: several ranges of 256 vertices
	p.lp_hidden[0] = 300;
	p.lp_hidden[1] = 200;
	p.dec_hidden[0] = 260;
	p.latent_count = 32;
	p.blend_count = 24;
	plTestAsset* model = plTestAsset_Create( &p );
	plTestTaskSystem* tasks = plTestTaskSystem_Create( workers );
	plContextDef def = plDefaultContextDef();
	def.force_scalar = force_scalar;
	if ( workers > 1 )
	{
		plTestTaskSystem_Install( tasks, &def );
	}
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, &def ), PLEAT_RESULT_OK );
	plInstance inst;
	assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	uint64_t hash = 0;
	float q[64 * 4], latent[64];
	for ( uint32_t t = 0; t < 30; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_true( plInstance_Step( inst, &in, NULL ) >= 0 );
		const float *positions, *normals;
		plInstance_GetPositions( inst, &positions, NULL );
		plInstance_GetNormals( inst, &normals, NULL );
		plInstance_GetLatent( inst, latent, 64 );
		hash = plTestHash( positions, model->N * 3 * sizeof( float ), hash );
		hash = plTestHash( normals, model->N * 3 * sizeof( float ), hash );
		hash = plTestHash( latent, model->L * sizeof( float ), hash );
	}
	*parallel_tasks = plTestTaskSystem_ParallelTaskCount( tasks );
	plTestRig_Free( &rig );
	plTestTaskSystem_Destroy( tasks );
	plTestAsset_Destroy( model );
	return hash;
}

static void test_same_hash_for_one_to_four_workers( void** state )
{
	(void)state;
	for ( int scalar = 0; scalar < 2; ++scalar )
	{
		uint32_t parallel = 0;
		uint64_t reference = plRunMotion( 1, scalar, &parallel );
		assert_int_equal( parallel, 0 );
		for ( uint32_t workers = 2; workers <= 4; ++workers )
		{
			uint64_t h = plRunMotion( workers, scalar, &parallel );
			assert_true( parallel > 0 ); // the work really was split
			assert_true( h == reference );
		}
		// Repeating a run gives the same hash as well (no dependence on uninitialised memory).
		assert_true( plRunMotion( 1, scalar, &parallel ) == reference );
	}
}

// A scene of 12 characters whose details the overrides move every few frames through LBS-only, two tiers on the
// display mesh and one on a coarser mesh, so that every frame has LBS-only characters, network ones and cross-fades
// of each kind in flight. The hash covers every character's positions, normals and result over 40 frames.
static uint64_t plRunScene( uint32_t workers, uint32_t* parallel_tasks )
{
	plTestTaskSystem* tasks = plTestTaskSystem_Create( workers );
	plContextDef def = plDefaultContextDef();
	if ( workers > 1 )
	{
		plTestTaskSystem_Install( tasks, &def );
	}
	plContext context;
	assert_int_equal( plCreateContext( &def, &context ), PLEAT_RESULT_OK );
	plTestSceneTiers set;
	assert_int_equal( plTestSceneTiers_Load( &set, context ), PLEAT_RESULT_OK );
	enum { CHARACTERS = 12 };
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = set.tiers;
	sdef.tier_count = 3;
	sdef.budget_us = 1e6f;
	sdef.character_capacity = CHARACTERS;
	sdef.min_frames_between_switches = 1;
	sdef.crossfade_frames = 4;
	plScene scene;
	assert_int_equal( plCreateScene( context, &sdef, &scene ), PLEAT_RESULT_OK );
	uint32_t J = set.models[0]->J, N0 = set.models[0]->N;
	for ( uint32_t i = 0; i < CHARACTERS; ++i )
	{
		plCharacterDef cdef = plDefaultCharacterDef();
		float beta[1] = { 0.1f * (float)i };
		cdef.beta = beta;
		cdef.beta_count = 1;
		uint32_t id;
		assert_int_equal( plScene_AddCharacter( scene, &cdef, &id ), PLEAT_RESULT_OK );
		assert_int_equal( id, i );
	}
	static float q[CHARACTERS][64 * 4], positions[CHARACTERS][4096 * 3], normals[CHARACTERS][4096 * 3];
	assert_true( N0 <= 4096 );
	plFrameInput inputs[CHARACTERS];
	plStepOutput outputs[CHARACTERS];
	plResult results[CHARACTERS];
	uint64_t hash = 0;
	for ( uint32_t t = 0; t < 40; ++t )
	{
		for ( uint32_t i = 0; i < CHARACTERS; ++i )
		{
			if ( ( t + i ) % 6 == 0 ) // each character every 6 frames, staggered: LBS-only, 0, 1, 2 in turn
			{
				plDetail detail = { (int32_t)( ( t / 6 + i ) % 4 ) - 1, 0.0f, 0 };
				assert_int_equal( plScene_SetOverride( scene, i, &detail ), PLEAT_RESULT_OK );
			}
			inputs[i] = plTestMotion( t + 3 * i, J, q[i] );
			outputs[i] = (plStepOutput){ 0 };
			outputs[i].positions = positions[i];
			outputs[i].normals = normals[i];
			outputs[i].vertex_capacity = N0;
		}
		assert_true( plScene_Step( scene, inputs, outputs, results, CHARACTERS ) >= 0 );
		plScenePlan plan;
		assert_int_equal( plScene_GetPlan( scene, &plan ), PLEAT_RESULT_OK );
		assert_true( t < 6 || plan.fading > 0 ); // cross-fades are in flight
		for ( uint32_t i = 0; i < CHARACTERS; ++i )
		{
			hash = plTestHash( positions[i], (size_t)N0 * 12, hash );
			hash = plTestHash( normals[i], (size_t)N0 * 12, hash );
			hash = plTestHash( &results[i], sizeof( results[i] ), hash );
		}
	}
	*parallel_tasks = plTestTaskSystem_ParallelTaskCount( tasks );
	plDestroyContext( context );
	plTestSceneTiers_Free( &set );
	plTestTaskSystem_Destroy( tasks );
	return hash;
}

static void test_scene_same_hash_for_one_to_four_workers( void** state )
{
	(void)state;
	uint32_t parallel = 0;
	uint64_t reference = plRunScene( 1, &parallel );
	assert_int_equal( parallel, 0 );
	for ( uint32_t workers = 2; workers <= 4; ++workers )
	{
		uint64_t h = plRunScene( workers, &parallel );
		assert_true( parallel > 0 );
		assert_true( h == reference );
	}
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_same_hash_for_one_to_four_workers ),
		cmocka_unit_test( test_scene_same_hash_for_one_to_four_workers ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
