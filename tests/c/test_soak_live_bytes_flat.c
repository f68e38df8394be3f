// Soak: one instance stepped for a long run (argv[1] steps; 3,000 in the default ctest run, 100,000 in the CI soak
// stage of scripts/ci-stages.sh) with β, material, update rate and resets changed along the way, output spans written,
// and a second instance created and destroyed every few thousand steps. The context's live bytes and the host
// allocator's own counter must stay exactly flat (no growth, no leak), steps and setters must never call the
// allocator, and every output must stay finite.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <cmocka.h>

#include "test_common.h"

static uint32_t s_steps = 3000;

static int plFinite( const float* v, size_t count )
{
	for ( size_t i = 0; i < count; ++i )
	{
		if ( !isfinite( v[i] ) )
		{
			return 0;
		}
	}
	return 1;
}

static void test_live_bytes_stay_flat_over_a_long_run( void** state )
{
	(void)state;
	plCountingHost host;
	plContextDef def = plCountingHost_ContextDef( &host );
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 20;
	p.grid_y = 15;
	p.lp_hidden[0] = 64;
	p.dec_hidden[0] = 48;
	p.latent_count = 16;
	p.blend_count = 12;
	plTestRig rig;
	assert_int_equal( plTestRig_Create( &rig, &p, &def ), PLEAT_RESULT_OK );
	const plTestAsset* model = rig.model;
	plInstance instance;
	assert_int_equal( plTestRig_Instance( &rig, &instance ), PLEAT_RESULT_OK );

	{
		// The context's handle table grows with the most instances alive at once (not counted as live bytes, but
		// the host sees it): have two alive once before the baselines are taken.
		plInstance other;
		assert_int_equal( plTestRig_Instance( &rig, &other ), PLEAT_RESULT_OK );
		assert_int_equal( plDestroyInstance( other ), PLEAT_RESULT_OK );
	}
	uint64_t context_baseline = 0;
	assert_int_equal( plContext_GetLiveBytes( rig.context, &context_baseline ), PLEAT_RESULT_OK );
	assert_true( context_baseline > 0 );
	const int64_t host_baseline = host.live_bytes, blocks_baseline = host.live_blocks;
	int64_t allocations = host.allocations;

	uint32_t N = model->N;
	float* span = (float*)malloc( (size_t)N * 8 * sizeof( float ) ); // interleaved position, normal, 32 bytes
	assert_non_null( span );
	plStepOutput out;
	memset( &out, 0, sizeof( out ) );
	out.positions = span;
	out.normals = span + 4;
	out.position_stride_bytes = out.normal_stride_bytes = 32;
	out.vertex_capacity = N;
	float q[64 * 4];
	uint32_t checks = 0, churns = 0;
	for ( uint32_t t = 0; t < s_steps; ++t )
	{
		if ( t % 997 == 500 )
		{
			float beta[2] = { 3.0f * sinf( (float)t ), 5.0f * cosf( (float)t ) }; // sometimes clamped
			assert_true( plInstance_SetShape( instance, beta, 2 ) >= 0 );
		}
		if ( t % 1511 == 700 )
		{
			float material[4] = { model->material_min[0] * 1.5f, model->material_max[1], model->material_default[2],
								  model->material_max[3] * 2.0f };
			assert_true( plInstance_SetMaterial( instance, material ) >= 0 );
		}
		if ( t % 2000 == 1000 )
		{
			assert_int_equal( plInstance_SetNetworkRate( instance, ( t / 2000 ) % 2 ? 0.0f : 30.0f ),
							  PLEAT_RESULT_OK );
		}
		if ( t % 5003 == 4000 )
		{
			assert_int_equal( plInstance_Reset( instance ), PLEAT_RESULT_OK );
		}
		// A clip that loops every 600 frames at 60 Hz, so the latent sees the same poses again and again.
		plFrameInput in = plTestMotion( t % 600, model->J, q );
		in.dt_s = 1.0f / 60.0f;
		plResult r = plInstance_Step( instance, &in, &out );
		assert_true( r == PLEAT_RESULT_OK || r == PLEAT_RESULT_CLAMPED );
		if ( t % 1000 == 999 || t + 1 == s_steps )
		{
			checks++;
			assert_int_equal( host.allocations, allocations ); // steps and setters never allocate
			uint64_t live = 0;
			assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
			assert_int_equal( live, context_baseline );
			assert_int_equal( host.live_bytes, host_baseline );
			assert_int_equal( host.live_blocks, blocks_baseline );
			for ( uint32_t v = 0; v < N; ++v )
			{
				assert_true( plFinite( span + (size_t)v * 8, 3 ) && plFinite( span + (size_t)v * 8 + 4, 3 ) );
			}
		}
		if ( t % 5000 == 2500 )
		{
			// Churn: another instance comes and goes; every byte of it comes back.
			plInstance other;
			assert_int_equal( plTestRig_Instance( &rig, &other ), PLEAT_RESULT_OK );
			assert_int_equal( plInstance_Step( other, &in, NULL ), PLEAT_RESULT_OK );
			assert_int_equal( plDestroyInstance( other ), PLEAT_RESULT_OK );
			uint64_t live = 0;
			assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
			assert_int_equal( live, context_baseline );
			assert_int_equal( host.live_bytes, host_baseline );
			allocations = host.allocations;
			churns++;
		}
	}
	assert_true( checks >= s_steps / 1000 );
	printf( "soak: %u steps, %u live-byte checks, %u instance churns, live bytes %llu (context) / %lld (host)\n",
			s_steps, checks, churns, (unsigned long long)context_baseline, (long long)host_baseline );
	assert_int_equal( plDestroyInstance( instance ), PLEAT_RESULT_OK );
	plTestRig_Free( &rig );
	assert_int_equal( host.live_bytes, 0 );
	assert_int_equal( host.live_blocks, 0 );
	assert_int_equal( host.bad_alignments, 0 );
	free( span );
}

int main( int argc, char** argv )
{
	if ( argc > 1 )
	{
		s_steps = (uint32_t)strtoul( argv[1], NULL, 10 );
		if ( s_steps == 0 )
		{
			fprintf( stderr, "usage: test_soak_live_bytes_flat [STEPS]\n" );
			return 2;
		}
	}
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_live_bytes_stay_flat_over_a_long_run ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
