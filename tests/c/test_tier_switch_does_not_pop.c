// A tier switch does not pop: on the shipped t-shirt tiers (argv[1] = the assets folder: tshirt.pleat, _medium, _small,
// _xsmall — whatever their sizes and training, the xsmall tier on its own coarser mesh), a scene character is walked
// through every kind of switch the policy can make — to a cheaper tier, to another mesh, to LBS-only, back up from
// LBS, a rate change, back to the top — by overrides. The largest per-vertex jump between consecutive frames of its
// display-mesh outputs from the first switch on (the cross-fades and the new details' first frames from a reset
// latent) must be no larger than the largest jump of an ordinary frame: the same character, the same motion, kept on
// any one of those details for the whole run. The first switch shown without a fade (plain instances of the two
// tiers, the new one reset at the switch) is printed beside it: on the tiers of 2026-11-25 it jumps further than any
// ordinary frame, i.e. the fade removes a real pop.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <cmocka.h>

#include "test_common.h"

static const char* s_assets = NULL;

static float plMaxJump( const float* a, const float* b, uint32_t n )
{
	float worst = 0.0f;
	for ( uint32_t v = 0; v < n; ++v )
	{
		float dx = a[v * 3] - b[v * 3], dy = a[v * 3 + 1] - b[v * 3 + 1], dz = a[v * 3 + 2] - b[v * 3 + 2];
		float d = sqrtf( dx * dx + dy * dy + dz * dz );
		worst = d > worst ? d : worst;
	}
	return worst;
}

typedef struct plSwitchRun
{
	float ordinary_mm; // the largest jump before the first switch
	float switch_mm;   // the largest jump from a switch to the end of the run
	float pop_mm;      // the first switch without a fade: tier 1 from a reset against tier 0's last frame
	uint32_t switches;
} plSwitchRun;

// top → medium → xsmall (another mesh) → LBS-only → small → small at 30 Hz → top
static const plDetail k_plan[] = { { 0, 0.0f, 0 }, { 1, 0.0f, 0 }, { 3, 0.0f, 0 }, { -1, 0.0f, 0 },
								   { 2, 0.0f, 0 }, { 2, 30.0f, 0 }, { 0, 0.0f, 0 } };
#define PLEAT_TEST_PLAN_COUNT ( sizeof( k_plan ) / sizeof( k_plan[0] ) )

// One character through the switches (or, with keep >= 0, kept on plan entry `keep` all along) with the scene's
// default cross-fade; 60 fps, the test motion.
static plSwitchRun plRunSwitches( int keep )
{
	plContextDef cdef = plDefaultContextDef();
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	const char* names[4] = { "tshirt.pleat", "tshirt_medium.pleat", "tshirt_small.pleat", "tshirt_xsmall.pleat" };
	plAsset tiers[4];
	for ( int t = 0; t < 4; ++t )
	{
		char path[1024];
		snprintf( path, sizeof( path ), "%s/%s", s_assets, names[t] );
		plAssetDef adef = plDefaultAssetDef();
		adef.path = path;
		assert_int_equal( plLoadAsset( context, &adef, &tiers[t] ), PLEAT_RESULT_OK );
	}
	plAssetInfo info;
	plAsset_GetInfo( tiers[0], &info );
	const float rates[1] = { 30.0f };
	plSceneDef sdef = plDefaultSceneDef();
	sdef.tiers = tiers;
	sdef.tier_count = 4;
	sdef.network_rates_hz = rates;
	sdef.network_rate_count = 1;
	sdef.min_frames_between_switches = 1;
	sdef.character_capacity = 1;
	plScene scene;
	assert_int_equal( plCreateScene( context, &sdef, &scene ), PLEAT_RESULT_OK );
	plCharacterDef chdef = plDefaultCharacterDef();
	float beta[2] = { 0.5f, -0.3f };
	chdef.beta = beta;
	chdef.beta_count = 2;
	uint32_t id;
	assert_true( plScene_AddCharacter( scene, &chdef, &id ) >= 0 );
	// The same body on tiers 0 and 1 as plain instances, for the switch without a fade.
	plInstance plain[2];
	for ( int t = 0; t < 2; ++t )
	{
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = tiers[t];
		idef.beta = beta;
		idef.beta_count = 2;
		assert_true( plCreateInstance( context, &idef, &plain[t] ) >= 0 );
	}

	const uint32_t warmup = 20, ordinary = 200, segment = 40; // 200 frames: a period of the motion at 60 fps
	uint32_t n = info.vertex_count;
	float* previous = (float*)malloc( (size_t)n * 12 );
	float q[64 * 4];
	plSwitchRun run = { 0.0f, 0.0f, 0.0f, 0 };
	uint32_t frame = 0;
	for ( size_t s = 0; s < PLEAT_TEST_PLAN_COUNT; ++s )
	{
		const plDetail* detail = &k_plan[keep >= 0 ? (size_t)keep : s];
		assert_int_equal( plScene_SetOverride( scene, id, detail ), PLEAT_RESULT_OK );
		uint32_t frames = s == 0 ? warmup + ordinary : segment;
		for ( uint32_t f = 0; f < frames; ++f, ++frame )
		{
			plFrameInput in = plTestMotion( frame, info.joint_count, q );
			in.dt_s = 1.0f / 60.0f;
			assert_true( plScene_Step( scene, &in, NULL, NULL, 1 ) >= 0 );
			if ( s == 0 && f + 1 == frames )
			{
				plInstance_Reset( plain[1] ); // tier 1 starts on the first switch's frame, as in the scene
			}
			if ( s == 0 || ( s == 1 && f == 0 ) )
			{
				const float *before, *after;
				plInstance_GetPositions( plain[0], &before, NULL ); // tier 0's last frame
				assert_true( plInstance_Step( plain[1], &in, NULL ) >= 0 );
				if ( s == 1 )
				{
					plInstance_GetPositions( plain[1], &after, NULL );
					run.pop_mm = plMaxJump( after, before, n ) * 1000.0f;
				}
				assert_true( plInstance_Step( plain[0], &in, NULL ) >= 0 );
			}
			if ( s == 1 && f == 0 && keep < 0 )
			{
				float fade = 1.0f;
				assert_int_equal( plScene_GetDetail( scene, id, &( plDetail ){ 0, 0.0f, 0 }, NULL, &fade ),
								  PLEAT_RESULT_OK );
				assert_true( fade < 1.0f ); // the switch is fading, not done
			}
			const float* positions;
			plScene_GetPositions( scene, id, &positions, NULL );
			if ( frame > 0 )
			{
				float jump = plMaxJump( positions, previous, n );
				if ( s == 0 && f >= warmup )
				{
					run.ordinary_mm = jump * 1000.0f > run.ordinary_mm ? jump * 1000.0f : run.ordinary_mm;
				}
				else if ( s > 0 || ( keep >= 0 && f >= warmup ) )
				{
					run.switch_mm = jump * 1000.0f > run.switch_mm ? jump * 1000.0f : run.switch_mm;
				}
			}
			memcpy( previous, positions, (size_t)n * 12 );
		}
		plDetail now;
		assert_int_equal( plScene_GetDetail( scene, id, &now, NULL, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( now.tier, detail->tier );
		run.switches += s > 0;
	}
	free( previous );
	plDestroyContext( context );
	return run;
}

static void test_switches_jump_no_more_than_ordinary_frames( void** state )
{
	(void)state;
	// Ordinary frames: each detail of the plan kept for the whole run (its every frame after the warm-up).
	float ordinary_mm = 0.0f;
	for ( int keep = 0; keep < (int)PLEAT_TEST_PLAN_COUNT; ++keep )
	{
		plSwitchRun kept = plRunSwitches( keep );
		ordinary_mm = kept.switch_mm > ordinary_mm ? kept.switch_mm : ordinary_mm;
		ordinary_mm = kept.ordinary_mm > ordinary_mm ? kept.ordinary_mm : ordinary_mm;
	}
	plSwitchRun run = plRunSwitches( -1 );
	printf( "ordinary frames: largest per-vertex jump %.2f mm; %u switches with the cross-fade: %.2f mm; the first "
			"switch without it: %.2f mm\n",
			ordinary_mm, run.switches, run.switch_mm, run.pop_mm );
	assert_true( ordinary_mm > 0.0f );
	assert_true( run.switch_mm <= ordinary_mm );
	assert_true( run.pop_mm > 0.0f ); // 75.1 mm against 46.2 on the tiers of 2026-11-25 18:18: a pop the fade removes
}

int main( int argc, char** argv )
{
	if ( argc < 2 )
	{
		return 77;
	}
	s_assets = argv[1];
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_switches_jump_no_more_than_ordinary_frames ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
