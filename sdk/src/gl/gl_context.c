#include "gl_context.h"
#include <dlfcn.h>
#include <epoxy/egl.h>
#include <string.h>
#if PLEAT_HAVE_OSMESA
// After epoxy/gl.h, which defines __gl_h_, so GL/gl.h (included by osmesa.h) adds nothing.
#include <GL/osmesa.h>
#else
typedef struct osmesa_context* OSMesaContext;
typedef void ( *OSMESAproc )( void );
#endif

// The OSMesa entry points, looked up with dlsym; the signatures are those of GL/osmesa.h.
typedef OSMesaContext ( *plOSMesaCreateContextAttribsFn )( const int* attribs, OSMesaContext sharelist );
typedef void ( *plOSMesaDestroyContextFn )( OSMesaContext context );
typedef GLboolean ( *plOSMesaMakeCurrentFn )( OSMesaContext context, void* buffer, GLenum type, GLsizei width,
											  GLsizei height );
typedef OSMesaContext ( *plOSMesaGetCurrentContextFn )( void );
typedef OSMESAproc ( *plOSMesaGetProcAddressFn )( const char* name );

struct plGlContext
{
	plAllocator allocator;
	plGlHeadlessBackend backend;
	plGlApi api;

	// EGL
	EGLDisplay egl_display;
	EGLContext egl_context;

	// OSMesa
	void* osmesa_library;
	OSMesaContext osmesa_context;
	plOSMesaDestroyContextFn osmesa_destroy_context;
	plOSMesaMakeCurrentFn osmesa_make_current;
	plOSMesaGetCurrentContextFn osmesa_get_current_context;
	plOSMesaGetProcAddressFn osmesa_get_proc_address;
	uint32_t osmesa_pixel; // the 1×1 colour buffer OSMesaMakeCurrent insists on

	// What was current before Enter, restored by Leave.
	EGLenum saved_api;
	EGLDisplay saved_display;
	EGLSurface saved_draw;
	EGLSurface saved_read;
	EGLContext saved_context;
	OSMesaContext saved_osmesa_context;
};

int plGlApi_CurrentVersion( const plGlApi* api )
{
	const GLubyte* version = api->GetString( GL_VERSION );
	if ( version == NULL || strncmp( (const char*)version, "OpenGL ES", 9 ) == 0 )
		return 0;
	GLint major = 0, minor = 0;
	api->GetIntegerv( GL_MAJOR_VERSION, &major );
	api->GetIntegerv( GL_MINOR_VERSION, &minor );
	return major * 10 + minor;
}

static int plHasExtension( const char* list, const char* name )
{
	size_t length = strlen( name );
	for ( const char* p = list; p != NULL && ( p = strstr( p, name ) ) != NULL; p += length )
	{
		if ( ( p == list || p[-1] == ' ' ) && ( p[length] == ' ' || p[length] == '\0' ) )
			return 1;
	}
	return 0;
}

static void plSaveEglCurrent( plGlContext* context )
{
	context->saved_api = eglQueryAPI();
	// The current context is per API; the SDK only ever binds EGL_OPENGL_API.
	eglBindAPI( EGL_OPENGL_API );
	context->saved_display = eglGetCurrentDisplay();
	context->saved_draw = eglGetCurrentSurface( EGL_DRAW );
	context->saved_read = eglGetCurrentSurface( EGL_READ );
	context->saved_context = eglGetCurrentContext();
}

static void plRestoreEglCurrent( plGlContext* context, EGLDisplay own_display )
{
	if ( context->saved_context != EGL_NO_CONTEXT )
		eglMakeCurrent( context->saved_display, context->saved_draw, context->saved_read, context->saved_context );
	else if ( own_display != EGL_NO_DISPLAY )
		eglMakeCurrent( own_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT );
	eglBindAPI( context->saved_api );
}

static plResult plCreateEgl( plGlContext* context )
{
	// Client extensions: EGL_NO_DISPLAY query is only valid with EGL_EXT_client_extensions (NULL otherwise).
	const char* client_extensions = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	if ( !plHasExtension( client_extensions, "EGL_MESA_platform_surfaceless" ) ||
		 !plHasExtension( client_extensions, "EGL_EXT_platform_base" ) )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	EGLDisplay display = eglGetPlatformDisplayEXT( EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL );
	EGLint major = 0, minor = 0;
	if ( display == EGL_NO_DISPLAY || !eglInitialize( display, &major, &minor ) )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	const char* extensions = eglQueryString( display, EGL_EXTENSIONS );
	if ( !plHasExtension( extensions, "EGL_KHR_surfaceless_context" ) ||
		 !plHasExtension( extensions, "EGL_KHR_create_context" ) )
	{
		eglTerminate( display );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	EGLConfig config = EGL_NO_CONFIG_KHR;
	if ( !plHasExtension( extensions, "EGL_KHR_no_config_context" ) )
	{
		const EGLint config_attribs[] = { EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE };
		EGLint config_count = 0;
		if ( !eglChooseConfig( display, config_attribs, &config, 1, &config_count ) || config_count < 1 )
		{
			eglTerminate( display );
			return PLEAT_RESULT_GL_UNAVAILABLE;
		}
	}
	const EGLint context_attribs[] = {
		EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
		EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE,
	};
	EGLenum previous_api = eglQueryAPI();
	EGLContext egl_context = EGL_NO_CONTEXT;
	if ( eglBindAPI( EGL_OPENGL_API ) )
		egl_context = eglCreateContext( display, config, EGL_NO_CONTEXT, context_attribs );
	eglBindAPI( previous_api );
	if ( egl_context == EGL_NO_CONTEXT )
	{
		eglTerminate( display );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	context->backend = PLEAT_GL_HEADLESS_EGL;
	context->egl_display = display;
	context->egl_context = egl_context;
	plGlApi_LoadEpoxy( &context->api );
	return PLEAT_RESULT_OK;
}

static plOSMesaGetProcAddressFn pl_osmesa_get_proc_address; // for the plGlApi_LoadWith callback

static void* plOsmesaGetProc( const char* name )
{
	OSMESAproc proc = pl_osmesa_get_proc_address( name );
	void* result;
	memcpy( &result, &proc, sizeof( result ) );
	return result;
}

static void* plSym( void* library, const char* name )
{
	return dlsym( library, name );
}

static plResult plCreateOsmesa( plGlContext* context )
{
#if !PLEAT_HAVE_OSMESA
	(void)context;
	(void)plOsmesaGetProc;
	(void)plSym;
	return PLEAT_RESULT_GL_UNAVAILABLE;
#else
	void* library = dlopen( "libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL );
	if ( library == NULL )
		library = dlopen( "libOSMesa.so", RTLD_NOW | RTLD_LOCAL );
	if ( library == NULL )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	plOSMesaCreateContextAttribsFn create_context;
	void* symbols[5] = {
		plSym( library, "OSMesaCreateContextAttribs" ), plSym( library, "OSMesaDestroyContext" ),
		plSym( library, "OSMesaMakeCurrent" ),          plSym( library, "OSMesaGetCurrentContext" ),
		plSym( library, "OSMesaGetProcAddress" ),
	};
	for ( int i = 0; i < 5; ++i )
	{
		if ( symbols[i] == NULL )
		{
			dlclose( library );
			return PLEAT_RESULT_GL_UNAVAILABLE;
		}
	}
	memcpy( &create_context, &symbols[0], sizeof( void* ) );
	memcpy( &context->osmesa_destroy_context, &symbols[1], sizeof( void* ) );
	memcpy( &context->osmesa_make_current, &symbols[2], sizeof( void* ) );
	memcpy( &context->osmesa_get_current_context, &symbols[3], sizeof( void* ) );
	memcpy( &context->osmesa_get_proc_address, &symbols[4], sizeof( void* ) );

	const int attribs[] = {
		OSMESA_FORMAT, OSMESA_RGBA, OSMESA_PROFILE, OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, 4,
		OSMESA_CONTEXT_MINOR_VERSION, 3, 0,
	};
	OSMesaContext osmesa_context = create_context( attribs, NULL );
	if ( osmesa_context == NULL )
	{
		dlclose( library );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	pl_osmesa_get_proc_address = context->osmesa_get_proc_address;
	if ( !plGlApi_LoadWith( &context->api, plOsmesaGetProc ) )
	{
		context->osmesa_destroy_context( osmesa_context );
		dlclose( library );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	context->backend = PLEAT_GL_HEADLESS_OSMESA;
	context->osmesa_library = library;
	context->osmesa_context = osmesa_context;
	return PLEAT_RESULT_OK;
#endif
}

static void plReleaseBackend( plGlContext* context )
{
	if ( context->backend == PLEAT_GL_HEADLESS_EGL )
	{
		eglDestroyContext( context->egl_display, context->egl_context );
		// eglTerminate is reference-less on most drivers: another user of the same surfaceless display (another
		// deformer, the host) would lose it, so the display stays initialised until the process ends.
	}
	else if ( context->backend == PLEAT_GL_HEADLESS_OSMESA )
	{
		context->osmesa_destroy_context( context->osmesa_context );
		// libOSMesa stays loaded: unloading LLVM-backed drivers at run time is not safe.
	}
}

plResult plGlContext_Create( plGlHeadlessBackend backend, const plAllocator* allocator, plGlContext** out )
{
	if ( allocator == NULL || out == NULL || backend < PLEAT_GL_HEADLESS_AUTO || backend > PLEAT_GL_HEADLESS_OSMESA )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	*out = NULL;
	plGlContext* context = plAllocZeroed( allocator, sizeof( *context ), 16 );
	if ( context == NULL )
		return PLEAT_RESULT_OUT_OF_MEMORY;
	context->allocator = *allocator;
	context->egl_display = EGL_NO_DISPLAY;
	context->egl_context = EGL_NO_CONTEXT;

	plResult result = PLEAT_RESULT_GL_UNAVAILABLE;
	if ( backend == PLEAT_GL_HEADLESS_AUTO || backend == PLEAT_GL_HEADLESS_EGL )
		result = plCreateEgl( context );
	if ( result != PLEAT_RESULT_OK && ( backend == PLEAT_GL_HEADLESS_AUTO || backend == PLEAT_GL_HEADLESS_OSMESA ) )
		result = plCreateOsmesa( context );
	if ( result == PLEAT_RESULT_OK )
	{
		// The context must really be desktop GL 4.3+ (compute shaders, SSBOs).
		result = plGlContext_Enter( context );
		if ( result == PLEAT_RESULT_OK )
		{
			int version = plGlApi_CurrentVersion( &context->api );
			plGlContext_Leave( context );
			if ( version < 43 )
				result = PLEAT_RESULT_GL_UNAVAILABLE;
		}
		if ( result != PLEAT_RESULT_OK )
			plReleaseBackend( context );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		plFree( allocator, context, sizeof( *context ) );
		return result;
	}
	*out = context;
	return PLEAT_RESULT_OK;
}

plResult plGlContext_Enter( plGlContext* context )
{
	if ( context->backend == PLEAT_GL_HEADLESS_EGL )
	{
		plSaveEglCurrent( context );
		if ( !eglMakeCurrent( context->egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, context->egl_context ) )
		{
			plRestoreEglCurrent( context, EGL_NO_DISPLAY );
			return PLEAT_RESULT_GL_ERROR;
		}
		return PLEAT_RESULT_OK;
	}
	context->saved_osmesa_context = context->osmesa_get_current_context();
	if ( !context->osmesa_make_current( context->osmesa_context, &context->osmesa_pixel, GL_UNSIGNED_BYTE, 1, 1 ) )
		return PLEAT_RESULT_GL_ERROR;
	return PLEAT_RESULT_OK;
}

void plGlContext_Leave( plGlContext* context )
{
	if ( context->backend == PLEAT_GL_HEADLESS_EGL )
	{
		plRestoreEglCurrent( context, context->egl_display );
		return;
	}
	// OSMesa cannot re-bind a foreign context without its colour buffer, so a previously current OSMesa context is
	// released rather than restored (documented in docs/gpu.md); "nothing current" is restored exactly.
	if ( context->saved_osmesa_context == NULL || context->saved_osmesa_context != context->osmesa_context )
		context->osmesa_make_current( NULL, NULL, 0, 0, 0 );
}

const plGlApi* plGlContext_Api( const plGlContext* context )
{
	return &context->api;
}

plGlHeadlessBackend plGlContext_Backend( const plGlContext* context )
{
	return context->backend;
}

void plGlContext_Destroy( plGlContext* context )
{
	if ( context == NULL )
		return;
	plReleaseBackend( context );
	plAllocator allocator = context->allocator;
	plFree( &allocator, context, sizeof( *context ) );
}
