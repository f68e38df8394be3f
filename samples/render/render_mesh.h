// The body's geometry both renders share (render.c, render_crowd.c): the body skinned with the garment's own matrices,
// and area-weighted vertex normals.
#ifndef PLEAT_RENDER_MESH_H
#define PLEAT_RENDER_MESH_H
#include "render_files.h"

#include <stdint.h>

// positions [N][3] = the body's vertices skinned with matrices [J][3][4] (the asset's joints; body_to_asset maps the
// body's joints to them).
void skinBody( const RenderBody* body, const int32_t* body_to_asset, const float* matrices, float* positions );
// normals [N][3], area-weighted and normalised (zero where a vertex has no area around it).
void vertexNormals( const float* positions, uint32_t vertex_count, const uint32_t* faces, uint32_t face_count,
					float* normals );

#endif
