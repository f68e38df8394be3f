// plStepInstances steps every instance of a crowd exactly as plInstance_Step steps it alone: the same results and,
// bit for bit, the same positions, normals, latent, blend weights, skinning matrices and copies to the caller's
// strided outputs — on the scalar and the AVX2 kernels (with the AVX2 and, where the CPU has them, the AVX-512 batched
// kernels; with and without the batched normals' scratch), fp32 and fp16 weights and int8 blend shapes, one and three
// workers, over several frames of a crowd that has more instances of one asset than one group holds (64), three
// assets (ReLU and SiLU),
// different β, network rates and dt, instances listed twice, a stale handle, an instance whose input is rejected on
// one frame (it must stay unchanged while the others step), body contact on most instances of the big asset (off or
// at another clearance on some) and an asset whose f_LP overflows whenever the root moves along x (the numeric reset
// inside a batch).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "core.h"
#include "kernels_batch.h"
#include "test_common.h"
#include "test_task_system.h"

enum
{
	PLEAT_TEST_A = 67, // instances of asset A: one full group of 64 and a second group
	PLEAT_TEST_B = 5,
	PLEAT_TEST_C = 4,
	PLEAT_TEST_INSTANCES = PLEAT_TEST_A + PLEAT_TEST_B + PLEAT_TEST_C,
	PLEAT_TEST_LIST = PLEAT_TEST_INSTANCES + 3, // + two second listings + one stale handle
	PLEAT_TEST_FRAMES = 9,
	PLEAT_TEST_MAX_N = 300,
	PLEAT_TEST_STRIDE_FLOATS = 8, // 32-byte interleaved outputs for some instances
};

typedef struct plTestWorld
{
	plTestTaskSystem* tasks;
	plContext context;
	plAsset assets[3];
	uint8_t* bytes[3];
	plInstance instances[PLEAT_TEST_INSTANCES];
	plInstance stale;
} plTestWorld;

// precision: 0 fp32, 1 fp16, 2 fp16 networks and int8 blend shapes.
static plTestAsset* plMakeModel( int which, int precision )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.fp16 = precision != 0;
	p.int8_blend_shapes = precision == 2;
	if ( which == 0 )
	{
		p.grid_x = 20;
		p.grid_y = 15; // N = 300: blend tiles of 16 elements plus leftovers, vertex ranges over workers
		p.lp_hidden[0] = 96;
		p.lp_hidden[1] = 67;
		p.dec_hidden[0] = 80;
		p.latent_count = 16;
		p.blend_count = 13;
		p.seed = 11;
	}
	else if ( which == 1 )
	{
		p.grid_x = 9;
		p.grid_y = 7;
		p.activation = 2; // SiLU
		p.latent_count = 9;
		p.blend_count = 5;
		p.seed = 12;
	}
	else
	{
		p.seed = 13;
		p.activation = 2; // SiLU passes ±inf and NaN on (a ReLU would turn an overflow's NaN into 0)
	}
	plTestAsset* model = plTestAsset_Create( &p );
	if ( which == 0 )
	{
		// Body anchors 2 mm behind the sheet: body contact moves vertices between the batched skinning and normals.
		assert_true( plTestAsset_AddBodyAnchors( model, 0.002f ) );
	}
	if ( which == 2 )
	{
		plTestAsset_OverflowOnRootMotion( model ); // any root motion along x: a numeric reset
	}
	return model;
}

// The widest kernel set the worlds' contexts may take (one test narrows it to AVX2 on an AVX-512 CPU).
static plKernelSet s_plTestMaxIsa = PLEAT_KERNEL_SET_AVX512;

static void plWorld_Init( plTestWorld* w, plTestAsset* models[3], int force_scalar, uint32_t workers )
{
	memset( w, 0, sizeof( *w ) );
	w->tasks = plTestTaskSystem_Create( workers );
	plContextDef def = plDefaultContextDef();
	def.force_scalar = force_scalar;
	def.max_isa = s_plTestMaxIsa;
	if ( workers > 1 )
	{
		plTestTaskSystem_Install( w->tasks, &def );
	}
	assert_int_equal( plCreateContext( &def, &w->context ), PLEAT_RESULT_OK );
	for ( int k = 0; k < 3; ++k )
	{
		size_t size;
		w->bytes[k] = plTestAsset_Write( models[k], &size );
		plAssetDef adef = plDefaultAssetDef();
		adef.data = w->bytes[k];
		adef.size = size;
		assert_int_equal( plLoadAsset( w->context, &adef, &w->assets[k] ), PLEAT_RESULT_OK );
	}
	for ( uint32_t i = 0; i < PLEAT_TEST_INSTANCES; ++i )
	{
		int which = i < PLEAT_TEST_A ? 0 : ( i < PLEAT_TEST_A + PLEAT_TEST_B ? 1 : 2 );
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = w->assets[which];
		float beta[2] = { 0.3f * (float)( i % 7 ) - 0.9f, 0.1f * (float)( i % 3 ) };
		idef.beta = beta;
		idef.beta_count = 2;
		idef.network_rate_hz = ( i % 3 == 1 ) ? 30.0f : ( i % 5 == 2 ? 20.0f : 0.0f );
		idef.body_contact = i % 4 != 3; // asset A: contact on for most, off for every fourth
		idef.body_contact_offset_m = i % 8 == 1 ? 0.004f : idef.body_contact_offset_m;
		assert_int_equal( plCreateInstance( w->context, &idef, &w->instances[i] ), PLEAT_RESULT_OK );
	}
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = w->assets[0];
	assert_int_equal( plCreateInstance( w->context, &idef, &w->stale ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( w->stale ), PLEAT_RESULT_OK );
}

static void plWorld_Free( plTestWorld* w )
{
	plDestroyContext( w->context );
	for ( int k = 0; k < 3; ++k )
	{
		plTestAsset_FreeBytes( w->bytes[k] );
	}
	plTestTaskSystem_Destroy( w->tasks );
}

// The crowd's list: the instances interleaved across the three assets, instance 5 and 70 listed a second time, the
// stale handle in the middle.
static plInstance plListEntry( const plTestWorld* w, uint32_t k, uint32_t* out_instance )
{
	static const uint32_t order_seed = 37; // coprime with PLEAT_TEST_INSTANCES: a permutation
	if ( k < PLEAT_TEST_INSTANCES )
	{
		*out_instance = ( k * order_seed ) % PLEAT_TEST_INSTANCES;
		return w->instances[*out_instance];
	}
	*out_instance = k == PLEAT_TEST_INSTANCES ? 5 : ( k == PLEAT_TEST_INSTANCES + 1 ? 70 : UINT32_MAX );
	return *out_instance == UINT32_MAX ? w->stale : w->instances[*out_instance];
}

static void plExpectSameInstance( plInstance a, plInstance b, const plTestAsset* model )
{
	const float *pa, *pb, *na, *nb;
	assert_int_equal( plInstance_GetPositions( a, &pa, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetPositions( b, &pb, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetNormals( a, &na, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetNormals( b, &nb, NULL ), PLEAT_RESULT_OK );
	assert_memory_equal( pa, pb, model->N * 3 * sizeof( float ) );
	assert_memory_equal( na, nb, model->N * 3 * sizeof( float ) );
	float la[64], lb[64], wa[64], wb[64], ma[64 * 12], mb[64 * 12];
	assert_int_equal( plInstance_GetLatent( a, la, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetLatent( b, lb, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( la, lb, model->L * sizeof( float ) );
	assert_int_equal( plInstance_GetBlendWeights( a, wa, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetBlendWeights( b, wb, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( wa, wb, model->D * sizeof( float ) );
	assert_int_equal( plInstance_GetSkinMatrices( a, ma, model->J ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetSkinMatrices( b, mb, model->J ), PLEAT_RESULT_OK );
	assert_memory_equal( ma, mb, model->J * 12 * sizeof( float ) );
}

// scratch_taken: every block of the batch context's scratch is marked in use (as if other threads were stepping their
// own batches), so the batched normals fall back to each instance's own.
static void plRunCrowdWith( int force_scalar, uint32_t workers, int precision, int scratch_taken )
{
	plTestAsset* models[3] = { plMakeModel( 0, precision ), plMakeModel( 1, precision ), plMakeModel( 2, precision ) };
	plTestWorld batch, single;
	plWorld_Init( &batch, models, force_scalar, workers );
	plWorld_Init( &single, models, force_scalar, workers );
	plContextData* batch_ctx = plGetContext( batch.context );
	for ( uint32_t i = 0; scratch_taken && i < batch_ctx->batch_scratch_slots; ++i )
	{
		atomic_store( &batch_ctx->batch_scratch_busy[i], 1 );
	}

	static float quats[PLEAT_TEST_LIST][64 * 4];
	static float out_batch[PLEAT_TEST_LIST][PLEAT_TEST_MAX_N * PLEAT_TEST_STRIDE_FLOATS * 2];
	static float out_single[PLEAT_TEST_LIST][PLEAT_TEST_MAX_N * PLEAT_TEST_STRIDE_FLOATS * 2];
	plInstance list_batch[PLEAT_TEST_LIST], list_single[PLEAT_TEST_LIST];
	plFrameInput inputs[PLEAT_TEST_LIST];
	plStepOutput outputs_batch[PLEAT_TEST_LIST], outputs_single[PLEAT_TEST_LIST];
	plResult results[PLEAT_TEST_LIST];
	uint32_t which_instance[PLEAT_TEST_LIST];
	for ( uint32_t k = 0; k < PLEAT_TEST_LIST; ++k )
	{
		list_batch[k] = plListEntry( &batch, k, &which_instance[k] );
		list_single[k] = plListEntry( &single, k, &which_instance[k] );
		memset( &outputs_batch[k], 0, sizeof( plStepOutput ) );
		if ( k % 2 == 0 )
		{
			// Interleaved positions and normals (32-byte stride), as a vertex buffer.
			outputs_batch[k].positions = out_batch[k];
			outputs_batch[k].normals = out_batch[k] + 3;
			outputs_batch[k].position_stride_bytes = PLEAT_TEST_STRIDE_FLOATS * 4;
			outputs_batch[k].normal_stride_bytes = PLEAT_TEST_STRIDE_FLOATS * 4;
			outputs_batch[k].vertex_capacity = PLEAT_TEST_MAX_N;
		}
		else if ( k % 3 == 0 )
		{
			outputs_batch[k].positions = out_batch[k]; // packed, positions only
			outputs_batch[k].vertex_capacity = PLEAT_TEST_MAX_N;
		}
		outputs_single[k] = outputs_batch[k];
		if ( outputs_single[k].positions != NULL )
		{
			outputs_single[k].positions = out_single[k];
		}
		if ( outputs_single[k].normals != NULL )
		{
			outputs_single[k].normals = out_single[k] + 3;
		}
	}
	memset( out_batch, 0, sizeof( out_batch ) );
	memset( out_single, 0, sizeof( out_single ) );

	uint32_t resets = 0, rejected = 0, clamped = 0;
	for ( uint32_t frame = 0; frame < PLEAT_TEST_FRAMES; ++frame )
	{
		for ( uint32_t k = 0; k < PLEAT_TEST_LIST; ++k )
		{
			uint32_t i = which_instance[k] == UINT32_MAX ? 0 : which_instance[k];
			uint32_t joints = i < PLEAT_TEST_A ? models[0]->J : ( i < PLEAT_TEST_A + PLEAT_TEST_B ? models[1]->J
																								 : models[2]->J );
			inputs[k] = plTestMotion( frame + i, joints, quats[k] );
			inputs[k].dt_s = ( i % 4 == 0 ) ? 1.0f / 60.0f : 1.0f / 30.0f;
			if ( i % 11 == 3 && frame == 5 )
			{
				inputs[k].dt_s = 0.0f; // rejected (INVALID_DT): this instance must not change on this frame
			}
			if ( i % 13 == 7 && frame == 3 )
			{
				inputs[k].dt_s = 0.9f; // above the asset's dt range: CLAMPED
			}
		}
		plResult r = plStepInstances( batch.context, list_batch, inputs, outputs_batch, results, PLEAT_TEST_LIST );
		plResult first_error = PLEAT_RESULT_OK, first_note = PLEAT_RESULT_OK;
		for ( uint32_t k = 0; k < PLEAT_TEST_LIST; ++k )
		{
			plResult expected = plInstance_Step( list_single[k], &inputs[k], &outputs_single[k] );
			assert_int_equal( results[k], expected );
			first_error = first_error == PLEAT_RESULT_OK && expected < 0 ? expected : first_error;
			first_note = first_note == PLEAT_RESULT_OK && expected > 0 ? expected : first_note;
			resets += expected == PLEAT_RESULT_NUMERIC_RESET;
			clamped += expected == PLEAT_RESULT_CLAMPED;
			rejected += expected == PLEAT_RESULT_INVALID_DT;
		}
		assert_int_equal( r, first_error != PLEAT_RESULT_OK ? first_error : first_note );
		for ( uint32_t i = 0; i < PLEAT_TEST_INSTANCES; ++i )
		{
			const plTestAsset* model = i < PLEAT_TEST_A ? models[0] : ( i < PLEAT_TEST_A + PLEAT_TEST_B ? models[1]
																									 : models[2] );
			plExpectSameInstance( batch.instances[i], single.instances[i], model );
		}
		assert_memory_equal( out_batch, out_single, sizeof( out_batch ) );
	}
	// The crowd really went through the paths it is meant to cover.
	assert_true( resets > 0 );
	assert_true( rejected > 0 );
	assert_true( clamped > 0 );

	plWorld_Free( &batch );
	plWorld_Free( &single );
	for ( int k = 0; k < 3; ++k )
	{
		plTestAsset_Destroy( models[k] );
	}
}

static void plRunCrowd( int force_scalar, uint32_t workers, int precision )
{
	plRunCrowdWith( force_scalar, workers, precision, 0 );
}

static void test_crowd_equals_one_by_one_scalar( void** state )
{
	(void)state;
	plRunCrowd( 1, 1, 0 );
	plRunCrowd( 1, 3, 1 );
	plRunCrowd( 1, 1, 2 );
}

static void test_crowd_equals_one_by_one_simd( void** state )
{
	(void)state;
	plRunCrowd( 0, 1, 0 );
	plRunCrowd( 0, 1, 1 );
	plRunCrowd( 0, 3, 0 );
	plRunCrowd( 0, 3, 1 );
	plRunCrowd( 0, 3, 2 );
}

// The AVX2 batched kernels where the CPU would take the AVX-512 ones (the same crowd: the AVX2 set is what an AVX2-only
// machine runs), and the fallback of the batched normals when no scratch block is free.
static void test_crowd_equals_one_by_one_avx2_batch_and_no_scratch( void** state )
{
	(void)state;
	plKernels k;
	if ( plChooseKernels( &k, PLEAT_KERNEL_SET_AVX2 ) != PLEAT_KERNEL_SET_AVX2 )
	{
		skip();
	}
	s_plTestMaxIsa = PLEAT_KERNEL_SET_AVX2;
	plRunCrowd( 0, 1, 0 );
	plRunCrowd( 0, 3, 1 );
	plRunCrowd( 0, 1, 2 );
	s_plTestMaxIsa = PLEAT_KERNEL_SET_AVX512;
	plRunCrowdWith( 0, 1, 0, 1 );
	plRunCrowdWith( 0, 3, 1, 1 );
}

// The scene's LBS-only level steps its characters in lane groups through the batched geometry kernels (scene.c,
// plStepLbsLevel). Each must get the bits of a lone instance of a zero network — its blend weights are exactly 0, so
// its T_def is the shaped template and its step is LBS with the fast body contact (PLEAT_BODY_CONTACT_FAST, which the
// LBS-only level runs, in lanes): positions and normals of 11 characters (a lane group and part of another) with
// different β and motion, over three frames.
static void plRunLbsLevel( int force_scalar )
{
	enum
	{
		CHARACTERS = 11,
		N = 300
	};
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 20;
	p.grid_y = 15;
	p.weight_scale = 0.0f; // every network weight and bias 0: w = 0
	p.seed = 21;
	plTestAsset* model = plTestAsset_Create( &p );
	// the stand-in body 0.5 mm behind the sheet, inside the default 1 mm clearance: body contact moves every anchored
	// vertex (four in five) on every step
	assert_true( plTestAsset_AddBodyAnchors( model, 0.0005f ) );
	plContextDef def = plDefaultContextDef();
	def.force_scalar = force_scalar;
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, &def ), PLEAT_RESULT_OK );
	rig.model = model; // plTestRig_Free destroys it
	plContext context = rig.context;
	plAsset asset = rig.asset;
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = &asset;
	sdef.tier_count = 1;
	sdef.character_capacity = CHARACTERS;
	plScene scene;
	assert_int_equal( plCreateScene( context, &sdef, &scene ), PLEAT_RESULT_OK );
	plInstance lone[CHARACTERS];
	const plDetail lbs = { -1, 0.0f, 0 };
	for ( uint32_t i = 0; i < CHARACTERS; ++i )
	{
		float beta[2] = { 0.3f * (float)( i % 5 ) - 0.6f, 0.1f * (float)( i % 3 ) };
		plCharacterDef cdef = plDefaultCharacterDef();
		cdef.beta = beta;
		cdef.beta_count = 2;
		uint32_t id;
		assert_int_equal( plScene_AddCharacter( scene, &cdef, &id ), PLEAT_RESULT_OK );
		assert_int_equal( id, i );
		assert_int_equal( plScene_SetOverride( scene, id, &lbs ), PLEAT_RESULT_OK );
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = asset;
		idef.beta = beta;
		idef.beta_count = 2;
		idef.body_contact = PLEAT_BODY_CONTACT_FAST; // what the scene's LBS-only characters get (pleat.h BODY CONTACT)
		assert_int_equal( plCreateInstance( context, &idef, &lone[i] ), PLEAT_RESULT_OK );
	}
	static float quats[CHARACTERS][64 * 4];
	static float scene_out[CHARACTERS][2][N * 3], lone_out[2][N * 3];
	plFrameInput inputs[CHARACTERS];
	plStepOutput outputs[CHARACTERS];
	plResult results[CHARACTERS];
	for ( uint32_t frame = 0; frame < 3; ++frame )
	{
		for ( uint32_t i = 0; i < CHARACTERS; ++i )
		{
			inputs[i] = plTestMotion( 2 * frame + 5 * i, model->J, quats[i] );
			outputs[i] = ( plStepOutput ){ scene_out[i][0], 12, scene_out[i][1], 12, N };
		}
		assert_true( plScene_Step( scene, inputs, outputs, results, CHARACTERS ) >= 0 );
		for ( uint32_t i = 0; i < CHARACTERS; ++i )
		{
			plStepOutput out = { lone_out[0], 12, lone_out[1], 12, N };
			assert_int_equal( results[i], plInstance_Step( lone[i], &inputs[i], &out ) );
			assert_memory_equal( scene_out[i][0], lone_out[0], sizeof( lone_out[0] ) );
			assert_memory_equal( scene_out[i][1], lone_out[1], sizeof( lone_out[1] ) );
		}
	}
	plTestRig_Free( &rig );
}

static void test_scene_lbs_level_equals_lone_instances( void** state )
{
	(void)state;
	plRunLbsLevel( 0 );
	plRunLbsLevel( 1 );
}

static void test_batch_arguments( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	plTestRig rig, other;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Init( &other, model, NULL ), PLEAT_RESULT_OK );
	plInstance inst[2];
	assert_int_equal( plTestRig_Instance( &rig, &inst[0] ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &other, &inst[1] ), PLEAT_RESULT_OK ); // another context's instance
	float q[2][64 * 4];
	plFrameInput in[2] = { plTestMotion( 0, model->J, q[0] ), plTestMotion( 0, model->J, q[1] ) };
	plResult results[2] = { PLEAT_RESULT_OK, PLEAT_RESULT_OK };
	plContext null_context = { 0, 0 };
	assert_int_equal( plStepInstances( null_context, inst, in, NULL, results, 1 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plStepInstances( rig.context, NULL, in, NULL, results, 1 ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plStepInstances( rig.context, inst, NULL, NULL, results, 1 ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plStepInstances( rig.context, NULL, NULL, NULL, NULL, 0 ), PLEAT_RESULT_OK );
	// Nothing stepped so far: the positions are still the rest template.
	const float* positions;
	assert_int_equal( plInstance_GetPositions( inst[0], &positions, NULL ), PLEAT_RESULT_OK );
	assert_memory_equal( positions, model->template_positions, model->N * 3 * sizeof( float ) );
	// The other context's instance is refused by name; the own one still steps.
	assert_int_equal( plStepInstances( rig.context, inst, in, NULL, results, 2 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( results[0], PLEAT_RESULT_OK );
	assert_int_equal( results[1], PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plStepInstances( rig.context, inst, in, NULL, NULL, 1 ), PLEAT_RESULT_OK );
	plTestRig_Free( &rig );
	plTestRig_Free( &other );
	plTestAsset_Destroy( model );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_crowd_equals_one_by_one_scalar ),
		cmocka_unit_test( test_crowd_equals_one_by_one_simd ),
		cmocka_unit_test( test_crowd_equals_one_by_one_avx2_batch_and_no_scratch ),
		cmocka_unit_test( test_batch_arguments ),
		cmocka_unit_test( test_scene_lbs_level_equals_lone_instances ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
