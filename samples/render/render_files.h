// Readers for the renderer's two input files, written by `python -m pleat.render_export` (formats in docs/demo.md).
#ifndef PLEAT_RENDER_FILES_H
#define PLEAT_RENDER_FILES_H
#include <stdint.h>

enum
{
	RENDER_NAME_BYTES = 32,
	RENDER_MAX_JOINTS = 64,
	RENDER_MAX_BETAS = 16,
};

// "PLBODY01": the body shaped for one β, with its skin.
typedef struct RenderBody
{
	uint32_t vertex_count;
	uint32_t face_count;
	uint32_t joint_count;
	uint32_t influence_count;
	uint32_t beta_count;
	float beta[RENDER_MAX_BETAS];
	char joint_names[RENDER_MAX_JOINTS][RENDER_NAME_BYTES]; // NUL-terminated here
	float* joints;        // [J][3] rest joint locations J(β), metres
	float* vertices;      // [V][3] shaped rest vertices, metres
	uint32_t* faces;      // [F][3]
	uint32_t* skin_indices; // [V][K] body joint indices
	float* skin_weights;  // [V][K]
	void* block;          // the file contents all the pointers above point into
} RenderBody;

// "PLMOTION": a clip at a fixed rate.
typedef struct RenderMotion
{
	uint32_t frame_count;
	uint32_t joint_count;
	float fps;
	char joint_names[RENDER_MAX_JOINTS][RENDER_NAME_BYTES];
	const float* frames; // per frame: rotations [J][4] (x,y,z,w), root_translation [3], root_rotation [4] (x,y,z,w)
	uint32_t frame_floats; // floats per frame = 4J + 7
	void* block;
} RenderMotion;

// Return 0 on success; on failure print why to stderr and return -1.
int renderBody_Load( RenderBody* body, const char* path );
void renderBody_Free( RenderBody* body );
int renderMotion_Load( RenderMotion* motion, const char* path );
void renderMotion_Free( RenderMotion* motion );

#endif
