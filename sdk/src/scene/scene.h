// Internal: the scene (pleat.h, SCENE BUDGET): scene.c makes it (characters, levels, the API between steps),
// scene_step.c steps it (switches with cross-fades, plStepInstances, the LBS-only level). Its two jobs have headers
// of their own, below it: scene_budget.h (the budget policy) and tier_transfer.h (a tier's mesh carried onto the
// display mesh).
#ifndef PLEAT_SCENE_H
#define PLEAT_SCENE_H
#include "instance/instance.h"
#include "scene_budget.h"
#include "tier_transfer.h"

#include <stddef.h>
#include <stdint.h>

typedef struct plSceneTier
{
	plAssetData* asset;
	plAsset handle;
	int same_mesh;      // the display mesh itself: no transfer
	uint32_t* triangles; // [N0][3] when !same_mesh
	float* weights;      // [N0][3]
	float* offsets;      // [N0]
} plSceneTier;

typedef struct plSceneCharacter
{
	int live;
	plInstance instances[2 * PLEAT_MAX_TIERS]; // one per tier, created with the character; a scene with a GPU mode
	                                           // also one per tier on the GPU, at PLEAT_MAX_TIERS + tier (plLevelSlot)
	uint32_t level;              // the current detail (index into the scene's levels)
	uint32_t fade_from;          // the detail being faded out while fade_alpha < 1
	float fade_alpha;            // the new detail's weight in the outputs (1: no fade)
	float motion_m;              // recent largest per-vertex jump of the outputs between frames (metres, decaying max)
	uint32_t frames_since_switch;
	int32_t override_level;      // −1: the policy decides
	int stepped;                 // it has outputs (a switch before the first step needs no fade)
	float importance;
	void* user_data;
	float* positions;            // [N0][3] the last outputs on the display mesh
	float* normals;              // [N0][3]
	float* back_positions;       // [N0][3] the next outputs while a step assembles them (then swapped)
	float* back_normals;
	float skin_matrices[PLEAT_MAX_JOINTS * 12]; // the last step's, of the detail shown
} plSceneCharacter;

typedef struct plSceneData
{
	plContextData* ctx;
	plSceneTier tiers[PLEAT_MAX_TIERS];
	uint32_t tier_count;
	uint32_t display_vertex_count;  // N0
	plBudgetLevel levels[PLEAT_SCENE_MAX_LEVELS]; // [0] = LBS-only, then per tier: full rate, then each reduced rate;
	                                              // then, with a GPU mode, the same on the GPU
	uint32_t level_count;
	uint32_t frontier[PLEAT_SCENE_MAX_LEVELS];     // LBS-only and the CPU levels (plBuildFrontiers)
	uint32_t frontier_count;
	uint32_t gpu_frontier[PLEAT_SCENE_MAX_LEVELS]; // from frontier[0] up the GPU levels (0 entries without a GPU mode)
	uint32_t gpu_frontier_count;
	plGpuMode gpu_mode;     // PLEAT_GPU_MODE_NONE: the CPU alone
	float gpu_budget_us;    // 0 = unlimited
	float tier_stream_cost_us[PLEAT_MAX_TIERS];
	float budget_us, hysteresis;
	uint32_t min_frames_between_switches, crossfade_frames;
	plScenePlan plan;
	float cost_scale;       // measured / modelled frame cost: the ratio of the two running means below
	double measured_avg_us, modelled_avg_us; // running means of the reported frame costs and of their plans' costs
	float model_cost_us;    // the last plan's cost in the model's units (before the correction)

	uint32_t capacity;
	plSceneCharacter* characters; // [capacity]
	// Scratch, [capacity] or [2 · capacity] (one step per character and tier it shows):
	float* importance;
	uint32_t* current;
	int32_t *pinned, *held;
	float* extra_cost_us;         // [capacity], then [capacity] the GPU's (extra_gpu_cost_us)
	float* extra_gpu_cost_us;
	uint32_t* planned;
	void* budget_scratch;
	size_t budget_scratch_bytes;
	uint32_t* live_ids;           // [capacity] the live characters of a step
	int uses_tiers;               // the tiers' instance counts include this scene
	plInstance* step_instances;   // [2 · capacity]
	plFrameInput* step_inputs;
	plResult* step_results;
	uint32_t worker_count;        // the context's task workers: one set of the scratch below each
	float* fade_positions;        // [workers][2][N0][3] the detail being faded out, on the display mesh
	plResult* verdicts;           // [capacity] a step's checks of each live character's output spans, then its result
	uint32_t* result_index;       // [capacity] where each live character's network result sits in step_results
	plResult* lbs_results;        // [capacity] the LBS-only level's result of each live character shown on it
	uint32_t* lbs_members;        // [capacity] the live characters (positions in live_ids) shown LBS-only this frame
	void* block;                  // everything above in one allocation
	size_t block_size;
} plSceneData;

// The live scene a handle names, or NULL.
plSceneData* plGetSceneData( plScene handle );
// The frontiers for the scene's budgets (scene.c; again whenever a budget changes: they weigh GPU µs by its ratio).
void plBuildFrontiers( plSceneData* s );
// The weight of a GPU µs against a CPU µs in the plan cost (plBudgetPlanCost): the CPU budget over the GPU's, or, with
// one of them unlimited, 1e-3 (the GPU's free) or 1e3 (the CPU's free); 1 with both unlimited.
float plSceneGpuWeight( const plSceneData* s );

// The instance a level shows in a character's instances: its tier's CPU one, or its GPU one (PLEAT_MAX_TIERS + tier);
// −1: LBS-only (tiers[0]'s CPU instance, networks off).
static inline int32_t plLevelSlot( const plSceneData* s, uint32_t level )
{
	const plBudgetLevel* l = &s->levels[level];
	return l->tier < 0 ? -1 : l->tier + ( l->gpu ? PLEAT_MAX_TIERS : 0 );
}

#endif
