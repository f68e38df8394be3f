// The GL entry points the compute path uses, as one table of function pointers. Filled from libepoxy (EGL headless
// context and the engine's own context, GLX or EGL) or from OSMesaGetProcAddress (OSMesa fallback: epoxy only
// resolves against a current GLX or EGL context, so it cannot dispatch into OSMesa). Every GL call in
// sdk/src/backends/gl/ goes through this table, so both back ends run the same code.
#ifndef PLEAT_GL_API_H
#define PLEAT_GL_API_H
#include <epoxy/gl.h>

// X(pointer type, name without the gl prefix)
#define PLEAT_GL_FUNCTIONS( X )                                                                                        \
	X( PFNGLGETERRORPROC, GetError )                                                                                   \
	X( PFNGLGETSTRINGPROC, GetString )                                                                                 \
	X( PFNGLGETINTEGERVPROC, GetIntegerv )                                                                             \
	X( PFNGLGETINTEGERI_VPROC, GetIntegeri_v )                                                                         \
	X( PFNGLGETINTEGER64I_VPROC, GetInteger64i_v )                                                                     \
	X( PFNGLGENBUFFERSPROC, GenBuffers )                                                                               \
	X( PFNGLDELETEBUFFERSPROC, DeleteBuffers )                                                                         \
	X( PFNGLISBUFFERPROC, IsBuffer )                                                                                   \
	X( PFNGLBINDBUFFERPROC, BindBuffer )                                                                               \
	X( PFNGLBINDBUFFERBASEPROC, BindBufferBase )                                                                       \
	X( PFNGLBINDBUFFERRANGEPROC, BindBufferRange )                                                                     \
	X( PFNGLBUFFERDATAPROC, BufferData )                                                                               \
	X( PFNGLBUFFERSUBDATAPROC, BufferSubData )                                                                         \
	X( PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData )                                                                   \
	X( PFNGLCOPYBUFFERSUBDATAPROC, CopyBufferSubData )                                                                 \
	X( PFNGLGETBUFFERPARAMETERI64VPROC, GetBufferParameteri64v )                                                       \
	X( PFNGLCREATESHADERPROC, CreateShader )                                                                           \
	X( PFNGLSHADERSOURCEPROC, ShaderSource )                                                                           \
	X( PFNGLCOMPILESHADERPROC, CompileShader )                                                                         \
	X( PFNGLGETSHADERIVPROC, GetShaderiv )                                                                             \
	X( PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog )                                                                   \
	X( PFNGLDELETESHADERPROC, DeleteShader )                                                                           \
	X( PFNGLCREATEPROGRAMPROC, CreateProgram )                                                                         \
	X( PFNGLATTACHSHADERPROC, AttachShader )                                                                           \
	X( PFNGLLINKPROGRAMPROC, LinkProgram )                                                                             \
	X( PFNGLGETPROGRAMIVPROC, GetProgramiv )                                                                           \
	X( PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog )                                                                 \
	X( PFNGLDELETEPROGRAMPROC, DeleteProgram )                                                                         \
	X( PFNGLUSEPROGRAMPROC, UseProgram )                                                                               \
	X( PFNGLDISPATCHCOMPUTEPROC, DispatchCompute )                                                                     \
	X( PFNGLMEMORYBARRIERPROC, MemoryBarrier )                                                                         \
	X( PFNGLFINISHPROC, Finish )                                                                                       \
	X( PFNGLGENQUERIESPROC, GenQueries )                                                                               \
	X( PFNGLDELETEQUERIESPROC, DeleteQueries )                                                                         \
	X( PFNGLBEGINQUERYPROC, BeginQuery )                                                                               \
	X( PFNGLENDQUERYPROC, EndQuery )                                                                                   \
	X( PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v )

typedef struct plGlApi
{
#define PLEAT_GL_DECLARE_MEMBER( type, name ) type name;
	PLEAT_GL_FUNCTIONS( PLEAT_GL_DECLARE_MEMBER )
#undef PLEAT_GL_DECLARE_MEMBER
} plGlApi;

// Fills the table with libepoxy's dispatch pointers (resolved lazily against the current GLX or EGL context).
void plGlApi_LoadEpoxy( plGlApi* api );
// Fills the table through a GetProcAddress-style loader (OSMesaGetProcAddress). Returns 0 if any entry is missing.
int plGlApi_LoadWith( plGlApi* api, void* ( *get_proc_address )( const char* name ) );

#endif
