// The GL compute path: blend_shapes.comp → skinning.comp (→ body_contact.comp) → face_normals.comp → normals_gather.comp
// over GPU-resident
// asset data. See
// sdk/src/gl_deformer.h for the contract and docs/gpu.md for the buffers, the saved state and the measurements.
#include "gl_internal.h"
#include "gl_shaders.h"
#include <stddef.h>
#include <string.h>

enum
{
	PLEAT_GL_PROGRAM_BLEND_SHAPES,
	PLEAT_GL_PROGRAM_SKINNING,
	PLEAT_GL_PROGRAM_FACE_NORMALS,
	PLEAT_GL_PROGRAM_NORMALS_GATHER,
	PLEAT_GL_PROGRAM_BODY_CONTACT, // assets with body anchors only (0 otherwise)
	PLEAT_GL_PROGRAM_COUNT
};

struct plGlDeformer
{
	plAllocator allocator;
	plGlDeformerMode mode;
	plGlContext* context; // headless mode only
	plGlApi api;

	uint32_t vertex_count;    // N
	uint32_t face_count;      // F
	uint32_t blend_count;     // D
	uint32_t influence_count; // K
	uint32_t joint_count;     // J
	uint32_t anchor_influence_count; // Ka, 0 without body anchors
	int body_contact;                // the contact pass runs (anchors present and enabled)
	float body_contact_offset_m;     // the clearance the params buffer holds

	GLuint programs[PLEAT_GL_PROGRAM_COUNT];
	GLuint params_buffer;                    // plGlDeformParams
	GLuint owned[PLEAT_GL_BINDING_COUNT];    // buffers the deformer created (0 where the host supplied one)
	GLuint bindings[PLEAT_GL_BINDING_COUNT]; // what Run binds at each binding point

	void* staging; // conversions on upload and read-backs; staging_bytes = max(16 N, 4 N K)
	size_t staging_bytes;

	plGlSavedState saved; // host-context mode: the engine's state during one of our calls
};

void plGlSaveState( const plGlApi* api, plGlSavedState* state )
{
	api->GetIntegerv( GL_CURRENT_PROGRAM, &state->program );
	api->GetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &state->storage_buffer );
	for ( GLuint i = 0; i < PLEAT_GL_BINDING_COUNT; ++i )
	{
		api->GetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, i, &state->storage_buffers[i] );
		api->GetInteger64i_v( GL_SHADER_STORAGE_BUFFER_START, i, &state->storage_starts[i] );
		api->GetInteger64i_v( GL_SHADER_STORAGE_BUFFER_SIZE, i, &state->storage_sizes[i] );
	}
	api->GetIntegerv( GL_UNIFORM_BUFFER_BINDING, &state->uniform_buffer );
	api->GetIntegeri_v( GL_UNIFORM_BUFFER_BINDING, PLEAT_GL_PARAMS_BINDING, &state->uniform_binding );
	api->GetInteger64i_v( GL_UNIFORM_BUFFER_START, PLEAT_GL_PARAMS_BINDING, &state->uniform_start );
	api->GetInteger64i_v( GL_UNIFORM_BUFFER_SIZE, PLEAT_GL_PARAMS_BINDING, &state->uniform_size );
}

static void plRestoreIndexed( const plGlApi* api, GLenum target, GLuint index, GLint buffer, GLint64 start,
							  GLint64 size )
{
	// A whole-buffer binding (glBindBufferBase) reads back as start 0, size 0.
	if ( buffer != 0 && size > 0 )
		api->BindBufferRange( target, index, (GLuint)buffer, (GLintptr)start, (GLsizeiptr)size );
	else
		api->BindBufferBase( target, index, (GLuint)buffer );
}

void plGlRestoreState( const plGlApi* api, const plGlSavedState* state )
{
	for ( GLuint i = 0; i < PLEAT_GL_BINDING_COUNT; ++i )
		plRestoreIndexed( api, GL_SHADER_STORAGE_BUFFER, i, state->storage_buffers[i], state->storage_starts[i],
						  state->storage_sizes[i] );
	plRestoreIndexed( api, GL_UNIFORM_BUFFER, PLEAT_GL_PARAMS_BINDING, state->uniform_binding, state->uniform_start,
					  state->uniform_size );
	// Indexed binds also set the generic binding, so the generic ones go last.
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, (GLuint)state->storage_buffer );
	api->BindBuffer( GL_UNIFORM_BUFFER, (GLuint)state->uniform_buffer );
	api->UseProgram( (GLuint)state->program );
}

// Makes the deformer's GL usable for one call: headless → make our context current; host → save the engine's state.
static plResult plBegin( plGlDeformer* deformer )
{
	if ( deformer->mode == PLEAT_GL_DEFORMER_HEADLESS )
		return plGlContext_Enter( deformer->context );
	plGlSaveState( &deformer->api, &deformer->saved );
	return PLEAT_RESULT_OK;
}

static void plEnd( plGlDeformer* deformer )
{
	if ( deformer->mode == PLEAT_GL_DEFORMER_HEADLESS )
		plGlContext_Leave( deformer->context );
	else
		plGlRestoreState( &deformer->api, &deformer->saved );
}

// Drains the GL error flags; GL_ERROR if any was set. (In host-context mode this also consumes an error the engine
// left pending before the call; docs/gpu.md says so.)
static plResult plCheckErrors( const plGlApi* api )
{
	plResult result = PLEAT_RESULT_OK;
	for ( int i = 0; i < 16 && api->GetError() != GL_NO_ERROR; ++i )
		result = PLEAT_RESULT_GL_ERROR;
	return result;
}

static GLuint plCompileProgram( const plGlApi* api, const char* source, const char* defines )
{
	// The #version line must come first, so the defines go between it and the rest of the file.
	const char* body = strchr( source, '\n' );
	if ( body == NULL )
		return 0;
	body += 1;
	const GLchar* strings[3] = { source, defines, body };
	const GLint lengths[3] = { (GLint)( body - source ), -1, -1 };
	GLuint shader = api->CreateShader( GL_COMPUTE_SHADER );
	if ( shader == 0 )
		return 0;
	api->ShaderSource( shader, 3, strings, lengths );
	api->CompileShader( shader );
	GLint compiled = GL_FALSE;
	api->GetShaderiv( shader, GL_COMPILE_STATUS, &compiled );
	GLuint program = 0;
	if ( compiled == GL_TRUE )
	{
		program = api->CreateProgram();
		api->AttachShader( program, shader );
		api->LinkProgram( program );
		GLint linked = GL_FALSE;
		api->GetProgramiv( program, GL_LINK_STATUS, &linked );
		if ( linked != GL_TRUE )
		{
			api->DeleteProgram( program );
			program = 0;
		}
	}
	api->DeleteShader( shader );
	return program;
}

static plResult plValidateDesc( const plGlDeformerDesc* desc )
{
	if ( desc->vertex_count == 0 || desc->face_count == 0 || desc->blend_count == 0 || desc->joint_count == 0 ||
		 desc->influence_count == 0 || desc->influence_count > 8 )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->shaped_template == NULL || desc->blend_shapes == NULL || desc->skin_indices == NULL ||
		 desc->skin_weights == NULL || desc->faces == NULL || desc->adjacency_offsets == NULL ||
		 desc->adjacency_faces == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	// Buffer sizes below are computed in size_t/GLsizeiptr; keep every one well inside 2^31 bytes.
	uint64_t n = desc->vertex_count;
	if ( n * 16u * desc->blend_count > 0x7fffffffu || n * 4u * desc->influence_count > 0x7fffffffu ||
		 (uint64_t)desc->face_count * 12u > 0x7fffffffu || (uint64_t)desc->joint_count * 48u > 0x7fffffffu )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->mode == PLEAT_GL_DEFORMER_HEADLESS && ( desc->host_position_buffer != 0 || desc->host_normal_buffer != 0 ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->body_anchors != NULL )
	{
		if ( desc->body_anchor_normals == NULL || desc->body_anchor_skin_indices == NULL ||
			 desc->body_anchor_skin_weights == NULL || desc->body_anchor_influence_count == 0 ||
			 desc->body_anchor_influence_count > 8 )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		for ( size_t e = 0; e < (size_t)desc->vertex_count * desc->body_anchor_influence_count; ++e )
		{
			if ( desc->body_anchor_skin_indices[e] >= desc->joint_count )
				return PLEAT_RESULT_INVALID_ARGUMENT;
		}
	}
	// The shaders index with these values unchecked, so they are checked once here (an out-of-range GPU read is
	// undefined behaviour without robust buffer access).
	for ( size_t e = 0; e < (size_t)desc->vertex_count * desc->influence_count; ++e )
	{
		if ( desc->skin_indices[e] >= desc->joint_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( size_t e = 0; e < (size_t)desc->face_count * 3u; ++e )
	{
		if ( desc->faces[e] >= desc->vertex_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( desc->adjacency_offsets[0] != 0 || desc->adjacency_offsets[desc->vertex_count] > 3u * desc->face_count )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	for ( uint32_t i = 0; i < desc->vertex_count; ++i )
	{
		if ( desc->adjacency_offsets[i + 1] < desc->adjacency_offsets[i] )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( uint32_t e = 0; e < desc->adjacency_offsets[desc->vertex_count]; ++e )
	{
		if ( desc->adjacency_faces[e] >= desc->face_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	return PLEAT_RESULT_OK;
}

static GLuint plCreateBuffer( plGlDeformer* deformer, plGlBinding binding, size_t bytes, const void* data, GLenum usage )
{
	const plGlApi* api = &deformer->api;
	GLuint buffer = 0;
	api->GenBuffers( 1, &buffer );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->BufferData( GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)bytes, data, usage );
	deformer->owned[binding] = buffer;
	deformer->bindings[binding] = buffer;
	return buffer;
}

// [N][3] → vec4 rows (w = w_value).
static void plToVec4( plGlVec4* rows, const float* xyz, uint32_t count, float w_value )
{
	for ( uint32_t i = 0; i < count; ++i )
		rows[i] = ( plGlVec4 ){ xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], w_value };
}

// The shaped template, then (with body anchors) the anchors of the same β in rows N..2N−1: one BufferSubData.
static void plUploadShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_anchors )
{
	const plGlApi* api = &deformer->api;
	plGlVec4* rows = deformer->staging;
	uint32_t n = deformer->vertex_count;
	plToVec4( rows, shaped_template, n, 1.0f );
	int anchors = deformer->anchor_influence_count > 0;
	if ( anchors )
		plToVec4( rows + n, body_anchors, n, 1.0f );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_SHAPED_TEMPLATE] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)n * 16 * ( anchors ? 2 : 1 ), rows );
}

// Rewrites the two body-contact fields of the params buffer (the rest never changes).
static void plUploadContactParams( plGlDeformer* deformer )
{
	const plGlApi* api = &deformer->api;
	float offset = deformer->body_contact_offset_m;
	api->BindBuffer( GL_UNIFORM_BUFFER, deformer->params_buffer );
	api->BufferSubData( GL_UNIFORM_BUFFER, (GLintptr)offsetof( plGlDeformParams, body_contact_offset_m ), 4, &offset );
}

// [D][N][3] → [D][N] vec4 (fp32) or plGlHalf4 (fp16), one blend shape at a time through the staging block.
static void plUploadBlendShapes( plGlDeformer* deformer, const void* blend_shapes, int fp16 )
{
	const plGlApi* api = &deformer->api;
	size_t n = deformer->vertex_count;
	size_t row_bytes = fp16 ? sizeof( plGlHalf4 ) : sizeof( plGlVec4 );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_BLEND_SHAPES, row_bytes * n * deformer->blend_count, NULL,
					GL_STATIC_DRAW );
	for ( uint32_t j = 0; j < deformer->blend_count; ++j )
	{
		if ( fp16 )
		{
			const uint16_t* shape = (const uint16_t*)blend_shapes + (size_t)j * n * 3;
			plGlHalf4* rows = deformer->staging;
			for ( size_t i = 0; i < n; ++i )
				rows[i] = ( plGlHalf4 ){ shape[3 * i], shape[3 * i + 1], shape[3 * i + 2], 0 };
		}
		else
		{
			const float* shape = (const float*)blend_shapes + (size_t)j * n * 3;
			plGlVec4* rows = deformer->staging;
			for ( size_t i = 0; i < n; ++i )
				rows[i] = ( plGlVec4 ){ shape[3 * i], shape[3 * i + 1], shape[3 * i + 2], 0.0f };
		}
		api->BufferSubData( GL_SHADER_STORAGE_BUFFER, (GLintptr)( row_bytes * n * j ), (GLsizeiptr)( row_bytes * n ),
							deformer->staging );
	}
}

static plResult plCheckHostBuffer( const plGlApi* api, GLuint buffer, uint32_t vertex_count )
{
	if ( !api->IsBuffer( buffer ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	GLint64 size = 0;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->GetBufferParameteri64v( GL_SHADER_STORAGE_BUFFER, GL_BUFFER_SIZE, &size );
	return size >= (GLint64)vertex_count * 16 ? PLEAT_RESULT_OK : PLEAT_RESULT_BUFFER_TOO_SMALL;
}

// Everything of Create that needs GL; runs between plBegin and plEnd.
static plResult plCreateGlObjects( plGlDeformer* deformer, const plGlDeformerDesc* desc )
{
	const plGlApi* api = &deformer->api;
	if ( plGlApi_CurrentVersion( api ) < 43 )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	// A host context may have errors pending from the engine; they are not ours to report.
	plCheckErrors( api );

	plResult result = PLEAT_RESULT_OK;
	if ( desc->host_position_buffer != 0 )
		result = plCheckHostBuffer( api, desc->host_position_buffer, desc->vertex_count );
	if ( result == PLEAT_RESULT_OK && desc->host_normal_buffer != 0 )
		result = plCheckHostBuffer( api, desc->host_normal_buffer, desc->vertex_count );
	if ( result != PLEAT_RESULT_OK )
		return result;

	deformer->programs[PLEAT_GL_PROGRAM_BLEND_SHAPES] = plCompileProgram(
		api, plGlShaderSource_blend_shapes,
		desc->blend_shapes_fp16 ? "#define PLEAT_BLEND_FP16 1\n" : "#define PLEAT_BLEND_FP16 0\n" );
	deformer->programs[PLEAT_GL_PROGRAM_SKINNING] = plCompileProgram( api, plGlShaderSource_skinning, "" );
	deformer->programs[PLEAT_GL_PROGRAM_FACE_NORMALS] = plCompileProgram( api, plGlShaderSource_face_normals, "" );
	deformer->programs[PLEAT_GL_PROGRAM_NORMALS_GATHER] = plCompileProgram( api, plGlShaderSource_normals_gather, "" );
	uint32_t Ka = deformer->anchor_influence_count;
	if ( Ka > 0 )
		deformer->programs[PLEAT_GL_PROGRAM_BODY_CONTACT] = plCompileProgram( api, plGlShaderSource_body_contact, "" );
	for ( int p = 0; p < PLEAT_GL_PROGRAM_COUNT; ++p )
	{
		if ( deformer->programs[p] == 0 && ( p != PLEAT_GL_PROGRAM_BODY_CONTACT || Ka > 0 ) )
			return PLEAT_RESULT_GL_ERROR;
	}

	size_t n = desc->vertex_count;
	plGlDeformParams params = { desc->vertex_count, desc->blend_count, desc->influence_count,   desc->joint_count,
								desc->face_count,   Ka,                deformer->body_contact_offset_m, 0 };
	api->GenBuffers( 1, &deformer->params_buffer );
	api->BindBuffer( GL_UNIFORM_BUFFER, deformer->params_buffer );
	api->BufferData( GL_UNIFORM_BUFFER, sizeof( params ), &params, GL_STATIC_DRAW );

	plCreateBuffer( deformer, PLEAT_GL_BINDING_SHAPED_TEMPLATE, n * 16 * ( Ka > 0 ? 2 : 1 ), NULL, GL_DYNAMIC_DRAW );
	plUploadShapedTemplate( deformer, desc->shaped_template, desc->body_anchors );
	plUploadBlendShapes( deformer, desc->blend_shapes, desc->blend_shapes_fp16 );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_BLEND_WEIGHTS, (size_t)desc->blend_count * 4, NULL, GL_STREAM_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_DEFORMED, n * 16, NULL, GL_DYNAMIC_COPY );

	uint32_t* skin_indices = deformer->staging; // u16 → the shader's uint
	for ( size_t e = 0; e < n * desc->influence_count; ++e )
		skin_indices[e] = desc->skin_indices[e];
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_INDICES, n * desc->influence_count * 4, skin_indices,
					GL_STATIC_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_WEIGHTS, n * desc->influence_count * 4, desc->skin_weights,
					GL_STATIC_DRAW );
	// [J][3][4] row-major floats are already three vec4 rows per joint.
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_MATRICES, (size_t)desc->joint_count * 48, NULL, GL_STREAM_DRAW );

	if ( desc->host_position_buffer != 0 )
		deformer->bindings[PLEAT_GL_BINDING_POSITIONS] = desc->host_position_buffer;
	else
		plCreateBuffer( deformer, PLEAT_GL_BINDING_POSITIONS, n * 16, NULL, GL_DYNAMIC_COPY );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_FACES, (size_t)desc->face_count * 12, desc->faces, GL_STATIC_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_ADJACENCY_OFFSETS, ( n + 1 ) * 4, desc->adjacency_offsets,
					GL_STATIC_DRAW );
	// At least one element: a zero-sized buffer cannot be bound.
	size_t adjacency_count = desc->adjacency_offsets[n] > 0 ? desc->adjacency_offsets[n] : 1;
	plCreateBuffer( deformer, PLEAT_GL_BINDING_ADJACENCY_FACES, adjacency_count * 4, desc->adjacency_faces,
					GL_STATIC_DRAW );
	if ( desc->host_normal_buffer != 0 )
		deformer->bindings[PLEAT_GL_BINDING_NORMALS] = desc->host_normal_buffer;
	else
		plCreateBuffer( deformer, PLEAT_GL_BINDING_NORMALS, n * 16, NULL, GL_DYNAMIC_COPY );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_FACE_NORMALS, (size_t)desc->face_count * 16, NULL, GL_DYNAMIC_COPY );
	if ( Ka > 0 )
	{
		plGlVec4* rows = deformer->staging;
		plToVec4( rows, desc->body_anchor_normals, desc->vertex_count, 0.0f );
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_NORMALS, n * 16, rows, GL_STATIC_DRAW );
		uint32_t* indices = deformer->staging; // u16 → the shader's uint
		for ( size_t e = 0; e < n * Ka; ++e )
			indices[e] = desc->body_anchor_skin_indices[e];
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_SKIN_INDICES, n * Ka * 4, indices, GL_STATIC_DRAW );
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS, n * Ka * 4, desc->body_anchor_skin_weights,
						GL_STATIC_DRAW );
	}
	else
	{
		// Nothing reads them, but every binding point gets a buffer, as the shaders' other buffers do.
		for ( int b = PLEAT_GL_BINDING_ANCHOR_NORMALS; b <= PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS; ++b )
			plCreateBuffer( deformer, (plGlBinding)b, 16, NULL, GL_STATIC_DRAW );
	}
	return plCheckErrors( api );
}

static void plDeleteGlObjects( plGlDeformer* deformer )
{
	const plGlApi* api = &deformer->api;
	for ( int p = 0; p < PLEAT_GL_PROGRAM_COUNT; ++p )
	{
		if ( deformer->programs[p] != 0 )
			api->DeleteProgram( deformer->programs[p] );
	}
	if ( deformer->params_buffer != 0 )
		api->DeleteBuffers( 1, &deformer->params_buffer );
	for ( int b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
	{
		if ( deformer->owned[b] != 0 )
			api->DeleteBuffers( 1, &deformer->owned[b] );
	}
}

static void plFreeDeformer( plGlDeformer* deformer )
{
	plAllocator allocator = deformer->allocator;
	if ( deformer->context != NULL )
		plGlContext_Destroy( deformer->context );
	plFree( &allocator, deformer->staging, deformer->staging_bytes );
	plFree( &allocator, deformer, sizeof( *deformer ) );
}

static plResult plCreate( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlHeadlessBackend backend,
						  plGlDeformer** out )
{
	if ( out == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	*out = NULL;
	if ( desc == NULL || allocator == NULL ||
		 ( desc->mode != PLEAT_GL_DEFORMER_HOST_CONTEXT && desc->mode != PLEAT_GL_DEFORMER_HEADLESS ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plValidateDesc( desc );
	if ( result != PLEAT_RESULT_OK )
		return result;

	plGlDeformer* deformer = plAllocZeroed( allocator, sizeof( *deformer ), 16 );
	if ( deformer == NULL )
		return PLEAT_RESULT_OUT_OF_MEMORY;
	deformer->allocator = *allocator;
	deformer->mode = desc->mode;
	deformer->vertex_count = desc->vertex_count;
	deformer->face_count = desc->face_count;
	deformer->blend_count = desc->blend_count;
	deformer->influence_count = desc->influence_count;
	deformer->joint_count = desc->joint_count;
	deformer->anchor_influence_count = desc->body_anchors != NULL ? desc->body_anchor_influence_count : 0;
	deformer->body_contact = deformer->anchor_influence_count > 0;
	deformer->body_contact_offset_m = PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M;
	size_t n = desc->vertex_count;
	// Staging holds the largest upload: 2N vec4 rows (template + anchors), N vec4 rows, or [N][K] / [N][Ka] uints.
	size_t rows = n * 16 * ( deformer->anchor_influence_count > 0 ? 2 : 1 );
	size_t widest_skin = desc->influence_count > deformer->anchor_influence_count ? desc->influence_count
																				 : deformer->anchor_influence_count;
	deformer->staging_bytes = rows > n * 4 * widest_skin ? rows : n * 4 * widest_skin;
	deformer->staging = plAlloc( allocator, deformer->staging_bytes, 64 );
	if ( deformer->staging == NULL )
	{
		plFreeDeformer( deformer );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}

	if ( desc->mode == PLEAT_GL_DEFORMER_HEADLESS )
	{
		result = plGlContext_Create( backend, allocator, &deformer->context, desc->report, desc->report_size );
		if ( result != PLEAT_RESULT_OK )
		{
			plFreeDeformer( deformer );
			return result;
		}
		deformer->api = *plGlContext_Api( deformer->context );
	}
	else
	{
		plGlApi_LoadEpoxy( &deformer->api );
		// Without a current context epoxy cannot resolve anything beyond GL 1.x; glGetString answers NULL then.
		if ( deformer->api.GetString( GL_VERSION ) == NULL )
		{
			plFreeDeformer( deformer );
			return PLEAT_RESULT_GL_UNAVAILABLE;
		}
	}

	result = plBegin( deformer );
	if ( result == PLEAT_RESULT_OK )
	{
		result = plCreateGlObjects( deformer, desc );
		if ( result != PLEAT_RESULT_OK )
		{
			plDeleteGlObjects( deformer );
			plCheckErrors( &deformer->api );
		}
		plEnd( deformer );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		plFreeDeformer( deformer );
		return result;
	}
	*out = deformer;
	return PLEAT_RESULT_OK;
}

plResult plGlDeformer_Create( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlDeformer** out )
{
	return plCreate( desc, allocator, PLEAT_GL_HEADLESS_AUTO, out );
}

plResult plGlDeformer_CreateHeadless( const plGlDeformerDesc* desc, const plAllocator* allocator,
									  plGlHeadlessBackend backend, plGlDeformer** out )
{
	if ( desc == NULL || desc->mode != PLEAT_GL_DEFORMER_HEADLESS )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	return plCreate( desc, allocator, backend, out );
}

plGlHeadlessBackend plGlDeformer_Backend( const plGlDeformer* deformer )
{
	return deformer->context != NULL ? plGlContext_Backend( deformer->context ) : PLEAT_GL_HEADLESS_AUTO;
}

plGlHeadlessPlatform plGlDeformer_Platform( const plGlDeformer* deformer )
{
	return deformer->context != NULL ? plGlContext_Platform( deformer->context ) : PLEAT_GL_PLATFORM_NONE;
}

plResult plGlDeformer_SetShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_anchors )
{
	if ( deformer == NULL || shaped_template == NULL || ( deformer->anchor_influence_count > 0 && body_anchors == NULL ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plCheckErrors( &deformer->api ); // an error the engine left pending is not ours to report
	plUploadShapedTemplate( deformer, shaped_template, body_anchors );
	result = plCheckErrors( &deformer->api );
	plEnd( deformer );
	return result;
}

// Reads one vec4 [N] buffer back and drops w: out is [N][3].
static void plReadBack( plGlDeformer* deformer, GLuint buffer, float* out )
{
	const plGlApi* api = &deformer->api;
	plGlVec4* rows = deformer->staging;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->vertex_count * 16, rows );
	for ( uint32_t i = 0; i < deformer->vertex_count; ++i )
	{
		out[3 * i] = rows[i].x;
		out[3 * i + 1] = rows[i].y;
		out[3 * i + 2] = rows[i].z;
	}
}

plResult plGlDeformer_SetBodyContact( plGlDeformer* deformer, int enabled, float offset_m )
{
	if ( deformer == NULL || !( offset_m >= 0.0f && offset_m <= PLEAT_BODY_CONTACT_MAX_OFFSET_M ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	int active = enabled != 0 && deformer->anchor_influence_count > 0;
	if ( offset_m == deformer->body_contact_offset_m || deformer->anchor_influence_count == 0 )
	{
		deformer->body_contact = active;
		return PLEAT_RESULT_OK;
	}
	plResult result = plBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plCheckErrors( &deformer->api ); // an error the engine left pending is not ours to report
	float previous = deformer->body_contact_offset_m;
	deformer->body_contact_offset_m = offset_m;
	plUploadContactParams( deformer );
	result = plCheckErrors( &deformer->api );
	if ( result == PLEAT_RESULT_OK )
		deformer->body_contact = active;
	else
		deformer->body_contact_offset_m = previous; // GL ignored the upload: nothing changed
	plEnd( deformer );
	return result;
}

plResult plGlDeformer_Run( plGlDeformer* deformer, const float* blend_weights, const float* skin_matrices,
						   float* positions, float* normals )
{
	if ( deformer == NULL || blend_weights == NULL || skin_matrices == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	const plGlApi* api = &deformer->api;
	plCheckErrors( api ); // an error the engine left pending is not ours to report

	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_BLEND_WEIGHTS] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->blend_count * 4, blend_weights );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_SKIN_MATRICES] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->joint_count * 48, skin_matrices );

	api->BindBufferBase( GL_UNIFORM_BUFFER, PLEAT_GL_PARAMS_BINDING, deformer->params_buffer );
	for ( GLuint b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
		api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, b, deformer->bindings[b] );

	GLuint groups = ( deformer->vertex_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE;
	GLuint face_groups = ( deformer->face_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE;
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_BLEND_SHAPES] );
	api->DispatchCompute( groups, 1, 1 );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_SKINNING] );
	api->DispatchCompute( groups, 1, 1 );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	if ( deformer->body_contact )
	{
		api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_BODY_CONTACT] );
		api->DispatchCompute( groups, 1, 1 );
		api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	}
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_FACE_NORMALS] );
	api->DispatchCompute( face_groups, 1, 1 );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_NORMALS_GATHER] );
	api->DispatchCompute( groups, 1, 1 );
	// Whatever reads the outputs next: our read-back, or the engine's vertex fetch / shaders from its buffers.
	api->MemoryBarrier( GL_BUFFER_UPDATE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT |
						GL_SHADER_STORAGE_BARRIER_BIT );

	if ( positions != NULL )
		plReadBack( deformer, deformer->bindings[PLEAT_GL_BINDING_POSITIONS], positions );
	if ( normals != NULL )
		plReadBack( deformer, deformer->bindings[PLEAT_GL_BINDING_NORMALS], normals );
	result = plCheckErrors( api );
	plEnd( deformer );
	return result;
}

void plGlDeformer_Destroy( plGlDeformer* deformer )
{
	if ( deformer == NULL )
		return;
	if ( plBegin( deformer ) == PLEAT_RESULT_OK )
	{
		plDeleteGlObjects( deformer );
		plEnd( deformer );
	}
	plFreeDeformer( deformer );
}
