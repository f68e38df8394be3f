// Headless GL rendering for the sample renderer: EGL surfaceless context through libepoxy, MSAA FBO, one shader.
#include "render_gl.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct RenderGl
{
	EGLDisplay display;
	EGLContext context;
	int version;
	int width;
	int height;
	GLuint msaa_fbo, msaa_color, msaa_depth;
	GLuint resolve_fbo, resolve_color;
	GLuint program;
	GLint u_view_projection, u_eye, u_base_color, u_inside_shade, u_ground, u_shadow_center, u_key_dir, u_fill_dir,
		u_fog_color, u_fog_range;
	GLuint ground_vao, ground_vbo;
	float eye[3];
	float fog_color[3];
	uint8_t* readback; // [height][width][4], bottom row first
};

struct RenderMesh
{
	RenderGl* gl;
	uint32_t vertex_count;
	GLsizei index_count;
	GLuint vao, ebo;
	GLuint position_buffer, normal_buffer;
	int owns_buffers;
};

static const char* s_vertex_shader = "#version 330 core\n"
									 "layout(location = 0) in vec3 position;\n"
									 "layout(location = 1) in vec3 normal;\n"
									 "uniform mat4 view_projection;\n"
									 "out vec3 world_position;\n"
									 "out vec3 world_normal;\n"
									 "void main() {\n"
									 "  world_position = position;\n"
									 "  world_normal = normal;\n"
									 "  gl_Position = view_projection * vec4(position, 1.0);\n"
									 "}\n";

// Lighting in linear space, written out as sRGB: a warm key light and a cool fill from the camera's side, a sky/ground
// hemisphere ambient and a little rim. The ground is a checkerboard with a soft contact shadow, fading into fog.
static const char* s_fragment_shader =
	"#version 330 core\n"
	"in vec3 world_position;\n"
	"in vec3 world_normal;\n"
	"uniform vec3 eye;\n"
	"uniform vec3 base_color;\n"
	"uniform float inside_shade;\n"
	"uniform int ground;\n"
	"uniform vec3 shadow_center;\n"
	"uniform vec3 key_dir;\n"
	"uniform vec3 fill_dir;\n"
	"uniform vec3 fog_color;\n"
	"uniform vec2 fog_range;\n"
	"out vec4 frag_color;\n"
	"void main() {\n"
	"  vec3 to_eye = normalize(eye - world_position);\n"
	"  vec3 albedo = pow(base_color, vec3(2.2));\n"
	"  vec3 n;\n"
	"  float occlusion = 1.0;\n"
	"  if (ground == 1) {\n"
	"    n = vec3(0.0, 1.0, 0.0);\n"
	"    vec2 cell = floor(world_position.xz / 0.5);\n"
	"    float checker = mod(cell.x + cell.y, 2.0);\n"
	"    albedo = pow(mix(vec3(0.60, 0.60, 0.58), vec3(0.70, 0.70, 0.68), checker), vec3(2.2));\n"
	"    float r = length(world_position.xz - shadow_center.xz);\n"
	"    occlusion = mix(0.45, 1.0, smoothstep(0.05, 0.55, r));\n"
	"  } else {\n"
	"    n = normalize(world_normal);\n"
	"    if (!gl_FrontFacing) { n = -n; albedo *= inside_shade; }\n"
	"  }\n"
	"  float hemi = 0.5 + 0.5 * n.y;\n"
	"  vec3 ambient = mix(vec3(0.20, 0.18, 0.16), vec3(0.42, 0.46, 0.55), hemi);\n"
	"  float key = max(dot(n, key_dir), 0.0);\n"
	"  float fill = max(dot(n, fill_dir), 0.0);\n"
	"  float rim = pow(1.0 - max(dot(n, to_eye), 0.0), 3.0);\n"
	"  float spec = pow(max(dot(n, normalize(key_dir + to_eye)), 0.0), 24.0);\n"
	"  vec3 light = ambient * occlusion + key * vec3(1.00, 0.96, 0.90) * 0.95 + fill * vec3(0.55, 0.62, 0.75) * 0.35;\n"
	"  vec3 c = albedo * light + vec3(0.06) * spec + vec3(0.10, 0.11, 0.13) * rim * (1.0 - float(ground));\n"
	"  float d = length(eye - world_position);\n"
	"  c = mix(c, pow(fog_color, vec3(2.2)), smoothstep(fog_range.x, fog_range.y, d));\n"
	"  frag_color = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);\n"
	"}\n";

static int createContext( RenderGl* gl )
{
	const char* client = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	if ( client == NULL || !epoxy_extension_in_string( client, "EGL_MESA_platform_surfaceless" ) )
	{
		fprintf( stderr, "render: EGL_MESA_platform_surfaceless is not available\n" );
		return -1;
	}
	gl->display = eglGetPlatformDisplayEXT( EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL );
	EGLint major = 0, minor = 0;
	if ( gl->display == EGL_NO_DISPLAY || !eglInitialize( gl->display, &major, &minor ) ||
		 !eglBindAPI( EGL_OPENGL_API ) )
	{
		fprintf( stderr, "render: cannot initialise the EGL surfaceless display\n" );
		return -1;
	}
	const EGLint config_attribs[] = { EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
									  EGL_NONE };
	EGLConfig config = NULL;
	EGLint config_count = 0;
	if ( !eglChooseConfig( gl->display, config_attribs, &config, 1, &config_count ) || config_count < 1 )
	{
		config = NULL; // EGL_KHR_no_config_context, which Mesa has
	}
	static const int versions[][2] = { { 4, 3 }, { 3, 3 } };
	for ( int i = 0; i < 2 && gl->context == EGL_NO_CONTEXT; ++i )
	{
		const EGLint context_attribs[] = { EGL_CONTEXT_MAJOR_VERSION, versions[i][0], EGL_CONTEXT_MINOR_VERSION,
										   versions[i][1], EGL_CONTEXT_OPENGL_PROFILE_MASK,
										   EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE };
		gl->context = eglCreateContext( gl->display, config, EGL_NO_CONTEXT, context_attribs );
		gl->version = versions[i][0] * 10 + versions[i][1];
	}
	if ( gl->context == EGL_NO_CONTEXT ||
		 !eglMakeCurrent( gl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, gl->context ) )
	{
		fprintf( stderr, "render: cannot create a GL 3.3+ core context (EGL error 0x%x)\n", eglGetError() );
		return -1;
	}
	return 0;
}

static GLuint compileShader( GLenum type, const char* source )
{
	GLuint shader = glCreateShader( type );
	glShaderSource( shader, 1, &source, NULL );
	glCompileShader( shader );
	GLint ok = 0;
	glGetShaderiv( shader, GL_COMPILE_STATUS, &ok );
	if ( !ok )
	{
		char log[2048];
		glGetShaderInfoLog( shader, sizeof( log ), NULL, log );
		fprintf( stderr, "render: shader compile failed:\n%s\n", log );
		glDeleteShader( shader );
		return 0;
	}
	return shader;
}

static int createProgram( RenderGl* gl )
{
	GLuint vs = compileShader( GL_VERTEX_SHADER, s_vertex_shader );
	GLuint fs = compileShader( GL_FRAGMENT_SHADER, s_fragment_shader );
	if ( vs == 0 || fs == 0 )
	{
		return -1;
	}
	gl->program = glCreateProgram();
	glAttachShader( gl->program, vs );
	glAttachShader( gl->program, fs );
	glLinkProgram( gl->program );
	glDeleteShader( vs );
	glDeleteShader( fs );
	GLint ok = 0;
	glGetProgramiv( gl->program, GL_LINK_STATUS, &ok );
	if ( !ok )
	{
		fprintf( stderr, "render: shader link failed\n" );
		return -1;
	}
	gl->u_view_projection = glGetUniformLocation( gl->program, "view_projection" );
	gl->u_eye = glGetUniformLocation( gl->program, "eye" );
	gl->u_base_color = glGetUniformLocation( gl->program, "base_color" );
	gl->u_inside_shade = glGetUniformLocation( gl->program, "inside_shade" );
	gl->u_ground = glGetUniformLocation( gl->program, "ground" );
	gl->u_shadow_center = glGetUniformLocation( gl->program, "shadow_center" );
	gl->u_key_dir = glGetUniformLocation( gl->program, "key_dir" );
	gl->u_fill_dir = glGetUniformLocation( gl->program, "fill_dir" );
	gl->u_fog_color = glGetUniformLocation( gl->program, "fog_color" );
	gl->u_fog_range = glGetUniformLocation( gl->program, "fog_range" );
	return 0;
}

static int createFramebuffers( RenderGl* gl )
{
	GLint max_samples = 0;
	glGetIntegerv( GL_MAX_SAMPLES, &max_samples );
	GLsizei samples = max_samples < 4 ? max_samples : 4;

	glGenRenderbuffers( 1, &gl->msaa_color );
	glBindRenderbuffer( GL_RENDERBUFFER, gl->msaa_color );
	glRenderbufferStorageMultisample( GL_RENDERBUFFER, samples, GL_RGBA8, gl->width, gl->height );
	glGenRenderbuffers( 1, &gl->msaa_depth );
	glBindRenderbuffer( GL_RENDERBUFFER, gl->msaa_depth );
	glRenderbufferStorageMultisample( GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, gl->width, gl->height );
	glGenFramebuffers( 1, &gl->msaa_fbo );
	glBindFramebuffer( GL_FRAMEBUFFER, gl->msaa_fbo );
	glFramebufferRenderbuffer( GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, gl->msaa_color );
	glFramebufferRenderbuffer( GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, gl->msaa_depth );
	if ( glCheckFramebufferStatus( GL_FRAMEBUFFER ) != GL_FRAMEBUFFER_COMPLETE )
	{
		fprintf( stderr, "render: the MSAA framebuffer is incomplete\n" );
		return -1;
	}

	glGenRenderbuffers( 1, &gl->resolve_color );
	glBindRenderbuffer( GL_RENDERBUFFER, gl->resolve_color );
	glRenderbufferStorage( GL_RENDERBUFFER, GL_RGBA8, gl->width, gl->height );
	glGenFramebuffers( 1, &gl->resolve_fbo );
	glBindFramebuffer( GL_FRAMEBUFFER, gl->resolve_fbo );
	glFramebufferRenderbuffer( GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, gl->resolve_color );
	if ( glCheckFramebufferStatus( GL_FRAMEBUFFER ) != GL_FRAMEBUFFER_COMPLETE )
	{
		fprintf( stderr, "render: the resolve framebuffer is incomplete\n" );
		return -1;
	}
	return 0;
}

RenderGl* renderGl_Create( int width, int height )
{
	RenderGl* gl = calloc( 1, sizeof( RenderGl ) );
	if ( gl == NULL )
	{
		return NULL;
	}
	gl->width = width;
	gl->height = height;
	gl->context = EGL_NO_CONTEXT;
	gl->fog_color[0] = 0.80f;
	gl->fog_color[1] = 0.83f;
	gl->fog_color[2] = 0.87f;
	gl->readback = malloc( (size_t)width * (size_t)height * 4 );
	if ( gl->readback == NULL || createContext( gl ) != 0 || createProgram( gl ) != 0 || createFramebuffers( gl ) != 0 )
	{
		renderGl_Destroy( gl );
		return NULL;
	}
	// A 60 m ground square at y = 0, moved under the camera target each frame through its vertices.
	glGenVertexArrays( 1, &gl->ground_vao );
	glGenBuffers( 1, &gl->ground_vbo );
	glBindVertexArray( gl->ground_vao );
	glBindBuffer( GL_ARRAY_BUFFER, gl->ground_vbo );
	glBufferData( GL_ARRAY_BUFFER, 4 * 3 * sizeof( float ), NULL, GL_DYNAMIC_DRAW );
	glEnableVertexAttribArray( 0 );
	glVertexAttribPointer( 0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof( float ), NULL );
	glVertexAttrib3f( 1, 0.0f, 1.0f, 0.0f );
	glBindVertexArray( 0 );
	return gl;
}

void renderGl_Destroy( RenderGl* gl )
{
	if ( gl == NULL )
	{
		return;
	}
	if ( gl->context != EGL_NO_CONTEXT )
	{
		if ( gl->program != 0 )
		{
			glDeleteProgram( gl->program );
		}
		glDeleteVertexArrays( 1, &gl->ground_vao );
		glDeleteBuffers( 1, &gl->ground_vbo );
		glDeleteFramebuffers( 1, &gl->msaa_fbo );
		glDeleteFramebuffers( 1, &gl->resolve_fbo );
		glDeleteRenderbuffers( 1, &gl->msaa_color );
		glDeleteRenderbuffers( 1, &gl->msaa_depth );
		glDeleteRenderbuffers( 1, &gl->resolve_color );
		eglMakeCurrent( gl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT );
		eglDestroyContext( gl->display, gl->context );
	}
	if ( gl->display != EGL_NO_DISPLAY && gl->display != NULL )
	{
		eglTerminate( gl->display );
	}
	free( gl->readback );
	free( gl );
}

int renderGl_Version( const RenderGl* gl )
{
	return gl->version;
}

uint32_t renderGl_CreateVec4Buffer( RenderGl* gl, uint32_t vertex_count )
{
	(void)gl;
	GLuint buffer = 0;
	glGenBuffers( 1, &buffer );
	glBindBuffer( GL_ARRAY_BUFFER, buffer );
	glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)vertex_count * 4 * (GLsizeiptr)sizeof( float ), NULL, GL_DYNAMIC_DRAW );
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	return buffer;
}

void renderGl_DeleteBuffer( RenderGl* gl, uint32_t buffer )
{
	(void)gl;
	GLuint name = buffer;
	glDeleteBuffers( 1, &name );
}

RenderMesh* renderMesh_Create( RenderGl* gl, uint32_t vertex_count, const uint32_t* faces, uint32_t face_count,
							   uint32_t position_buffer, uint32_t normal_buffer )
{
	RenderMesh* mesh = calloc( 1, sizeof( RenderMesh ) );
	if ( mesh == NULL )
	{
		return NULL;
	}
	mesh->gl = gl;
	mesh->vertex_count = vertex_count;
	mesh->index_count = (GLsizei)face_count * 3;
	mesh->owns_buffers = position_buffer == 0;
	GLsizei stride = mesh->owns_buffers ? 3 * sizeof( float ) : 4 * sizeof( float );
	if ( mesh->owns_buffers )
	{
		GLuint buffers[2];
		glGenBuffers( 2, buffers );
		position_buffer = buffers[0];
		normal_buffer = buffers[1];
		for ( int i = 0; i < 2; ++i )
		{
			glBindBuffer( GL_ARRAY_BUFFER, buffers[i] );
			glBufferData( GL_ARRAY_BUFFER, (GLsizeiptr)vertex_count * 3 * (GLsizeiptr)sizeof( float ), NULL,
						  GL_STREAM_DRAW );
		}
	}
	mesh->position_buffer = position_buffer;
	mesh->normal_buffer = normal_buffer;
	glGenVertexArrays( 1, &mesh->vao );
	glBindVertexArray( mesh->vao );
	glBindBuffer( GL_ARRAY_BUFFER, position_buffer );
	glEnableVertexAttribArray( 0 );
	glVertexAttribPointer( 0, 3, GL_FLOAT, GL_FALSE, stride, NULL );
	glBindBuffer( GL_ARRAY_BUFFER, normal_buffer );
	glEnableVertexAttribArray( 1 );
	glVertexAttribPointer( 1, 3, GL_FLOAT, GL_FALSE, stride, NULL );
	glGenBuffers( 1, &mesh->ebo );
	glBindBuffer( GL_ELEMENT_ARRAY_BUFFER, mesh->ebo );
	glBufferData( GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)face_count * 3 * (GLsizeiptr)sizeof( uint32_t ), faces,
				  GL_STATIC_DRAW );
	glBindVertexArray( 0 );
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	return mesh;
}

void renderMesh_Update( RenderMesh* mesh, const float* positions, const float* normals )
{
	GLsizeiptr bytes = (GLsizeiptr)mesh->vertex_count * 3 * (GLsizeiptr)sizeof( float );
	glBindBuffer( GL_ARRAY_BUFFER, mesh->position_buffer );
	glBufferSubData( GL_ARRAY_BUFFER, 0, bytes, positions );
	glBindBuffer( GL_ARRAY_BUFFER, mesh->normal_buffer );
	glBufferSubData( GL_ARRAY_BUFFER, 0, bytes, normals );
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
}

void renderMesh_Destroy( RenderMesh* mesh )
{
	if ( mesh == NULL )
	{
		return;
	}
	glDeleteVertexArrays( 1, &mesh->vao );
	glDeleteBuffers( 1, &mesh->ebo );
	if ( mesh->owns_buffers )
	{
		GLuint buffers[2] = { mesh->position_buffer, mesh->normal_buffer };
		glDeleteBuffers( 2, buffers );
	}
	free( mesh );
}

static void normalize3( float v[3] )
{
	float length = sqrtf( v[0] * v[0] + v[1] * v[1] + v[2] * v[2] );
	if ( length > 0.0f )
	{
		v[0] /= length;
		v[1] /= length;
		v[2] /= length;
	}
}

static void cross3( float out[3], const float a[3], const float b[3] )
{
	out[0] = a[1] * b[2] - a[2] * b[1];
	out[1] = a[2] * b[0] - a[0] * b[2];
	out[2] = a[0] * b[1] - a[1] * b[0];
}

// Column-major view-projection: a right-handed look-at followed by a GL perspective (near 0.05 m, far 100 m).
static void viewProjection( float out[16], const RenderCamera* camera, float aspect, float basis[3][3] )
{
	float forward[3] = { camera->target[0] - camera->eye[0], camera->target[1] - camera->eye[1],
						 camera->target[2] - camera->eye[2] };
	normalize3( forward );
	const float world_up[3] = { 0.0f, 1.0f, 0.0f };
	float right[3], up[3];
	cross3( right, forward, world_up );
	normalize3( right );
	cross3( up, right, forward );
	float view[16] = { right[0], up[0], -forward[0], 0.0f, right[1], up[1], -forward[1], 0.0f,
					   right[2], up[2], -forward[2], 0.0f, 0.0f, 0.0f, 0.0f, 1.0f };
	for ( int r = 0; r < 3; ++r )
	{
		view[12 + r] = -( view[r] * camera->eye[0] + view[4 + r] * camera->eye[1] + view[8 + r] * camera->eye[2] );
	}
	float near = 0.05f, far = 100.0f;
	float f = 1.0f / tanf( camera->fov_y_deg * 3.14159265f / 360.0f );
	float projection[16] = { 0 };
	projection[0] = f / aspect;
	projection[5] = f;
	projection[10] = ( far + near ) / ( near - far );
	projection[11] = -1.0f;
	projection[14] = 2.0f * far * near / ( near - far );
	for ( int c = 0; c < 4; ++c )
	{
		for ( int r = 0; r < 4; ++r )
		{
			float sum = 0.0f;
			for ( int k = 0; k < 4; ++k )
			{
				sum += projection[k * 4 + r] * view[c * 4 + k];
			}
			out[c * 4 + r] = sum;
		}
	}
	memcpy( basis[0], right, sizeof( right ) );
	memcpy( basis[1], up, sizeof( up ) );
	memcpy( basis[2], forward, sizeof( forward ) );
}

void renderGl_BeginFrame( RenderGl* gl, const RenderCamera* camera, const float shadow_center[3] )
{
	float matrix[16], basis[3][3];
	viewProjection( matrix, camera, (float)gl->width / (float)gl->height, basis );
	memcpy( gl->eye, camera->eye, sizeof( gl->eye ) );

	glBindFramebuffer( GL_FRAMEBUFFER, gl->msaa_fbo );
	glViewport( 0, 0, gl->width, gl->height );
	glClearColor( gl->fog_color[0], gl->fog_color[1], gl->fog_color[2], 1.0f );
	glClear( GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT );
	glEnable( GL_DEPTH_TEST );
	glDisable( GL_CULL_FACE ); // garments are open: their insides show at the neck and sleeves
	glUseProgram( gl->program );
	glUniformMatrix4fv( gl->u_view_projection, 1, GL_FALSE, matrix );
	glUniform3fv( gl->u_eye, 1, camera->eye );
	glUniform3fv( gl->u_shadow_center, 1, shadow_center );
	glUniform3fv( gl->u_fog_color, 1, gl->fog_color );
	glUniform2f( gl->u_fog_range, 8.0f, 30.0f );
	// Lights fixed relative to the camera, so every frame is lit the same way: key from the upper left, fill from
	// the right, both slightly from the camera's side.
	float key[3], fill[3];
	for ( int i = 0; i < 3; ++i )
	{
		key[i] = -0.55f * basis[0][i] + 0.75f * basis[1][i] - 0.45f * basis[2][i];
		fill[i] = 0.8f * basis[0][i] + 0.1f * basis[1][i] - 0.5f * basis[2][i];
	}
	normalize3( key );
	normalize3( fill );
	glUniform3fv( gl->u_key_dir, 1, key );
	glUniform3fv( gl->u_fill_dir, 1, fill );

	const float half = 30.0f;
	float cx = camera->target[0], cz = camera->target[2];
	float ground[12] = { cx - half, 0.0f, cz - half, cx + half, 0.0f, cz - half,
						 cx + half, 0.0f, cz + half, cx - half, 0.0f, cz + half };
	glBindBuffer( GL_ARRAY_BUFFER, gl->ground_vbo );
	glBufferSubData( GL_ARRAY_BUFFER, 0, sizeof( ground ), ground );
	glBindBuffer( GL_ARRAY_BUFFER, 0 );
	glUniform1i( gl->u_ground, 1 );
	glUniform3f( gl->u_base_color, 1.0f, 1.0f, 1.0f );
	glUniform1f( gl->u_inside_shade, 1.0f );
	glBindVertexArray( gl->ground_vao );
	glDrawArrays( GL_TRIANGLE_FAN, 0, 4 );
	glBindVertexArray( 0 );
	glUniform1i( gl->u_ground, 0 );
}

void renderGl_DrawMesh( RenderGl* gl, RenderMesh* mesh, const float color[3], float inside_shade )
{
	glUniform3fv( gl->u_base_color, 1, color );
	glUniform1f( gl->u_inside_shade, inside_shade );
	glBindVertexArray( mesh->vao );
	glDrawElements( GL_TRIANGLES, mesh->index_count, GL_UNSIGNED_INT, NULL );
	glBindVertexArray( 0 );
}

int renderGl_EndFrame( RenderGl* gl, RenderImage* image )
{
	glBindFramebuffer( GL_READ_FRAMEBUFFER, gl->msaa_fbo );
	glBindFramebuffer( GL_DRAW_FRAMEBUFFER, gl->resolve_fbo );
	glBlitFramebuffer( 0, 0, gl->width, gl->height, 0, 0, gl->width, gl->height, GL_COLOR_BUFFER_BIT, GL_NEAREST );
	glBindFramebuffer( GL_READ_FRAMEBUFFER, gl->resolve_fbo );
	glPixelStorei( GL_PACK_ALIGNMENT, 1 );
	glReadPixels( 0, 0, gl->width, gl->height, GL_RGBA, GL_UNSIGNED_BYTE, gl->readback );
	glBindFramebuffer( GL_FRAMEBUFFER, 0 );
	GLenum error = glGetError();
	if ( error != GL_NO_ERROR )
	{
		fprintf( stderr, "render: GL error 0x%x\n", error );
		return -1;
	}
	for ( int y = 0; y < gl->height; ++y )
	{
		const uint8_t* src = gl->readback + (size_t)( gl->height - 1 - y ) * (size_t)gl->width * 4;
		uint8_t* dst = image->rgb + (size_t)y * (size_t)image->width * 3;
		for ( int x = 0; x < gl->width; ++x )
		{
			dst[x * 3 + 0] = src[x * 4 + 0];
			dst[x * 3 + 1] = src[x * 4 + 1];
			dst[x * 3 + 2] = src[x * 4 + 2];
		}
	}
	return 0;
}
