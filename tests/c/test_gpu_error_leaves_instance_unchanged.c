// A GL error inside plInstance_Step (host-context mode; the engine deleted the buffers it gave the instance, so
// binding them fails with GL_INVALID_OPERATION) returns PLEAT_RESULT_GL_ERROR and leaves the instance's CPU-side state
// exactly as it was: positions and normals (read back into scratch, committed only on success), latent, blend weights,
// skinning matrices, and the caller's output spans. Skips (77) without an EGL surfaceless GL 4.3 context.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <epoxy/gl.h>

#include "test_common.h"
#include "test_gl_support.h"

static void test_gl_error_in_step_changes_nothing( void** state )
{
	(void)state;
	plTestEglContext engine;
	if ( !plTestEgl_Create( &engine ) )
	{
		print_message( "SKIP: no EGL surfaceless desktop GL 4.3 core context\n" );
		skip();
	}
	assert_true( plTestEgl_MakeCurrent( &engine ) );
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	uint32_t n = rig.info.vertex_count;
	GLuint buffers[2];
	glGenBuffers( 2, buffers );
	for ( int b = 0; b < 2; ++b )
	{
		glBindBuffer( GL_ARRAY_BUFFER, buffers[b] );
		glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 16 * n ), NULL, GL_DYNAMIC_DRAW );
	}
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.gpu_mode = PLEAT_GPU_HOST_CONTEXT;
	idef.host_position_buffer = buffers[0];
	idef.host_normal_buffer = buffers[1];
	plInstance inst;
	plResult r = plCreateInstance( rig.context, &idef, &inst );
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		glDeleteBuffers( 2, buffers );
		plTestRig_Free( &rig );
		plTestAsset_Destroy( model );
		plTestEgl_Destroy( &engine );
		skip();
	}
	assert_int_equal( r, PLEAT_RESULT_OK );

	float* out_positions = (float*)malloc( (size_t)n * 12 );
	float* out_normals = (float*)malloc( (size_t)n * 12 );
	plStepOutput output = { out_positions, 12, out_normals, 12, n };
	float q[64 * 4];
	for ( uint32_t t = 0; t < 4; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( inst, &in, &output ), PLEAT_RESULT_OK );
	}
	const float *positions, *normals;
	assert_int_equal( plInstance_GetPositions( inst, &positions, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetNormals( inst, &normals, NULL ), PLEAT_RESULT_OK );
	float* positions_before = (float*)malloc( (size_t)n * 12 );
	float* normals_before = (float*)malloc( (size_t)n * 12 );
	memcpy( positions_before, positions, (size_t)n * 12 );
	memcpy( normals_before, normals, (size_t)n * 12 );
	float latent_before[64], weights_before[64], matrices_before[64 * 12];
	float latent_after[64], weights_after[64], matrices_after[64 * 12];
	assert_int_equal( plInstance_GetLatent( inst, latent_before, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetBlendWeights( inst, weights_before, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetSkinMatrices( inst, matrices_before, 64 ), PLEAT_RESULT_OK );

	// The engine deletes the buffers the instance writes into; the next step's GL calls fail.
	glDeleteBuffers( 2, buffers );
	for ( size_t i = 0; i < (size_t)n * 3; ++i )
	{
		out_positions[i] = -7.0f;
		out_normals[i] = -7.0f;
	}
	plFrameInput in = plTestMotion( 4, model->J, q );
	assert_int_equal( plInstance_Step( inst, &in, &output ), PLEAT_RESULT_GL_ERROR );

	assert_int_equal( plInstance_GetPositions( inst, &positions, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetNormals( inst, &normals, NULL ), PLEAT_RESULT_OK );
	assert_memory_equal( positions, positions_before, (size_t)n * 12 );
	assert_memory_equal( normals, normals_before, (size_t)n * 12 );
	assert_int_equal( plInstance_GetLatent( inst, latent_after, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetBlendWeights( inst, weights_after, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetSkinMatrices( inst, matrices_after, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( latent_after, latent_before, rig.info.latent_count * sizeof( float ) );
	assert_memory_equal( weights_after, weights_before, rig.info.blend_count * sizeof( float ) );
	assert_memory_equal( matrices_after, matrices_before, rig.info.joint_count * 12 * sizeof( float ) );
	for ( size_t i = 0; i < (size_t)n * 3; ++i )
	{
		assert_true( out_positions[i] == -7.0f && out_normals[i] == -7.0f );
	}
	while ( glGetError() != GL_NO_ERROR )
	{
	}
	assert_int_equal( plDestroyInstance( inst ), PLEAT_RESULT_OK );
	free( positions_before );
	free( normals_before );
	free( out_positions );
	free( out_normals );
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
	plTestEgl_Release( &engine );
	plTestEgl_Destroy( &engine );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_gl_error_in_step_changes_nothing ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
