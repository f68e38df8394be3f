// Internal: the scene's budget policy as a job (scene_budget.c): levels of detail, their efficient frontier, the plan
// under a budget. Spans and numbers only: it knows no scene, instance or asset.
#ifndef PLEAT_SCENE_BUDGET_H
#define PLEAT_SCENE_BUDGET_H
#include "pleat/pleat.h"

#include <stddef.h>
#include <stdint.h>

// Levels of a scene: LBS-only + every tier at its full rate and each reduced rate.
#define PLEAT_SCENE_MAX_LEVELS ( 1 + PLEAT_MAX_TIERS * ( 1 + PLEAT_MAX_NETWORK_RATES ) )

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

#endif
