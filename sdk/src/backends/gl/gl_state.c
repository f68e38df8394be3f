// The engine's GL state that a host-context deformer changes, saved before each call and restored after it
// (docs/gpu.md lists it).
#include "gl_internal.h"

void plGlSaveState( const plGlApi* api, uint32_t binding_count, plGlSavedState* state )
{
	api->GetIntegerv( GL_CURRENT_PROGRAM, &state->program );
	api->GetIntegerv( GL_SHADER_STORAGE_BUFFER_BINDING, &state->storage_buffer );
	for ( GLuint i = 0; i < binding_count; ++i )
	{
		api->GetIntegeri_v( GL_SHADER_STORAGE_BUFFER_BINDING, i, &state->storage_buffers[i] );
		api->GetInteger64i_v( GL_SHADER_STORAGE_BUFFER_START, i, &state->storage_starts[i] );
		api->GetInteger64i_v( GL_SHADER_STORAGE_BUFFER_SIZE, i, &state->storage_sizes[i] );
	}
	api->GetIntegerv( GL_UNIFORM_BUFFER_BINDING, &state->uniform_buffer );
	api->GetIntegeri_v( GL_UNIFORM_BUFFER_BINDING, PLEAT_GL_PARAMS_BINDING, &state->uniform_binding );
	api->GetInteger64i_v( GL_UNIFORM_BUFFER_START, PLEAT_GL_PARAMS_BINDING, &state->uniform_start );
	api->GetInteger64i_v( GL_UNIFORM_BUFFER_SIZE, PLEAT_GL_PARAMS_BINDING, &state->uniform_size );
	api->GetIntegerv( GL_COPY_READ_BUFFER_BINDING, &state->copy_read_buffer );
	api->GetIntegerv( GL_COPY_WRITE_BUFFER_BINDING, &state->copy_write_buffer );
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

void plGlRestoreState( const plGlApi* api, uint32_t binding_count, const plGlSavedState* state )
{
	for ( GLuint i = 0; i < binding_count; ++i )
		plRestoreIndexed( api, GL_SHADER_STORAGE_BUFFER, i, state->storage_buffers[i], state->storage_starts[i],
						  state->storage_sizes[i] );
	plRestoreIndexed( api, GL_UNIFORM_BUFFER, PLEAT_GL_PARAMS_BINDING, state->uniform_binding, state->uniform_start,
					  state->uniform_size );
	// Indexed binds also set the generic binding, so the generic ones go last.
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, (GLuint)state->storage_buffer );
	api->BindBuffer( GL_UNIFORM_BUFFER, (GLuint)state->uniform_buffer );
	api->BindBuffer( GL_COPY_READ_BUFFER, (GLuint)state->copy_read_buffer );
	api->BindBuffer( GL_COPY_WRITE_BUFFER, (GLuint)state->copy_write_buffer );
	api->UseProgram( (GLuint)state->program );
}
