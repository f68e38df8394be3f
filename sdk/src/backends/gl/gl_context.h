// The headless GL context the SDK creates for PLEAT_GL_DEFORMER_HEADLESS, desktop GL 4.3+ core with no surface, tried
// in this order: EGL's device platform (EGL_EXT_platform_device: enumerate the EGL devices and take the first hardware
// one — the route to the GPU on NVIDIA's driver, which has no surfaceless platform), then Mesa's surfaceless platform
// (EGL_MESA_platform_surfaceless: Mesa's own pick, llvmpipe on a machine without a GPU), then OSMesa (loaded at run
// time with dlopen, so libpleat does not depend on it). A report says which platform, device and renderer it got.
// The context is current only between plGlContext_Enter and plGlContext_Leave; Leave restores whatever EGL context
// (display, surfaces, API) was current on the thread before Enter.
#ifndef PLEAT_GL_CONTEXT_H
#define PLEAT_GL_CONTEXT_H
#include "core/allocator.h"
#include "gl_api.h"
#include "pleat/pleat.h"

typedef enum plGlHeadlessBackend
{
	PLEAT_GL_HEADLESS_AUTO = 0,   // EGL device (hardware), then EGL surfaceless, then OSMesa
	PLEAT_GL_HEADLESS_EGL = 1,    // EGL device (hardware), then EGL surfaceless
	PLEAT_GL_HEADLESS_OSMESA = 2, // OSMesa only
	// EGL device platform only, software devices accepted after hardware ones: lets a machine without a GPU (Mesa's
	// EGL_MESA_device_software device) run the device path in tests. A context made this way reports backend EGL.
	PLEAT_GL_HEADLESS_EGL_DEVICE = 3,
} plGlHeadlessBackend;

// Where a headless context came from (the back end says only EGL or OSMesa).
typedef enum plGlHeadlessPlatform
{
	PLEAT_GL_PLATFORM_NONE = 0,
	PLEAT_GL_PLATFORM_EGL_DEVICE = 1,      // EGL_EXT_platform_device
	PLEAT_GL_PLATFORM_EGL_SURFACELESS = 2, // EGL_MESA_platform_surfaceless
	PLEAT_GL_PLATFORM_OSMESA = 3,
} plGlHeadlessPlatform;

typedef struct plGlContext plGlContext;

// Creates the context and checks it is desktop GL 4.3 or newer; nothing is left current. GL_UNAVAILABLE when no back
// end can make one. report (optional, report_size bytes, NUL-terminated): on success the platform, device and
// GL_VENDOR / GL_RENDERER / GL_VERSION it got, then what was passed over; on failure why each route failed.
plResult plGlContext_Create( plGlHeadlessBackend backend, const plAllocator* allocator, plGlContext** out,
							 char* report, size_t report_size );
// Makes the context current on the calling thread after saving the current one. GL_ERROR if that fails.
plResult plGlContext_Enter( plGlContext* context );
void plGlContext_Leave( plGlContext* context );
// The entry points for this context (valid between Enter and Leave).
const plGlApi* plGlContext_Api( const plGlContext* context );
// The back end actually in use (EGL or OSMESA).
plGlHeadlessBackend plGlContext_Backend( const plGlContext* context );
// The platform it was made on.
plGlHeadlessPlatform plGlContext_Platform( const plGlContext* context );
void plGlContext_Destroy( plGlContext* context );

// Desktop GL version of the current context as major * 10 + minor (43 for 4.3); 0 if none is current or it is GL ES.
int plGlApi_CurrentVersion( const plGlApi* api );

#endif
