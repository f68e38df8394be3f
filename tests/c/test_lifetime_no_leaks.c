// Lifetimes: 1,000 instances created, stepped and destroyed with a counting host allocator; every byte comes back
// (the context's live-bytes counter and the host's own counter both return to their baselines). Allocation failures
// at every point of creation are reported as OUT_OF_MEMORY without leaking. Run under PLEAT_SANITIZE for ASan/UBSan.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"

// A rig on the default test asset whose context allocates through host.
static void plCountingRig_Create( plCountingHost* host, plTestRig* rig )
{
	plContextDef def = plCountingHost_ContextDef( host );
	assert_int_equal( plTestRig_Create( rig, NULL, &def ), PLEAT_RESULT_OK );
}

// Destroys the rig's context (and with it whatever the test left alive): the host gets every byte and block back, and
// every alignment asked for was a power of two >= 16. Frees the rest of the rig (asset bytes, model).
static void plExpectEverythingReturned( const plCountingHost* host, plTestRig* rig )
{
	assert_int_equal( plDestroyContext( rig->context ), PLEAT_RESULT_OK );
	assert_int_equal( host->live_bytes, 0 );
	assert_int_equal( host->live_blocks, 0 );
	assert_int_equal( host->bad_alignments, 0 );
	plTestRig_Free( rig );
}

static void test_thousand_instances_leave_no_leak( void** state )
{
	(void)state;
	plCountingHost host;
	plTestRig rig;
	plCountingRig_Create( &host, &rig );
	uint64_t with_asset = 0;
	assert_int_equal( plContext_GetLiveBytes( rig.context, &with_asset ), PLEAT_RESULT_OK );
	assert_true( with_asset >= rig.size ); // the asset was copied (not in place): at least its bytes are live
	float q[64 * 4];
	plInstance alive[10];
	for ( int i = 0; i < 1000; ++i )
	{
		plInstance* inst = &alive[i % 10];
		if ( i >= 10 )
		{
			assert_int_equal( plDestroyInstance( *inst ), PLEAT_RESULT_OK );
			assert_false( plInstance_IsValid( *inst ) );
		}
		assert_int_equal( plTestRig_Instance( &rig, inst ), PLEAT_RESULT_OK );
		for ( uint32_t t = 0; t < 3; ++t )
		{
			plFrameInput in = plTestMotion( t + (uint32_t)i, rig.model->J, q );
			assert_int_equal( plInstance_Step( *inst, &in, NULL ), PLEAT_RESULT_OK );
		}
	}
	// A destroyed handle stays invalid even after its slot is reused (generation).
	plInstance stale = alive[0];
	assert_int_equal( plDestroyInstance( stale ), PLEAT_RESULT_OK );
	plInstance reused;
	assert_int_equal( plTestRig_Instance( &rig, &reused ), PLEAT_RESULT_OK );
	assert_int_equal( reused.index1, stale.index1 );
	assert_false( plInstance_IsValid( stale ) );
	assert_int_equal( plDestroyInstance( stale ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plDestroyInstance( reused ), PLEAT_RESULT_OK );
	for ( int i = 1; i < 10; ++i )
	{
		assert_int_equal( plDestroyInstance( alive[i] ), PLEAT_RESULT_OK );
	}
	assert_int_equal( plDestroyAsset( rig.asset ), PLEAT_RESULT_OK );
	uint64_t live = 1;
	assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
	// pleat.h: exactly 0 once no asset or instance is alive (the grown handle tables are the context's own).
	assert_int_equal( live, 0 );
	assert_true( host.live_bytes > 0 ); // ... but they are still the host's until the context goes
	plExpectEverythingReturned( &host, &rig );
}

// Destroying a context with live assets and instances frees them all.
static void test_destroying_context_frees_everything( void** state )
{
	(void)state;
	plCountingHost host;
	plTestRig rig;
	plCountingRig_Create( &host, &rig );
	plInstance inst;
	for ( int i = 0; i < 20; ++i )
	{
		assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	}
	assert_int_equal( plDestroyAsset( rig.asset ), PLEAT_RESULT_ASSET_IN_USE );
	assert_true( plAsset_IsValid( rig.asset ) );
	plExpectEverythingReturned( &host, &rig );
	assert_false( plInstance_IsValid( inst ) );
	assert_false( plAsset_IsValid( rig.asset ) );
}

// pleat.h: live bytes are exactly 0 right after plCreateContext and whenever no asset or instance is alive, however
// many objects the context's handle tables once held; the host still sees those tables until plDestroyContext.
static void test_live_bytes_are_zero_whenever_nothing_is_alive( void** state )
{
	(void)state;
	plCountingHost host;
	plTestRig rig;
	plCountingRig_Create( &host, &rig );
	assert_int_equal( plDestroyAsset( rig.asset ), PLEAT_RESULT_OK );
	uint64_t live = 1;
	assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
	assert_int_equal( live, 0 );
	for ( int round = 0; round < 3; ++round )
	{
		plAssetDef adef = plDefaultAssetDef();
		adef.data = rig.bytes;
		adef.size = rig.size;
		assert_int_equal( plLoadAsset( rig.context, &adef, &rig.asset ), PLEAT_RESULT_OK );
		uint64_t with_asset = 0, with_instances = 0;
		assert_int_equal( plContext_GetLiveBytes( rig.context, &with_asset ), PLEAT_RESULT_OK );
		assert_true( with_asset >= rig.size );
		plInstance many[40]; // more than the first handle table holds (16): the table grows
		for ( int i = 0; i < 40; ++i )
		{
			assert_int_equal( plTestRig_Instance( &rig, &many[i] ), PLEAT_RESULT_OK );
		}
		assert_int_equal( plContext_GetLiveBytes( rig.context, &with_instances ), PLEAT_RESULT_OK );
		assert_true( with_instances > with_asset );
		// A failed load (truncated data) adds nothing.
		adef.size = rig.size / 2;
		plAsset broken;
		assert_int_equal( plLoadAsset( rig.context, &adef, &broken ), PLEAT_RESULT_TRUNCATED );
		assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
		assert_int_equal( live, with_instances );
		for ( int i = 0; i < 40; ++i )
		{
			assert_int_equal( plDestroyInstance( many[i] ), PLEAT_RESULT_OK );
		}
		assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
		assert_int_equal( live, with_asset );
		assert_int_equal( plDestroyAsset( rig.asset ), PLEAT_RESULT_OK );
		assert_int_equal( plContext_GetLiveBytes( rig.context, &live ), PLEAT_RESULT_OK );
		assert_int_equal( live, 0 );
		assert_true( host.live_bytes > 0 ); // the context block and its tables
	}
	plExpectEverythingReturned( &host, &rig );
}

// Allocation failure at the k-th allocation, for every k that creation reaches: OUT_OF_MEMORY, null handle, no leak.
static void test_allocation_failures_are_reported_without_leaks( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	size_t size = 0;
	uint8_t* bytes = plTestAsset_Write( model, &size );
	int succeeded = 0;
	for ( int64_t k = 0; k < 64 && !succeeded; ++k )
	{
		plCountingHost host;
		plContextDef def = plCountingHost_ContextDef( &host );
		host.fail_after = k;
		plContext ctx;
		plResult r = plCreateContext( &def, &ctx );
		if ( r == PLEAT_RESULT_OK )
		{
			plAssetDef adef = plDefaultAssetDef();
			adef.data = bytes;
			adef.size = size;
			plAsset asset;
			r = plLoadAsset( ctx, &adef, &asset );
			if ( r == PLEAT_RESULT_OK )
			{
				plInstance inst;
				r = plTestRig_Instance( &( plTestRig ){ .context = ctx, .asset = asset }, &inst );
				if ( r == PLEAT_RESULT_OK )
				{
					succeeded = 1;
				}
				else
				{
					assert_false( plInstance_IsValid( inst ) );
				}
			}
			else
			{
				assert_false( plAsset_IsValid( asset ) );
			}
			plDestroyContext( ctx );
		}
		if ( !succeeded )
		{
			assert_int_equal( r, PLEAT_RESULT_OUT_OF_MEMORY );
		}
		assert_int_equal( host.live_bytes, 0 );
		assert_int_equal( host.bad_alignments, 0 );
	}
	assert_true( succeeded );
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_thousand_instances_leave_no_leak ),
		cmocka_unit_test( test_destroying_context_frees_everything ),
		cmocka_unit_test( test_live_bytes_are_zero_whenever_nothing_is_alive ),
		cmocka_unit_test( test_allocation_failures_are_reported_without_leaks ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
