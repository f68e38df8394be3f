// pleat-render --crowd: many characters in one scene under a budget (render_crowd.c; docs/scene-budget.md).
#ifndef PLEAT_RENDER_CROWD_H
#define PLEAT_RENDER_CROWD_H
#include "render_files.h"

#include <stdint.h>

enum
{
	CROWD_MAX_FILES = 8,
};

typedef struct CrowdOptions
{
	const char* tier_paths[CROWD_MAX_FILES]; // the garment's tiers, most accurate first
	int tier_count;
	float tier_errors_mm[CROWD_MAX_FILES + 1]; // per tier, then LBS-only (all 0 = the scene's relative ranks)
	const char* body_paths[CROWD_MAX_FILES]; // bodies of different β (PLBODY01, each with its own β)
	int body_count;
	const char* clip_paths[CROWD_MAX_FILES]; // clips (PLMOTION), looped
	int clip_count;
	const char* out_dir;
	int characters;  // 1..64
	float budget_us; // per frame (µs); 0 = unlimited
	int width, height;
	int frames, frame_step, sheet_tiles;
} CrowdOptions;

// Non-zero if the command line asks for --crowd; then renderCrowd_Main parses it (2 = bad options) and runs the crowd.
int renderCrowd_Requested( int argc, char** argv );
int renderCrowd_Main( int argc, char** argv );

// Steps the crowd through a plScene and writes DIR/crowd_NNNN.png frames and DIR/crowd_sheet.png. Returns 0, 1 (failed)
// or 77 (no GL).
int renderCrowd( const CrowdOptions* o );

#endif
