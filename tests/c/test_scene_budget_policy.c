// The scene budget policy (scene_budget.c) and the scene that runs it (scene.c): the frontier keeps only levels that
// buy error with cost at a falling rate; a plan never exceeds the budget (unless the cheapest level for everyone
// already does); an unlimited budget gives everyone the best level and a budget of nothing the cheapest; more
// important characters never get worse levels than less important ones; hysteresis keeps a plan through small changes
// of importance and gives way to large ones; pins and holds are honoured; the scene's overrides, reads, budget changes
// and minimum time between switches behave as pleat.h says, over several frames on a small test garment in three
// tiers (one on a coarser mesh).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "scene.h"
#include "test_common.h"

static uint32_t s_rng = 99;

static float plRand01( void )
{
	s_rng ^= s_rng << 13;
	s_rng ^= s_rng >> 17;
	s_rng ^= s_rng << 5;
	return (float)( s_rng >> 8 ) / 16777216.0f;
}

// LBS (10 µs, 30 mm), tier 0 at full / 30 Hz, tier 1 at full / 30 Hz, tier 2 (full only).
static uint32_t plLadder( plBudgetLevel* levels )
{
	const plBudgetLevel l[] = {
		{ 10.0f, 30.0f, -1, 0.0f, 0.0f, 0 },  { 150.0f, 10.0f, 0, 0.0f, 0.0f, 0 },  { 90.0f, 10.5f, 0, 30.0f, 0.0f, 0 },
		{ 60.0f, 14.0f, 1, 0.0f, 0.0f, 0 },   { 40.0f, 14.5f, 1, 30.0f, 0.0f, 0 },  { 30.0f, 24.0f, 2, 0.0f, 0.0f, 0 },
		{ 200.0f, 12.0f, 0, 15.0f, 0.0f, 0 }, // dominated: dearer than tier 0's full rate and less accurate
	};
	memcpy( levels, l, sizeof( l ) );
	return (uint32_t)( sizeof( l ) / sizeof( l[0] ) );
}

static void test_frontier_is_sorted_convex_and_drops_dominated_levels( void** state )
{
	(void)state;
	plBudgetLevel levels[8];
	uint32_t count = plLadder( levels ), frontier[PLEAT_SCENE_MAX_LEVELS];
	uint32_t k = plBudgetFrontier( levels, count, frontier );
	assert_true( k >= 2 );
	assert_int_equal( frontier[0], 0 ); // the cheapest
	for ( uint32_t i = 1; i < k; ++i )
	{
		assert_true( levels[frontier[i]].cost_us > levels[frontier[i - 1]].cost_us );
		assert_true( levels[frontier[i]].error_mm < levels[frontier[i - 1]].error_mm );
		assert_int_not_equal( frontier[i], 6 );
		if ( i >= 2 ) // error saved per µs falls along the frontier
		{
			const plBudgetLevel *a = &levels[frontier[i - 2]], *b = &levels[frontier[i - 1]], *c = &levels[frontier[i]];
			assert_true( ( a->error_mm - b->error_mm ) / ( b->cost_us - a->cost_us ) >=
						 ( b->error_mm - c->error_mm ) / ( c->cost_us - b->cost_us ) );
		}
	}
	assert_int_equal( frontier[k - 1], 1 ); // the most accurate level ends it
}

typedef struct plPlanner
{
	plBudgetLevel levels[8];
	uint32_t level_count, frontier[PLEAT_SCENE_MAX_LEVELS], frontier_count;
	float stream[3];
	float importance[64];
	uint32_t current[64], out[64];
	int32_t pinned[64], held[64];
	uint8_t scratch[64 * PLEAT_SCENE_MAX_LEVELS * 12 + 64 * 4];
} plPlanner;

static void plPlanner_Init( plPlanner* p )
{
	memset( p, 0, sizeof( *p ) );
	p->level_count = plLadder( p->levels );
	p->frontier_count = plBudgetFrontier( p->levels, p->level_count, p->frontier );
	for ( int i = 0; i < 64; ++i )
	{
		p->pinned[i] = p->held[i] = -1;
	}
}

static float plPlan( plPlanner* p, uint32_t n, float budget, float hysteresis )
{
	float cost = -1.0f;
	plSceneBudgetJob job = { p->levels,   p->level_count, p->frontier, p->frontier_count, p->stream, 3,
							 n,           p->importance,  p->current,  p->pinned,         p->held,   NULL,
							 budget,      hysteresis,     p->scratch,  sizeof( p->scratch ), p->out,  &cost,
							 NULL,        0,              0.0f,        0.0f,              NULL,      NULL }; // the CPU alone
	assert_int_equal( plSceneBudgetJob_Run( &job ), PLEAT_RESULT_OK );
	// The reported cost is the plan's own.
	double sum = 0.0;
	int used[3] = { 0, 0, 0 };
	for ( uint32_t c = 0; c < n; ++c )
	{
		sum += p->levels[p->out[c]].cost_us;
		if ( p->levels[p->out[c]].tier >= 0 && !used[p->levels[p->out[c]].tier] )
		{
			used[p->levels[p->out[c]].tier] = 1;
			sum += p->stream[p->levels[p->out[c]].tier];
		}
	}
	assert_true( fabs( sum - cost ) <= 1e-3 * ( 1.0 + sum ) );
	return cost;
}

static void test_plans_stay_within_budget_and_follow_importance( void** state )
{
	(void)state;
	plPlanner p;
	plPlanner_Init( &p );
	p.stream[0] = 40.0f, p.stream[1] = 20.0f, p.stream[2] = 5.0f;
	const uint32_t n = 48;
	for ( int trial = 0; trial < 200; ++trial )
	{
		for ( uint32_t c = 0; c < n; ++c )
		{
			p.importance[c] = plRand01();
			p.current[c] = 0;
		}
		float budget = n * 10.0f + plRand01() * n * 150.0f;
		float cost = plPlan( &p, n, budget, 0.0f );
		assert_true( cost <= budget );
		// Importance order: a more important character is never on a less accurate level.
		for ( uint32_t a = 0; a < n; ++a )
		{
			for ( uint32_t b = 0; b < n; ++b )
			{
				if ( p.importance[a] > p.importance[b] )
				{
					assert_true( p.levels[p.out[a]].error_mm <= p.levels[p.out[b]].error_mm );
				}
			}
		}
	}
	// Unlimited: everyone on the most accurate level. Nothing: everyone on the cheapest (which then exceeds it).
	plPlan( &p, n, INFINITY, 0.0f );
	for ( uint32_t c = 0; c < n; ++c )
	{
		assert_int_equal( p.out[c], 1 );
	}
	float cost = plPlan( &p, n, 0.0f, 0.0f );
	for ( uint32_t c = 0; c < n; ++c )
	{
		assert_int_equal( p.out[c], 0 );
	}
	assert_true( cost == n * 10.0f );
	// Importance 0 takes nothing above the cheapest level, whatever the budget.
	p.importance[3] = 0.0f;
	plPlan( &p, n, INFINITY, 0.0f );
	assert_int_equal( p.out[3], 0 );
}

// n characters of random importance planned from the cheapest level at budget (hysteresis 0.25) and settled there:
// the plan in first[] and in p->current.
static void plSettle( plPlanner* p, uint32_t n, float budget, uint32_t* first )
{
	plPlanner_Init( p );
	for ( uint32_t c = 0; c < n; ++c )
	{
		p->importance[c] = 0.2f + 0.6f * plRand01();
		p->current[c] = 0;
	}
	plPlan( p, n, budget, 0.25f );
	memcpy( first, p->out, sizeof( p->out ) );
	memcpy( p->current, p->out, sizeof( p->current ) );
}

static void test_hysteresis_keeps_plans_through_small_changes( void** state )
{
	(void)state;
	plPlanner p;
	const uint32_t n = 32;
	float budget = n * 55.0f; // room for about half of the characters above LBS
	uint32_t first[64];
	plSettle( &p, n, budget, first );
	uint32_t changed_small = 0, changed_large = 0, changed_without = 0;
	for ( int trial = 0; trial < 50; ++trial )
	{
		float saved[64];
		memcpy( saved, p.importance, sizeof( saved ) );
		for ( uint32_t c = 0; c < n; ++c )
		{
			p.importance[c] *= 1.0f + 0.1f * ( 2.0f * plRand01() - 1.0f ); // ±10 %: below the 25 % hysteresis
		}
		plPlan( &p, n, budget, 0.25f );
		for ( uint32_t c = 0; c < n; ++c )
		{
			changed_small += p.out[c] != first[c];
		}
		plPlan( &p, n, budget, 0.0f );
		for ( uint32_t c = 0; c < n; ++c )
		{
			changed_without += p.out[c] != first[c];
		}
		memcpy( p.importance, saved, sizeof( saved ) );
	}
	assert_int_equal( changed_small, 0 );
	assert_true( changed_without > 0 ); // the same jitter without hysteresis does move characters
	// A large change does get through: the least important character becomes the most important.
	uint32_t least = 0;
	for ( uint32_t c = 1; c < n; ++c )
	{
		least = p.importance[c] < p.importance[least] ? c : least;
	}
	p.importance[least] = 10.0f;
	plPlan( &p, n, budget, 0.25f );
	changed_large += p.out[least] != first[least];
	assert_int_equal( changed_large, 1 );
	assert_int_equal( p.out[least], 1 );
}

// The dead band: a step above a character's current level must leave 5 % of the budget free, keeping a level needs
// only the budget. So a plan made at budget B survives the budget falling by up to that share (a cost correction that
// wobbles moves nobody), and a larger fall does move characters down.
static void test_budget_wobble_inside_the_dead_band_moves_nobody( void** state )
{
	(void)state;
	plPlanner p;
	const uint32_t n = 32;
	float budget = n * 55.0f;
	uint32_t first[64];
	plSettle( &p, n, budget, first );
	uint32_t mixed = 0;
	for ( uint32_t c = 0; c < n; ++c )
	{
		mixed += first[c] != first[0];
	}
	assert_true( mixed > 0 ); // the budget matters: the characters are on different levels
	for ( int trial = 0; trial < 20; ++trial )
	{
		float wobble = 1.0f - 0.045f * (float)trial / 19.0f; // down to −4.5 %
		plPlan( &p, n, budget * wobble, 0.25f );
		for ( uint32_t c = 0; c < n; ++c )
		{
			assert_int_equal( p.out[c], first[c] );
		}
	}
	plPlan( &p, n, budget * 0.85f, 0.25f );
	uint32_t moved = 0;
	for ( uint32_t c = 0; c < n; ++c )
	{
		moved += p.out[c] != first[c];
	}
	assert_true( moved > 0 );
}

static void test_pins_and_holds( void** state )
{
	(void)state;
	plPlanner p;
	plPlanner_Init( &p );
	const uint32_t n = 8;
	for ( uint32_t c = 0; c < n; ++c )
	{
		p.importance[c] = 1.0f;
	}
	p.importance[0] = 0.0f;
	p.pinned[0] = 1; // the engine insists: the best level for an unimportant character
	p.held[1] = 3;   // switched recently to tier 1
	float cost = plPlan( &p, n, 150.0f + 60.0f + 6 * 10.0f, 0.0f );
	assert_int_equal( p.out[0], 1 );
	assert_int_equal( p.out[1], 3 );
	assert_true( cost <= 270.0f );
	// Not enough budget for the hold: it is given up (the pin is not).
	plPlan( &p, n, 150.0f + 7 * 10.0f, 0.0f );
	assert_int_equal( p.out[0], 1 );
	assert_int_equal( p.out[1], 0 );
	// Invalid jobs are refused.
	plSceneBudgetJob job = { p.levels, p.level_count, p.frontier, p.frontier_count, p.stream, 3, n, p.importance,
							 p.current, p.pinned, p.held, NULL, 100.0f, 0.0f, p.scratch, 16, p.out, NULL,
							 NULL, 0, 0.0f, 0.0f, NULL, NULL };
	assert_false( plSceneBudgetJob_Validate( &job ) ); // scratch too small
	job.scratch_bytes = sizeof( p.scratch );
	assert_true( plSceneBudgetJob_Validate( &job ) );
	p.pinned[2] = 99;
	assert_int_equal( plSceneBudgetJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
	p.pinned[2] = -1;
	p.importance[2] = NAN;
	assert_false( plSceneBudgetJob_Validate( &job ) );
}

// ---- the scene ----

typedef struct plSceneRig
{
	plContext context;
	plTestSceneTiers set;
} plSceneRig;

static void plSceneRig_Init( plSceneRig* rig )
{
	memset( rig, 0, sizeof( *rig ) );
	plContextDef cdef = plDefaultContextDef();
	assert_int_equal( plCreateContext( &cdef, &rig->context ), PLEAT_RESULT_OK );
	assert_int_equal( plTestSceneTiers_Load( &rig->set, rig->context ), PLEAT_RESULT_OK );
}

static void plSceneRig_Free( plSceneRig* rig )
{
	uint64_t live = 1;
	plContext_GetLiveBytes( rig->context, &live );
	assert_true( live > 0 );
	plDestroyContext( rig->context );
	plTestSceneTiers_Free( &rig->set );
}

static void test_scene_follows_budget_overrides_and_switch_limits( void** state )
{
	(void)state;
	plSceneRig rig;
	plSceneRig_Init( &rig );
	const float costs[3] = { 100.0f, 50.0f, 20.0f }, errors[3] = { 5.0f, 8.0f, 15.0f }, rates[1] = { 30.0f };
	const float no_stream[3] = { 0.0f, 0.0f, 0.0f };
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = rig.set.tiers;
	sdef.tier_count = 3;
	sdef.tier_cost_us = costs;
	sdef.tier_stream_cost_us = no_stream;
	sdef.tier_error_mm = errors;
	sdef.lbs_cost_us = 10.0f;
	sdef.lbs_error_mm = 25.0f;
	sdef.network_rates_hz = rates;
	sdef.network_rate_count = 1;
	sdef.budget_us = 8 * 10.0f + 200.0f;
	sdef.character_capacity = 8;
	sdef.min_frames_between_switches = 5;
	sdef.crossfade_frames = 3;
	plScene scene;
	assert_int_equal( plCreateScene( rig.context, &sdef, &scene ), PLEAT_RESULT_OK );
	assert_true( plScene_IsValid( scene ) );
	// A bad def names its field and creates nothing.
	plSceneDef bad = sdef;
	bad.tier_count = 0;
	plScene none;
	assert_int_equal( plCreateScene( rig.context, &bad, &none ), PLEAT_RESULT_INVALID_DEF );
	assert_false( plScene_IsValid( none ) );
	bad = sdef;
	bad.internal_cookie = 0;
	assert_int_equal( plCreateScene( rig.context, &bad, &none ), PLEAT_RESULT_INVALID_DEF );
	// An asset used by a scene cannot be destroyed under it.
	assert_int_equal( plDestroyAsset( rig.set.tiers[2] ), PLEAT_RESULT_ASSET_IN_USE );

	uint32_t ids[8];
	for ( uint32_t i = 0; i < 8; ++i )
	{
		plCharacterDef cdef = plDefaultCharacterDef();
		float beta[1] = { 0.2f * (float)i };
		cdef.beta = beta;
		cdef.beta_count = 1;
		cdef.importance = 1.0f + (float)i; // character 7 most important
		assert_int_equal( plScene_AddCharacter( scene, &cdef, &ids[i] ), PLEAT_RESULT_OK );
		assert_int_equal( ids[i], i );
	}
	plCharacterDef cdef = plDefaultCharacterDef();
	uint32_t extra;
	assert_int_equal( plScene_AddCharacter( scene, &cdef, &extra ), PLEAT_RESULT_CAPACITY_EXCEEDED );

	plDetail lbs = { -1, 0.0f, 0 }, best = { 0, 0.0f, 0 }, bogus = { 0, 45.0f, 0 };
	assert_int_equal( plScene_SetOverride( scene, 0, &best ), PLEAT_RESULT_OK ); // the least important, at the best
	assert_int_equal( plScene_SetOverride( scene, 1, &bogus ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_SetOverride( scene, 99, &lbs ), PLEAT_RESULT_INVALID_ARGUMENT );

	static float q[8][64 * 4];
	plFrameInput inputs[8];
	plResult results[8];
	plDetail last[8];
	uint32_t since_switch[8] = { 0 };
	for ( uint32_t frame = 0; frame < 40; ++frame )
	{
		if ( frame == 20 )
		{
			assert_int_equal( plScene_SetBudget( scene, 0.0f ), PLEAT_RESULT_OK ); // unlimited
			assert_int_equal( plScene_SetOverride( scene, 0, NULL ), PLEAT_RESULT_OK );
		}
		for ( uint32_t i = 0; i < 8; ++i )
		{
			inputs[i] = plTestMotion( frame + 3 * i, rig.set.models[0]->J, q[i] );
		}
		assert_true( plScene_Step( scene, inputs, NULL, results, 8 ) >= 0 );
		plScenePlan plan;
		assert_int_equal( plScene_GetPlan( scene, &plan ), PLEAT_RESULT_OK );
		if ( frame < 20 )
		{
			assert_true( plan.cost_us <= sdef.budget_us + 1e-3f );
		}
		for ( uint32_t i = 0; i < 8; ++i )
		{
			plDetail d;
			float fade;
			assert_int_equal( plScene_GetDetail( scene, i, &d, NULL, &fade ), PLEAT_RESULT_OK );
			if ( frame < 20 && i == 0 )
			{
				assert_int_equal( d.tier, 0 );
				assert_true( d.network_rate_hz == 0.0f );
			}
			if ( frame > 0 && ( d.tier != last[i].tier || d.network_rate_hz != last[i].network_rate_hz ) )
			{
				// A budget change may force a switch at any time; otherwise a detail is kept for the minimum time.
				assert_true( since_switch[i] >= 5 || frame == 20 || i == 0 );
				since_switch[i] = 0;
			}
			since_switch[i]++;
			last[i] = d;
		}
		if ( frame >= 25 )
		{
			// Unlimited: everyone on tier 0 at its full rate once the switches are through.
			for ( uint32_t i = 0; i < 8; ++i )
			{
				assert_int_equal( last[i].tier, 0 );
			}
		}
	}
	// Outputs are on the display mesh (tier 0's vertices), finite.
	const float* positions;
	uint32_t count;
	assert_int_equal( plScene_GetPositions( scene, 7, &positions, &count ), PLEAT_RESULT_OK );
	assert_int_equal( count, rig.set.models[0]->N );
	for ( uint32_t v = 0; v < count * 3; ++v )
	{
		assert_true( isfinite( positions[v] ) );
	}
	// Measured frame costs feed a correction of the cost model, bounded to ×4.
	assert_int_equal( plScene_ReportFrameCost( scene, -1.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_ReportFrameCost( scene, NAN ), PLEAT_RESULT_INVALID_ARGUMENT );
	for ( int i = 0; i < 200; ++i )
	{
		assert_int_equal( plScene_ReportFrameCost( scene, 1e9f ), PLEAT_RESULT_OK );
	}
	assert_int_equal( plScene_SetBudget( scene, sdef.budget_us ), PLEAT_RESULT_OK );
	assert_true( plScene_Step( scene, inputs, NULL, results, 8 ) >= 0 );
	plScenePlan corrected;
	assert_int_equal( plScene_GetPlan( scene, &corrected ), PLEAT_RESULT_OK );
	assert_true( corrected.cost_scale == 4.0f );
	float skin[64 * 12];
	assert_int_equal( plScene_GetSkinMatrices( scene, 7, skin, rig.set.models[0]->J - 1 ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	assert_int_equal( plScene_GetSkinMatrices( scene, 7, skin, rig.set.models[0]->J ), PLEAT_RESULT_OK );
	for ( uint32_t i = 0; i < rig.set.models[0]->J * 12; ++i )
	{
		assert_true( isfinite( skin[i] ) );
	}
	assert_int_equal( plScene_RemoveCharacter( scene, 3 ), PLEAT_RESULT_OK );
	assert_int_equal( plScene_SetImportance( scene, 3, 1.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_SetImportance( scene, 4, -1.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plScene_AddCharacter( scene, &cdef, &extra ), PLEAT_RESULT_OK );
	assert_int_equal( extra, 3 );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_OK );
	assert_false( plScene_IsValid( scene ) );
	assert_int_equal( plDestroyScene( scene ), PLEAT_RESULT_INVALID_HANDLE );
	uint64_t live = 1;
	plContext_GetLiveBytes( rig.context, &live );
	// Only the three assets remain (the scene and its 24 instances gave everything back).
	assert_int_equal( plDestroyAsset( rig.set.tiers[2] ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyAsset( rig.set.tiers[1] ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyAsset( rig.set.tiers[0] ), PLEAT_RESULT_OK );
	plContext_GetLiveBytes( rig.context, &live );
	assert_int_equal( live, 0 );
	plDestroyContext( rig.context );
	plTestSceneTiers_Free( &rig.set );
}

static void test_scene_destroyed_with_its_context( void** state )
{
	(void)state;
	plSceneRig rig;
	plSceneRig_Init( &rig );
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = rig.set.tiers;
	sdef.tier_count = 3;
	sdef.budget_us = 500.0f;
	plScene scene;
	assert_int_equal( plCreateScene( rig.context, &sdef, &scene ), PLEAT_RESULT_OK );
	plCharacterDef cdef = plDefaultCharacterDef();
	uint32_t id;
	assert_int_equal( plScene_AddCharacter( scene, &cdef, &id ), PLEAT_RESULT_OK );
	plSceneRig_Free( &rig ); // the context takes the scene and its instances with it (ASan would see a leak)
	assert_false( plScene_IsValid( scene ) );
}

// Fading-out details (extra_cost_us) close the budget to steps up, but never push a character below the level it is
// on: otherwise every fade would start more fades (the bench scene switched ~10 characters a frame that way).
static void test_fades_block_steps_up_but_push_nobody_down( void** state )
{
	(void)state;
	plPlanner p;
	plPlanner_Init( &p );
	uint32_t n = 8;
	for ( uint32_t c = 0; c < n; ++c )
	{
		p.importance[c] = 1.0f;
	}
	float budget = n * 40.0f;
	plPlan( &p, n, budget, 0.25f ); // settle: some characters above the cheapest level
	uint32_t settled[8];
	int above = 0;
	for ( uint32_t c = 0; c < n; ++c )
	{
		settled[c] = p.current[c] = p.out[c];
		above += p.out[c] != p.frontier[0];
	}
	assert_true( above > 0 );
	float extra[8] = { 0 };
	extra[0] = budget; // a fade as dear as the whole budget
	float cost = -1.0f;
	plSceneBudgetJob job = { p.levels, p.level_count, p.frontier, p.frontier_count, p.stream, 3,
							 n,        p.importance,  p.current,  p.pinned,         p.held,   extra,
							 budget,   0.25f,         p.scratch,  sizeof( p.scratch ), p.out, &cost,
							 NULL,     0,             0.0f,       0.0f,               NULL,  NULL };
	assert_int_equal( plSceneBudgetJob_Run( &job ), PLEAT_RESULT_OK );
	for ( uint32_t c = 0; c < n; ++c )
	{
		assert_int_equal( p.out[c], settled[c] ); // kept, not pushed down by the fade
	}
	assert_true( cost > budget ); // the fade's cost is reported on top of the plan
	// A character on the cheapest level gets no step up while the fade lasts.
	uint32_t low = 0;
	while ( low < n && settled[low] != p.frontier[0] )
	{
		low++;
	}
	if ( low < n )
	{
		p.importance[low] = 1000.0f;
		assert_int_equal( plSceneBudgetJob_Run( &job ), PLEAT_RESULT_OK );
		assert_int_equal( p.out[low], p.frontier[0] );
	}
}

// Characters that switch to a reduced network rate together do not all run their networks on the same frames: 8
// characters of one body on the same motion, put at 15 Hz under 60 fps on the same frame, would give the same outputs
// on every frame if their updates stayed in step; staggered, they fall into groups by the frame of the rate's
// 4-frame cycle on which they update, and every group still updates once a cycle (a character's outputs stay equal
// to its group's).
static void test_reduced_rates_stagger_the_network_updates( void** state )
{
	(void)state;
	plSceneRig rig;
	plSceneRig_Init( &rig );
	const float rates[1] = { 15.0f };
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = rig.set.tiers;
	sdef.tier_count = 3;
	sdef.network_rates_hz = rates;
	sdef.network_rate_count = 1;
	sdef.character_capacity = 8;
	plScene scene;
	assert_int_equal( plCreateScene( rig.context, &sdef, &scene ), PLEAT_RESULT_OK );
	plDetail slow = { 0, 15.0f, 0 };
	for ( uint32_t i = 0; i < 8; ++i )
	{
		plCharacterDef cdef = plDefaultCharacterDef();
		uint32_t id;
		assert_int_equal( plScene_AddCharacter( scene, &cdef, &id ), PLEAT_RESULT_OK );
		assert_int_equal( plScene_SetOverride( scene, id, &slow ), PLEAT_RESULT_OK );
	}

	uint32_t n = rig.set.models[0]->N;
	static float q[64 * 4];
	plFrameInput inputs[8];
	uint32_t group[8] = { 0 }, group_count = 0;
	for ( uint32_t frame = 0; frame < 24; ++frame )
	{
		plFrameInput in = plTestMotion( frame, rig.set.models[0]->J, q );
		in.dt_s = 1.0f / 60.0f;
		for ( uint32_t i = 0; i < 8; ++i )
		{
			inputs[i] = in;
		}
		assert_true( plScene_Step( scene, inputs, NULL, NULL, 8 ) >= 0 );
		const float* p[8];
		for ( uint32_t i = 0; i < 8; ++i )
		{
			uint32_t count;
			assert_int_equal( plScene_GetPositions( scene, i, &p[i], &count ), PLEAT_RESULT_OK );
		}
		// Groups of equal outputs, numbered in order of first appearance.
		uint32_t groups = 0, first_of[8];
		for ( uint32_t i = 0; i < 8; ++i )
		{
			uint32_t g = 0;
			while ( g < groups && memcmp( p[first_of[g]], p[i], (size_t)n * 12 ) != 0 )
			{
				g++;
			}
			if ( g == groups )
			{
				first_of[groups++] = i;
			}
			if ( frame >= 8 )
			{
				assert_int_equal( g, group[i] ); // once a character has updated early it keeps its own cycle
			}
			group[i] = g;
		}
		if ( frame == 0 )
		{
			assert_int_equal( groups, 1 ); // the first frame runs everyone's networks from the same reset
		}
		group_count = groups;
	}
	assert_true( group_count >= 3 ); // of the 4 frames of a cycle, 3 or 4 carry updates (not all on one)
	plSceneRig_Free( &rig );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_frontier_is_sorted_convex_and_drops_dominated_levels ),
		cmocka_unit_test( test_plans_stay_within_budget_and_follow_importance ),
		cmocka_unit_test( test_hysteresis_keeps_plans_through_small_changes ),
		cmocka_unit_test( test_budget_wobble_inside_the_dead_band_moves_nobody ),
		cmocka_unit_test( test_pins_and_holds ),
		cmocka_unit_test( test_fades_block_steps_up_but_push_nobody_down ),
		cmocka_unit_test( test_scene_follows_budget_overrides_and_switch_limits ),
		cmocka_unit_test( test_scene_destroyed_with_its_context ),
		cmocka_unit_test( test_reduced_rates_stagger_the_network_updates ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
