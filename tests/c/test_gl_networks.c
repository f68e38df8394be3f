// The networks on the GPU (PLEAT_MLP_BACKEND_GPU, docs/gpu.md "Networks on the GPU"): f_LP, the latent guard and
// f_dec as GLSL compute (mlp_layer.comp, latent_guard.comp) beside the deformation. Against the CPU backend on the same
// asset and motion, on Mesa llvmpipe:
// - one instance, stepped alone, headless and in the engine's context (whose GL state comes back as it was, the
//   networks' bindings 20..27 included): positions, normals and the latent within the tolerances below over 40 frames;
//   fp32 ReLU networks with a block-diagonal hidden layer (the windows layer_blocks.c finds) and fp16 SiLU networks;
// - a crowd through plStepInstances (different β, a network rate that holds the weights between updates): each within
//   the same tolerances of its CPU twin, and one dispatch per layer, one for the guard and one per deformation pass for
//   the whole crowd;
// - an f_LP that overflows whenever the root moves along x: the GPU instance takes the numeric reset on exactly the
//   frames the CPU instance does, and its outputs stay finite;
// - a crowd larger than the CPU's groups (150 instances, gpu_share): one set of dispatches for all of them, each within
//   the tolerances of its CPU twin; with the context's scratch blocks taken, groups of 64 (three sets) and the same
//   results;
// - instances that share one copy of the asset's GPU data (plInstanceDef.gpu_share; headless: one context): a sharer
//   compiles no program, steps like its CPU twin, and keeps working after the instance it shared with is gone;
// - the defs: the GPU backend without a GPU mode, and a gpu_share of another asset, mode or a stale handle, are
//   INVALID_DEF.
// The sums run in another order than the CPU kernels' (column by column) and the latent feeds the next frame's input,
// yet the deformation's tolerances hold (test_gl_instance: 2e-5 m, 1e-3 per normal component), with 1e-5 in latent
// units (llvmpipe measures about 2e-6 m and 3e-8). Skips (exit 77) without a GL 4.3 context.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "asset/asset.h"
#include "backends/gl_deformer.h"
#include "core/core.h"
#include "pleat/pleat.h"
#include "test_asset_builder.h"
#include "test_common.h"
#include "test_gl_support.h"
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLEAT_TEST_FRAMES 40
#define PLEAT_TEST_CROWD 6
#define PLEAT_TEST_POSITION_TOLERANCE_M 2e-5
#define PLEAT_TEST_NORMAL_TOLERANCE 1e-3
#define PLEAT_TEST_LATENT_TOLERANCE 1e-5

enum
{
	PLEAT_TEST_FP32_BLOCKS, // fp32, ReLU, a block-diagonal hidden layer in f_LP, body contact
	PLEAT_TEST_FP16_SILU,   // fp16 weights and blend shapes, SiLU
	PLEAT_TEST_OVERFLOW,    // f_LP overflows whenever the root moves along x
	PLEAT_TEST_ASSETS
};

typedef struct plNetworksFixture
{
	plTestRig rigs[PLEAT_TEST_ASSETS];
	plTestEglContext engine;
} plNetworksFixture;

static plTestAsset* plMakeModel( int which )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 21;
	p.grid_y = 17;
	p.joint_count = 12;
	p.input_joint_count = 9;
	p.beta_count = 4;
	p.latent_count = 24;
	p.blend_count = 20;
	p.lp_hidden[0] = 64;
	p.lp_hidden[1] = 64;
	p.lp_hidden[2] = 0;
	p.dec_hidden[0] = 48;
	p.dec_hidden[1] = 0;
	p.weight_scale = 0.8f;
	p.blend_scale = 0.03f;
	p.seed = 31u + (uint32_t)which;
	p.activation = which == PLEAT_TEST_FP32_BLOCKS ? 1u : 2u;
	p.fp16 = which == PLEAT_TEST_FP16_SILU;
	plTestAsset* model = plTestAsset_Create( &p );
	assert_non_null( model );
	if ( which == PLEAT_TEST_FP32_BLOCKS )
	{
		// f_LP's second layer block-diagonal (two 32 × 32 blocks): the loader finds the windows, the GPU skips the rest.
		plTestLayer* l = &model->lp[1];
		for ( uint32_t r = 0; r < l->out_count; ++r )
		{
			for ( uint32_t c = 0; c < l->in_count; ++c )
			{
				if ( ( r < 32 ) != ( c < 32 ) )
					l->weight[(size_t)r * l->in_count + c] = 0.0f;
			}
		}
		assert_true( plTestAsset_AddBodyAnchors( model, 0.002f ) );
	}
	if ( which == PLEAT_TEST_OVERFLOW )
	{
		plTestAsset_OverflowOnRootMotion( model ); // any root motion along x: a numeric reset
	}
	return model;
}

static int plSetup( void** state )
{
	plNetworksFixture* fixture = calloc( 1, sizeof( *fixture ) );
	for ( int k = 0; k < PLEAT_TEST_ASSETS; ++k )
	{
		plTestAsset* model = plMakeModel( k );
		assert_int_equal( plTestRig_Init( &fixture->rigs[k], model, NULL ), PLEAT_RESULT_OK );
		plTestAsset_Destroy( model );
	}
	plTestEgl_Create( &fixture->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = fixture;
	return 0;
}

static int plTeardown( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Destroy( &fixture->engine );
	for ( int k = 0; k < PLEAT_TEST_ASSETS; ++k )
	{
		plDestroyAsset( fixture->rigs[k].asset );
		plTestRig_Free( &fixture->rigs[k] );
	}
	free( fixture );
	return 0;
}

static plInstance plMake( const plTestRig* rig, plGpuMode mode, plMlpBackend backend, uint32_t k )
{
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = rig->asset;
	def.gpu_mode = mode;
	def.mlp_backend = backend;
	def.network_rate_hz = k == 3 ? 12.0f : 0.0f; // one holds its weights between network updates
	float beta[2] = { -1.0f + 0.4f * (float)k, 0.3f * (float)( k % 3 ) };
	def.beta = beta;
	def.beta_count = 2;
	plInstance instance;
	assert_int_equal( plCreateInstance( rig->context, &def, &instance ), PLEAT_RESULT_OK );
	return instance;
}

typedef struct plWorst
{
	double position, normal, latent;
} plWorst;

// positions and normals [N][3] each of the CPU twin (a) and the GPU one (b), and their latents.
static void plCompare( const plTestRig* rig, const float* a, const float* b, plInstance cpu, plInstance gpu,
					   plWorst* worst )
{
	uint32_t n = rig->info.vertex_count;
	for ( size_t e = 0; e < 3u * n; ++e )
	{
		assert_true( isfinite( b[e] ) && isfinite( b[3u * n + e] ) );
		worst->position = fmax( worst->position, fabs( (double)a[e] - b[e] ) );
		worst->normal = fmax( worst->normal, fabs( (double)a[3u * n + e] - b[3u * n + e] ) );
	}
	float za[64], zb[64];
	uint32_t L = rig->info.latent_count;
	assert_int_equal( plInstance_GetLatent( cpu, za, L ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetLatent( gpu, zb, L ), PLEAT_RESULT_OK );
	for ( uint32_t i = 0; i < L; ++i )
		worst->latent = fmax( worst->latent, fabs( (double)za[i] - zb[i] ) );
}

static void plAssertWithin( const char* what, const plWorst* worst )
{
	print_message( "%s: max |cpu - gpu| position %.3g m, normal %.3g, latent %.3g\n", what, worst->position,
				   worst->normal, worst->latent );
	assert_true( worst->position <= PLEAT_TEST_POSITION_TOLERANCE_M );
	assert_true( worst->normal <= PLEAT_TEST_NORMAL_TOLERANCE );
	assert_true( worst->latent <= PLEAT_TEST_LATENT_TOLERANCE );
}

// One CPU-backend and one GPU-backend instance stepped side by side; returns the resets the two took (equal).
static uint32_t plCompareSingle( const plTestRig* rig, plGpuMode mode, const char* what )
{
	uint32_t n = rig->info.vertex_count, j = rig->info.joint_count;
	plInstance cpu = plMake( rig, PLEAT_GPU_MODE_NONE, PLEAT_MLP_BACKEND_PLEAT, 0 );
	plInstance gpu = plMake( rig, mode, PLEAT_MLP_BACKEND_GPU, 0 );
	float* rotations = malloc( sizeof( float ) * 4 * j );
	float* out = malloc( sizeof( float ) * 12 * n ); // [cpu, gpu][positions, normals][N][3]
	plWorst worst = { 0.0, 0.0, 0.0 };
	uint32_t resets = 0;
	for ( uint32_t frame = 0; frame < PLEAT_TEST_FRAMES; ++frame )
	{
		plFrameInput input;
		plTestMotion_WalkPose( frame, 0.0f, 0.6f, j, rotations, &input );
		plResult results[2];
		for ( int i = 0; i < 2; ++i )
		{
			float* o = out + 6 * (size_t)n * i;
			memset( o, 0xff, sizeof( float ) * 6 * n );
			plStepOutput output = { o, 0, o + 3 * (size_t)n, 0, n };
			results[i] = plInstance_Step( i == 0 ? cpu : gpu, &input, &output );
			assert_true( results[i] >= 0 );
		}
		assert_int_equal( results[0], results[1] );
		resets += results[0] == PLEAT_RESULT_NUMERIC_RESET;
		plCompare( rig, out, out + 6 * (size_t)n, cpu, gpu, &worst );
	}
	plAssertWithin( what, &worst );
	free( rotations );
	free( out );
	assert_int_equal( plDestroyInstance( cpu ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( gpu ), PLEAT_RESULT_OK );
	return resets;
}

static void test_headless_networks_match_cpu( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	// The block layer is there for the GPU to skip: the loader found its two windows.
	assert_int_equal( plGetAssetData( fixture->rigs[PLEAT_TEST_FP32_BLOCKS].asset )->lp[1].block_count, 2 );
	plCompareSingle( &fixture->rigs[PLEAT_TEST_FP32_BLOCKS], PLEAT_GPU_MODE_HEADLESS, "fp32 ReLU, blocks" );
	plCompareSingle( &fixture->rigs[PLEAT_TEST_FP16_SILU], PLEAT_GPU_MODE_HEADLESS, "fp16 SiLU" );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
}

static void test_host_context_networks_match_cpu_and_restore_state( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	// The engine's own buffer at a binding the networks use, and a program of its own: both must come back.
	GLuint engine_buffer = 0;
	glGenBuffers( 1, &engine_buffer );
	glBindBuffer( GL_SHADER_STORAGE_BUFFER, engine_buffer );
	glBufferData( GL_SHADER_STORAGE_BUFFER, 64, NULL, GL_STATIC_DRAW );
	glBindBufferBase( GL_SHADER_STORAGE_BUFFER, 25, engine_buffer );
	glBindBufferRange( GL_SHADER_STORAGE_BUFFER, 20, engine_buffer, 0, 32 );
	plCompareSingle( &fixture->rigs[PLEAT_TEST_FP32_BLOCKS], PLEAT_GPU_MODE_HOST_CONTEXT, "host context" );
	GLint bound = 0;
	GLint64 size = 0;
	glGetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, 25, &bound );
	assert_int_equal( bound, (GLint)engine_buffer );
	glGetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, 20, &bound );
	glGetInteger64i_v( GL_SHADER_STORAGE_BUFFER_SIZE, 20, &size );
	assert_int_equal( bound, (GLint)engine_buffer );
	assert_int_equal( size, 32 );
	for ( GLuint b = 21; b < 28; ++b )
	{
		if ( b == 25 )
			continue;
		glGetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, b, &bound );
		assert_int_equal( bound, 0 );
	}
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	assert_int_equal( glGetError(), GL_NO_ERROR );
	glDeleteBuffers( 1, &engine_buffer );
	plTestEgl_Release( &fixture->engine );
}

static void test_crowd_networks_run_in_one_set_of_dispatches( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	const plTestRig* rig = &fixture->rigs[PLEAT_TEST_FP32_BLOCKS];
	uint32_t n = rig->info.vertex_count, j = rig->info.joint_count;
	plInstance cpu[PLEAT_TEST_CROWD], gpu[PLEAT_TEST_CROWD];
	for ( uint32_t k = 0; k < PLEAT_TEST_CROWD; ++k )
	{
		cpu[k] = plMake( rig, PLEAT_GPU_MODE_NONE, PLEAT_MLP_BACKEND_PLEAT, k );
		gpu[k] = plMake( rig, PLEAT_GPU_MODE_HEADLESS, PLEAT_MLP_BACKEND_GPU, k );
	}
	float* rotations = malloc( sizeof( float ) * 4 * j * PLEAT_TEST_CROWD );
	float* out = malloc( sizeof( float ) * 12 * n * PLEAT_TEST_CROWD ); // [k][cpu, gpu][positions, normals][N][3]
	const plAssetData* a = plGetAssetData( rig->asset );
	// f_LP's and f_dec's layers, the guard, then blend, skinning, the three contact passes and the two normals passes.
	uint64_t expected = a->lp_layer_count + a->dec_layer_count + 1u + 7u;
	plWorst worst = { 0.0, 0.0, 0.0 };
	uint32_t held = 0, L = rig->info.latent_count;
	float latent_before[64], latent_after[64];
	for ( uint32_t frame = 0; frame < 20; ++frame )
	{
		plFrameInput inputs[PLEAT_TEST_CROWD];
		plStepOutput outputs[PLEAT_TEST_CROWD];
		plResult results[PLEAT_TEST_CROWD];
		for ( uint32_t k = 0; k < PLEAT_TEST_CROWD; ++k )
		{
			plTestMotion_WalkPose( frame, 3.0f * (float)k, 0.6f, j, rotations + 4 * (size_t)j * k, &inputs[k] );
			float* o = out + 12 * (size_t)n * k;
			memset( o, 0xff, sizeof( float ) * 12 * n );
			plStepOutput single = { o, 0, o + 3 * (size_t)n, 0, n };
			assert_true( plInstance_Step( cpu[k], &inputs[k], &single ) >= 0 );
			outputs[k] = ( plStepOutput ){ o + 6 * (size_t)n, 0, o + 9 * (size_t)n, 0, n };
		}
		assert_int_equal( plInstance_GetLatent( gpu[3], latent_before, L ), PLEAT_RESULT_OK );
		uint64_t before = atomic_load( &g_plGlDispatches );
		assert_true( plStepInstances( rig->context, gpu, inputs, outputs, results, PLEAT_TEST_CROWD ) >= 0 );
		uint64_t dispatches = atomic_load( &g_plGlDispatches ) - before;
		// Frames where the held instance skips its update still run the others' networks: the same count.
		assert_int_equal( dispatches, expected );
		for ( uint32_t k = 0; k < PLEAT_TEST_CROWD; ++k )
		{
			assert_true( results[k] >= 0 );
			const float* o = out + 12 * (size_t)n * k;
			plCompare( rig, o, o + 6 * (size_t)n, cpu[k], gpu[k], &worst );
		}
		// The rate instance between its network updates: its latent stays, its held weights are blended.
		assert_int_equal( plInstance_GetLatent( gpu[3], latent_after, L ), PLEAT_RESULT_OK );
		held += frame > 0 && memcmp( latent_before, latent_after, sizeof( float ) * L ) == 0;
	}
	assert_true( held > 0 );
	plAssertWithin( "crowd", &worst );
	for ( uint32_t k = 0; k < PLEAT_TEST_CROWD; ++k )
	{
		assert_int_equal( plDestroyInstance( cpu[k] ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( gpu[k] ), PLEAT_RESULT_OK );
	}
	free( rotations );
	free( out );
}

static void test_overflow_takes_the_numeric_reset_on_the_same_frames( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	uint32_t resets = plCompareSingle( &fixture->rigs[PLEAT_TEST_OVERFLOW], PLEAT_GPU_MODE_HEADLESS, "overflow" );
	assert_true( resets > 0 );
}

static void test_shared_instances_match_and_outlive_each_other( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	const plTestRig* rig = &fixture->rigs[PLEAT_TEST_FP32_BLOCKS];
	uint32_t n = rig->info.vertex_count, j = rig->info.joint_count;
	enum { SHARERS = 3 };
	plInstance cpu[SHARERS], gpu[SHARERS];
	for ( uint32_t k = 0; k < SHARERS; ++k )
	{
		cpu[k] = plMake( rig, PLEAT_GPU_MODE_NONE, PLEAT_MLP_BACKEND_PLEAT, k );
		uint64_t compiled = atomic_load( &g_plGlProgramsCompiled );
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = rig->asset;
		def.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
		def.mlp_backend = PLEAT_MLP_BACKEND_GPU;
		float beta[2] = { -1.0f + 0.4f * (float)k, 0.3f * (float)( k % 3 ) };
		def.beta = beta;
		def.beta_count = 2;
		if ( k > 0 )
			def.gpu_share = gpu[k - 1]; // a chain: each shares with the one before
		assert_int_equal( plCreateInstance( rig->context, &def, &gpu[k] ), PLEAT_RESULT_OK );
		uint64_t programs = atomic_load( &g_plGlProgramsCompiled ) - compiled;
		if ( k == 0 )
			assert_true( programs >= 6 ); // the deformation's and the networks' programs
		else
			assert_int_equal( programs, 0 );
	}
	float* rotations = malloc( sizeof( float ) * 4 * j * SHARERS );
	float* out = malloc( sizeof( float ) * 12 * n * SHARERS );
	plWorst worst = { 0.0, 0.0, 0.0 };
	for ( uint32_t frame = 0; frame < 16; ++frame )
	{
		if ( frame == 8 )
		{
			// The first instance goes: the others keep the shared data (and the context) alive.
			assert_int_equal( plDestroyInstance( gpu[0] ), PLEAT_RESULT_OK );
			assert_int_equal( plDestroyInstance( cpu[0] ), PLEAT_RESULT_OK );
		}
		uint32_t first = frame >= 8 ? 1u : 0u;
		plFrameInput inputs[SHARERS];
		plStepOutput outputs[SHARERS];
		plResult results[SHARERS];
		for ( uint32_t k = first; k < SHARERS; ++k )
		{
			plTestMotion_WalkPose( frame, 3.0f * (float)k, 0.6f, j, rotations + 4 * (size_t)j * k, &inputs[k] );
			float* o = out + 12 * (size_t)n * k;
			plStepOutput single = { o, 0, o + 3 * (size_t)n, 0, n };
			assert_true( plInstance_Step( cpu[k], &inputs[k], &single ) >= 0 );
			outputs[k] = ( plStepOutput ){ o + 6 * (size_t)n, 0, o + 9 * (size_t)n, 0, n };
		}
		// In a crowd on even frames, one by one on odd ones.
		if ( frame % 2 == 0 )
			assert_true( plStepInstances( rig->context, gpu + first, inputs + first, outputs + first, results + first,
										  SHARERS - first ) >= 0 );
		else
		{
			for ( uint32_t k = first; k < SHARERS; ++k )
				assert_true( plInstance_Step( gpu[k], &inputs[k], &outputs[k] ) >= 0 );
		}
		for ( uint32_t k = first; k < SHARERS; ++k )
		{
			const float* o = out + 12 * (size_t)n * k;
			plCompare( rig, o, o + 6 * (size_t)n, cpu[k], gpu[k], &worst );
		}
	}
	plAssertWithin( "shared", &worst );
	for ( uint32_t k = 1; k < SHARERS; ++k )
	{
		assert_int_equal( plDestroyInstance( cpu[k] ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( gpu[k] ), PLEAT_RESULT_OK );
	}
	free( rotations );
	free( out );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
}

static void test_large_crowd_is_one_set_of_dispatches( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	const plTestRig* rig = &fixture->rigs[PLEAT_TEST_FP16_SILU]; // no body contact: 7 - 3 deformation passes
	enum { CROWD = 150 };
	uint32_t n = rig->info.vertex_count, j = rig->info.joint_count;
	plInstance* cpu = calloc( CROWD, sizeof( plInstance ) );
	plInstance* gpu = calloc( CROWD, sizeof( plInstance ) );
	for ( uint32_t k = 0; k < CROWD; ++k )
	{
		cpu[k] = plMake( rig, PLEAT_GPU_MODE_NONE, PLEAT_MLP_BACKEND_PLEAT, k % 3 );
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = rig->asset;
		def.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
		def.mlp_backend = PLEAT_MLP_BACKEND_GPU;
		float beta[2] = { -1.0f + 0.4f * (float)( k % 3 ), 0.3f * (float)( k % 3 ) }; // plMake( ..., k % 3 )'s
		def.beta = beta;
		def.beta_count = 2;
		if ( k > 0 )
			def.gpu_share = gpu[0]; // one context for the crowd: a batch spans one context
		assert_int_equal( plCreateInstance( rig->context, &def, &gpu[k] ), PLEAT_RESULT_OK );
	}
	float* rotations = malloc( sizeof( float ) * 4 * j * CROWD );
	float* out = malloc( sizeof( float ) * 12 * n * CROWD );
	plFrameInput* inputs = calloc( CROWD, sizeof( plFrameInput ) );
	plStepOutput* outputs = calloc( CROWD, sizeof( plStepOutput ) );
	plResult* results = calloc( CROWD, sizeof( plResult ) );
	const plAssetData* a = plGetAssetData( rig->asset );
	uint64_t one_set = a->lp_layer_count + a->dec_layer_count + 1u + 4u; // networks, guard, blend, skin, 2 normals
	plContextData* ctx = plGetContext( rig->context );
	plWorst worst = { 0.0, 0.0, 0.0 };
	for ( uint32_t frame = 0; frame < 4; ++frame )
	{
		for ( uint32_t k = 0; k < CROWD; ++k )
		{
			plTestMotion_WalkPose( frame, 3.0f * (float)k, 0.6f, j, rotations + 4 * (size_t)j * k, &inputs[k] );
			float* o = out + 12 * (size_t)n * k;
			plStepOutput single = { o, 0, o + 3 * (size_t)n, 0, n };
			assert_true( plInstance_Step( cpu[k], &inputs[k], &single ) >= 0 );
			outputs[k] = ( plStepOutput ){ o + 6 * (size_t)n, 0, o + 9 * (size_t)n, 0, n };
		}
		// Odd frames: every scratch block taken (as by other threads' calls), so the crowd steps in groups of 64.
		int taken[PLEAT_BATCH_SCRATCH_SLOTS];
		uint32_t taken_count = 0;
		while ( ( frame & 1u ) && taken_count < PLEAT_BATCH_SCRATCH_SLOTS &&
				( taken[taken_count] = plClaimBatchScratch( ctx, 1 ) ) >= 0 )
			taken_count++;
		uint64_t before = atomic_load( &g_plGlDispatches );
		assert_true( plStepInstances( rig->context, gpu, inputs, outputs, results, CROWD ) >= 0 );
		uint64_t dispatches = atomic_load( &g_plGlDispatches ) - before;
		for ( uint32_t t = 0; t < taken_count; ++t )
			plReleaseBatchScratch( ctx, taken[t] );
		assert_int_equal( dispatches, ( frame & 1u ) ? 3 * one_set : one_set ); // 64 + 64 + 22, or all 150
		for ( uint32_t k = 0; k < CROWD; ++k )
		{
			assert_true( results[k] >= 0 );
			const float* o = out + 12 * (size_t)n * k;
			plCompare( rig, o, o + 6 * (size_t)n, cpu[k], gpu[k], &worst );
		}
	}
	plAssertWithin( "150 in one set", &worst );
	for ( uint32_t k = 0; k < CROWD; ++k )
	{
		assert_int_equal( plDestroyInstance( cpu[k] ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( gpu[k] ), PLEAT_RESULT_OK );
	}
	free( cpu );
	free( gpu );
	free( rotations );
	free( out );
	free( inputs );
	free( outputs );
	free( results );
}

static void test_gpu_share_must_match( void** state )
{
	plNetworksFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	const plTestRig* rig = &fixture->rigs[PLEAT_TEST_FP32_BLOCKS];
	plInstance cpu = plMake( rig, PLEAT_GPU_MODE_NONE, PLEAT_MLP_BACKEND_PLEAT, 0 );
	plInstance gpu = plMake( rig, PLEAT_GPU_MODE_HEADLESS, PLEAT_MLP_BACKEND_GPU, 0 );
	plInstance deform_only = plMake( rig, PLEAT_GPU_MODE_HEADLESS, PLEAT_MLP_BACKEND_PLEAT, 0 );
	plInstance stale = plMake( rig, PLEAT_GPU_MODE_HEADLESS, PLEAT_MLP_BACKEND_GPU, 0 );
	assert_int_equal( plDestroyInstance( stale ), PLEAT_RESULT_OK );
	const plInstance shares[4] = { cpu, deform_only, stale, gpu };
	for ( int k = 0; k < 4; ++k )
	{
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = k == 3 ? fixture->rigs[PLEAT_TEST_FP16_SILU].asset : rig->asset; // another asset (and context)
		def.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
		def.mlp_backend = PLEAT_MLP_BACKEND_GPU;
		def.gpu_share = shares[k];
		plInstance instance;
		memset( &instance, 0, sizeof( instance ) );
		plContext context = k == 3 ? fixture->rigs[PLEAT_TEST_FP16_SILU].context : rig->context;
		assert_int_equal( plCreateInstance( context, &def, &instance ), PLEAT_RESULT_INVALID_DEF );
		assert_false( plInstance_IsValid( instance ) );
	}
	assert_int_equal( plDestroyInstance( cpu ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( gpu ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( deform_only ), PLEAT_RESULT_OK );
}

static void test_gpu_backend_needs_a_gpu_mode( void** state )
{
	plNetworksFixture* fixture = *state;
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = fixture->rigs[0].asset;
	def.mlp_backend = PLEAT_MLP_BACKEND_GPU;
	plInstance instance;
	memset( &instance, 0, sizeof( instance ) );
	assert_int_equal( plCreateInstance( fixture->rigs[0].context, &def, &instance ), PLEAT_RESULT_INVALID_DEF );
	assert_false( plInstance_IsValid( instance ) );
	def.mlp_backend = (plMlpBackend)3;
	def.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
	assert_int_equal( plCreateInstance( fixture->rigs[0].context, &def, &instance ), PLEAT_RESULT_INVALID_DEF );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_gpu_backend_needs_a_gpu_mode ),
		cmocka_unit_test( test_headless_networks_match_cpu ),
		cmocka_unit_test( test_host_context_networks_match_cpu_and_restore_state ),
		cmocka_unit_test( test_crowd_networks_run_in_one_set_of_dispatches ),
		cmocka_unit_test( test_overflow_takes_the_numeric_reset_on_the_same_frames ),
		cmocka_unit_test( test_shared_instances_match_and_outlive_each_other ),
		cmocka_unit_test( test_large_crowd_is_one_set_of_dispatches ),
		cmocka_unit_test( test_gpu_share_must_match ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
