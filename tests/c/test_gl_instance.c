// Instance level: plInstance_Step with PLEAT_GPU_MODE_HEADLESS and PLEAT_GPU_MODE_HOST_CONTEXT gives the same positions and
// normals as PLEAT_GPU_MODE_NONE (the CPU path) on the same asset and motion, over 40 frames, on Mesa llvmpipe.
// The asset comes from the core's C test asset builder (tests/c/test_asset_builder.h): a 79 × 56 = 4,424-vertex sheet,
// 24 joints, K = 4, D = 64 random blend shapes of ±3 cm, small random networks. The MLPs run on the CPU in every mode,
// so blend weights and skin matrices are identical and only the deformation differs.
// Tolerances as in test_gl_deformer.c (fp32 on both sides): positions 2e-5 m, normals 1e-3 per component, except that
// a vertex whose CPU normal is not unit length (a zero-area neighbourhood) is compared only for finiteness.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "pleat/pleat.h"
#include "test_asset_builder.h"
#include "test_common.h"
#include "test_gl_support.h"
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLEAT_TEST_FRAMES 40
#define PLEAT_TEST_POSITION_TOLERANCE_M 2e-5
#define PLEAT_TEST_NORMAL_TOLERANCE 1e-3

typedef struct plInstanceFixture
{
	plTestRig rig; // context, asset and its info
	plTestEglContext engine;
	plTestAllocatorState allocator_state; // every SDK allocation goes through it (context def hooks)
} plInstanceFixture;

static int plSetup( void** state )
{
	plInstanceFixture* fixture = calloc( 1, sizeof( *fixture ) );
	plTestAssetParams params = plTestAsset_DefaultParams();
	params.grid_x = 79;
	params.grid_y = 56;
	params.joint_count = 24;
	params.input_joint_count = 19;
	params.influence_count = 4;
	params.beta_count = 10;
	params.latent_count = 32;
	params.blend_count = 64;
	params.lp_hidden[0] = 64;
	params.lp_hidden[1] = 0;
	params.dec_hidden[0] = 64;
	params.weight_scale = 0.5f;
	params.blend_scale = 0.03f;
	plTestAsset* model = plTestAsset_Create( &params );
	assert_non_null( model );
	plContextDef context_def = plDefaultContextDef();
	plAllocator allocator = plTestAllocator( &fixture->allocator_state );
	context_def.alloc = allocator.alloc;
	context_def.free = allocator.free;
	context_def.allocator_context = allocator.user;
	assert_int_equal( plTestRig_Init( &fixture->rig, model, &context_def ), PLEAT_RESULT_OK );
	plTestAsset_Destroy( model );
	plTestEgl_Create( &fixture->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = fixture;
	return 0;
}

static int plTeardown( void** state )
{
	plInstanceFixture* fixture = *state;
	plTestEgl_Destroy( &fixture->engine );
	plDestroyAsset( fixture->rig.asset );
	plTestRig_Free( &fixture->rig );
	long long live = fixture->allocator_state.live_bytes;
	int mismatch = fixture->allocator_state.size_mismatch;
	free( fixture );
	if ( live != 0 || mismatch )
		print_error( "after destroying everything: %lld bytes still allocated, size mismatch %d\n", live, mismatch );
	return live == 0 && !mismatch ? 0 : -1; // everything the instances and deformers allocated was given back
}

// Steps a CPU instance and a GPU instance side by side and compares every frame.
static void plCompareWithCpu( plInstanceFixture* fixture, plGpuMode mode, uint32_t host_position_buffer,
							  uint32_t host_normal_buffer )
{
	uint32_t n = fixture->rig.info.vertex_count, j = fixture->rig.info.joint_count;
	plInstance instances[2];
	for ( int i = 0; i < 2; ++i )
	{
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = fixture->rig.asset;
		def.gpu_mode = i == 0 ? PLEAT_GPU_MODE_NONE : mode;
		def.host_position_buffer = i == 0 ? 0 : host_position_buffer;
		def.host_normal_buffer = i == 0 ? 0 : host_normal_buffer;
		assert_int_equal( plCreateInstance( fixture->rig.context, &def, &instances[i] ), PLEAT_RESULT_OK );
	}
	float* rotations = malloc( sizeof( float ) * 4 * j );
	float* outputs = malloc( sizeof( float ) * 12 * n ); // [instance][positions, normals][N][3]
	double worst_position = 0.0, worst_normal = 0.0;
	for ( uint32_t frame = 0; frame < PLEAT_TEST_FRAMES; ++frame )
	{
		plFrameInput input;
		plTestMotion_WalkPose( frame, 0.0f, 0.5f, j, rotations, &input );
		for ( int i = 0; i < 2; ++i )
		{
			memset( outputs + 6 * (size_t)n * i, 0xff, sizeof( float ) * 6 * n );
			plStepOutput output = { outputs + 6 * (size_t)n * i, 0, outputs + 6 * (size_t)n * i + 3 * n, 0, n };
			assert_true( plInstance_Step( instances[i], &input, &output ) >= 0 );
		}
		const float *cpu_positions = outputs, *cpu_normals = outputs + 3 * (size_t)n;
		const float *gl_positions = outputs + 6 * (size_t)n, *gl_normals = outputs + 9 * (size_t)n;
		for ( size_t v = 0; v < n; ++v )
		{
			double length = 0.0;
			for ( int c = 0; c < 3; ++c )
			{
				size_t e = 3 * v + (size_t)c;
				assert_true( isfinite( gl_positions[e] ) && isfinite( gl_normals[e] ) );
				worst_position = fmax( worst_position, fabs( (double)cpu_positions[e] - gl_positions[e] ) );
				length += (double)cpu_normals[e] * cpu_normals[e];
			}
			if ( fabs( length - 1.0 ) < 1e-3 )
			{
				for ( int c = 0; c < 3; ++c )
					worst_normal = fmax( worst_normal, fabs( (double)cpu_normals[3 * v + c] - gl_normals[3 * v + c] ) );
			}
		}
	}
	print_message( "%s: max |cpu - gl| position %.3g m, normal %.3g over %d frames\n",
				   mode == PLEAT_GPU_MODE_HEADLESS ? "headless" : "host context", worst_position, worst_normal,
				   PLEAT_TEST_FRAMES );
	assert_true( worst_position <= PLEAT_TEST_POSITION_TOLERANCE_M );
	assert_true( worst_normal <= PLEAT_TEST_NORMAL_TOLERANCE );
	free( rotations );
	free( outputs );
	assert_int_equal( plDestroyInstance( instances[0] ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( instances[1] ), PLEAT_RESULT_OK );
}

static void test_headless_instance_matches_cpu_instance( void** state )
{
	plInstanceFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plCompareWithCpu( fixture, PLEAT_GPU_MODE_HEADLESS, 0, 0 );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
}

static void test_host_context_instance_matches_cpu_instance( void** state )
{
	plInstanceFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	GLuint buffers[2];
	glGenBuffers( 2, buffers );
	for ( int b = 0; b < 2; ++b )
	{
		glBindBuffer( GL_ARRAY_BUFFER, buffers[b] );
		glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 16 * fixture->rig.info.vertex_count ), NULL, GL_DYNAMIC_DRAW );
	}
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plCompareWithCpu( fixture, PLEAT_GPU_MODE_HOST_CONTEXT, buffers[0], buffers[1] );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	assert_int_equal( glGetError(), GL_NO_ERROR );
	glDeleteBuffers( 2, buffers );
	plTestEgl_Release( &fixture->engine );
}

static void test_host_context_instance_without_current_context_fails_cleanly( void** state )
{
	plInstanceFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = fixture->rig.asset;
	def.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
	plInstance instance;
	memset( &instance, 0, sizeof( instance ) );
	assert_int_equal( plCreateInstance( fixture->rig.context, &def, &instance ), PLEAT_RESULT_GL_UNAVAILABLE );
	assert_false( plInstance_IsValid( instance ) );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_headless_instance_matches_cpu_instance ),
		cmocka_unit_test( test_host_context_instance_matches_cpu_instance ),
		cmocka_unit_test( test_host_context_instance_without_current_context_fails_cleanly ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
