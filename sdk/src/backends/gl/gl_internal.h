// Internal to sdk/src/backends/gl/ and its tests: choosing the headless back end explicitly, and the state the
// host-context mode saves and restores.
#ifndef PLEAT_GL_INTERNAL_H
#define PLEAT_GL_INTERNAL_H
#include "backends/gl_deformer.h"
#include "gl_context.h"
#include "gl_types.h"

// plGlDeformer_Create with desc->mode == PLEAT_GL_DEFORMER_HEADLESS and a given back end (AUTO is what Create uses).
plResult plGlDeformer_CreateHeadless( const plGlDeformerDesc* desc, const plAllocator* allocator,
									  plGlHeadlessBackend backend, plGlDeformer** out );
// The back end a headless deformer runs on (EGL or OSMESA); 0 for a host-context deformer.
plGlHeadlessBackend plGlDeformer_Backend( const plGlDeformer* deformer );
// The platform a headless deformer's context came from; PLEAT_GL_PLATFORM_NONE for a host-context deformer.
plGlHeadlessPlatform plGlDeformer_Platform( const plGlDeformer* deformer );

// Every piece of GL state the deformer changes in the engine's context (docs/gpu.md lists it).
typedef struct plGlSavedState
{
	GLint program;                                      // GL_CURRENT_PROGRAM
	GLint storage_buffer;                               // GL_SHADER_STORAGE_BUFFER_BINDING (generic)
	GLint storage_buffers[PLEAT_GL_BINDING_COUNT];      // indexed GL_SHADER_STORAGE_BUFFER_BINDING 0..27
	GLint64 storage_starts[PLEAT_GL_BINDING_COUNT];     // GL_SHADER_STORAGE_BUFFER_START
	GLint64 storage_sizes[PLEAT_GL_BINDING_COUNT];      // GL_SHADER_STORAGE_BUFFER_SIZE
	GLint uniform_buffer;                               // GL_UNIFORM_BUFFER_BINDING (generic)
	GLint uniform_binding;                              // indexed GL_UNIFORM_BUFFER_BINDING 0
	GLint64 uniform_start;                              // GL_UNIFORM_BUFFER_START 0
	GLint64 uniform_size;                               // GL_UNIFORM_BUFFER_SIZE 0
	GLint copy_read_buffer;                             // GL_COPY_READ_BUFFER_BINDING (a batch's copies to host buffers)
	GLint copy_write_buffer;                            // GL_COPY_WRITE_BUFFER_BINDING
} plGlSavedState;

// The indexed storage bindings 0 .. binding_count − 1 (the deformer's: 20 without networks, 28 with), and the rest.
void plGlSaveState( const plGlApi* api, uint32_t binding_count, plGlSavedState* state );
void plGlRestoreState( const plGlApi* api, uint32_t binding_count, const plGlSavedState* state );

#endif
