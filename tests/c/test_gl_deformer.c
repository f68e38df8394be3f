// The GL compute path (sdk/src/gl/, shaders/) against a double-precision reference of the same equations, on Mesa
// llvmpipe: host-context mode (the test plays the engine: its own EGL context and output buffers, and GL state that
// must come back unchanged), headless mode (the automatic choice, the EGL device platform forced, OSMesa forced), fp16
// blend shapes, bad descriptions.
//
// Tolerances: positions within 2e-5 m (fp32 accumulation of D = 32 shapes of a few cm and a 3×4 transform on
// coordinates up to ~1.5 m gives errors of a few 1e-7 m; 2e-5 m leaves room for GPU FMA contraction and is still far
// below the 1 mm scale of anything visible); normals within 1e-3 per component (a normal is a cross product of ~2 cm
// edge differences, so the fp32 position rounding of ~1e-7 m becomes a relative error of ~1e-5, amplified where
// adjacent faces nearly cancel).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "gl/gl_internal.h"
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

typedef struct plTestFixture
{
	plTestMesh mesh;
	plTestAllocatorState allocator_state;
	plAllocator allocator;
	plTestEglContext engine; // the "engine" context; only made current by host-context tests
	float* blend_weights;
	float* skin_matrices;
	float* positions;
	float* normals;
	double* expected_positions;
	double* expected_normals;
} plTestFixture;

static int plSetup( void** state )
{
	plTestFixture* fixture = calloc( 1, sizeof( *fixture ) );
	plTestMesh_Build( &fixture->mesh, 79, 56, 32, 7 ); // 4,424 vertices
	fixture->allocator = plTestAllocator( &fixture->allocator_state );
	size_t n = fixture->mesh.vertex_count;
	fixture->blend_weights = malloc( sizeof( float ) * fixture->mesh.blend_count );
	fixture->skin_matrices = malloc( sizeof( float ) * 12 * fixture->mesh.joint_count );
	fixture->positions = malloc( sizeof( float ) * 3 * n );
	fixture->normals = malloc( sizeof( float ) * 3 * n );
	fixture->expected_positions = malloc( sizeof( double ) * 3 * n );
	fixture->expected_normals = malloc( sizeof( double ) * 3 * n );
	plTestEgl_Create( &fixture->engine ); // none on this machine: the tests skip (plTestEgl_Require)
	*state = fixture;
	return 0;
}

static int plTeardown( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Destroy( &fixture->engine );
	plTestMesh_Free( &fixture->mesh );
	free( fixture->blend_weights );
	free( fixture->skin_matrices );
	free( fixture->positions );
	free( fixture->normals );
	free( fixture->expected_positions );
	free( fixture->expected_normals );
	free( fixture );
	return 0;
}

static plGlDeformerDesc plDescFor( const plTestMesh* mesh, plGlDeformerMode mode, int fp16 )
{
	plGlDeformerDesc desc;
	memset( &desc, 0, sizeof( desc ) );
	desc.mode = mode;
	desc.vertex_count = mesh->vertex_count;
	desc.face_count = mesh->face_count;
	desc.blend_count = mesh->blend_count;
	desc.influence_count = mesh->influence_count;
	desc.joint_count = mesh->joint_count;
	desc.shaped_template = mesh->shaped_template;
	desc.blend_shapes = fp16 ? (const void*)mesh->blend_shapes_fp16 : (const void*)mesh->blend_shapes;
	desc.blend_shapes_fp16 = fp16;
	desc.skin_indices = mesh->skin_indices;
	desc.skin_weights = mesh->skin_weights;
	desc.faces = mesh->faces;
	desc.adjacency_offsets = mesh->adjacency_offsets;
	desc.adjacency_faces = mesh->adjacency_faces;
	return desc;
}

// Runs the motion for frame_count frames and checks every frame against the reference; returns the worst errors.
static void plRunMotion( plTestFixture* fixture, plGlDeformer* deformer, int fp16, uint32_t frame_count,
						 double* worst_position, double* worst_normal )
{
	const plTestMesh* mesh = &fixture->mesh;
	size_t values = (size_t)3 * mesh->vertex_count;
	*worst_position = 0.0;
	*worst_normal = 0.0;
	for ( uint32_t frame = 0; frame < frame_count; ++frame )
	{
		plTestMotion_Frame( mesh, frame, fixture->blend_weights, fixture->skin_matrices );
		memset( fixture->positions, 0xff, sizeof( float ) * values ); // NaN: a frame that writes nothing fails
		memset( fixture->normals, 0xff, sizeof( float ) * values );
		assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices,
											fixture->positions, fixture->normals ),
						  PLEAT_RESULT_OK );
		plTestReference_Deform( mesh, fp16 ? mesh->blend_shapes_rounded : mesh->blend_shapes, fixture->blend_weights,
								fixture->skin_matrices, fixture->expected_positions, fixture->expected_normals );
		double position_error = plTestMaxAbsDiff( fixture->positions, fixture->expected_positions, values );
		double normal_error = plTestMaxAbsDiff( fixture->normals, fixture->expected_normals, values );
		*worst_position = fmax( *worst_position, position_error );
		*worst_normal = fmax( *worst_normal, normal_error );
	}
	assert_true( *worst_position <= PLEAT_TEST_POSITION_TOLERANCE_M );
	assert_true( *worst_normal <= PLEAT_TEST_NORMAL_TOLERANCE );
}

static void plExpectNoLeak( const plTestFixture* fixture )
{
	assert_int_equal( fixture->allocator_state.live_bytes, 0 );
	assert_false( fixture->allocator_state.size_mismatch );
}

static void test_headless_matches_reference_over_motion( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_EGL );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT ); // nothing current before → nothing after
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, PLEAT_TEST_FRAMES, &position_error, &normal_error );
	print_message( "headless EGL: max position error %.3g m, max normal error %.3g over %d frames\n", position_error,
				   normal_error, PLEAT_TEST_FRAMES );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_headless_restores_the_callers_current_context( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 2, &position_error, &normal_error );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	assert_int_equal( eglQueryAPI(), EGL_OPENGL_API );
	plGlDeformer_Destroy( deformer );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_headless_osmesa_fallback_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	plResult result = plGlDeformer_CreateHeadless( &desc, &fixture->allocator, PLEAT_GL_HEADLESS_OSMESA, &deformer );
	if ( result == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		print_message( "SKIP: OSMesa (libOSMesa.so.8 with GL 4.3 core) is not available here\n" );
		skip();
	}
	assert_int_equal( result, PLEAT_RESULT_OK );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_OSMESA );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 3, &position_error, &normal_error );
	print_message( "headless OSMesa: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

// The EGL device platform route itself (EGL_EXT_platform_device), forced with software devices allowed so that it
// runs here on Mesa's llvmpipe device too: same results as the reference, and the report names the route.
static void test_headless_egl_device_platform_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	char report[448] = { 0 };
	desc.report = report;
	desc.report_size = sizeof( report );
	plGlDeformer* deformer = NULL;
	plResult result = plGlDeformer_CreateHeadless( &desc, &fixture->allocator, PLEAT_GL_HEADLESS_EGL_DEVICE, &deformer );
	if ( result == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		print_message( "SKIP: no EGL device gives a GL 4.3 core context here: %s\n", report );
		skip();
	}
	assert_int_equal( result, PLEAT_RESULT_OK );
	print_message( "report: %s\n", report );
	assert_int_equal( plGlDeformer_Backend( deformer ), PLEAT_GL_HEADLESS_EGL );
	assert_int_equal( plGlDeformer_Platform( deformer ), PLEAT_GL_PLATFORM_EGL_DEVICE );
	assert_true( strncmp( report, "EGL device platform (EGL_EXT_platform_device), device ", 54 ) == 0 );
	assert_non_null( strstr( report, "GL_RENDERER '" ) );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 5, &position_error, &normal_error );
	print_message( "headless EGL device: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_fp16_blend_shapes_match_rounded_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HEADLESS, 1 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 1, 5, &position_error, &normal_error );
	print_message( "fp16 blend shapes: max position error %.3g m, max normal error %.3g\n", position_error,
				   normal_error );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

static void test_set_shaped_template_moves_the_output( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	plTestMesh* mesh = &fixture->mesh;
	plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	// A new shape: the template scaled radially by 1.1 (what a β change does, conceptually).
	size_t values = (size_t)3 * mesh->vertex_count;
	float* original = malloc( sizeof( float ) * values );
	memcpy( original, mesh->shaped_template, sizeof( float ) * values );
	for ( uint32_t i = 0; i < mesh->vertex_count; ++i )
	{
		mesh->shaped_template[3 * i] *= 1.1f;
		mesh->shaped_template[3 * i + 2] *= 1.1f;
	}
	assert_int_equal( plGlDeformer_SetShapedTemplate( deformer, mesh->shaped_template, NULL ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, 2, &position_error, &normal_error );
	memcpy( mesh->shaped_template, original, sizeof( float ) * values );
	free( original );
	assert_int_equal( plGlDeformer_SetShapedTemplate( deformer, NULL, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	plGlDeformer_Destroy( deformer );
	plExpectNoLeak( fixture );
}

// --- host-context mode ---------------------------------------------------------------------------------------------

// Engine-side GL objects with distinctive bindings that the deformer must leave exactly as they were.
typedef struct plEngineState
{
	GLuint program;
	GLuint buffers[4];
} plEngineState;

static GLuint plEngineProgram( void )
{
	const char* source = "#version 430 core\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
	GLuint shader = glCreateShader( GL_COMPUTE_SHADER );
	glShaderSource( shader, 1, &source, NULL );
	glCompileShader( shader );
	GLuint program = glCreateProgram();
	glAttachShader( program, shader );
	glLinkProgram( program );
	glDeleteShader( shader );
	GLint linked = 0;
	glGetProgramiv( program, GL_LINK_STATUS, &linked );
	assert_int_equal( linked, GL_TRUE );
	return program;
}

static void plEngineBind( plEngineState* engine )
{
	engine->program = plEngineProgram();
	glGenBuffers( 4, engine->buffers );
	for ( int b = 0; b < 4; ++b )
	{
		glBindBuffer( GL_SHADER_STORAGE_BUFFER, engine->buffers[b] );
		glBufferData( GL_SHADER_STORAGE_BUFFER, 4096, NULL, GL_STATIC_DRAW );
	}
	glUseProgram( engine->program );
	glBindBufferBase( GL_SHADER_STORAGE_BUFFER, 0, engine->buffers[0] );
	glBindBufferRange( GL_SHADER_STORAGE_BUFFER, 3, engine->buffers[1], 256, 512 );
	glBindBufferBase( GL_SHADER_STORAGE_BUFFER, 11, engine->buffers[2] );
	glBindBufferRange( GL_UNIFORM_BUFFER, 0, engine->buffers[3], 512, 256 );
	glBindBuffer( GL_UNIFORM_BUFFER, engine->buffers[2] );
	glBindBuffer( GL_SHADER_STORAGE_BUFFER, engine->buffers[3] ); // generic bindings last (indexed binds set them)
}

static void plExpectEngineState( const plEngineState* engine )
{
	GLint value = -1;
	GLint64 value64 = -1;
	glGetIntegerv( GL_CURRENT_PROGRAM, &value );
	assert_int_equal( value, engine->program );
	glGetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &value );
	assert_int_equal( value, engine->buffers[3] );
	glGetIntegerv( GL_UNIFORM_BUFFER_BINDING, &value );
	assert_int_equal( value, engine->buffers[2] );
	for ( GLuint i = 0; i < PLEAT_GL_BINDING_COUNT; ++i )
	{
		GLint expected = i == 0 ? (GLint)engine->buffers[0]
								: i == 3 ? (GLint)engine->buffers[1] : i == 11 ? (GLint)engine->buffers[2] : 0;
		glGetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, i, &value );
		assert_int_equal( value, expected );
		glGetInteger64i_v( GL_SHADER_STORAGE_BUFFER_START, i, &value64 );
		assert_int_equal( value64, i == 3 ? 256 : 0 );
		glGetInteger64i_v( GL_SHADER_STORAGE_BUFFER_SIZE, i, &value64 );
		assert_int_equal( value64, i == 3 ? 512 : 0 );
	}
	glGetIntegeri_v( GL_UNIFORM_BUFFER_BINDING, 0, &value );
	assert_int_equal( value, engine->buffers[3] );
	glGetInteger64i_v( GL_UNIFORM_BUFFER_START, 0, &value64 );
	assert_int_equal( value64, 512 );
	glGetInteger64i_v( GL_UNIFORM_BUFFER_SIZE, 0, &value64 );
	assert_int_equal( value64, 256 );
	assert_int_equal( glGetError(), GL_NO_ERROR );
}

static void plEngineRelease( plEngineState* engine )
{
	glUseProgram( 0 );
	glDeleteProgram( engine->program );
	glDeleteBuffers( 4, engine->buffers );
}

static void test_host_context_matches_reference_and_restores_state( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	const plTestMesh* mesh = &fixture->mesh;
	size_t n = mesh->vertex_count;

	// The engine's vertex buffers the deformer writes into (vec4 per vertex).
	GLuint outputs[2];
	glGenBuffers( 2, outputs );
	for ( int b = 0; b < 2; ++b )
	{
		glBindBuffer( GL_ARRAY_BUFFER, outputs[b] );
		glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 16 * n ), NULL, GL_DYNAMIC_DRAW );
	}
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plEngineState engine;
	plEngineBind( &engine );

	plGlDeformerDesc desc = plDescFor( mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	desc.host_position_buffer = outputs[0];
	desc.host_normal_buffer = outputs[1];
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	plExpectEngineState( &engine );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );

	double position_error, normal_error;
	plRunMotion( fixture, deformer, 0, PLEAT_TEST_FRAMES, &position_error, &normal_error );
	print_message( "host context: max position error %.3g m, max normal error %.3g over %d frames\n",
				   position_error, normal_error, PLEAT_TEST_FRAMES );
	plExpectEngineState( &engine );
	assert_ptr_equal( eglGetCurrentContext(), fixture->engine.context );

	// The engine's own buffers hold the last frame: xyz as read back, w = 1 for positions and 0 for normals.
	float* rows = malloc( 16 * n );
	for ( int b = 0; b < 2; ++b )
	{
		const float* expected = b == 0 ? fixture->positions : fixture->normals;
		glBindBuffer( GL_COPY_READ_BUFFER, outputs[b] );
		glGetBufferSubData( GL_COPY_READ_BUFFER, 0, (GLsizeiptr)( 16 * n ), rows );
		for ( size_t i = 0; i < n; ++i )
		{
			assert_memory_equal( rows + 4 * i, expected + 3 * i, 3 * sizeof( float ) );
			assert_true( rows[4 * i + 3] == ( b == 0 ? 1.0f : 0.0f ) );
		}
	}
	free( rows );
	glBindBuffer( GL_COPY_READ_BUFFER, 0 );

	// Running without read-back leaves the result in the engine's buffers only, and still restores state.
	assert_int_equal( plGlDeformer_Run( deformer, fixture->blend_weights, fixture->skin_matrices, NULL, NULL ),
					  PLEAT_RESULT_OK );
	plExpectEngineState( &engine );
	plGlDeformer_Destroy( deformer );
	plExpectEngineState( &engine );
	plEngineRelease( &engine );
	glDeleteBuffers( 2, outputs );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_host_context_without_output_buffers_matches_reference( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 1 );
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_OK );
	double position_error, normal_error;
	plRunMotion( fixture, deformer, 1, 3, &position_error, &normal_error );
	plGlDeformer_Destroy( deformer );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_host_context_without_current_context_is_unavailable( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_ptr_equal( eglGetCurrentContext(), EGL_NO_CONTEXT );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	plGlDeformer* deformer = (plGlDeformer*)&desc; // must be overwritten with NULL
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_GL_UNAVAILABLE );
	assert_null( deformer );
	plExpectNoLeak( fixture );
}

static void test_host_buffer_too_small_is_rejected( void** state )
{
	plTestFixture* fixture = *state;
	plTestEgl_Require( &fixture->engine );
	assert_true( plTestEgl_MakeCurrent( &fixture->engine ) );
	GLuint small;
	glGenBuffers( 1, &small );
	glBindBuffer( GL_ARRAY_BUFFER, small );
	glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)( 12 * fixture->mesh.vertex_count ), NULL, GL_DYNAMIC_DRAW ); // vec3
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	plGlDeformerDesc desc = plDescFor( &fixture->mesh, PLEAT_GL_DEFORMER_HOST_CONTEXT, 0 );
	desc.host_position_buffer = small;
	plGlDeformer* deformer = NULL;
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	desc.host_position_buffer = small + 1000; // not a buffer name
	assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	GLint bound = -1;
	glGetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &bound );
	assert_int_equal( bound, 0 );
	assert_int_equal( glGetError(), GL_NO_ERROR );
	glDeleteBuffers( 1, &small );
	plTestEgl_Release( &fixture->engine );
	plExpectNoLeak( fixture );
}

static void test_invalid_descriptions_are_rejected( void** state )
{
	plTestFixture* fixture = *state;
	const plTestMesh* mesh = &fixture->mesh;
	plGlDeformer* deformer = NULL;
	plGlDeformerDesc valid = plDescFor( mesh, PLEAT_GL_DEFORMER_HEADLESS, 0 );
	assert_int_equal( plGlDeformer_Create( NULL, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plGlDeformer_Create( &valid, NULL, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plGlDeformer_Create( &valid, &fixture->allocator, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );

	uint16_t* bad_indices = malloc( sizeof( uint16_t ) * mesh->influence_count * mesh->vertex_count );
	memcpy( bad_indices, mesh->skin_indices, sizeof( uint16_t ) * mesh->influence_count * mesh->vertex_count );
	bad_indices[17] = (uint16_t)mesh->joint_count;
	uint32_t* bad_faces = malloc( sizeof( uint32_t ) * 3 * mesh->face_count );
	memcpy( bad_faces, mesh->faces, sizeof( uint32_t ) * 3 * mesh->face_count );
	bad_faces[3 * mesh->face_count - 1] = mesh->vertex_count;
	uint32_t* bad_offsets = malloc( sizeof( uint32_t ) * ( mesh->vertex_count + 1 ) );
	memcpy( bad_offsets, mesh->adjacency_offsets, sizeof( uint32_t ) * ( mesh->vertex_count + 1 ) );
	bad_offsets[5] = bad_offsets[6] + 1; // not monotonic

	for ( int c = 0;; ++c )
	{
		plGlDeformerDesc desc = valid;
		switch ( c )
		{
		case 0: desc.mode = (plGlDeformerMode)0; break;
		case 1: desc.vertex_count = 0; break;
		case 2: desc.influence_count = 9; break;
		case 3: desc.influence_count = 0; break;
		case 4: desc.blend_count = 0; break;
		case 5: desc.joint_count = 0; break;
		case 6: desc.face_count = 0; break;
		case 7: desc.shaped_template = NULL; break;
		case 8: desc.blend_shapes = NULL; break;
		case 9: desc.skin_indices = NULL; break;
		case 10: desc.skin_weights = NULL; break;
		case 11: desc.faces = NULL; break;
		case 12: desc.adjacency_offsets = NULL; break;
		case 13: desc.adjacency_faces = NULL; break;
		case 14: desc.skin_indices = bad_indices; break;
		case 15: desc.faces = bad_faces; break;
		case 16: desc.adjacency_offsets = bad_offsets; break;
		case 17: desc.host_position_buffer = 1; break; // host buffers in headless mode
		case 18: desc.vertex_count = 0x10000000u; break; // buffers past 2 GiB
		default: goto done;
		}
		deformer = (plGlDeformer*)&desc;
		assert_int_equal( plGlDeformer_Create( &desc, &fixture->allocator, &deformer ), PLEAT_RESULT_INVALID_ARGUMENT );
		assert_null( deformer );
	}
done:
	free( bad_indices );
	free( bad_faces );
	free( bad_offsets );
	assert_int_equal( plGlDeformer_Run( NULL, fixture->blend_weights, fixture->skin_matrices, NULL, NULL ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	plGlDeformer_Destroy( NULL );
	plExpectNoLeak( fixture );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_invalid_descriptions_are_rejected ),
		cmocka_unit_test( test_headless_matches_reference_over_motion ),
		cmocka_unit_test( test_headless_restores_the_callers_current_context ),
		cmocka_unit_test( test_headless_osmesa_fallback_matches_reference ),
		cmocka_unit_test( test_headless_egl_device_platform_matches_reference ),
		cmocka_unit_test( test_fp16_blend_shapes_match_rounded_reference ),
		cmocka_unit_test( test_set_shaped_template_moves_the_output ),
		cmocka_unit_test( test_host_context_matches_reference_and_restores_state ),
		cmocka_unit_test( test_host_context_without_output_buffers_matches_reference ),
		cmocka_unit_test( test_host_context_without_current_context_is_unavailable ),
		cmocka_unit_test( test_host_buffer_too_small_is_rejected ),
	};
	return cmocka_run_group_tests( tests, plSetup, plTeardown );
}
