// The headless GL context the SDK creates for PLEAT_GL_DEFORMER_HEADLESS: EGL on Mesa's surfaceless platform
// (EGL_MESA_platform_surfaceless, desktop GL 4.3+ core, no surface, made current with EGL_NO_SURFACE), with OSMesa
// (loaded at run time with dlopen, so libpleat does not depend on it) as the fallback.
// The context is current only between plGlContext_Enter and plGlContext_Leave; Leave restores whatever EGL context
// (display, surfaces, API) was current on the thread before Enter.
#ifndef PLEAT_GL_CONTEXT_H
#define PLEAT_GL_CONTEXT_H
#include "../allocator.h"
#include "gl_api.h"
#include "pleat/pleat.h"

typedef enum plGlHeadlessBackend
{
	PLEAT_GL_HEADLESS_AUTO = 0, // EGL surfaceless, then OSMesa
	PLEAT_GL_HEADLESS_EGL = 1,
	PLEAT_GL_HEADLESS_OSMESA = 2,
} plGlHeadlessBackend;

typedef struct plGlContext plGlContext;

// Creates the context and checks it is desktop GL 4.3 or newer; nothing is left current. GL_UNAVAILABLE when no back
// end can make one.
plResult plGlContext_Create( plGlHeadlessBackend backend, const plAllocator* allocator, plGlContext** out );
// Makes the context current on the calling thread after saving the current one. GL_ERROR if that fails.
plResult plGlContext_Enter( plGlContext* context );
void plGlContext_Leave( plGlContext* context );
// The entry points for this context (valid between Enter and Leave).
const plGlApi* plGlContext_Api( const plGlContext* context );
// The back end actually in use (EGL or OSMESA).
plGlHeadlessBackend plGlContext_Backend( const plGlContext* context );
void plGlContext_Destroy( plGlContext* context );

// Desktop GL version of the current context as major * 10 + minor (43 for 4.3); 0 if none is current or it is GL ES.
int plGlApi_CurrentVersion( const plGlApi* api );

#endif
