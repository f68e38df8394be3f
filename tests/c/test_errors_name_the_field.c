// Error reporting through the log callback: every plCreateInstance rejection logs PLEAT_LOG_INSTANCE_BAD_DEF naming
// the def field (and entry), two asset joints mapped to one engine joint naming both entries; a call through a stale
// instance handle logs PLEAT_LOG_INSTANCE_STALE_HANDLE naming the function; a bad joint rotation is reported with the ENGINE's joint index when a joint map is used;
// an ONNX Runtime library that cannot be found is reported with PLEAT_ONNXRUNTIME_LIBRARY. (The headless GL report is
// checked in test_gl_headless_reports_platform.c, which needs the GL build.)
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"

typedef struct plLogRig
{
	plTestAsset* model;
	plTestRig rig;
	plTestLog log;
} plLogRig;

static plLogRig* plLogRig_Create( const void* onnx_payload, size_t onnx_size )
{
	plLogRig* r = calloc( 1, sizeof( *r ) );
	assert_non_null( r );
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.joint_count = 5;
	r->model = plTestAsset_Create( &p );
	assert_non_null( r->model );
	r->model->onnx_lp = onnx_payload;
	r->model->onnx_lp_size = onnx_size;
	r->model->onnx_dec = onnx_payload;
	r->model->onnx_dec_size = onnx_size;
	plContextDef cdef = plDefaultContextDef();
	cdef.log = plTestLog_Record;
	cdef.log_context = &r->log;
	assert_int_equal( plTestRig_Init( &r->rig, r->model, &cdef ), PLEAT_RESULT_OK );
	return r;
}

static void plLogRig_Destroy( plLogRig* r )
{
	plTestRig_Free( &r->rig );
	plTestAsset_Destroy( r->model );
	free( r );
}

// The one message the call logged, or a failure naming what came instead.
static void plExpectLogged( const plTestLog* log, int count_before, plLogLevel level, plLogItem item,
							const char* needle )
{
	assert_int_equal( log->count, count_before + 1 );
	assert_int_equal( log->level, level );
	assert_int_equal( log->item, item );
	assert_non_null( strstr( log->message, plLogItemString( item ) ) );
	print_message( "  logged: %s\n", log->message );
	if ( strstr( log->message, needle ) == NULL )
	{
		print_error( "expected '%s' in: %s\n", needle, log->message );
		fail();
	}
}

enum { PL_ENGINE_JOINTS = 8 };

// An instance def on the rig's asset (5 joints) driven through map from an engine skeleton of PL_ENGINE_JOINTS.
static plInstanceDef plMappedDef( const plLogRig* r, const int32_t* map )
{
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = r->rig.asset;
	def.joint_map = map;
	def.joint_map_count = 5;
	def.engine_joint_count = PL_ENGINE_JOINTS;
	return def;
}

typedef struct plBadDefCase
{
	const char* what;
	plResult result;
	const char* needle;
} plBadDefCase;

// One table entry per def field: the mutation is chosen by index in plMutate.
static const plBadDefCase s_bad_def_cases[] = {
	{ "joint map entry past the engine's joints", PLEAT_RESULT_JOINT_COUNT_MISMATCH, "joint_map[3]" },
	{ "joint map entry below -1", PLEAT_RESULT_JOINT_COUNT_MISMATCH, "joint_map[2]" },
	{ "joint map count", PLEAT_RESULT_JOINT_COUNT_MISMATCH, "joint_map_count 4" },
	{ "engine joint count without a map", PLEAT_RESULT_JOINT_COUNT_MISMATCH, "engine_joint_count 7" },
	{ "NaN material", PLEAT_RESULT_NON_FINITE_INPUT, "material[1] (mu)" },
	{ "infinite beta", PLEAT_RESULT_NON_FINITE_INPUT, "beta[1]" },
	{ "beta count", PLEAT_RESULT_INVALID_DEF, "beta_count 9" },
	{ "MLP backend", PLEAT_RESULT_INVALID_DEF, "mlp_backend 7" },
	{ "GPU mode", PLEAT_RESULT_INVALID_DEF, "gpu_mode 9" },
	{ "network rate", PLEAT_RESULT_INVALID_DEF, "network_rate_hz" },
	{ "cookie", PLEAT_RESULT_INVALID_DEF, "internal_cookie" },
	{ "two asset joints on one engine joint", PLEAT_RESULT_INVALID_DEF, "joint_map[1]" },
};

static void plMutate( size_t index, plInstanceDef* def, int32_t* map, float* material, float* beta )
{
	switch ( index )
	{
		case 0: map[3] = PL_ENGINE_JOINTS; break;
		case 1: map[2] = -2; break;
		case 2: def->joint_map_count = 4; break;
		case 3: def->joint_map = NULL, def->engine_joint_count = 7; break;
		case 4: material[1] = NAN, def->material = material; break;
		case 5: beta[1] = INFINITY, def->beta = beta, def->beta_count = 2; break;
		case 6: def->beta = beta, def->beta_count = 9; break;
		case 7: def->mlp_backend = (plMlpBackend)7; break;
		case 8: def->gpu_mode = (plGpuMode)9; break;
		case 9: def->network_rate_hz = NAN; break;
		case 10: def->internal_cookie = 0; break;
		case 11: map[3] = 2; break; // asset joints 1 and 3 both on engine joint 2
		default: fail();
	}
}

static void test_create_failures_name_the_def_field( void** state )
{
	(void)state;
	plLogRig* r = plLogRig_Create( NULL, 0 );
	for ( size_t i = 0; i < sizeof( s_bad_def_cases ) / sizeof( s_bad_def_cases[0] ); ++i )
	{
		const plBadDefCase* c = &s_bad_def_cases[i];
		int32_t map[5] = { 1, 2, 3, 4, -1 };
		float material[4] = { r->rig.info.material_default[0], r->rig.info.material_default[1],
							  r->rig.info.material_default[2], r->rig.info.material_default[3] };
		float beta[10] = { 0 };
		plInstanceDef def = plMappedDef( r, map );
		plMutate( i, &def, map, material, beta );
		int before = r->log.count;
		plInstance inst;
		print_message( "%s:\n", c->what );
		assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), c->result );
		assert_int_equal( inst.index1, 0 );
		plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, c->needle );
	}
	// The out-of-range entry also names the asset joint and the range it must lie in.
	int32_t map[5] = { 1, 2, 3, PL_ENGINE_JOINTS, -1 };
	plInstanceDef def = plMappedDef( r, map );
	plInstance inst;
	assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	assert_non_null( strstr( r->log.message, r->model->joint_names[3] ) );
	assert_non_null( strstr( r->log.message, "-1..7 (engine_joint_count 8)" ) );
	// One engine joint cannot drive two asset joints: the message names both entries, both joints and the engine
	// joint. Several identity (-1) entries are fine.
	int32_t shared[5] = { -1, 6, 0, 6, -1 };
	def = plMappedDef( r, shared );
	assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), PLEAT_RESULT_INVALID_DEF );
	print_message( "  logged: %s\n", r->log.message );
	assert_non_null( strstr( r->log.message, "joint_map[1]" ) );
	assert_non_null( strstr( r->log.message, "joint_map[3]" ) );
	assert_non_null( strstr( r->log.message, r->model->joint_names[1] ) );
	assert_non_null( strstr( r->log.message, r->model->joint_names[3] ) );
	assert_non_null( strstr( r->log.message, "engine joint 6" ) );
	int32_t identities[5] = { -1, 6, -1, 5, -1 };
	def = plMappedDef( r, identities );
	assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( inst ), PLEAT_RESULT_OK );
	plLogRig_Destroy( r );
}

// A call through the handle of a destroyed instance returns INVALID_HANDLE and logs INSTANCE_STALE_HANDLE with the
// function's name (as a stale asset in an instance def is logged); asking plInstance_IsValid logs nothing.
static void test_stale_instance_handle_is_logged( void** state )
{
	(void)state;
	plLogRig* r = plLogRig_Create( NULL, 0 );
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = r->rig.asset;
	plInstance stale;
	assert_int_equal( plCreateInstance( r->rig.context, &def, &stale ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( stale ), PLEAT_RESULT_OK );
	int before = r->log.count;
	assert_false( plInstance_IsValid( stale ) );
	assert_int_equal( r->log.count, before );

	float q[64 * 4];
	plFrameInput in = plTestMotion( 0, r->rig.info.joint_count, q );
	assert_int_equal( plInstance_Step( stale, &in, NULL ), PLEAT_RESULT_INVALID_HANDLE );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_STALE_HANDLE, "plInstance_Step" );
	before = r->log.count;
	const float beta[1] = { 0.5f };
	assert_int_equal( plInstance_SetShape( stale, beta, 1 ), PLEAT_RESULT_INVALID_HANDLE );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_STALE_HANDLE, "plInstance_SetShape" );
	before = r->log.count;
	assert_int_equal( plDestroyInstance( stale ), PLEAT_RESULT_INVALID_HANDLE );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_STALE_HANDLE, "plDestroyInstance" );
	before = r->log.count;
	plResult result = PLEAT_RESULT_OK;
	assert_int_equal( plStepInstances( r->rig.context, &stale, &in, NULL, &result, 1 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( result, PLEAT_RESULT_INVALID_HANDLE );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_STALE_HANDLE, "plStepInstances" );
	plLogRig_Destroy( r );
}

static void test_bad_rotation_names_the_engine_joint( void** state )
{
	(void)state;
	plLogRig* r = plLogRig_Create( NULL, 0 );
	// Asset joint k is driven by engine joint 7 − k (the engine stores its joints in reverse), engine joint 2 unused.
	int32_t map[5] = { 7, 6, 5, 4, 3 };
	plInstanceDef def = plMappedDef( r, map );
	plInstance inst;
	assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), PLEAT_RESULT_OK );
	float engine[PL_ENGINE_JOINTS][4];
	for ( int e = 0; e < PL_ENGINE_JOINTS; ++e )
	{
		engine[e][0] = engine[e][1] = engine[e][2] = 0.0f;
		engine[e][3] = 1.0f;
	}
	plFrameInput in;
	memset( &in, 0, sizeof( in ) );
	in.joint_rotations = &engine[0][0];
	in.joint_count = PL_ENGINE_JOINTS;
	in.root_rotation.w = 1.0f;
	in.dt_s = 1.0f / 30.0f;

	engine[5][3] = 2.0f; // engine joint 5 drives asset joint 2
	int before = r->log.count;
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_INVALID_QUATERNION );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "engine joint 5 (asset joint 2" );
	assert_non_null( strstr( r->log.message, "quaternion length 2" ) );

	engine[5][3] = 1.0f;
	engine[6][1] = NAN; // engine joint 6 drives asset joint 1
	before = r->log.count;
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_NON_FINITE_INPUT );
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT,
					"engine joint 6 rotation is not finite" );

	// An unused engine joint is not read, so garbage there is no error and logs nothing.
	engine[6][1] = 0.0f;
	engine[2][3] = NAN;
	before = r->log.count;
	assert_int_equal( plInstance_Step( inst, &in, NULL ), PLEAT_RESULT_OK );
	assert_int_equal( r->log.count, before );
	plLogRig_Destroy( r );
}

static void test_missing_onnxruntime_library_names_the_variable( void** state )
{
	(void)state;
	// A placeholder ONNX payload: the library is looked for before the model is read, so its content never matters
	// beyond the loader's check that it is a well-formed, self-contained ModelProto (here: ir_version = 7, field 1).
	static const uint8_t payload[2] = { 0x08, 0x07 };
	plLogRig* r = plLogRig_Create( payload, sizeof( payload ) );
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = r->rig.asset;
	def.mlp_backend = PLEAT_MLP_BACKEND_ONNXRUNTIME;
	def.onnxruntime_library = "/nonexistent/pleat-test/libonnxruntime.so";
	int before = r->log.count;
	uint64_t live_before = 0, live_after = 1;
	assert_int_equal( plContext_GetLiveBytes( r->rig.context, &live_before ), PLEAT_RESULT_OK );
	plInstance inst;
	assert_int_equal( plCreateInstance( r->rig.context, &def, &inst ), PLEAT_RESULT_BACKEND_UNAVAILABLE );
	assert_int_equal( plContext_GetLiveBytes( r->rig.context, &live_after ), PLEAT_RESULT_OK );
	assert_int_equal( live_after, live_before ); // the failed instance kept nothing
	plExpectLogged( &r->log, before, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_BACKEND_UNAVAILABLE, "PLEAT_ONNXRUNTIME_LIBRARY" );
	// With the header built in, the log also says what was tried (the stub build says it has no ONNX Runtime).
	if ( strstr( r->log.message, "built without the ONNX Runtime C API header" ) == NULL )
	{
		assert_non_null( strstr( r->log.message, "library not found" ) );
		assert_non_null( strstr( r->log.message, "/nonexistent/pleat-test/libonnxruntime.so" ) );
	}
	plLogRig_Destroy( r );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_create_failures_name_the_def_field ),
		cmocka_unit_test( test_bad_rotation_names_the_engine_joint ),
		cmocka_unit_test( test_stale_instance_handle_is_logged ),
		cmocka_unit_test( test_missing_onnxruntime_library_names_the_variable ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
