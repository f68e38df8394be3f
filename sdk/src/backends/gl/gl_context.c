#include "gl_context.h"
#include <dlfcn.h>
#include <epoxy/egl.h>
#include <stdarg.h>
#include <stdio.h>
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

// EGL_EXT_device_drm_render_node's token (EGL registry value), for libepoxy versions that predate the extension.
#ifndef EGL_DRM_RENDER_NODE_FILE_EXT
#define EGL_DRM_RENDER_NODE_FILE_EXT 0x3377
#endif
// Enough for every GPU of a large node plus Mesa's software device; more are simply not looked at.
#define PLEAT_GL_MAX_EGL_DEVICES 16

struct plGlContext
{
	plAllocator allocator;
	plGlHeadlessBackend backend;
	plGlHeadlessPlatform platform;
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

// What plGlContext_Create reports: the route it took (chosen) and what it passed over or failed on (tried). Kept
// apart so the chosen route comes first in the log line, which the log bounds.
typedef struct plGlReport
{
	char chosen[256];
	char tried[320];
} plGlReport;

static void plAppend( char* buffer, size_t size, const char* format, ... )
#if defined( __GNUC__ )
	__attribute__( ( format( printf, 3, 4 ) ) )
#endif
	;

static void plAppend( char* buffer, size_t size, const char* format, ... )
{
	size_t length = strlen( buffer );
	if ( length + 1 >= size )
		return;
	va_list args;
	va_start( args, format );
	vsnprintf( buffer + length, size - length, format, args );
	va_end( args );
}

#define PL_TRIED( report, ... ) plAppend( ( report )->tried, sizeof( ( report )->tried ), __VA_ARGS__ )

// Makes the freshly created context current once to check it is desktop GL 4.3+ (compute shaders, SSBOs) and to
// record who renders; releases the back end if it is not usable.
static void plReleaseBackend( plGlContext* context );

static plResult plVerifyContext( plGlContext* context, plGlReport* report, const char* route )
{
	plResult result = plGlContext_Enter( context );
	if ( result != PLEAT_RESULT_OK )
	{
		PL_TRIED( report, "%s: context not made current; ", route );
		plReleaseBackend( context );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	int version = plGlApi_CurrentVersion( &context->api );
	const GLubyte* vendor = context->api.GetString( GL_VENDOR );
	const GLubyte* renderer = context->api.GetString( GL_RENDERER );
	const GLubyte* version_string = context->api.GetString( GL_VERSION );
	char strings[200];
	snprintf( strings, sizeof( strings ), "GL_VENDOR '%s', GL_RENDERER '%s', GL_VERSION '%s'",
			  vendor != NULL ? (const char*)vendor : "?", renderer != NULL ? (const char*)renderer : "?",
			  version_string != NULL ? (const char*)version_string : "?" );
	plGlContext_Leave( context );
	if ( version < 43 )
	{
		PL_TRIED( report, "%s: not desktop GL 4.3+ (%s); ", route, strings );
		plReleaseBackend( context );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	plAppend( report->chosen, sizeof( report->chosen ), "%s; %s", route, strings );
	return PLEAT_RESULT_OK;
}

// A GL 4.3 core context without a surface on an EGL display got from eglGetPlatformDisplayEXT. The display is
// terminated on failure only if this call initialised it: a display someone else initialised (the engine, another
// deformer) is the same object for the same platform and device, and eglTerminate would pull it from under them.
static plResult plCreateEglOnDisplay( plGlContext* context, EGLDisplay display, plGlReport* report, const char* route )
{
	if ( display == EGL_NO_DISPLAY )
	{
		PL_TRIED( report, "%s: no display; ", route );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	int initialised_before = eglQueryString( display, EGL_VENDOR ) != NULL;
	EGLint major = 0, minor = 0;
	if ( !eglInitialize( display, &major, &minor ) )
	{
		PL_TRIED( report, "%s: eglInitialize failed (0x%x); ", route, (unsigned)eglGetError() );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	const char* extensions = eglQueryString( display, EGL_EXTENSIONS );
	EGLContext egl_context = EGL_NO_CONTEXT;
	if ( !epoxy_extension_in_string( extensions, "EGL_KHR_surfaceless_context" ) ||
		 !epoxy_extension_in_string( extensions, "EGL_KHR_create_context" ) )
	{
		PL_TRIED( report, "%s: no EGL_KHR_surfaceless_context/EGL_KHR_create_context; ", route );
	}
	else
	{
		EGLConfig config = EGL_NO_CONFIG_KHR;
		int have_config = 1;
		if ( !epoxy_extension_in_string( extensions, "EGL_KHR_no_config_context" ) )
		{
			const EGLint config_attribs[] = { EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE };
			EGLint config_count = 0;
			have_config = eglChooseConfig( display, config_attribs, &config, 1, &config_count ) && config_count >= 1;
			if ( !have_config )
				PL_TRIED( report, "%s: no desktop GL config; ", route );
		}
		if ( have_config )
		{
			const EGLint context_attribs[] = {
				EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
				EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE,
			};
			EGLenum previous_api = eglQueryAPI();
			if ( eglBindAPI( EGL_OPENGL_API ) )
				egl_context = eglCreateContext( display, config, EGL_NO_CONTEXT, context_attribs );
			eglBindAPI( previous_api );
			if ( egl_context == EGL_NO_CONTEXT )
				PL_TRIED( report, "%s: no GL 4.3 core context (0x%x); ", route, (unsigned)eglGetError() );
		}
	}
	if ( egl_context == EGL_NO_CONTEXT )
	{
		if ( !initialised_before )
			eglTerminate( display );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	context->backend = PLEAT_GL_HEADLESS_EGL;
	context->egl_display = display;
	context->egl_context = egl_context;
	plGlApi_LoadEpoxy( &context->api );
	return plVerifyContext( context, report, route );
}

// Mesa marks its software rasteriser's device with EGL_MESA_device_software; a device without that mark is taken to
// be hardware (NVIDIA's devices carry EGL_NV_device_cuda and, with the DRM module loaded, EGL_EXT_device_drm).
static int plEglDeviceIsSoftware( EGLDeviceEXT device )
{
	return epoxy_extension_in_string( eglQueryDeviceStringEXT( device, EGL_EXTENSIONS ), "EGL_MESA_device_software" );
}

// "/dev/dri/renderD128" or the like: the render node when the driver names one, else the primary node, else "".
static const char* plEglDeviceFile( EGLDeviceEXT device )
{
	const char* extensions = eglQueryDeviceStringEXT( device, EGL_EXTENSIONS );
	const char* file = NULL;
	if ( epoxy_extension_in_string( extensions, "EGL_EXT_device_drm_render_node" ) )
		file = eglQueryDeviceStringEXT( device, EGL_DRM_RENDER_NODE_FILE_EXT );
	if ( file == NULL && epoxy_extension_in_string( extensions, "EGL_EXT_device_drm" ) )
		file = eglQueryDeviceStringEXT( device, EGL_DRM_DEVICE_FILE_EXT );
	return file != NULL ? file : "";
}

// libepoxy aborts the process when an EGL entry point is first called and it cannot dlopen libEGL.so.1 (a GPU
// container with the driver's EGL vendor library but no libglvnd loader, a server without Mesa): the SDK never
// aborts, so the EGL routes are taken only when that library loads. The handle is kept; epoxy opens it again itself.
static int plEglLibraryLoads( plGlReport* report )
{
	if ( dlopen( "libEGL.so.1", RTLD_LAZY | RTLD_LOCAL | RTLD_NOLOAD ) != NULL ||
		 dlopen( "libEGL.so.1", RTLD_LAZY | RTLD_LOCAL ) != NULL )
		return 1;
	PL_TRIED( report, "EGL: libEGL.so.1 not found; " );
	return 0;
}

// EGL_EXT_platform_device: hardware devices in enumeration order first; software devices only when allowed (the
// surfaceless platform is the better software route: Mesa picks there for itself).
static plResult plCreateEglDevice( plGlContext* context, int allow_software, plGlReport* report )
{
	const char* client_extensions = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	int has_enumeration = epoxy_extension_in_string( client_extensions, "EGL_EXT_device_base" ) ||
						  ( epoxy_extension_in_string( client_extensions, "EGL_EXT_device_enumeration" ) &&
							epoxy_extension_in_string( client_extensions, "EGL_EXT_device_query" ) );
	if ( !epoxy_extension_in_string( client_extensions, "EGL_EXT_platform_device" ) ||
		 !epoxy_extension_in_string( client_extensions, "EGL_EXT_platform_base" ) || !has_enumeration )
	{
		PL_TRIED( report, "EGL device platform: not offered; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	EGLDeviceEXT devices[PLEAT_GL_MAX_EGL_DEVICES];
	EGLint device_count = 0;
	if ( !eglQueryDevicesEXT( PLEAT_GL_MAX_EGL_DEVICES, devices, &device_count ) || device_count <= 0 )
	{
		PL_TRIED( report, "EGL device platform: no devices; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	for ( int pass = 0; pass < 2; ++pass )
	{
		int want_software = pass == 1;
		if ( want_software && !allow_software )
			break;
		for ( EGLint i = 0; i < device_count; ++i )
		{
			int software = plEglDeviceIsSoftware( devices[i] );
			if ( software != want_software )
			{
				if ( software && !allow_software )
					PL_TRIED( report, "EGL device %d of %d: software, passed over; ", (int)i, (int)device_count );
				continue;
			}
			const char* file = plEglDeviceFile( devices[i] );
			char route[160];
			snprintf( route, sizeof( route ), "EGL device platform (EGL_EXT_platform_device), device %d of %d%s%s, %s",
					  (int)i, (int)device_count, file[0] != '\0' ? " " : "", file, software ? "software" : "hardware" );
			EGLDisplay display = eglGetPlatformDisplayEXT( EGL_PLATFORM_DEVICE_EXT, devices[i], NULL );
			if ( plCreateEglOnDisplay( context, display, report, route ) == PLEAT_RESULT_OK )
			{
				context->platform = PLEAT_GL_PLATFORM_EGL_DEVICE;
				return PLEAT_RESULT_OK;
			}
		}
	}
	return PLEAT_RESULT_GL_UNAVAILABLE;
}

static plResult plCreateEglSurfaceless( plGlContext* context, plGlReport* report )
{
	// Client extensions: EGL_NO_DISPLAY query is only valid with EGL_EXT_client_extensions (NULL otherwise).
	const char* client_extensions = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	if ( !epoxy_extension_in_string( client_extensions, "EGL_MESA_platform_surfaceless" ) ||
		 !epoxy_extension_in_string( client_extensions, "EGL_EXT_platform_base" ) )
	{
		PL_TRIED( report, "EGL surfaceless platform: not offered; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	EGLDisplay display = eglGetPlatformDisplayEXT( EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL );
	plResult result = plCreateEglOnDisplay( context, display, report,
											"EGL surfaceless platform (EGL_MESA_platform_surfaceless)" );
	if ( result == PLEAT_RESULT_OK )
		context->platform = PLEAT_GL_PLATFORM_EGL_SURFACELESS;
	return result;
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

static plResult plCreateOsmesa( plGlContext* context, plGlReport* report )
{
#if !PLEAT_HAVE_OSMESA
	(void)context;
	(void)plOsmesaGetProc;
	(void)plSym;
	PL_TRIED( report, "OSMesa: not built in (no GL/osmesa.h); " );
	return PLEAT_RESULT_GL_UNAVAILABLE;
#else
	void* library = dlopen( "libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL );
	if ( library == NULL )
		library = dlopen( "libOSMesa.so", RTLD_NOW | RTLD_LOCAL );
	if ( library == NULL )
	{
		PL_TRIED( report, "OSMesa: libOSMesa not found; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
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
			PL_TRIED( report, "OSMesa: entry points missing; " );
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
		PL_TRIED( report, "OSMesa: no GL 4.3 core context; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	pl_osmesa_get_proc_address = context->osmesa_get_proc_address;
	if ( !plGlApi_LoadWith( &context->api, plOsmesaGetProc ) )
	{
		context->osmesa_destroy_context( osmesa_context );
		dlclose( library );
		PL_TRIED( report, "OSMesa: GL entry points missing; " );
		return PLEAT_RESULT_GL_UNAVAILABLE;
	}
	context->backend = PLEAT_GL_HEADLESS_OSMESA;
	context->platform = PLEAT_GL_PLATFORM_OSMESA;
	context->osmesa_library = library;
	context->osmesa_context = osmesa_context;
	return plVerifyContext( context, report, "OSMesa (libOSMesa, software)" );
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
	// Back to "nothing made": a failed route leaves the context ready for the next one.
	context->backend = PLEAT_GL_HEADLESS_AUTO;
	context->platform = PLEAT_GL_PLATFORM_NONE;
	context->egl_display = EGL_NO_DISPLAY;
	context->egl_context = EGL_NO_CONTEXT;
	context->osmesa_context = NULL;
}

plResult plGlContext_Create( plGlHeadlessBackend backend, const plAllocator* allocator, plGlContext** out,
							 char* report, size_t report_size )
{
	if ( report != NULL && report_size > 0 )
		report[0] = '\0';
	if ( allocator == NULL || out == NULL || backend < PLEAT_GL_HEADLESS_AUTO || backend > PLEAT_GL_HEADLESS_EGL_DEVICE )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	*out = NULL;
	plGlContext* context = plAllocZeroed( allocator, sizeof( *context ), 16 );
	if ( context == NULL )
		return PLEAT_RESULT_OUT_OF_MEMORY;
	context->allocator = *allocator;
	context->egl_display = EGL_NO_DISPLAY;
	context->egl_context = EGL_NO_CONTEXT;

	// Each route verifies its context (desktop GL 4.3+) before it counts, so a route that yields an unusable context
	// falls through to the next.
	plGlReport route_report;
	memset( &route_report, 0, sizeof( route_report ) );
	plResult result = PLEAT_RESULT_GL_UNAVAILABLE;
	int wants_egl = backend != PLEAT_GL_HEADLESS_OSMESA;
	int egl = wants_egl && plEglLibraryLoads( &route_report );
	if ( egl && backend != PLEAT_GL_HEADLESS_OSMESA )
		result = plCreateEglDevice( context, backend == PLEAT_GL_HEADLESS_EGL_DEVICE, &route_report );
	if ( egl && result != PLEAT_RESULT_OK && ( backend == PLEAT_GL_HEADLESS_AUTO || backend == PLEAT_GL_HEADLESS_EGL ) )
		result = plCreateEglSurfaceless( context, &route_report );
	if ( result != PLEAT_RESULT_OK && ( backend == PLEAT_GL_HEADLESS_AUTO || backend == PLEAT_GL_HEADLESS_OSMESA ) )
		result = plCreateOsmesa( context, &route_report );
	if ( report != NULL && report_size > 0 )
	{
		size_t tried = strlen( route_report.tried );
		while ( tried >= 2 && route_report.tried[tried - 2] == ';' ) // drop the trailing "; "
			route_report.tried[tried -= 2] = '\0';
		if ( result == PLEAT_RESULT_OK )
			snprintf( report, report_size, "%s%s%s", route_report.chosen, tried > 0 ? "; tried first: " : "",
					  route_report.tried );
		else
			snprintf( report, report_size, "%s", route_report.tried );
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

plGlHeadlessPlatform plGlContext_Platform( const plGlContext* context )
{
	return context->platform;
}

void plGlContext_Destroy( plGlContext* context )
{
	if ( context == NULL )
		return;
	plReleaseBackend( context );
	plAllocator allocator = context->allocator;
	plFree( &allocator, context, sizeof( *context ) );
}
