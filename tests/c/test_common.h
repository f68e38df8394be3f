// Test helpers: a context + asset fixture over plTestAsset (a cmocka setup/teardown pair on the default asset), a
// counting host allocator, a log recorder, and a deterministic little motion.
#ifndef PLEAT_TEST_COMMON_H
#define PLEAT_TEST_COMMON_H
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pleat/pleat.h"
#include "test_asset_builder.h"

typedef struct plTestRig
{
	plContext context;
	plAsset asset;
	uint8_t* bytes;
	size_t size;
	plAssetInfo info;
	plTestAsset* model; // the rig's own model (plTestRig_Create), destroyed by plTestRig_Free; NULL after plTestRig_Init
} plTestRig;

// Loads a written test asset into a fresh context (def may be NULL = defaults). Returns the load result.
static inline plResult plTestRig_Init( plTestRig* rig, plTestAsset* model, const plContextDef* def )
{
	memset( rig, 0, sizeof( *rig ) );
	plContextDef cdef = def != NULL ? *def : plDefaultContextDef();
	plResult r = plCreateContext( &cdef, &rig->context );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	rig->bytes = plTestAsset_Write( model, &rig->size );
	plAssetDef adef = plDefaultAssetDef();
	adef.data = rig->bytes;
	adef.size = rig->size;
	r = plLoadAsset( rig->context, &adef, &rig->asset );
	if ( r == PLEAT_RESULT_OK )
	{
		plAsset_GetInfo( rig->asset, &rig->info );
	}
	return r;
}

// Builds a model from params (NULL = plTestAsset_DefaultParams()) and loads it as plTestRig_Init does; the rig owns
// the model (rig->model).
static inline plResult plTestRig_Create( plTestRig* rig, const plTestAssetParams* params, const plContextDef* def )
{
	plTestAssetParams p = params != NULL ? *params : plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	plResult r = plTestRig_Init( rig, model, def );
	rig->model = model;
	return r;
}

// plTestRig_Create, with a stand-in body depth_m behind the sheet (plTestAsset_AddBodyAnchors) when depth_m > 0.
static inline plResult plTestRig_CreateWithBody( plTestRig* rig, const plTestAssetParams* params, float depth_m )
{
	plTestAssetParams p = params != NULL ? *params : plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	if ( model == NULL || ( depth_m > 0.0f && !plTestAsset_AddBodyAnchors( model, depth_m ) ) )
	{
		plTestAsset_Destroy( model );
		memset( rig, 0, sizeof( *rig ) );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	plResult r = plTestRig_Init( rig, model, NULL );
	rig->model = model;
	return r;
}

static inline void plTestRig_Free( plTestRig* rig )
{
	plDestroyContext( rig->context );
	plTestAsset_FreeBytes( rig->bytes );
	plTestAsset_Destroy( rig->model );
}

// The three tiers of one garment the scene tests dress characters in: tiers 0 and 1 on one mesh (12 and 6 blend
// shapes), tier 2 a coarser sheet over the same area; written and loaded into a context, which owns the assets.
typedef struct plTestSceneTiers
{
	plAsset tiers[3];
	uint8_t* bytes[3];
	plTestAsset* models[3];
} plTestSceneTiers;

static inline plResult plTestSceneTiers_Load( plTestSceneTiers* set, plContext context )
{
	memset( set, 0, sizeof( *set ) );
	for ( int t = 0; t < 3; ++t )
	{
		plTestAssetParams p = plTestAsset_DefaultParams();
		p.seed = 5; // one garment
		p.blend_count = t == 0 ? 12 : 6;
		p.lp_hidden[0] = t == 0 ? 64 : 32;
		if ( t == 2 )
		{
			p.grid_x = 4;
			p.grid_y = 4;
		}
		set->models[t] = plTestAsset_Create( &p );
		size_t size;
		set->bytes[t] = plTestAsset_Write( set->models[t], &size );
		plAssetDef adef = plDefaultAssetDef();
		adef.data = set->bytes[t];
		adef.size = size;
		plResult r = plLoadAsset( context, &adef, &set->tiers[t] );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
	}
	return PLEAT_RESULT_OK;
}

// The written bytes and the models (the assets go with their context).
static inline void plTestSceneTiers_Free( plTestSceneTiers* set )
{
	for ( int t = 0; t < 3; ++t )
	{
		plTestAsset_FreeBytes( set->bytes[t] );
		plTestAsset_Destroy( set->models[t] );
	}
}

// cmocka fixture (PLEAT_TEST_WITH_RIG( test ) in the test table): *state is a rig on the default test asset in a
// default context.
#define PLEAT_TEST_WITH_RIG( test ) cmocka_unit_test_setup_teardown( test, plTestRig_Setup, plTestRig_Teardown )

static inline int plTestRig_Setup( void** state )
{
	plTestRig* rig = (plTestRig*)malloc( sizeof( plTestRig ) );
	if ( rig == NULL )
	{
		return -1;
	}
	*state = rig;
	return plTestRig_Create( rig, NULL, NULL ) == PLEAT_RESULT_OK ? 0 : -1;
}

static inline int plTestRig_Teardown( void** state )
{
	plTestRig* rig = (plTestRig*)*state;
	plTestRig_Free( rig );
	free( rig );
	return 0;
}

static inline plResult plTestRig_Instance( plTestRig* rig, plInstance* out )
{
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig->asset;
	return plCreateInstance( rig->context, &idef, out );
}

// A counting host allocator for plContextDef (plCountingHost_ContextDef): the bytes and blocks live as the host sees
// them, the allocations made, alignments that were not a power of two >= 16, and an optional point after which every
// allocation fails (out-of-memory tests).
typedef struct plCountingHost
{
	int64_t live_bytes;
	int64_t live_blocks;
	int64_t allocations;
	int64_t bad_alignments;
	int64_t fail_after; // allocations that succeed before every later one fails; < 0: never fail
} plCountingHost;

static inline void* plCountingHost_Alloc( size_t size, size_t align, void* user )
{
	plCountingHost* h = (plCountingHost*)user;
	if ( h->fail_after >= 0 && h->allocations >= h->fail_after )
	{
		return NULL;
	}
	h->allocations++;
	if ( align < 16 || ( align & ( align - 1 ) ) != 0 )
	{
		h->bad_alignments++;
		return NULL;
	}
	void* p = aligned_alloc( align, ( size + align - 1 ) & ~( align - 1 ) );
	if ( p != NULL )
	{
		h->live_bytes += (int64_t)size;
		h->live_blocks++;
	}
	return p;
}

static inline void plCountingHost_Free( void* ptr, size_t size, void* user )
{
	plCountingHost* h = (plCountingHost*)user;
	h->live_bytes -= (int64_t)size;
	h->live_blocks--;
	free( ptr );
}

// Zeroes the host (never failing) and returns a default context def that allocates through it.
static inline plContextDef plCountingHost_ContextDef( plCountingHost* host )
{
	memset( host, 0, sizeof( *host ) );
	host->fail_after = -1;
	plContextDef def = plDefaultContextDef();
	def.alloc = plCountingHost_Alloc;
	def.free = plCountingHost_Free;
	def.allocator_context = host;
	return def;
}

// A log recorder for plContextDef.log (log_context = the record): the message count, the last message and the last
// error.
typedef struct plTestLog
{
	int count;
	plLogLevel level;
	plLogItem item;
	char message[512];
	plLogItem last_error_item;
	char last_error[512];
} plTestLog;

static inline void plTestLog_Record( plLogLevel level, plLogItem item, const char* message, void* user )
{
	plTestLog* log = (plTestLog*)user;
	log->count++;
	log->level = level;
	log->item = item;
	snprintf( log->message, sizeof( log->message ), "%s", message != NULL ? message : "" );
	if ( level == PLEAT_LOG_LEVEL_ERROR )
	{
		log->last_error_item = item;
		snprintf( log->last_error, sizeof( log->last_error ), "%s", log->message );
	}
}

// One row of a table of invalid jobs: a copy of job (of type Job) with member set to value must fail Job##_Validate.
#define PLEAT_EXPECT_INVALID( Job, job, member, value )                                                                \
	do                                                                                                                 \
	{                                                                                                                  \
		Job invalid_ = ( job );                                                                                        \
		invalid_.member = ( value );                                                                                   \
		assert_false( Job##_Validate( &invalid_ ) );                                                                   \
	} while ( 0 )

// The next number of a xorshift32 stream (*state, never 0) as a float in [-1, 1): deterministic test data.
static inline float plTestRandom( uint32_t* state )
{
	*state ^= *state << 13;
	*state ^= *state >> 17;
	*state ^= *state << 5;
	return (float)( *state >> 8 ) / 8388608.0f - 1.0f;
}

// Frame `frame` of a smooth motion: every joint swings about an axis, the root walks and turns. quats: [J][4].
static inline plFrameInput plTestMotion( uint32_t frame, uint32_t joint_count, float* quats )
{
	float t = (float)frame / 30.0f;
	for ( uint32_t j = 0; j < joint_count; ++j )
	{
		float angle = 0.4f * sinf( 2.0f * t + (float)j );
		float ax = 0.3f, ay = 0.5f + 0.1f * (float)j, az = 0.8f;
		float n = sqrtf( ax * ax + ay * ay + az * az );
		float s = sinf( 0.5f * angle ) / n;
		quats[j * 4 + 0] = ax * s;
		quats[j * 4 + 1] = ay * s;
		quats[j * 4 + 2] = az * s;
		quats[j * 4 + 3] = cosf( 0.5f * angle );
	}
	plFrameInput in;
	memset( &in, 0, sizeof( in ) );
	in.joint_rotations = quats;
	in.joint_count = joint_count;
	in.joint_stride_bytes = 16;
	in.root_translation.x = 0.5f * t;
	in.root_translation.y = 0.02f * sinf( 6.0f * t );
	in.root_translation.z = 0.3f * sinf( t );
	float yaw = 0.6f * sinf( 0.7f * t );
	in.root_rotation.y = sinf( 0.5f * yaw );
	in.root_rotation.w = cosf( 0.5f * yaw );
	in.dt_s = 1.0f / 30.0f;
	return in;
}

#endif
