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

#include <math.h>
#include <stdlib.h>
#include <string.h>

// The share of the budget a step above a character's current level must leave free (the dead band).
#define PLEAT_SCENE_STEP_UP_MARGIN 0.05f

typedef struct plBudgetStep
{
	float value;        // importance × error saved / cost added (× 1 + hysteresis for held steps)
	uint32_t character;
	uint32_t position;  // the frontier position this step reaches
	uint32_t device;    // PL_ON_CPU or PL_ON_GPU: which frontier
} plBudgetStep;

// A free character's device while the steps are taken (the low two bits): none yet (on the shared cheapest level), or
// the frontier it climbs; and a bit per device whose next step did not fit (PL_CLOSED( d )), and one once it has tried
// the other device (PL_TRIED).
#define PL_ON_NONE 0u
#define PL_ON_CPU 1u
#define PL_ON_GPU 2u
#define PL_DEVICE( bits ) ( ( bits ) & 3u )
#define PL_CLOSED( d ) ( 4u << ( d ) )
#define PL_TRIED 32u

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
	if ( (uint64_t)job->scratch_bytes < plSceneBudgetScratchBytes( job->character_count, job->frontier_count,
																		 job->gpu_frontier_count ) )
	{
		return 0;
	}
	if ( job->gpu_frontier_count > 0 &&
		 ( job->gpu_frontier == NULL || job->gpu_frontier_count > job->level_count ||
		   job->gpu_frontier[0] != job->frontier[0] ) )
	{
		return 0;
	}
	// The GPU frontier's first step may cost less than the shared start (a free improvement); the rest climb.
	for ( uint32_t k = 1; k < job->gpu_frontier_count; ++k )
	{
		if ( job->gpu_frontier[k] >= job->level_count ||
			 ( k > 1 && !( plBudgetPlanCost( &job->levels[job->gpu_frontier[k]], job->gpu_weight ) >
						   plBudgetPlanCost( &job->levels[job->gpu_frontier[k - 1]], job->gpu_weight ) ) ) )
		{
			return 0;
		}
	}
	if ( !( job->gpu_weight >= 0.0f && isfinite( job->gpu_weight ) ) || job->gpu_budget_us < 0.0f ||
		 isnan( job->gpu_budget_us ) )
	{
		return 0;
	}
	for ( uint32_t k = 0; k < job->frontier_count; ++k )
	{
		if ( job->frontier[k] >= job->level_count ||
			 ( k > 0 && !( plBudgetPlanCost( &job->levels[job->frontier[k]], job->gpu_weight ) >
						   plBudgetPlanCost( &job->levels[job->frontier[k - 1]], job->gpu_weight ) ) ) )
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

size_t plSceneBudgetScratchBytes( uint32_t character_count, uint32_t frontier_count, uint32_t gpu_frontier_count )
{
	return (size_t)character_count * ( frontier_count + gpu_frontier_count ) * sizeof( plBudgetStep ) +
		   (size_t)character_count * 8u;
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
	if ( x->device != y->device )
	{
		return x->device < y->device ? -1 : 1;
	}
	return x->position < y->position ? -1 : ( x->position > y->position );
}

// The tier whose weights a level streams on the CPU (−1: none, LBS-only or a GPU level, whose weights stay on it).
static int32_t plStreamTier( const plBudgetLevel* level )
{
	return level->gpu ? -1 : level->tier;
}

// The plan's CPU cost change when a character moves from level `from` (UINT32_MAX: from nowhere) to level `to`, given
// the CPU characters each tier has: a tier's stream cost comes with its first character and goes with its last.
static float plMoveCost( const plSceneBudgetJob* job, const uint32_t* tier_users, uint32_t from, uint32_t to )
{
	const plBudgetLevel* b = &job->levels[to];
	float cost = b->cost_us;
	int32_t from_tier = -1, to_tier = plStreamTier( b );
	if ( from != UINT32_MAX )
	{
		cost -= job->levels[from].cost_us;
		from_tier = plStreamTier( &job->levels[from] );
	}
	if ( to_tier >= 0 && (uint32_t)to_tier < job->tier_count && to_tier != from_tier && tier_users[to_tier] == 0 )
	{
		cost += job->tier_stream_cost_us[to_tier];
	}
	if ( from_tier >= 0 && (uint32_t)from_tier < job->tier_count && from_tier != to_tier && tier_users[from_tier] == 1 )
	{
		cost -= job->tier_stream_cost_us[from_tier];
	}
	return cost;
}

// The plan's GPU cost change of the same move.
static float plMoveGpuCost( const plSceneBudgetJob* job, uint32_t from, uint32_t to )
{
	return job->levels[to].gpu_cost_us - ( from != UINT32_MAX ? job->levels[from].gpu_cost_us : 0.0f );
}

static void plMove( const plSceneBudgetJob* job, uint32_t* tier_users, uint32_t from, uint32_t to )
{
	int32_t from_tier = from != UINT32_MAX ? plStreamTier( &job->levels[from] ) : -1;
	int32_t to_tier = plStreamTier( &job->levels[to] );
	if ( from_tier >= 0 && (uint32_t)from_tier < job->tier_count )
	{
		tier_users[from_tier] -= 1;
	}
	if ( to_tier >= 0 && (uint32_t)to_tier < job->tier_count )
	{
		tier_users[to_tier] += 1;
	}
}

// The position on a frontier that a character now on `level` holds: the highest one costing no more, on the frontier
// of its own device (0 on the other's: a move across is a new detail, not a kept one).
static uint32_t plHeldPosition( const plSceneBudgetJob* job, const uint32_t* frontier, uint32_t frontier_count,
								uint32_t device, uint32_t level )
{
	uint32_t held = 0;
	const plBudgetLevel* l = &job->levels[level];
	if ( l->tier >= 0 && ( l->gpu ? PL_ON_GPU : PL_ON_CPU ) != device )
	{
		return 0;
	}
	float cost = plBudgetPlanCost( l, job->gpu_weight );
	for ( uint32_t k = 0; k < frontier_count; ++k )
	{
		held = plBudgetPlanCost( &job->levels[frontier[k]], job->gpu_weight ) <= cost ? k : held;
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
	size_t step_bytes = (size_t)n * ( k_count + job->gpu_frontier_count ) * sizeof( plBudgetStep );
	uint32_t* position = (uint32_t*)( (uint8_t*)job->scratch + step_bytes );
	uint32_t tier_users[PLEAT_MAX_TIERS];
	memset( tier_users, 0, sizeof( tier_users ) );
	// The fading-out details' costs end with their fades. They close the budget to steps above where a character
	// already is, but they do not push anyone below it: that would start more fades, whose costs push more down (the
	// bench scene at 3 ms switched ~10 characters a frame that way and ran at 1.6x its budget).
	float spent = 0.0f, fading = 0.0f, spent_gpu = 0.0f, fading_gpu = 0.0f;
	for ( uint32_t c = 0; c < n; ++c )
	{
		fading += job->extra_cost_us != NULL ? job->extra_cost_us[c] : 0.0f;
		fading_gpu += job->extra_gpu_cost_us != NULL ? job->extra_gpu_cost_us[c] : 0.0f;
	}

	// Pinned characters first, whatever they cost.
	for ( uint32_t c = 0; c < n; ++c )
	{
		position[c] = UINT32_MAX; // not free
		if ( job->pinned[c] >= 0 )
		{
			job->out_level[c] = (uint32_t)job->pinned[c];
			spent += plMoveCost( job, tier_users, UINT32_MAX, job->out_level[c] );
			spent_gpu += plMoveGpuCost( job, UINT32_MAX, job->out_level[c] );
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
			spent_gpu += plMoveGpuCost( job, UINT32_MAX, job->frontier[0] );
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
		float extra_gpu = plMoveGpuCost( job, job->frontier[0], (uint32_t)job->held[best] );
		if ( spent + extra <= job->budget_us && ( extra_gpu <= 0.0f || spent_gpu + extra_gpu <= job->gpu_budget_us ) )
		{
			spent += extra;
			spent_gpu += extra_gpu;
			plMove( job, tier_users, job->frontier[0], (uint32_t)job->held[best] );
			job->out_level[best] = (uint32_t)job->held[best];
		}
		else
		{
			position[best] = 0; // could not be held: free, from the bottom
		}
	}

	// The steps up the frontiers of every free character, in order of worth: the CPU's and, with a GPU, the GPU's. A
	// character's first step commits it to that device; its steps on the other are passed over.
	uint8_t* device = (uint8_t*)( position + n );
	const uint32_t* frontiers[3] = { NULL, job->frontier, job->gpu_frontier };
	const uint32_t counts[3] = { 0, k_count, job->gpu_frontier_count };
	uint32_t step_count = 0;
	for ( uint32_t c = 0; c < n; ++c )
	{
		device[c] = PL_ON_NONE;
		if ( job->pinned[c] >= 0 || ( job->held[c] >= 0 && position[c] == UINT32_MAX - 1u ) )
		{
			continue;
		}
		position[c] = 0;
		for ( uint32_t d = PL_ON_CPU; d <= PL_ON_GPU; ++d )
		{
			uint32_t held = plHeldPosition( job, frontiers[d], counts[d], d, job->current[c] );
			for ( uint32_t k = 1; k < counts[d]; ++k )
			{
				const plBudgetLevel* lo = &job->levels[frontiers[d][k - 1]];
				const plBudgetLevel* hi = &job->levels[frontiers[d][k]];
				float added = plBudgetPlanCost( hi, job->gpu_weight ) - plBudgetPlanCost( lo, job->gpu_weight );
				// A step that costs nothing more (the GPU's first, below the start) is worth any other.
				float value = added > 0.0f ? job->importance[c] * ( lo->error_mm - hi->error_mm ) / added : INFINITY;
				steps[step_count].value = k <= held ? value * ( 1.0f + job->hysteresis ) : value;
				steps[step_count].character = c;
				steps[step_count].position = k;
				steps[step_count].device = d;
				step_count++;
			}
		}
	}
	qsort( steps, step_count, sizeof( plBudgetStep ), plCompareSteps );
	// Two rounds: the steps in order of worth, then the characters that ran out of room on their device moved to the
	// other; what those moves freed is taken up by a second round of the same steps.
	uint32_t rounds = job->gpu_frontier_count > 1 ? 2u : 1u;
	for ( uint32_t round = 0; round < rounds; ++round )
	{
		for ( uint32_t c = 0; round > 0 && c < n; ++c )
		{
			device[c] = (uint8_t)PL_DEVICE( device[c] ); // open again: the budget may have room now
		}
		for ( uint32_t s = 0; s < step_count; ++s )
		{
			uint32_t c = steps[s].character, k = steps[s].position, d = steps[s].device;
			uint32_t on = PL_DEVICE( device[c] );
			if ( ( on != PL_ON_NONE && on != d ) || ( device[c] & PL_CLOSED( d ) ) || position[c] != k - 1 ||
				 !( steps[s].value > 0.0f ) )
			{
				continue; // on the other device, or an earlier step of this character did not fit: it stays there
			}
			const uint32_t* f = frontiers[d];
			float extra = plMoveCost( job, tier_users, f[k - 1], f[k] );
			float extra_gpu = plMoveGpuCost( job, f[k - 1], f[k] );
			int keeps = k <= plHeldPosition( job, f, counts[d], d, job->current[c] ); // back to where it already is
			// A step above where the character is must also leave a margin: a correction that wobbles by a few percent
			// then moves nobody up and down (a dead band), only a real change of the budget or the costs does.
			float margin = keeps ? 1.0f : 1.0f - PLEAT_SCENE_STEP_UP_MARGIN;
			int cpu_over = spent + ( keeps ? 0.0f : fading ) + extra > job->budget_us * margin;
			int gpu_over =
				extra_gpu > 0.0f && spent_gpu + ( keeps ? 0.0f : fading_gpu ) + extra_gpu > job->gpu_budget_us * margin;
			if ( cpu_over || gpu_over )
			{
				// Closed on this device; one not yet on either may still take its first step on the other.
				device[c] = (uint8_t)( device[c] | PL_CLOSED( d ) );
				continue;
			}
			spent += extra;
			spent_gpu += extra_gpu;
			plMove( job, tier_users, f[k - 1], f[k] );
			position[c] = k;
			device[c] = (uint8_t)( ( device[c] & ~3u ) | d );
			job->out_level[c] = f[k];
		}
		// Characters that ran out of room on their device try the other: the most important first, each to the most
		// accurate level there that improves on where it is and fits both budgets once its own costs are freed.
		for ( uint32_t pass = 0; job->gpu_frontier_count > 1 && pass < n; ++pass )
		{
			uint32_t best = UINT32_MAX;
			for ( uint32_t c = 0; c < n; ++c )
			{
				uint32_t on = PL_DEVICE( device[c] );
				if ( on != PL_ON_NONE && ( device[c] & PL_CLOSED( on ) ) && !( device[c] & PL_TRIED ) &&
					 ( best == UINT32_MAX || job->importance[c] > job->importance[best] ) )
				{
					best = c;
				}
			}
			if ( best == UINT32_MAX )
			{
				break;
			}
			uint32_t other = PL_DEVICE( device[best] ) == PL_ON_CPU ? PL_ON_GPU : PL_ON_CPU;
			device[best] = (uint8_t)( device[best] | PL_TRIED );
			uint32_t from = job->out_level[best];
			if ( position[best] >= counts[PL_DEVICE( device[best] )] )
			{
				continue; // held or pinned: not a free character's
			}
			for ( uint32_t k = counts[other] - 1; k >= 1; --k )
			{
				uint32_t to = frontiers[other][k];
				if ( !( job->levels[to].error_mm < job->levels[from].error_mm ) )
				{
					break; // lower on that frontier is no better than where it is
				}
				float extra = plMoveCost( job, tier_users, from, to );
				float extra_gpu = plMoveGpuCost( job, from, to );
				float margin = 1.0f - PLEAT_SCENE_STEP_UP_MARGIN;
				if ( ( extra > 0.0f && spent + fading + extra > job->budget_us * margin ) ||
					 ( extra_gpu > 0.0f && spent_gpu + fading_gpu + extra_gpu > job->gpu_budget_us * margin ) )
				{
					continue;
				}
				spent += extra;
				spent_gpu += extra_gpu;
				plMove( job, tier_users, from, to );
				job->out_level[best] = to;
				position[best] = k;
				device[best] = (uint8_t)( other | PL_TRIED );
				break;
			}
		}
	}
	if ( job->out_cost_us != NULL )
	{
		*job->out_cost_us = spent + fading;
	}
	if ( job->out_gpu_cost_us != NULL )
	{
		*job->out_gpu_cost_us = spent_gpu + fading_gpu;
	}
	return PLEAT_RESULT_OK;
}

// Whether level a sorts after level b on the frontier: dearer, or as dear and less accurate.
static int plSortsAfter( const plBudgetLevel* a, const plBudgetLevel* b, float gpu_weight )
{
	float ca = plBudgetPlanCost( a, gpu_weight ), cb = plBudgetPlanCost( b, gpu_weight );
	return ca > cb || ( ca == cb && a->error_mm > b->error_mm );
}

uint32_t plBudgetFrontier( const plBudgetLevel* levels, uint32_t level_count, uint32_t* out_frontier )
{
	return plBudgetFrontierWeighted( levels, level_count, 0.0f, out_frontier );
}

uint32_t plBudgetFrontierWeighted( const plBudgetLevel* levels, uint32_t level_count, float gpu_weight,
								   uint32_t* out_frontier )
{
	// Sort indices by cost (then error): insertion sort, the levels are few.
	uint32_t order[PLEAT_SCENE_MAX_LEVELS];
	uint32_t count = level_count < PLEAT_SCENE_MAX_LEVELS ? level_count : PLEAT_SCENE_MAX_LEVELS;
	for ( uint32_t i = 0; i < count; ++i )
	{
		uint32_t j = i;
		while ( j > 0 && plSortsAfter( &levels[order[j - 1]], &levels[i], gpu_weight ) )
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
						 plBudgetPlanCost( p, gpu_weight ) >
							 plBudgetPlanCost( &levels[out_frontier[k - 1]], gpu_weight ) ) )
		{
			continue;
		}
		while ( k >= 2 )
		{
			const plBudgetLevel* a = &levels[out_frontier[k - 2]];
			const plBudgetLevel* b = &levels[out_frontier[k - 1]];
			// b is above the segment a→p (or on it): its error saved per µs is no better than going straight to p.
			double ca = plBudgetPlanCost( a, gpu_weight ), cb = plBudgetPlanCost( b, gpu_weight );
			double cp = plBudgetPlanCost( p, gpu_weight );
			double cross = ( cb - ca ) * ( (double)p->error_mm - a->error_mm ) -
						   ( (double)b->error_mm - a->error_mm ) * ( cp - ca );
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
