// A destroyed handle never names another object: not after a new context takes the slot of the context it came from
// (asset and instance handles carry their context's generation), not after its own slot has been reused more times
// than a 16-bit generation counts, and not at the end of the 32-bit generations either, where a slot retires instead
// of wrapping (pleat.h, HANDLES). The retirement tests start a slot near its last
// generation through the internal tables (core.h) instead of cycling it 2^32 times.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "core.h"
#include "test_common.h"

// More create/destroy cycles of one slot than a 16-bit generation has values: the old counter wrapped after 65,534.
#define PLEAT_TEST_CYCLES_PAST_16_BIT_WRAP 65600u

static int plSameInstance( plInstance a, plInstance b )
{
	return memcmp( &a, &b, sizeof( a ) ) == 0;
}

static int plSameContext( plContext a, plContext b )
{
	return memcmp( &a, &b, sizeof( a ) ) == 0;
}

// A handle outliving its context, step by step: context A with an asset and instances i1, i2; A destroyed; context B in the same
// slot with its own asset and instances m1, m2. A's handles must name nothing in B.
static void test_handles_of_a_destroyed_context_name_nothing_in_the_context_that_reuses_its_slot( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	plTestRig a;
	assert_int_equal( plTestRig_Init( &a, model, NULL ), PLEAT_RESULT_OK );
	plInstance i1, i2;
	assert_int_equal( plTestRig_Instance( &a, &i1 ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &a, &i2 ), PLEAT_RESULT_OK );
	plContext context_a = a.context;
	plAsset asset_a = a.asset;
	plTestRig_Free( &a );
	assert_false( plInstance_IsValid( i1 ) );
	assert_false( plAsset_IsValid( asset_a ) );

	plTestRig b;
	assert_int_equal( plTestRig_Init( &b, model, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( b.context.index1, context_a.index1 ); // the scenario needs the same context slot
	assert_false( plContext_IsValid( context_a ) );
	plInstance m1, m2;
	assert_int_equal( plTestRig_Instance( &b, &m1 ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( &b, &m2 ), PLEAT_RESULT_OK );
	assert_int_equal( m1.index1, i1.index1 ); // ... and the same object slots
	assert_int_equal( m2.index1, i2.index1 );

	float q[64 * 4];
	plFrameInput in = plTestMotion( 1, model->J, q );
	assert_int_equal( plInstance_Step( m1, &in, NULL ), PLEAT_RESULT_OK );
	const float* positions = NULL;
	assert_int_equal( plInstance_GetPositions( m1, &positions, NULL ), PLEAT_RESULT_OK );
	size_t bytes = (size_t)b.info.vertex_count * 3 * sizeof( float );
	float* m1_before = (float*)malloc( bytes );
	memcpy( m1_before, positions, bytes );
	float latent_before[64], latent_after[64];
	assert_int_equal( plInstance_GetLatent( m1, latent_before, 64 ), PLEAT_RESULT_OK );

	// A's instance handles: invalid, and every call through them is rejected without touching m1 or m2.
	assert_false( plInstance_IsValid( i1 ) );
	assert_false( plInstance_IsValid( i2 ) );
	in = plTestMotion( 2, model->J, q );
	assert_int_equal( plInstance_Step( i1, &in, NULL ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_Reset( i1 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_GetPositions( m1, &positions, NULL ), PLEAT_RESULT_OK );
	assert_memory_equal( positions, m1_before, bytes );
	assert_int_equal( plInstance_GetLatent( m1, latent_after, 64 ), PLEAT_RESULT_OK );
	assert_memory_equal( latent_after, latent_before, b.info.latent_count * sizeof( float ) );
	assert_int_equal( plDestroyInstance( i2 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_true( plInstance_IsValid( m2 ) );

	// A's asset handle: invalid, cannot be destroyed, cannot make instances in B.
	assert_false( plAsset_IsValid( asset_a ) );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( asset_a, &info ), PLEAT_RESULT_INVALID_HANDLE );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset_a;
	plInstance from_stale_asset;
	assert_int_equal( plCreateInstance( b.context, &idef, &from_stale_asset ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plDestroyAsset( asset_a ), PLEAT_RESULT_INVALID_HANDLE );
	assert_true( plAsset_IsValid( b.asset ) );
	assert_int_equal( plDestroyContext( context_a ), PLEAT_RESULT_INVALID_HANDLE );
	assert_true( plContext_IsValid( b.context ) );

	assert_int_equal( plDestroyInstance( m1 ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( m2 ), PLEAT_RESULT_OK );
	free( m1_before );
	plTestRig_Free( &b );
	plTestAsset_Destroy( model );
}

// A generation that wraps: one instance slot created and destroyed past the point where a 16-bit generation wraps; the
// first handle of the slot must stay invalid throughout (it named the 65,535th object of the slot before the fix).
static void test_destroyed_instance_handle_stays_invalid_past_16_bit_generation_wrap( void** state )
{
	plTestRig* rig = *state;
	plInstance first;
	assert_int_equal( plTestRig_Instance( rig, &first ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( first ), PLEAT_RESULT_OK );
	uint32_t same_slot = 0;
	for ( uint32_t cycle = 0; cycle < PLEAT_TEST_CYCLES_PAST_16_BIT_WRAP; ++cycle )
	{
		plInstance next;
		assert_int_equal( plTestRig_Instance( rig, &next ), PLEAT_RESULT_OK );
		same_slot += next.index1 == first.index1;
		if ( plInstance_IsValid( first ) || plSameInstance( next, first ) )
		{
			fail_msg( "cycle %u: the destroyed handle names a live instance again", cycle );
		}
		assert_int_equal( plDestroyInstance( next ), PLEAT_RESULT_OK );
	}
	assert_int_equal( same_slot, PLEAT_TEST_CYCLES_PAST_16_BIT_WRAP ); // the wrap needs one slot reused throughout
	assert_int_equal( plDestroyInstance( first ), PLEAT_RESULT_INVALID_HANDLE );
}

// Contexts too: the process-wide table had 16-bit generations as well.
static void test_destroyed_context_handle_stays_invalid_past_16_bit_generation_wrap( void** state )
{
	(void)state;
	plContextDef def = plDefaultContextDef();
	plContext first;
	assert_int_equal( plCreateContext( &def, &first ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyContext( first ), PLEAT_RESULT_OK );
	uint32_t same_slot = 0;
	for ( uint32_t cycle = 0; cycle < PLEAT_TEST_CYCLES_PAST_16_BIT_WRAP; ++cycle )
	{
		plContext next;
		assert_int_equal( plCreateContext( &def, &next ), PLEAT_RESULT_OK );
		same_slot += next.index1 == first.index1;
		if ( plContext_IsValid( first ) || plSameContext( next, first ) )
		{
			fail_msg( "cycle %u: the destroyed context handle names a live context again", cycle );
		}
		assert_int_equal( plDestroyContext( next ), PLEAT_RESULT_OK );
	}
	assert_int_equal( same_slot, PLEAT_TEST_CYCLES_PAST_16_BIT_WRAP );
	assert_int_equal( plDestroyContext( first ), PLEAT_RESULT_INVALID_HANDLE );
}

// The last generations of an instance slot: the object that gets PLEAT_GENERATION_LAST is the slot's last; after it
// is destroyed the slot is never handed out again, and no handle of the slot becomes valid. Asset slots share the code
// (plSlotTable) and are checked the same way.
static void test_object_slot_retires_at_its_last_generation_instead_of_wrapping( void** state )
{
	plTestRig* rig = *state;
	plContextData* ctx = plGetContext( rig->context );
	assert_non_null( ctx );
	plInstance first;
	assert_int_equal( plTestRig_Instance( rig, &first ), PLEAT_RESULT_OK );
	assert_int_equal( first.generation, 1 );
	assert_int_equal( plDestroyInstance( first ), PLEAT_RESULT_OK );
	ctx->instances.slots[first.index1 - 1].generation = PLEAT_GENERATION_LAST - 2; // as if 2^32 − 3 objects had lived there

	plInstance last_two[2];
	for ( int i = 0; i < 2; ++i )
	{
		assert_int_equal( plTestRig_Instance( rig, &last_two[i] ), PLEAT_RESULT_OK );
		assert_int_equal( last_two[i].index1, first.index1 );
		assert_int_equal( last_two[i].generation, PLEAT_GENERATION_LAST - 1 + (uint32_t)i );
		assert_int_equal( plDestroyInstance( last_two[i] ), PLEAT_RESULT_OK );
	}
	for ( uint32_t cycle = 0; cycle < 4; ++cycle )
	{
		plInstance next;
		assert_int_equal( plTestRig_Instance( rig, &next ), PLEAT_RESULT_OK );
		assert_int_not_equal( next.index1, first.index1 ); // the retired slot is skipped
		assert_true( plInstance_IsValid( next ) );
		assert_false( plInstance_IsValid( first ) );
		assert_false( plInstance_IsValid( last_two[0] ) );
		assert_false( plInstance_IsValid( last_two[1] ) );
		for ( uint32_t g = 0; g < 3; ++g ) // what a wrap would have issued next: 0, 1, 2
		{
			plInstance wrapped = first;
			wrapped.generation = g;
			assert_false( plInstance_IsValid( wrapped ) );
		}
		assert_int_equal( plDestroyInstance( next ), PLEAT_RESULT_OK );
	}
	assert_null( ctx->instances.slots[first.index1 - 1].object );
	assert_int_equal( ctx->instances.slots[first.index1 - 1].generation, PLEAT_GENERATION_LAST );

	// An asset slot, the same way.
	plAsset asset = rig->asset;
	assert_int_equal( plDestroyAsset( asset ), PLEAT_RESULT_OK );
	ctx->assets.slots[asset.index1 - 1].generation = PLEAT_GENERATION_LAST - 1;
	plAssetDef adef = plDefaultAssetDef();
	adef.data = rig->bytes;
	adef.size = rig->size;
	plAsset last_asset, next_asset;
	assert_int_equal( plLoadAsset( rig->context, &adef, &last_asset ), PLEAT_RESULT_OK );
	assert_int_equal( last_asset.index1, asset.index1 );
	assert_int_equal( last_asset.generation, PLEAT_GENERATION_LAST );
	assert_int_equal( plDestroyAsset( last_asset ), PLEAT_RESULT_OK );
	assert_int_equal( plLoadAsset( rig->context, &adef, &next_asset ), PLEAT_RESULT_OK );
	assert_int_not_equal( next_asset.index1, asset.index1 );
	assert_false( plAsset_IsValid( asset ) );
	assert_false( plAsset_IsValid( last_asset ) );
	assert_true( plAsset_IsValid( next_asset ) );
	rig->asset = next_asset;
}

// The last generation of a context slot: the context that gets it is the slot's last; the slot then stays empty for
// the rest of the process and the next context takes another slot.
static void test_context_slot_retires_at_its_last_generation_instead_of_wrapping( void** state )
{
	(void)state;
	plContextDef def = plDefaultContextDef();
	plContext first;
	assert_int_equal( plCreateContext( &def, &first ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyContext( first ), PLEAT_RESULT_OK );
	uint32_t slot = first.index1 - 1;
	g_plContextTable.generations[slot] = PLEAT_GENERATION_LAST - 1;
	plContext last;
	assert_int_equal( plCreateContext( &def, &last ), PLEAT_RESULT_OK );
	assert_int_equal( last.index1, first.index1 );
	assert_int_equal( last.generation, PLEAT_GENERATION_LAST );
	assert_int_equal( plDestroyContext( last ), PLEAT_RESULT_OK );
	for ( uint32_t cycle = 0; cycle < 4; ++cycle )
	{
		plContext next;
		assert_int_equal( plCreateContext( &def, &next ), PLEAT_RESULT_OK );
		assert_int_not_equal( next.index1, first.index1 );
		assert_false( plContext_IsValid( first ) );
		assert_false( plContext_IsValid( last ) );
		for ( uint32_t g = 0; g < 3; ++g )
		{
			plContext wrapped = { first.index1, g };
			assert_false( plContext_IsValid( wrapped ) );
		}
		assert_int_equal( plDestroyContext( next ), PLEAT_RESULT_OK );
	}
	assert_null( g_plContextTable.contexts[slot] );
	assert_int_equal( g_plContextTable.generations[slot], PLEAT_GENERATION_LAST ); // retired for this process
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_handles_of_a_destroyed_context_name_nothing_in_the_context_that_reuses_its_slot ),
		PLEAT_TEST_WITH_RIG( test_destroyed_instance_handle_stays_invalid_past_16_bit_generation_wrap ),
		cmocka_unit_test( test_destroyed_context_handle_stays_invalid_past_16_bit_generation_wrap ),
		PLEAT_TEST_WITH_RIG( test_object_slot_retires_at_its_last_generation_instead_of_wrapping ),
		cmocka_unit_test( test_context_slot_retires_at_its_last_generation_instead_of_wrapping ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
