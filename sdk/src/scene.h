// Internal: the scene (pleat.h, SCENE BUDGET) and its two jobs —
//     scene_budget.c   the budget policy: levels of detail, their efficient frontier, the plan under a budget
//     tier_transfer.c  a tier's mesh carried onto the display mesh (a barycentric map built at creation)
//     scene.c          the scene object: characters, switches with cross-fades, stepping through plStepInstances
#ifndef PLEAT_SCENE_H
#define PLEAT_SCENE_H
#include "instance.h"

#include <stddef.h>
#include <stdint.h>

// LBS-only + every tier at its full rate and each reduced rate.
#define PLEAT_SCENE_MAX_LEVELS ( 1 + PLEAT_MAX_TIERS * ( 1 + PLEAT_MAX_NETWORK_RATES ) )

// ---- scene_budget.c ----

typedef struct plBudgetLevel
{
	float cost_us;    // per character and frame
	float error_mm;   // expected mean error
	int32_t tier;     // −1: LBS-only
	float rate_hz;    // 0: every step
} plBudgetLevel;

// The efficient frontier of levels: indices sorted by cost, each strictly more accurate than the one before and on
// the lower convex hull of (cost, error). Returns the count (>= 1 for level_count >= 1).
uint32_t plBudgetFrontier( const plBudgetLevel* levels, uint32_t level_count, uint32_t* out_frontier );

typedef struct plSceneBudgetJob
{
	const plBudgetLevel* levels;      // [level_count]
	uint32_t level_count;
	const uint32_t* frontier;         // [frontier_count] from plBudgetFrontier: the levels a free character walks
	uint32_t frontier_count;
	const float* tier_stream_cost_us; // [tier_count] paid once by each tier the plan uses
	uint32_t tier_count;
	uint32_t character_count;
	const float* importance;          // [n] >= 0
	const uint32_t* current;          // [n] each character's level now (the hysteresis favours it)
	const int32_t* pinned;            // [n] −1, or a level the character must take (an override, a fade in progress)
	const int32_t* held;              // [n] −1, or a level the character keeps while the budget allows (a recent switch)
	const float* extra_cost_us;       // [n] or NULL: costs outside the plan (a fading-out detail)
	float budget_us;                  // the plan's limit (µs); nothing but pinned levels and the cheapest level exceed it
	float hysteresis;                 // >= 0
	void* scratch;                    // n · frontier_count · 12 + n · 4 bytes, 4-byte aligned
	size_t scratch_bytes;
	uint32_t* out_level;              // [n] the plan
	float* out_cost_us;               // optional: the plan's cost
} plSceneBudgetJob;

int plSceneBudgetJob_Validate( const plSceneBudgetJob* job );
plResult plSceneBudgetJob_Run( const plSceneBudgetJob* job );

// ---- tier_transfer.c ----

// Each display vertex as a point of one triangle of a tier's mesh in the rest pose: barycentric weights of the closest
// point, plus the signed distance along that triangle's normal. Applied to the tier's deformed positions it gives the
// display vertex's position (the weighted point moved out along the deformed triangle's unit normal) and normal (the
// weighted tier normals, normalised).
typedef struct plTierTransferJob
{
	const float* display_rest;  // [display_count][3] the display mesh's rest positions
	uint32_t display_count;
	const float* tier_rest;     // [tier_count][3]
	uint32_t tier_vertex_count;
	const uint32_t* tier_faces; // [tier_face_count][3]
	uint32_t tier_face_count;
	uint32_t* out_triangles;    // [display_count][3] tier vertex indices
	float* out_weights;         // [display_count][3] barycentric weights (sum 1)
	float* out_offsets;         // [display_count] signed distance along the triangle's normal (metres)
} plTierTransferJob;

plResult plTierTransferJob_Build( const plTierTransferJob* job );
// positions / normals [display_count][3] from the tier's [tier_vertex_count][3] outputs.
void plTierTransfer_Apply( const uint32_t* triangles, const float* weights, const float* offsets, uint32_t display_count,
						   const float* tier_positions, const float* tier_normals, float* out_positions,
						   float* out_normals );

// ---- scene.c ----

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
	plInstance instances[PLEAT_MAX_TIERS]; // one per tier, created with the character
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
	plBudgetLevel levels[PLEAT_SCENE_MAX_LEVELS]; // [0] = LBS-only, then per tier: full rate, then each reduced rate
	uint32_t level_count;
	uint32_t frontier[PLEAT_SCENE_MAX_LEVELS];
	uint32_t frontier_count;
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
	float* extra_cost_us;
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
	float* lbs_sums;              // [workers][max(N0, F0)][4] normals scratch of the LBS-only detail
	size_t lbs_sums_floats;       // one worker's share of lbs_sums
	plResult* verdicts;           // [capacity] a step's checks of each live character's output spans, then its result
	uint32_t* result_index;       // [capacity] where each live character's network result sits in step_results
	plResult* lbs_results;        // [capacity] the LBS-only level's result of each live character shown on it
	uint32_t* lbs_members;        // [capacity] the live characters (positions in live_ids) shown LBS-only this frame
	void* block;                  // everything above in one allocation
	size_t block_size;
} plSceneData;

#endif
