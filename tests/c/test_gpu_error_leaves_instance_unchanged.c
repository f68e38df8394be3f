// A GL error inside plInstance_Step (host-context mode; the engine deleted the buffers it gave the instance, so
// binding them fails with GL_INVALID_OPERATION) returns PLEAT_RESULT_GL_ERROR and leaves the instance's CPU-side state
// exactly as it was: positions and normals (read back into scratch, committed only on success), latent, blend weights,
// skinning matrices, and the caller's output spans. A GL error inside plInstance_SetShape (the engine called it with
// another GL context current, where the instance's buffer names do not exist) leaves β, J(β) and the shaped template
// as they were. With no GL context current at all, plInstance_SetShape and plInstance_Step
// return PLEAT_RESULT_GL_UNAVAILABLE and change nothing (GL calls without a context are silently ignored, so nothing
// else would notice: β would be committed on the CPU and never reach the GPU). Skips (77) without an EGL surfaceless
// GL 4.3 context.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <epoxy/gl.h>

#include "test_common.h"
#include "test_gl_support.h"

// The engine's GL context, made current, and a rig on the default test asset; skips without an EGL surfaceless
// desktop GL 4.3 core context.
static void plEngineRig_Create( plTestEglContext* engine, plTestRig* rig )
{
	if ( !plTestEgl_Create( engine ) )
	{
		print_message( "SKIP: no EGL surfaceless desktop GL 4.3 core context\n" );
		skip();
	}
	assert_true( plTestEgl_MakeCurrent( engine ) );
	assert_int_equal( plTestRig_Create( rig, NULL, NULL ), PLEAT_RESULT_OK );
}

static void test_gl_error_in_step_changes_nothing( void** state )
{
	(void)state;
	plTestEglContext engine;
	plTestRig rig;
	plEngineRig_Create( &engine, &rig );
	const plTestAsset* model = rig.model;
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
	idef.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
	idef.host_position_buffer = buffers[0];
	idef.host_normal_buffer = buffers[1];
	plInstance inst;
	plResult r = plCreateInstance( rig.context, &idef, &inst );
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		glDeleteBuffers( 2, buffers );
		plTestRig_Free( &rig );
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
	plTestEgl_Release( &engine );
	plTestEgl_Destroy( &engine );
}

// Two host-context instances step in lockstep; one gets a plInstance_SetShape that fails with a GL error. Afterwards it
// must report the old β and step bit for bit like its twin that never saw the call (before the fix β, J(β) and the
// shaped template changed on the CPU while the GPU kept the old template, and GL_ERROR was returned all the same).
static void test_gl_error_in_set_shape_changes_nothing( void** state )
{
	(void)state;
	plTestEglContext engine, other;
	plTestRig rig;
	plEngineRig_Create( &engine, &rig );
	assert_true( plTestEgl_Create( &other ) ); // a second context of the same kind, sharing nothing with the first
	const plTestAsset* model = rig.model;
	uint32_t n = rig.info.vertex_count;
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
	plInstance failed, twin;
	plResult r = plCreateInstance( rig.context, &idef, &failed );
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		plTestRig_Free( &rig );
		plTestEgl_Destroy( &other );
		plTestEgl_Destroy( &engine );
		skip();
	}
	assert_int_equal( r, PLEAT_RESULT_OK );
	assert_int_equal( plCreateInstance( rig.context, &idef, &twin ), PLEAT_RESULT_OK );

	size_t bytes = (size_t)n * 3 * sizeof( float );
	float* out_failed = (float*)malloc( 2 * bytes );
	float* out_twin = (float*)malloc( 2 * bytes );
	plStepOutput output_failed = { out_failed, 12, out_failed + (size_t)n * 3, 12, n };
	plStepOutput output_twin = { out_twin, 12, out_twin + (size_t)n * 3, 12, n };
	float q[64 * 4];
	for ( uint32_t t = 0; t < 3; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( failed, &in, &output_failed ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
	}
	assert_memory_equal( out_failed, out_twin, 2 * bytes );
	float beta_before[16], material_before[4], beta_after[16], material_after[4];
	assert_int_equal( plInstance_GetShape( failed, beta_before, 16, material_before ), PLEAT_RESULT_OK );

	// Another context current: binding the instance's template buffer fails (GL_INVALID_OPERATION, a name that
	// context never generated). The β asked for is far outside the range, so a clamp would show too.
	assert_true( plTestEgl_MakeCurrent( &other ) );
	const float beta[2] = { 1.5f, -40.0f };
	assert_int_equal( plInstance_SetShape( failed, beta, 2 ), PLEAT_RESULT_GL_ERROR );
	while ( glGetError() != GL_NO_ERROR )
	{
	}
	assert_true( plTestEgl_MakeCurrent( &engine ) );

	assert_int_equal( plInstance_GetShape( failed, beta_after, 16, material_after ), PLEAT_RESULT_OK );
	assert_memory_equal( beta_after, beta_before, rig.info.beta_count * sizeof( float ) );
	assert_memory_equal( material_after, material_before, sizeof( material_before ) );
	for ( uint32_t t = 3; t < 6; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( failed, &in, &output_failed ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
		assert_memory_equal( out_failed, out_twin, 2 * bytes );
	}
	float matrices_failed[64 * 12], matrices_twin[64 * 12];
	assert_int_equal( plInstance_GetSkinMatrices( failed, matrices_failed, 64 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetSkinMatrices( twin, matrices_twin, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( matrices_failed, matrices_twin, rig.info.joint_count * 12 * sizeof( float ) );

	// The same call with the right context current succeeds and does change the shape (the test asks for a real change).
	assert_int_equal( plInstance_SetShape( failed, beta, 2 ), PLEAT_RESULT_CLAMPED );
	assert_int_equal( plInstance_GetShape( failed, beta_after, 16, material_after ), PLEAT_RESULT_OK );
	assert_memory_not_equal( beta_after, beta_before, rig.info.beta_count * sizeof( float ) );
	plFrameInput in = plTestMotion( 6, model->J, q );
	assert_int_equal( plInstance_Step( failed, &in, &output_failed ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
	assert_memory_not_equal( out_failed, out_twin, bytes );

	assert_int_equal( plDestroyInstance( failed ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( twin ), PLEAT_RESULT_OK );
	free( out_failed );
	free( out_twin );
	plTestRig_Free( &rig );
	plTestEgl_Release( &engine );
	plTestEgl_Destroy( &other );
	plTestEgl_Destroy( &engine );
}

// Two host-context instances step in lockstep; the engine then calls plInstance_SetShape and plInstance_Step on one of
// them with no GL context current on the thread. Both calls must fail with GL_UNAVAILABLE and leave it exactly as it
// was: the same β, and the same outputs as its twin, bit for bit, once the context is current again. (Before the fix
// both returned OK: β was committed on the CPU but never uploaded, and the later steps drifted from the twin.)
static void test_no_current_context_in_set_shape_and_step_changes_nothing( void** state )
{
	(void)state;
	plTestEglContext engine;
	plTestRig rig;
	plEngineRig_Create( &engine, &rig );
	const plTestAsset* model = rig.model;
	uint32_t n = rig.info.vertex_count;
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
	plInstance lost, twin;
	plResult r = plCreateInstance( rig.context, &idef, &lost );
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		plTestRig_Free( &rig );
		plTestEgl_Destroy( &engine );
		skip();
	}
	assert_int_equal( r, PLEAT_RESULT_OK );
	assert_int_equal( plCreateInstance( rig.context, &idef, &twin ), PLEAT_RESULT_OK );

	size_t bytes = (size_t)n * 3 * sizeof( float );
	float* out_lost = (float*)malloc( 2 * bytes );
	float* out_twin = (float*)malloc( 2 * bytes );
	plStepOutput output_lost = { out_lost, 12, out_lost + (size_t)n * 3, 12, n };
	plStepOutput output_twin = { out_twin, 12, out_twin + (size_t)n * 3, 12, n };
	float q[64 * 4];
	for ( uint32_t t = 0; t < 3; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( lost, &in, &output_lost ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
	}
	assert_memory_equal( out_lost, out_twin, 2 * bytes );
	float beta_before[16], material_before[4], beta_after[16], material_after[4];
	assert_int_equal( plInstance_GetShape( lost, beta_before, 16, material_before ), PLEAT_RESULT_OK );
	float latent_before[64], latent_after[64];
	assert_int_equal( plInstance_GetLatent( lost, latent_before, 64 ), PLEAT_RESULT_OK );

	plTestEgl_Release( &engine );
	const float beta[2] = { 1.5f, -0.5f };
	assert_int_equal( plInstance_SetShape( lost, beta, 2 ), PLEAT_RESULT_GL_UNAVAILABLE );
	for ( size_t i = 0; i < (size_t)n * 6; ++i )
	{
		out_lost[i] = -7.0f;
	}
	plFrameInput lost_frame = plTestMotion( 3, model->J, q );
	assert_int_equal( plInstance_Step( lost, &lost_frame, &output_lost ), PLEAT_RESULT_GL_UNAVAILABLE );
	for ( size_t i = 0; i < (size_t)n * 6; ++i )
	{
		assert_true( out_lost[i] == -7.0f );
	}
	assert_true( plTestEgl_MakeCurrent( &engine ) );

	assert_int_equal( plInstance_GetShape( lost, beta_after, 16, material_after ), PLEAT_RESULT_OK );
	assert_memory_equal( beta_after, beta_before, rig.info.beta_count * sizeof( float ) );
	assert_memory_equal( material_after, material_before, sizeof( material_before ) );
	assert_int_equal( plInstance_GetLatent( lost, latent_after, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( latent_after, latent_before, rig.info.latent_count * sizeof( float ) );
	for ( uint32_t t = 3; t < 6; ++t )
	{
		plFrameInput in = plTestMotion( t, model->J, q );
		assert_int_equal( plInstance_Step( lost, &in, &output_lost ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
		assert_memory_equal( out_lost, out_twin, 2 * bytes );
	}

	// With the context current the same shape call works and changes the output.
	assert_int_equal( plInstance_SetShape( lost, beta, 2 ), PLEAT_RESULT_OK );
	plFrameInput in = plTestMotion( 6, model->J, q );
	assert_int_equal( plInstance_Step( lost, &in, &output_lost ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Step( twin, &in, &output_twin ), PLEAT_RESULT_OK );
	assert_memory_not_equal( out_lost, out_twin, bytes );

	assert_int_equal( plDestroyInstance( lost ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( twin ), PLEAT_RESULT_OK );
	free( out_lost );
	free( out_twin );
	plTestRig_Free( &rig );
	plTestEgl_Release( &engine );
	plTestEgl_Destroy( &engine );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_gl_error_in_step_changes_nothing ),
		cmocka_unit_test( test_gl_error_in_set_shape_changes_nothing ),
		cmocka_unit_test( test_no_current_context_in_set_shape_and_step_changes_nothing ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
