// The renderer's GL side: a headless EGL surfaceless context (through libepoxy), an MSAA framebuffer, one lit
// shader for meshes and the ground, read-back into an RGB image.
#ifndef PLEAT_RENDER_GL_H
#define PLEAT_RENDER_GL_H
#include "render_image.h"

#include <stdint.h>

typedef struct RenderGl RenderGl;
typedef struct RenderMesh RenderMesh;

typedef struct RenderCamera
{
	float eye[3];    // metres, world
	float target[3]; // metres, world
	float fov_y_deg;
} RenderCamera;

// Makes a GL context current on this thread: 4.3 core if it can (the SDK's host-context GPU path needs it),
// else 3.3 core. Returns NULL (and prints why) if no context can be made.
RenderGl* renderGl_Create( int width, int height );
void renderGl_Destroy( RenderGl* gl );
// GL major * 10 + minor of the context made.
int renderGl_Version( const RenderGl* gl );

// A triangle mesh whose vertices change every frame. position_buffer / normal_buffer: 0 = the mesh owns tightly
// packed vec3 buffers filled by renderMesh_Update; otherwise GL buffer names holding one vec4 per vertex (the SDK's
// host-context output), which the mesh reads but does not own.
RenderMesh* renderMesh_Create( RenderGl* gl, uint32_t vertex_count, const uint32_t* faces, uint32_t face_count,
							   uint32_t position_buffer, uint32_t normal_buffer );
void renderMesh_Update( RenderMesh* mesh, const float* positions, const float* normals );
void renderMesh_Destroy( RenderMesh* mesh );
// A GL buffer of vertex_count vec4s for the SDK to write into (host-context mode).
uint32_t renderGl_CreateVec4Buffer( RenderGl* gl, uint32_t vertex_count );
void renderGl_DeleteBuffer( RenderGl* gl, uint32_t buffer );

// shadow_center: world point under which a soft contact shadow is drawn on the ground (y = 0).
void renderGl_BeginFrame( RenderGl* gl, const RenderCamera* camera, const float shadow_center[3] );
// color: sRGB albedo; inside_shade: factor for back faces (the inside of a garment), 1 = same as outside.
void renderGl_DrawMesh( RenderGl* gl, RenderMesh* mesh, const float color[3], float inside_shade );
// Resolves the frame and reads it into image (top row first); image must have the renderer's size.
int renderGl_EndFrame( RenderGl* gl, RenderImage* image );

#endif
