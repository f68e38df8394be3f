// Internal: the scene's budget policy as a job (scene_budget.c): levels of detail, their efficient frontier, the plan
// under a budget. Spans and numbers only: it knows no scene, instance or asset.
#ifndef PLEAT_SCENE_BUDGET_H
#define PLEAT_SCENE_BUDGET_H
#include "pleat/pleat.h"

#include <stddef.h>
#include <stdint.h>

// Levels of a scene: LBS-only + every tier at its full rate and each reduced rate, on the CPU and (a scene with a GPU
// mode) on the GPU.
#define PLEAT_SCENE_MAX_LEVELS ( 1 + 2 * PLEAT_MAX_TIERS * ( 1 + PLEAT_MAX_NETWORK_RATES ) )

typedef struct plBudgetLevel
{
	float cost_us;     // per character and frame, on the CPU
	float error_mm;    // expected mean error
	int32_t tier;      // −1: LBS-only
	float rate_hz;     // 0: every step
	float gpu_cost_us; // per character and frame, on the GPU (0 for a CPU level)
	int32_t gpu;       // 1: the tier on the GPU (its stream cost is not the CPU's)
} plBudgetLevel;

// Two devices, one order: a level's plan cost is cost_us + gpu_weight · gpu_cost_us, its CPU and GPU µs in one unit
// (plSceneGpuWeight: the ratio of the two budgets), which orders the frontier and the steps; each step must still fit
// both budgets. gpu_weight 0: the CPU cost alone (a scene without a GPU).
static inline float plBudgetPlanCost( const plBudgetLevel* level, float gpu_weight )
{
	return level->cost_us + gpu_weight * level->gpu_cost_us;
}

// The efficient frontier of levels: indices sorted by plan cost, each strictly more accurate than the one before and
// on the lower convex hull of (plan cost, error). Returns the count (>= 1 for level_count >= 1).
uint32_t plBudgetFrontierWeighted( const plBudgetLevel* levels, uint32_t level_count, float gpu_weight,
								   uint32_t* out_frontier );
// plBudgetFrontierWeighted by the CPU cost alone.
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
	void* scratch;                    // plSceneBudgetScratchBytes, 4-byte aligned
	size_t scratch_bytes;
	uint32_t* out_level;              // [n] the plan
	float* out_cost_us;               // optional: the plan's cost
	// Two devices (all zero / NULL: the CPU alone): the GPU levels' frontier (from the same cheapest level as
	// frontier[0]: a character climbs one of the two), the GPU's budget (INFINITY: unlimited; levels' gpu_cost_us count
	// against it), the weight of the plan cost (plBudgetPlanCost; both frontiers were made with it), the fading-out
	// details' GPU costs and the plan's GPU cost.
	const uint32_t* gpu_frontier;
	uint32_t gpu_frontier_count;
	float gpu_budget_us;
	float gpu_weight;
	const float* extra_gpu_cost_us;   // [n] or NULL
	float* out_gpu_cost_us;           // optional
} plSceneBudgetJob;

// The scratch a job of n characters needs.
size_t plSceneBudgetScratchBytes( uint32_t character_count, uint32_t frontier_count, uint32_t gpu_frontier_count );
int plSceneBudgetJob_Validate( const plSceneBudgetJob* job );
plResult plSceneBudgetJob_Run( const plSceneBudgetJob* job );

#endif
