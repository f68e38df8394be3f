// The scene budget policy (docs/scene-budget.md): given a per-frame budget and each character's importance, which
// level of detail every character gets — a tier at a network rate, or LBS-only. A job in the jobs.h sense: spans of
// the caller's memory in, the plan out, nothing allocated, the same plan for the same inputs.
//
// The levels a free character may take are the efficient frontier of (cost, error): sorted by cost, each one strictly
// more accurate than the one before, and on the lower convex hull, so that every step up the frontier buys less error
// per µs than the step before it. Everyone starts on the cheapest level; then the steps of all characters are taken in
// the order of importance × error saved / cost added, each while the budget still holds it (a character whose next
// step no longer fits stops there). With convex frontiers this greedy order is the optimum of the fractional problem
// (minimise Σ importance · error at Σ cost ≤ budget), i.e. it spends each µs where it removes the most weighted error.
//
// Hysteresis: the steps a character already holds are valued (1 + hysteresis) times their worth, so it keeps its level
// unless someone else's use of the budget is worth that much more; small changes of importance move nobody. Pinned
// characters (an engine override) take their level first; held ones (a recent switch, still within its minimum time)
// keep theirs if the budget allows, the most important first. A tier's weights are read once per group of characters
// sharing it (plStepInstances), so the first character on a tier also pays that tier's stream cost.
#include "scene_budget.h"

#include <stdlib.h>
#include <string.h>

// The share of the budget a step above a character's current level must leave free (the dead band).
#define PLEAT_SCENE_STEP_UP_MARGIN 0.05f

typedef struct plBudgetStep
{
	float value;        // importance × error saved / cost added (× 1 + hysteresis for held steps)
	uint32_t character;
	uint32_t position;  // the frontier position this step reaches
} plBudgetStep;

int plSceneBudgetJob_Validate( const plSceneBudgetJob* job )
{
	if ( job == NULL || job->levels == NULL || job->level_count == 0 || job->frontier == NULL ||
		 job->frontier_count == 0 || job->frontier_count > job->level_count || job->importance == NULL ||
		 job->current == NULL || job->pinned == NULL || job->held == NULL || job->out_level == NULL ||
		 ( job->scratch == NULL && job->character_count > 0 ) || !( job->hysteresis >= 0.0f ) ||
		 !( job->budget_us >= 0.0f ) )
	{
		return 0;
	}
	if ( (uint64_t)job->scratch_bytes <
		 (uint64_t)job->character_count * job->frontier_count * sizeof( plBudgetStep ) + job->character_count * 4u )
	{
		return 0;
	}
	for ( uint32_t k = 0; k < job->frontier_count; ++k )
	{
		if ( job->frontier[k] >= job->level_count ||
			 ( k > 0 && !( job->levels[job->frontier[k]].cost_us > job->levels[job->frontier[k - 1]].cost_us ) ) )
		{
			return 0;
		}
	}
	for ( uint32_t c = 0; c < job->character_count; ++c )
	{
		if ( ( job->pinned[c] >= 0 && (uint32_t)job->pinned[c] >= job->level_count ) ||
			 ( job->held[c] >= 0 && (uint32_t)job->held[c] >= job->level_count ) ||
			 job->current[c] >= job->level_count || !( job->importance[c] >= 0.0f ) )
		{
			return 0;
		}
	}
	return job->tier_count == 0 || job->tier_stream_cost_us != NULL;
}

static int plCompareSteps( const void* a, const void* b )
{
	const plBudgetStep* x = (const plBudgetStep*)a;
	const plBudgetStep* y = (const plBudgetStep*)b;
	if ( x->value != y->value )
	{
		return x->value > y->value ? -1 : 1;
	}
	if ( x->character != y->character )
	{
		return x->character < y->character ? -1 : 1;
	}
	return x->position < y->position ? -1 : ( x->position > y->position );
}

// The plan's cost change when a character moves from level `from` (UINT32_MAX: from nowhere) to level `to`, given the
// characters each tier has: a tier's stream cost comes with its first character and goes with its last.
static float plMoveCost( const plSceneBudgetJob* job, const uint32_t* tier_users, uint32_t from, uint32_t to )
{
	const plBudgetLevel* b = &job->levels[to];
	float cost = b->cost_us;
	int32_t from_tier = -1;
	if ( from != UINT32_MAX )
	{
		cost -= job->levels[from].cost_us;
		from_tier = job->levels[from].tier;
	}
	if ( b->tier >= 0 && (uint32_t)b->tier < job->tier_count && b->tier != from_tier && tier_users[b->tier] == 0 )
	{
		cost += job->tier_stream_cost_us[b->tier];
	}
	if ( from_tier >= 0 && (uint32_t)from_tier < job->tier_count && from_tier != b->tier && tier_users[from_tier] == 1 )
	{
		cost -= job->tier_stream_cost_us[from_tier];
	}
	return cost;
}

static void plMove( const plSceneBudgetJob* job, uint32_t* tier_users, uint32_t from, uint32_t to )
{
	if ( from != UINT32_MAX && job->levels[from].tier >= 0 && (uint32_t)job->levels[from].tier < job->tier_count )
	{
		tier_users[job->levels[from].tier] -= 1;
	}
	if ( job->levels[to].tier >= 0 && (uint32_t)job->levels[to].tier < job->tier_count )
	{
		tier_users[job->levels[to].tier] += 1;
	}
}

// The frontier position a character now on `level` holds: the highest one costing no more.
static uint32_t plHeldPosition( const plSceneBudgetJob* job, uint32_t level )
{
	uint32_t held = 0;
	for ( uint32_t k = 0; k < job->frontier_count; ++k )
	{
		held = job->levels[job->frontier[k]].cost_us <= job->levels[level].cost_us ? k : held;
	}
	return held;
}

plResult plSceneBudgetJob_Run( const plSceneBudgetJob* job )
{
	if ( !plSceneBudgetJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	uint32_t n = job->character_count, k_count = job->frontier_count;
	plBudgetStep* steps = (plBudgetStep*)job->scratch;
	uint32_t* position = (uint32_t*)( (uint8_t*)job->scratch + (size_t)n * k_count * sizeof( plBudgetStep ) );
	uint32_t tier_users[PLEAT_MAX_TIERS];
	memset( tier_users, 0, sizeof( tier_users ) );
	// The fading-out details' costs end with their fades. They close the budget to steps above where a character
	// already is, but they do not push anyone below it: that would start more fades, whose costs push more down (the
	// bench scene at 3 ms switched ~10 characters a frame that way and ran at 1.6x its budget).
	float spent = 0.0f, fading = 0.0f;
	for ( uint32_t c = 0; c < n; ++c )
	{
		fading += job->extra_cost_us != NULL ? job->extra_cost_us[c] : 0.0f;
	}

	// Pinned characters first, whatever they cost.
	for ( uint32_t c = 0; c < n; ++c )
	{
		position[c] = UINT32_MAX; // not free
		if ( job->pinned[c] >= 0 )
		{
			job->out_level[c] = (uint32_t)job->pinned[c];
			spent += plMoveCost( job, tier_users, UINT32_MAX, job->out_level[c] );
			plMove( job, tier_users, UINT32_MAX, job->out_level[c] );
		}
	}
	// Everyone else starts on the cheapest level.
	for ( uint32_t c = 0; c < n; ++c )
	{
		if ( job->pinned[c] < 0 )
		{
			job->out_level[c] = job->frontier[0];
			spent += plMoveCost( job, tier_users, UINT32_MAX, job->frontier[0] );
			plMove( job, tier_users, UINT32_MAX, job->frontier[0] );
		}
	}
	// Held characters keep their level while the budget allows, the most important first (selection by scan: the
	// held are few, those that switched in the last moments).
	for ( ;; )
	{
		uint32_t best = UINT32_MAX;
		for ( uint32_t c = 0; c < n; ++c )
		{
			if ( job->pinned[c] < 0 && job->held[c] >= 0 && job->out_level[c] == job->frontier[0] &&
				 position[c] == UINT32_MAX && (uint32_t)job->held[c] != job->frontier[0] &&
				 ( best == UINT32_MAX || job->importance[c] > job->importance[best] ) )
			{
				best = c;
			}
		}
		if ( best == UINT32_MAX )
		{
			break;
		}
		position[best] = UINT32_MAX - 1u; // decided
		float extra = plMoveCost( job, tier_users, job->frontier[0], (uint32_t)job->held[best] );
		if ( spent + extra <= job->budget_us )
		{
			spent += extra;
			plMove( job, tier_users, job->frontier[0], (uint32_t)job->held[best] );
			job->out_level[best] = (uint32_t)job->held[best];
		}
		else
		{
			position[best] = 0; // could not be held: free, from the bottom
		}
	}

	// The steps up the frontier of every free character, in order of worth.
	uint32_t step_count = 0;
	for ( uint32_t c = 0; c < n; ++c )
	{
		if ( job->pinned[c] >= 0 || ( job->held[c] >= 0 && position[c] == UINT32_MAX - 1u ) )
		{
			continue;
		}
		position[c] = 0;
		uint32_t held = plHeldPosition( job, job->current[c] );
		for ( uint32_t k = 1; k < k_count; ++k )
		{
			const plBudgetLevel* lo = &job->levels[job->frontier[k - 1]];
			const plBudgetLevel* hi = &job->levels[job->frontier[k]];
			float value = job->importance[c] * ( lo->error_mm - hi->error_mm ) / ( hi->cost_us - lo->cost_us );
			steps[step_count].value = k <= held ? value * ( 1.0f + job->hysteresis ) : value;
			steps[step_count].character = c;
			steps[step_count].position = k;
			step_count++;
		}
	}
	qsort( steps, step_count, sizeof( plBudgetStep ), plCompareSteps );
	for ( uint32_t s = 0; s < step_count; ++s )
	{
		uint32_t c = steps[s].character, k = steps[s].position;
		if ( position[c] != k - 1 || !( steps[s].value > 0.0f ) )
		{
			continue; // an earlier step of this character did not fit: it stays where it is
		}
		float extra = plMoveCost( job, tier_users, job->frontier[k - 1], job->frontier[k] );
		int keeps = k <= plHeldPosition( job, job->current[c] ); // back to where the character already is
		// A step above where the character is must also leave a margin: a correction that wobbles by a few percent
		// then moves nobody up and down (a dead band), only a real change of the budget or the costs does.
		float limit = keeps ? job->budget_us : job->budget_us * ( 1.0f - PLEAT_SCENE_STEP_UP_MARGIN );
		if ( spent + ( keeps ? 0.0f : fading ) + extra > limit )
		{
			position[c] = UINT32_MAX - 2u; // closed
			continue;
		}
		spent += extra;
		plMove( job, tier_users, job->frontier[k - 1], job->frontier[k] );
		position[c] = k;
		job->out_level[c] = job->frontier[k];
	}
	if ( job->out_cost_us != NULL )
	{
		*job->out_cost_us = spent + fading;
	}
	return PLEAT_RESULT_OK;
}

uint32_t plBudgetFrontier( const plBudgetLevel* levels, uint32_t level_count, uint32_t* out_frontier )
{
	// Sort indices by cost (then error): insertion sort, the levels are few.
	uint32_t order[PLEAT_SCENE_MAX_LEVELS];
	uint32_t count = level_count < PLEAT_SCENE_MAX_LEVELS ? level_count : PLEAT_SCENE_MAX_LEVELS;
	for ( uint32_t i = 0; i < count; ++i )
	{
		uint32_t j = i;
		while ( j > 0 && ( levels[order[j - 1]].cost_us > levels[i].cost_us ||
						   ( levels[order[j - 1]].cost_us == levels[i].cost_us &&
							 levels[order[j - 1]].error_mm > levels[i].error_mm ) ) )
		{
			order[j] = order[j - 1];
			j--;
		}
		order[j] = i;
	}
	// The lower convex hull from the cheapest level, keeping only levels that lower the error.
	uint32_t k = 0;
	for ( uint32_t i = 0; i < count; ++i )
	{
		const plBudgetLevel* p = &levels[order[i]];
		if ( k > 0 && !( p->error_mm < levels[out_frontier[k - 1]].error_mm &&
						 p->cost_us > levels[out_frontier[k - 1]].cost_us ) )
		{
			continue;
		}
		while ( k >= 2 )
		{
			const plBudgetLevel* a = &levels[out_frontier[k - 2]];
			const plBudgetLevel* b = &levels[out_frontier[k - 1]];
			// b is above the segment a→p (or on it): its error saved per µs is no better than going straight to p.
			double cross = ( (double)b->cost_us - a->cost_us ) * ( (double)p->error_mm - a->error_mm ) -
						   ( (double)b->error_mm - a->error_mm ) * ( (double)p->cost_us - a->cost_us );
			if ( cross > 0.0 )
			{
				break;
			}
			k--;
		}
		out_frontier[k++] = order[i];
	}
	return k;
}
