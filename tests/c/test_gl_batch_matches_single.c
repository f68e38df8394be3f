// GPU modes in a batch (docs/gpu.md, "Batches"): plStepInstances runs a group of GPU-mode instances of one asset with ONE dispatch
// per shader pass (blend shapes, skinning, posing the body points, their normals from the posed body rings, the
// body-contact push, face normals, normals gather: the instance in gl_WorkGroupID.y), and every instance ends where
// stepping it alone with plInstance_Step ends — the same results, the same positions and normals (read back, and in
// the engine's vertex buffers in host-context mode) within the GL-vs-CPU tolerance of test_gl_instance (2e-5 m, 1e-3
// per normal component; on llvmpipe the two are in fact equal), and the same as the CPU path within that tolerance.
// The crowd: different β, body contact on and off (the asset carries body points 2 mm behind the sheet, each interior
// one with the ring of grid points around it (asset 1.2, BARG: its normal comes from the posed ring), and candidate
// points beside it, plTestAsset_AddBodyAnchors, so contact moves vertices), a network rate (steps that re-blend the held
// weights), read-backs for some instances and none for others. Skips (exit 77 through cmocka's skip) without a GL 4.3
// context.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "gl_deformer.h"
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

#define PLEAT_TEST_FRAMES 12
#define PLEAT_TEST_CROWD 6
#define PLEAT_TEST_POSITION_TOLERANCE_M 2e-5
#define PLEAT_TEST_NORMAL_TOLERANCE 1e-3

typedef struct plBatchFixture
{
	plTestRig rig; // context, asset and its info
	plTestEglContext engine;
} plBatchFixture;

static int plSetup( void** state )
{
	plBatchFixture* fixture = calloc( 1, sizeof( *fixture ) );
	plTestAssetParams params = plTestAsset_DefaultParams();
	params.grid_x = 17;
	params.grid_y = 19; // N = 323: 6 workgroups per instance, the last one partial
	plTestAsset* model = plTestAsset_Create( &params );
	assert_non_null( model );
	assert_true( plTestAsset_AddBodyAnchors( model, 0.002f ) );
	assert_non_null( model->body_ring ); // the points' normals from the posed rings: the batch's second posing pass
	assert_int_equal( plTestRig_Init( &fixture->rig, model, NULL ), PLEAT_RESULT_OK );
	plTestAsset_Destroy( model );
	assert_true( fixture->rig.info.has_body_contact );
	plTestEgl_Create( &fixture->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = fixture;
	return 0;
}

static int plTeardown( void** state )
{
	plBatchFixture* fixture = *state;
	plTestEgl_Destroy( &fixture->engine );
	plDestroyAsset( fixture->rig.asset );
	plTestRig_Free( &fixture->rig );
	free( fixture );
	return 0;
}

// Three sets of the same crowd: stepped as a batch, stepped one by one (same GPU mode), and on the CPU.
typedef struct plCrowd
{
	plInstance batch[PLEAT_TEST_CROWD], single[PLEAT_TEST_CROWD], cpu[PLEAT_TEST_CROWD];
	uint32_t host_buffers[2][PLEAT_TEST_CROWD][2]; // [set batch/single][instance][positions, normals], 0 = none
} plCrowd;

static void plCreateCrowd( plBatchFixture* fixture, plGpuMode mode, plCrowd* crowd )
{
	memset( crowd->host_buffers, 0, sizeof( crowd->host_buffers ) );
	for ( int set = 0; set < 3; ++set )
	{
		for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
		{
			plInstanceDef def = plDefaultInstanceDef();
			def.asset = fixture->rig.asset;
			def.gpu_mode = set == 2 ? PLEAT_GPU_MODE_NONE : mode;
			def.body_contact = i != 2;              // one instance with contact off
			def.network_rate_hz = i == 3 ? 15.0f : 0.0f; // one re-blends the held weights between updates
			float beta[2] = { -1.0f + 0.4f * (float)i, 0.3f * (float)( i % 3 ) };
			def.beta = beta;
			def.beta_count = 2;
			if ( mode == PLEAT_GPU_MODE_HOST_CONTEXT && set < 2 && i != 1 )
			{
				// the engine's vertex buffers (instance 1 keeps the deformer's own)
				GLuint buffers[2];
				glGenBuffers( 2, buffers );
				for ( int b = 0; b < 2; ++b )
				{
					glBindBuffer( GL_ARRAY_BUFFER, buffers[b] );
					GLsizeiptr bytes = (GLsizeiptr)( 16 * fixture->rig.info.vertex_count );
					glBufferData( GL_ARRAY_BUFFER, bytes, NULL, GL_DYNAMIC_DRAW );
					crowd->host_buffers[set][i][b] = buffers[b];
				}
				glBindBuffer( GL_ARRAY_BUFFER, 0 );
				def.host_position_buffer = buffers[0];
				def.host_normal_buffer = buffers[1];
			}
			plInstance* out = set == 0 ? &crowd->batch[i] : set == 1 ? &crowd->single[i] : &crowd->cpu[i];
			assert_int_equal( plCreateInstance( fixture->rig.context, &def, out ), PLEAT_RESULT_OK );
		}
	}
}

static void plDestroyCrowd( plCrowd* crowd )
{
	for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
	{
		assert_int_equal( plDestroyInstance( crowd->batch[i] ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( crowd->single[i] ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( crowd->cpu[i] ), PLEAT_RESULT_OK );
		for ( int set = 0; set < 2; ++set )
		{
			for ( int b = 0; b < 2; ++b )
			{
				GLuint buffer = crowd->host_buffers[set][i][b];
				if ( buffer != 0 )
					glDeleteBuffers( 1, &buffer );
			}
		}
	}
}

// Largest |a - b| over the positions (which = 0) or normals (which = 1) of n vertices; normals only where b's normal
// is unit length (a zero-area neighbourhood has none), positions always.
static double plWorst( const float* a, const float* b, uint32_t n, int which )
{
	double worst = 0.0;
	for ( uint32_t v = 0; v < n; ++v )
	{
		double length = 0.0;
		for ( int c = 0; c < 3; ++c )
		{
			assert_true( isfinite( a[3 * v + c] ) );
			length += (double)b[3 * v + c] * b[3 * v + c];
		}
		if ( which == 0 || fabs( length - 1.0 ) < 1e-3 )
		{
			for ( int c = 0; c < 3; ++c )
				worst = fmax( worst, fabs( (double)a[3 * v + c] - b[3 * v + c] ) );
		}
	}
	return worst;
}

// Steps the crowd; reads back every instance on the last frame (and the even ones on every frame).
static void plRunCrowd( plBatchFixture* fixture, plGpuMode mode )
{
	uint32_t n = fixture->rig.info.vertex_count, J = fixture->rig.info.joint_count;
	plCrowd crowd;
	plCreateCrowd( fixture, mode, &crowd );
	float* buffers = malloc( sizeof( float ) * 6 * n * PLEAT_TEST_CROWD * 3 ); // [set][instance][positions, normals]
	float quats[64 * 4];
	double worst[2][2] = { { 0, 0 }, { 0, 0 } }; // [vs single, vs cpu][positions, normals]
	for ( uint32_t t = 0; t < PLEAT_TEST_FRAMES; ++t )
	{
		plFrameInput inputs[PLEAT_TEST_CROWD];
		plStepOutput outputs[3][PLEAT_TEST_CROWD];
		for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
		{
			inputs[i] = plTestMotion( t + 5 * i, J, quats ); // the same quaternions for all: the phase moves the root
			for ( int set = 0; set < 3; ++set )
			{
				float* p = buffers + ( (size_t)set * PLEAT_TEST_CROWD + i ) * 6 * n;
				memset( p, 0xff, sizeof( float ) * 6 * n );
				plStepOutput o = { p, 0, p + 3 * (size_t)n, 0, n };
				int read_back = set == 2 || i % 2 == 0 || t + 1 == PLEAT_TEST_FRAMES;
				memset( &outputs[set][i], 0, sizeof( plStepOutput ) );
				if ( read_back )
					outputs[set][i] = o;
			}
		}
		plResult batch_results[PLEAT_TEST_CROWD];
		uint64_t before = atomic_load( &g_plGlDispatches );
		assert_true( plStepInstances( fixture->rig.context, crowd.batch, inputs, outputs[0], batch_results,
									  PLEAT_TEST_CROWD ) >= 0 );
		uint64_t dispatches = atomic_load( &g_plGlDispatches ) - before;
		// one per pass for the whole crowd: blend, skinning, body points, their ring normals, body contact, face
		// normals, gather
		assert_int_equal( dispatches, 7 );
		for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
		{
			assert_int_equal( plInstance_Step( crowd.single[i], &inputs[i], &outputs[1][i] ), batch_results[i] );
			assert_int_equal( plInstance_Step( crowd.cpu[i], &inputs[i], &outputs[2][i] ), batch_results[i] );
		}
		for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
		{
			if ( outputs[0][i].positions == NULL )
				continue;
			const float* b = buffers + ( 0 * PLEAT_TEST_CROWD + (size_t)i ) * 6 * n;
			const float* s = buffers + ( 1 * PLEAT_TEST_CROWD + (size_t)i ) * 6 * n;
			const float* c = buffers + ( 2 * PLEAT_TEST_CROWD + (size_t)i ) * 6 * n;
			for ( int which = 0; which < 2; ++which )
			{
				size_t at = 3 * (size_t)n * (size_t)which;
				worst[0][which] = fmax( worst[0][which], plWorst( b + at, s + at, n, which ) );
				worst[1][which] = fmax( worst[1][which], plWorst( b + at, c + at, n, which ) );
			}
			// the instance's own buffers hold the read-back too, as after plInstance_Step
			const float *pb, *ps;
			assert_int_equal( plInstance_GetPositions( crowd.batch[i], &pb, NULL ), PLEAT_RESULT_OK );
			assert_int_equal( plInstance_GetPositions( crowd.single[i], &ps, NULL ), PLEAT_RESULT_OK );
			assert_true( plWorst( pb, ps, n, 0 ) <= PLEAT_TEST_POSITION_TOLERANCE_M );
		}
	}
	if ( mode == PLEAT_GPU_MODE_HOST_CONTEXT )
	{
		// The engine's vertex buffers of both sets hold the same vertices (vec4 rows).
		float* rows = malloc( sizeof( float ) * 8 * n );
		for ( uint32_t i = 0; i < PLEAT_TEST_CROWD; ++i )
		{
			for ( int b = 0; b < 2 && crowd.host_buffers[0][i][b] != 0; ++b )
			{
				for ( int set = 0; set < 2; ++set )
				{
					glBindBuffer( GL_COPY_READ_BUFFER, crowd.host_buffers[set][i][b] );
					glGetBufferSubData( GL_COPY_READ_BUFFER, 0, (GLsizeiptr)( 16 * n ), rows + 4 * (size_t)n * set );
				}
				double host_worst = 0.0;
				for ( size_t e = 0; e < 4 * (size_t)n; ++e )
					host_worst = fmax( host_worst, fabs( (double)rows[e] - rows[4 * (size_t)n + e] ) );
				assert_true( host_worst <= ( b == 0 ? PLEAT_TEST_POSITION_TOLERANCE_M : PLEAT_TEST_NORMAL_TOLERANCE ) );
				assert_true( rows[0] == rows[0] && rows[3] == ( b == 0 ? 1.0f : 0.0f ) ); // written: w = 1 / 0
			}
		}
		glBindBuffer( GL_COPY_READ_BUFFER, 0 );
		free( rows );
	}
	print_message( "%s, %d instances, %d frames: max |batch - one by one| position %.3g m, normal %.3g; max |batch - "
				   "cpu| position %.3g m, normal %.3g; 7 dispatches per batch\n",
				   mode == PLEAT_GPU_MODE_HEADLESS ? "headless" : "host context", PLEAT_TEST_CROWD, PLEAT_TEST_FRAMES,
				   worst[0][0], worst[0][1], worst[1][0], worst[1][1] );
	assert_true( worst[0][0] <= PLEAT_TEST_POSITION_TOLERANCE_M && worst[0][1] <= PLEAT_TEST_NORMAL_TOLERANCE );
	assert_true( worst[1][0] <= PLEAT_TEST_POSITION_TOLERANCE_M && worst[1][1] <= PLEAT_TEST_NORMAL_TOLERANCE );
	free( buffers );
	plDestroyCrowd( &crowd );
}

static void test_headless_batch_matches_one_by_one( void** state )
{
	plBatchFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plRunCrowd( fixture, PLEAT_GPU_MODE_HEADLESS );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
}

static void test_host_context_batch_matches_one_by_one( void** state )
{
	plBatchFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	GLuint engine_copy_buffer;
	glGenBuffers( 1, &engine_copy_buffer );
	glBindBuffer( GL_COPY_WRITE_BUFFER, engine_copy_buffer ); // the engine's state: the batch must restore it
	plRunCrowd( fixture, PLEAT_GPU_MODE_HOST_CONTEXT );
	GLint bound = 0;
	glGetIntegerv( GL_COPY_WRITE_BUFFER_BINDING, &bound );
	assert_int_equal( bound, (GLint)engine_copy_buffer );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	assert_int_equal( glGetError(), GL_NO_ERROR );
	glDeleteBuffers( 1, &engine_copy_buffer );
	plTestEgl_Release( &fixture->engine );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_headless_batch_matches_one_by_one ),
		cmocka_unit_test( test_host_context_batch_matches_one_by_one ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
