// The helpers every file of the GL path uses, below all of them: one counted dispatch, a storage buffer, a compute
// program from a shader source, draining the error flags.
#include "gl_deformer_data.h"
#include <string.h>

_Atomic uint64_t g_plGlDispatches;
_Atomic uint64_t g_plGlProgramsCompiled;

// One dispatch, counted (tests check that a batch runs one per shader).
void plGlDispatch( const plGlApi* api, GLuint groups_x, GLuint groups_y )
{
	api->DispatchCompute( groups_x, groups_y, 1 );
	atomic_fetch_add_explicit( &g_plGlDispatches, 1, memory_order_relaxed );
}

GLuint plGlNewStorageBuffer( const plGlApi* api, size_t bytes, const void* data, GLenum usage )
{
	GLuint buffer = 0;
	api->GenBuffers( 1, &buffer );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->BufferData( GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)bytes, data, usage );
	return buffer;
}

// Drains the GL error flags; GL_ERROR if any was set. (In host-context mode this also consumes an error the engine
// left pending before the call; docs/gpu.md says so.)
plResult plGlCheckErrors( const plGlApi* api )
{
	plResult result = PLEAT_RESULT_OK;
	for ( int i = 0; i < 16 && api->GetError() != GL_NO_ERROR; ++i )
		result = PLEAT_RESULT_GL_ERROR;
	return result;
}

GLuint plGlCompileProgram( const plGlApi* api, const char* source, const char* defines )
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
	atomic_fetch_add_explicit( &g_plGlProgramsCompiled, 1, memory_order_relaxed );
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
