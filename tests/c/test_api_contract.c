// The public API's contract: defs must come from plDefault...Def, handles are index + generation, every entry point
// validates its arguments, result and log-item names are stable, joint lookup and the joint map work.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"

static void test_result_and_log_item_names_are_stable( void** state )
{
	(void)state;
	assert_string_equal( plResultString( PLEAT_RESULT_OK ), "PLEAT_RESULT_OK" );
	assert_string_equal( plResultString( PLEAT_RESULT_CLAMPED ), "PLEAT_RESULT_CLAMPED" );
	assert_string_equal( plResultString( PLEAT_RESULT_NUMERIC_RESET ), "PLEAT_RESULT_NUMERIC_RESET" );
	assert_string_equal( plResultString( PLEAT_RESULT_CHECKSUM_MISMATCH ), "PLEAT_RESULT_CHECKSUM_MISMATCH" );
	assert_string_equal( plResultString( PLEAT_RESULT_ASSET_IN_USE ), "PLEAT_RESULT_ASSET_IN_USE" );
	assert_string_equal( plResultString( PLEAT_RESULT_INTERNAL_ERROR ), "PLEAT_RESULT_INTERNAL_ERROR" );
	assert_string_equal( plResultString( (plResult)12345 ), "PLEAT_RESULT_UNKNOWN" );
	assert_string_equal( plResultDescription( PLEAT_RESULT_INVALID_DT ), "dt_s <= 0 or dt_s > 1 s" );
	assert_string_equal( plResultDescription( (plResult)12345 ), "unknown result" );
	// Every code from −24 to 2 has its own name and a description, and the values are those of the list.
	for ( int a = -24; a <= 2; ++a )
	{
		assert_string_not_equal( plResultString( (plResult)a ), "PLEAT_RESULT_UNKNOWN" );
		assert_string_not_equal( plResultDescription( (plResult)a ), "unknown result" );
		for ( int b = a + 1; b <= 2; ++b )
		{
			assert_string_not_equal( plResultString( (plResult)a ), plResultString( (plResult)b ) );
		}
	}
	// The names come from PLEAT_RESULTS itself: "PLEAT_RESULT_" + name for each entry, at its value.
#define PLEAT_CHECK_RESULT_( name, value, description )                                                                \
	assert_int_equal( PLEAT_RESULT_##name, value );                                                                    \
	assert_string_equal( plResultString( PLEAT_RESULT_##name ), "PLEAT_RESULT_" #name );                               \
	assert_string_equal( plResultDescription( PLEAT_RESULT_##name ), description );
	PLEAT_RESULTS( PLEAT_CHECK_RESULT_ )
#undef PLEAT_CHECK_RESULT_
	assert_true( PLEAT_RESULT_CLAMPED > 0 && PLEAT_RESULT_NUMERIC_RESET > 0 );
	assert_true( PLEAT_RESULT_INVALID_ARGUMENT < 0 && PLEAT_RESULT_ASSET_IN_USE < 0 );
	assert_int_equal( PLEAT_LOG_ASSET_LOADED, 10 );
	assert_string_equal( plLogItemString( PLEAT_LOG_ASSET_LOADED ), "asset loaded" );
	assert_string_equal( plLogItemString( (plLogItem)9999 ), "unknown item" );
}

// The library's version is the header's (this test links the library it was built with), the asset major included.
static void test_runtime_version_matches_the_header( void** state )
{
	(void)state;
	plVersion version = plGetVersion();
	assert_int_equal( version.major, PLEAT_VERSION_MAJOR );
	assert_int_equal( version.minor, PLEAT_VERSION_MINOR );
	assert_int_equal( version.patch, PLEAT_VERSION_PATCH );
	assert_int_equal( version.asset_major, PLEAT_ASSET_VERSION_MAJOR );
}

static void test_defs_not_from_default_are_rejected( void** state )
{
	(void)state;
	plContextDef cdef;
	memset( &cdef, 0, sizeof( cdef ) );
	plContext ctx = { 7, 7 };
	assert_int_equal( plCreateContext( &cdef, &ctx ), PLEAT_RESULT_INVALID_DEF );
	assert_int_equal( ctx.index1, 0 ); // zeroed on failure
	assert_int_equal( plCreateContext( NULL, &ctx ), PLEAT_RESULT_INVALID_ARGUMENT );
	cdef = plDefaultContextDef();
	assert_int_equal( plCreateContext( &cdef, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	cdef.free = NULL;
	cdef.alloc = (plAllocFn*)1; // alloc without free
	assert_int_equal( plCreateContext( &cdef, &ctx ), PLEAT_RESULT_INVALID_DEF );
	cdef = plDefaultContextDef();
	assert_int_equal( plCreateContext( &cdef, &ctx ), PLEAT_RESULT_OK );
	assert_true( plContext_IsValid( ctx ) );

	plAssetDef adef;
	memset( &adef, 0, sizeof( adef ) );
	adef.path = "x.pleat";
	plAsset asset;
	assert_int_equal( plLoadAsset( ctx, &adef, &asset ), PLEAT_RESULT_INVALID_DEF );
	adef = plDefaultAssetDef();
	assert_int_equal( plLoadAsset( ctx, &adef, &asset ), PLEAT_RESULT_INVALID_DEF ); // neither data nor path
	adef.path = "nonexistent-file.pleat";
	assert_int_equal( plLoadAsset( ctx, &adef, &asset ), PLEAT_RESULT_IO_ERROR );
	assert_false( plAsset_IsValid( asset ) );

	plInstanceDef idef;
	memset( &idef, 0, sizeof( idef ) );
	plInstance inst;
	assert_int_equal( plCreateInstance( ctx, &idef, &inst ), PLEAT_RESULT_INVALID_DEF );
	idef = plDefaultInstanceDef();
	assert_int_equal( plCreateInstance( ctx, &idef, &inst ), PLEAT_RESULT_INVALID_HANDLE ); // null asset
	assert_int_equal( plDestroyContext( ctx ), PLEAT_RESULT_OK );
	assert_false( plContext_IsValid( ctx ) );
	assert_int_equal( plDestroyContext( ctx ), PLEAT_RESULT_INVALID_HANDLE );
}

static void test_null_and_stale_handles_are_rejected( void** state )
{
	(void)state;
	plContext no_ctx = { 0, 0 };
	plAsset no_asset = { 0, 0, { 0, 0 } };
	plInstance no_inst = { 0, 0, { 0, 0 } };
	assert_false( plContext_IsValid( no_ctx ) );
	assert_false( plAsset_IsValid( no_asset ) );
	assert_false( plInstance_IsValid( no_inst ) );
	uint64_t bytes;
	assert_int_equal( plContext_GetLiveBytes( no_ctx, &bytes ), PLEAT_RESULT_INVALID_HANDLE );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( no_asset, &info ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plDestroyAsset( no_asset ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plDestroyInstance( no_inst ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_Reset( no_inst ), PLEAT_RESULT_INVALID_HANDLE );
	float f[16];
	assert_int_equal( plInstance_SetShape( no_inst, f, 1 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_SetMaterial( no_inst, f ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_SetNetworkRate( no_inst, 30.0f ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_GetSkinMatrices( no_inst, f, 1 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_GetLatent( no_inst, f, 16 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_GetBlendWeights( no_inst, f, 16 ), PLEAT_RESULT_INVALID_HANDLE );
	void* user_data = &user_data;
	assert_int_equal( plInstance_GetUserData( no_inst, &user_data ), PLEAT_RESULT_INVALID_HANDLE );
	assert_null( user_data ); // zeroed on failure

	plTestRig rig;
	assert_int_equal( plTestRig_Create( &rig, NULL, NULL ), PLEAT_RESULT_OK );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	int user = 42;
	idef.user_data = &user;
	plInstance inst;
	assert_int_equal( plCreateInstance( rig.context, &idef, &inst ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetUserData( inst, &user_data ), PLEAT_RESULT_OK );
	assert_ptr_equal( user_data, &user );
	assert_int_equal( plInstance_GetUserData( inst, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	plAsset back;
	assert_int_equal( plInstance_GetAsset( inst, &back ), PLEAT_RESULT_OK );
	assert_memory_equal( &back, &rig.asset, sizeof( back ) );
	// An instance handle from another context is not valid there; a handle with a wrong generation is stale.
	plInstance forged = inst;
	forged.generation++;
	assert_false( plInstance_IsValid( forged ) );
	assert_int_equal( plDestroyInstance( inst ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_Reset( inst ), PLEAT_RESULT_INVALID_HANDLE );
	plTestRig_Free( &rig );
	assert_false( plAsset_IsValid( rig.asset ) );
}

static void test_find_joint_and_info( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	model->meta = "{\"trained\": false}";
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	int32_t index = 99;
	assert_int_equal( plAsset_FindJoint( rig.asset, "joint_03", &index ), PLEAT_RESULT_OK );
	assert_int_equal( index, 3 );
	assert_int_equal( plAsset_FindJoint( rig.asset, "joint_3", &index ), PLEAT_RESULT_NOT_FOUND );
	assert_int_equal( index, -1 );
	assert_int_equal( plAsset_FindJoint( rig.asset, NULL, &index ), PLEAT_RESULT_INVALID_ARGUMENT );
	const char* name;
	assert_int_equal( plAsset_GetJointName( rig.asset, 4, &name ), PLEAT_RESULT_OK );
	assert_string_equal( name, "joint_04" );
	assert_int_equal( plAsset_GetJointName( rig.asset, 5, &name ), PLEAT_RESULT_INVALID_ARGUMENT );
	plAssetInfo* info = &rig.info;
	assert_int_equal( info->vertex_count, 48 );
	assert_int_equal( info->face_count, 70 );
	assert_int_equal( info->joint_count, 5 );
	assert_int_equal( info->input_joint_count, 3 );
	assert_int_equal( info->latent_count, 8 );
	assert_int_equal( info->blend_count, 6 );
	assert_int_equal( info->input_count, 8 + 8 + 3 * ( 6 * 3 + 6 ) + 9 * 3 + 2 + 4 );
	assert_int_equal( info->lp_layer_count, 3 );
	assert_int_equal( info->dec_layer_count, 2 );
	assert_string_equal( info->name, "test-sheet" );
	assert_int_equal( info->meta_json_size, strlen( model->meta ) );
	assert_memory_equal( info->meta_json, model->meta, info->meta_json_size );
	assert_false( info->has_onnx_lp );
	assert_false( info->weights_fp16 );
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

// The garment's triangles and template come back exactly as the asset was written (the builder's own arrays), from
// the asset's block in place; bad arguments and stale handles are rejected with zeroed outputs.
static void test_faces_and_template_come_from_the_asset( void** state )
{
	plTestRig* rig = *state;
	const uint32_t* faces = NULL;
	uint32_t face_count = 0;
	assert_int_equal( plAsset_GetFaces( rig->asset, &faces, &face_count ), PLEAT_RESULT_OK );
	assert_int_equal( face_count, rig->model->F );
	assert_memory_equal( faces, rig->model->faces, (size_t)rig->model->F * 3 * sizeof( uint32_t ) );
	const float* rest = NULL;
	uint32_t vertex_count = 0;
	assert_int_equal( plAsset_GetTemplatePositions( rig->asset, &rest, &vertex_count ), PLEAT_RESULT_OK );
	assert_int_equal( vertex_count, rig->model->N );
	assert_memory_equal( rest, rig->model->template_positions, (size_t)rig->model->N * 3 * sizeof( float ) );
	// Before its first step a β = 0 instance's positions are the template.
	plInstance inst;
	assert_int_equal( plTestRig_Instance( rig, &inst ), PLEAT_RESULT_OK );
	const float* positions = NULL;
	assert_int_equal( plInstance_GetPositions( inst, &positions, NULL ), PLEAT_RESULT_OK );
	assert_memory_equal( positions, rig->model->template_positions, (size_t)rig->model->N * 3 * sizeof( float ) );
	assert_int_equal( plDestroyInstance( inst ), PLEAT_RESULT_OK );

	// Loaded in place: the pointers are inside the caller's buffer.
	plAssetDef adef = plDefaultAssetDef();
	adef.data = rig->bytes;
	adef.size = rig->size;
	adef.flags = PLEAT_ASSET_FLAG_USE_IN_PLACE;
	plAsset in_place;
	assert_int_equal( plLoadAsset( rig->context, &adef, &in_place ), PLEAT_RESULT_OK );
	assert_int_equal( plAsset_GetFaces( in_place, &faces, &face_count ), PLEAT_RESULT_OK );
	assert_ptr_equal( (const uint8_t*)faces, rig->bytes + plTestAsset_SectionOffset( rig->bytes, "FACE" ) );
	assert_int_equal( plAsset_GetTemplatePositions( in_place, &rest, &vertex_count ), PLEAT_RESULT_OK );
	assert_ptr_equal( (const uint8_t*)rest, rig->bytes + plTestAsset_SectionOffset( rig->bytes, "TMPL" ) );
	assert_int_equal( plDestroyAsset( in_place ), PLEAT_RESULT_OK );

	// Bad arguments, stale and null handles.
	assert_int_equal( plAsset_GetFaces( rig->asset, NULL, &face_count ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plAsset_GetFaces( rig->asset, &faces, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plAsset_GetTemplatePositions( rig->asset, NULL, &vertex_count ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plAsset_GetTemplatePositions( rig->asset, &rest, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	plAsset null_asset = { 0, 0, { 0, 0 } };
	assert_int_equal( plAsset_GetFaces( null_asset, &faces, &face_count ), PLEAT_RESULT_INVALID_HANDLE );
	assert_null( faces );
	assert_int_equal( face_count, 0 );
	assert_int_equal( plAsset_GetFaces( in_place, &faces, &face_count ), PLEAT_RESULT_INVALID_HANDLE ); // destroyed
	assert_null( faces );
	assert_int_equal( plAsset_GetTemplatePositions( in_place, &rest, &vertex_count ), PLEAT_RESULT_INVALID_HANDLE );
	assert_null( rest );
	assert_int_equal( vertex_count, 0 );
}

// An engine skeleton in a different order (reversed, plus two joints the asset does not have) through the joint map
// gives exactly the output of the asset-order instance.
static void test_joint_map_reorders_engine_joints( void** state )
{
	plTestRig* rig = *state;
	uint32_t J = rig->model->J, E = J + 2;
	int32_t map[64];
	for ( uint32_t j = 0; j < J; ++j )
	{
		map[j] = (int32_t)( E - 1 - j );
	}
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig->asset;
	idef.joint_map = map;
	idef.joint_map_count = J;
	idef.engine_joint_count = E;
	plInstance mapped, plain;
	assert_int_equal( plCreateInstance( rig->context, &idef, &mapped ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Instance( rig, &plain ), PLEAT_RESULT_OK );
	float q[64 * 4], engine[66 * 8];
	for ( uint32_t t = 0; t < 5; ++t )
	{
		plFrameInput in = plTestMotion( t, J, q );
		// Engine layout: 32-byte stride (quaternion + 4 floats of something else), reversed order, junk in extras.
		for ( uint32_t e = 0; e < E; ++e )
		{
			for ( int c = 0; c < 8; ++c )
			{
				engine[e * 8 + c] = 1e9f;
			}
		}
		for ( uint32_t j = 0; j < J; ++j )
		{
			memcpy( &engine[map[j] * 8], &q[j * 4], 16 );
		}
		plFrameInput ein = in;
		ein.joint_rotations = engine;
		ein.joint_count = E;
		ein.joint_stride_bytes = 32;
		for ( uint32_t e = 0; e < 2; ++e ) // engine joints 0 and 1 are not mapped: their junk must be ignored
		{
			engine[e * 8 + 0] = engine[e * 8 + 1] = engine[e * 8 + 2] = 0.0f;
			engine[e * 8 + 3] = 1.0f;
		}
		assert_int_equal( plInstance_Step( mapped, &ein, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( plain, &in, NULL ), PLEAT_RESULT_OK );
		const float *pa, *pb;
		plInstance_GetPositions( mapped, &pa, NULL );
		plInstance_GetPositions( plain, &pb, NULL );
		assert_memory_equal( pa, pb, rig->model->N * 3 * sizeof( float ) );
	}
}

typedef struct plLogRecord
{
	int count;
	plLogItem last_item;
	int saw_loaded;
} plLogRecord;

static void plRecordLog( plLogLevel level, plLogItem item, const char* message, void* user )
{
	(void)level;
	plLogRecord* r = (plLogRecord*)user;
	r->count++;
	r->last_item = item;
	r->saw_loaded |= item == PLEAT_LOG_ASSET_LOADED && strstr( message, "asset loaded" ) != NULL;
}

static void test_log_callback_receives_stable_items( void** state )
{
	(void)state;
	plLogRecord record = { 0, PLEAT_LOG_NONE, 0 };
	plContextDef def = plDefaultContextDef();
	def.log = plRecordLog;
	def.log_context = &record;
	plTestRig rig;
	assert_int_equal( plTestRig_Create( &rig, NULL, &def ), PLEAT_RESULT_OK );
	assert_true( record.saw_loaded );
	plInstance inst;
	assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	float q[64 * 4];
	plFrameInput in = plTestMotion( 0, rig.model->J, q );
	in.dt_s = -1.0f;
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_INVALID_DT );
	assert_int_equal( record.last_item, PLEAT_LOG_INSTANCE_BAD_INPUT );
	plTestRig_Free( &rig );
}

// Backends not built or not available: the instance is refused with the documented code, nothing leaks.
static void test_unavailable_backends_are_reported( void** state )
{
	plTestRig* rig = *state;
	uint64_t before = 0, after = 1;
	plContext_GetLiveBytes( rig->context, &before );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig->asset;
	idef.mlp_backend = PLEAT_MLP_BACKEND_ONNXRUNTIME; // the test asset has no OXLP/OXDC sections
	plInstance inst;
	assert_int_equal( plCreateInstance( rig->context, &idef, &inst ), PLEAT_RESULT_BACKEND_UNAVAILABLE );
	idef.mlp_backend = (plMlpBackend)7;
	assert_int_equal( plCreateInstance( rig->context, &idef, &inst ), PLEAT_RESULT_INVALID_DEF );
	idef.mlp_backend = PLEAT_MLP_BACKEND_PLEAT;
	idef.network_rate_hz = -1.0f; // a network rate must be finite and >= 0
	assert_int_equal( plCreateInstance( rig->context, &idef, &inst ), PLEAT_RESULT_INVALID_DEF );
	idef.network_rate_hz = NAN;
	assert_int_equal( plCreateInstance( rig->context, &idef, &inst ), PLEAT_RESULT_INVALID_DEF );
	idef.network_rate_hz = 0.0f;
	idef.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT; // no GL context is current in this test
	plResult r = plCreateInstance( rig->context, &idef, &inst );
	assert_true( r == PLEAT_RESULT_GL_UNAVAILABLE || r == PLEAT_RESULT_GL_ERROR );
	plContext_GetLiveBytes( rig->context, &after );
	assert_int_equal( before, after );
	assert_int_equal( plDestroyAsset( rig->asset ), PLEAT_RESULT_OK ); // no instance kept a reference
}

// Body contact's settings: a clearance outside 0 .. PLEAT_BODY_CONTACT_MAX_OFFSET_M or not finite is refused at create
// (INVALID_DEF) and at run time (INVALID_ARGUMENT, the setting unchanged), and so is a mode other than off, on and
// fast; on an asset without anchors it is accepted and changes nothing; on one with anchors turning it off gives plain
// skinning back.
static void test_body_contact_settings_are_checked( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	for ( int anchors = 0; anchors < 2; ++anchors )
	{
		plTestRig rig;
		assert_int_equal( plTestRig_CreateWithBody( &rig, &p, anchors ? 0.002f : 0.0f ), PLEAT_RESULT_OK );
		const plTestAsset* model = rig.model;
		assert_int_equal( rig.info.has_body_contact, anchors );
		plInstanceDef def = plDefaultInstanceDef();
		assert_int_equal( def.body_contact, 1 );
		assert_true( def.body_contact_offset_m == PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M );
		def.asset = rig.asset;
		const float bad[3] = { -0.001f, PLEAT_BODY_CONTACT_MAX_OFFSET_M * 2.0f, NAN };
		plInstance inst;
		for ( int i = 0; i < 3; ++i )
		{
			def.body_contact_offset_m = bad[i];
			assert_int_equal( plCreateInstance( rig.context, &def, &inst ), PLEAT_RESULT_INVALID_DEF );
		}
		def.body_contact_offset_m = 0.0f; // allowed: push to the plane itself
		const int bad_modes[2] = { -1, PLEAT_BODY_CONTACT_FAST + 1 };
		for ( int i = 0; i < 2; ++i )
		{
			def.body_contact = bad_modes[i];
			assert_int_equal( plCreateInstance( rig.context, &def, &inst ), PLEAT_RESULT_INVALID_DEF );
		}
		def.body_contact = PLEAT_BODY_CONTACT_ON;
		assert_int_equal( plCreateInstance( rig.context, &def, &inst ), PLEAT_RESULT_OK );
		for ( int i = 0; i < 3; ++i )
		{
			assert_int_equal( plInstance_SetBodyContact( inst, 1, bad[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
		}
		for ( int i = 0; i < 2; ++i )
		{
			assert_int_equal( plInstance_SetBodyContact( inst, bad_modes[i], 0.0f ), PLEAT_RESULT_INVALID_ARGUMENT );
		}
		plInstance plain;
		plInstanceDef plain_def = plDefaultInstanceDef();
		plain_def.asset = rig.asset;
		plain_def.body_contact = 0;
		assert_int_equal( plCreateInstance( rig.context, &plain_def, &plain ), PLEAT_RESULT_OK );
		float q[64 * 4];
		plFrameInput in = plTestMotion( 3, model->J, q );
		const float *with, *without;
		assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( plain, &in, NULL ), PLEAT_RESULT_OK );
		plInstance_GetPositions( inst, &with, NULL );
		plInstance_GetPositions( plain, &without, NULL );
		int differ = memcmp( with, without, (size_t)model->N * 3 * sizeof( float ) ) != 0;
		assert_int_equal( differ, anchors ); // the blend shapes (±1 cm) push vertices through the plane 2 mm behind
		// Off at run time: the next step is plain skinning again, bit for bit.
		assert_int_equal( plInstance_SetBodyContact( inst, 0, 0.001f ), PLEAT_RESULT_OK );
		plFrameInput next = plTestMotion( 4, model->J, q );
		assert_int_equal( plInstance_Step( inst, &next, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_Step( plain, &next, NULL ), PLEAT_RESULT_OK );
		plInstance_GetPositions( inst, &with, NULL );
		plInstance_GetPositions( plain, &without, NULL );
		assert_memory_equal( with, without, (size_t)model->N * 3 * sizeof( float ) );
		plTestRig_Free( &rig );
	}
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_result_and_log_item_names_are_stable ),
		cmocka_unit_test( test_runtime_version_matches_the_header ),
		cmocka_unit_test( test_defs_not_from_default_are_rejected ),
		cmocka_unit_test( test_null_and_stale_handles_are_rejected ),
		cmocka_unit_test( test_find_joint_and_info ),
		PLEAT_TEST_WITH_RIG( test_faces_and_template_come_from_the_asset ),
		PLEAT_TEST_WITH_RIG( test_joint_map_reorders_engine_joints ),
		cmocka_unit_test( test_log_callback_receives_stable_items ),
		PLEAT_TEST_WITH_RIG( test_unavailable_backends_are_reported ),
		cmocka_unit_test( test_body_contact_settings_are_checked ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
