// libFuzzer target for the runtime behind the loader (built with -DPLEAT_FUZZ=ON and CC=clang; scripts/fuzz.sh).
//
// fuzz_asset mutates raw bytes, so almost every input dies in the structure checks or on the CRC. This harness keeps
// the structure and mutates meaning: an input is a 64-byte control block followed by a valid asset; the custom
// mutator below changes the control block or the *contents* of one section (typed: boundary indices, special floats,
// swapped elements, CONF fields ±1), keeps the section table intact and recomputes the CRC-32. The harness then loads
// the asset with the checksum checked and, when the loader accepts it, drives the public API the way an engine would,
// with the host hooks and the instance def chosen by the control block:
//
//   - context: scalar or AVX2 kernels; 1–4 workers through task hooks that run the ranges inline in forward or
//     reverse order, or defer them to finish_task; a counting allocator that can fail one chosen allocation; a log
//     callback that checks every message;
//   - asset: from memory (copied or in place) or from a file (plReadFile); GetInfo, joint names, FindJoint, faces,
//     template;
//   - instance: no joint map, a map with -1 entries, a reversed map into a larger engine skeleton, a map built with
//     plAsset_FindJoint, or an invalid map; initial β and material; a network update rate; the ONNX Runtime backend
//     (only with PLEAT_ONNXRUNTIME_LIBRARY set, for assets with OXLP/OXDC);
//   - steps: poses with strided input (NaN in the padding and in unreferenced engine joints, which must not be read),
//     quaternions off unit length by 4e-4 (renormalised), dt inside and outside the asset's clamp range, output spans
//     planar, strided or interleaved over sentinel-filled buffers, setters (β, material, rate, reset) between steps,
//     rejected inputs (NaN dt, a span too small, β count too large) that must change nothing.
//
// Beyond ASan/UBSan, the harness aborts on any broken contract: a failed call with a non-null handle, an allocation
// failure reported as anything but OUT_OF_MEMORY, live bytes left after destroy (context counter or host counter), a
// step that allocates, an OK step with non-finite output, an output span that differs from the instance's buffers
// or writes outside its fields, a clamp that is not the documented one, and — when the control block asks — a
// different output hash with one worker than with the chosen task system (results must be bit-identical for any
// worker count).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_control.h"
#include "pleat/pleat.h"
#include "test_asset_builder.h"

int LLVMFuzzerTestOneInput( const uint8_t* data, size_t size );
int LLVMFuzzerInitialize( int* argc, char*** argv );
size_t LLVMFuzzerCustomMutator( uint8_t* data, size_t size, size_t max_size, unsigned int seed );
size_t LLVMFuzzerMutate( uint8_t* data, size_t size, size_t max_size );

#define PLEAT_FUZZ_REQUIRE( condition )                                                                                        \
	do                                                                                                                 \
	{                                                                                                                  \
		if ( !( condition ) )                                                                                          \
		{                                                                                                              \
			fprintf( stderr, "fuzz_asset_semantic: contract broken at line %d: %s\n", __LINE__, #condition );         \
			abort();                                                                                                   \
		}                                                                                                              \
	} while ( 0 )

static const float s_rates[8] = { 0.0f, 0.0f, 10.0f, 15.0f, 30.0f, 60.0f, 1000.0f, 0.5f };
static const float s_dts[8] = { 1.0f / 30.0f, 1.0f / 60.0f, 1.0f / 120.0f, 1.0f / 1000.0f,
								0.5f,         1.0f,         1.0f / 15.0f,  1.0f / 240.0f };

// ---- host hooks ----

typedef struct plFuzzHost
{
	int64_t live_bytes;
	int64_t live_blocks;
	uint64_t allocations;
	uint64_t fail_at;     // 1-based allocation number that returns NULL; 0 = none
	uint64_t failed;      // allocations refused so far
} plFuzzHost;

static void* plFuzzAlloc( size_t size, size_t align, void* user )
{
	plFuzzHost* h = (plFuzzHost*)user;
	PLEAT_FUZZ_REQUIRE( align >= 16 && ( align & ( align - 1 ) ) == 0 );
	h->allocations++;
	if ( h->allocations == h->fail_at || size > ( (size_t)1 << 30 ) )
	{
		h->failed++;
		return NULL;
	}
	size_t rounded = ( ( size > 0 ? size : 1 ) + align - 1 ) & ~( align - 1 );
	void* p = aligned_alloc( align, rounded );
	if ( p == NULL )
	{
		h->failed++;
		return NULL;
	}
	memset( p, 0xCD, rounded ); // the SDK must not depend on fresh memory being zero
	h->live_bytes += (int64_t)size;
	h->live_blocks++;
	return p;
}

static void plFuzzFree( void* ptr, size_t size, void* user )
{
	plFuzzHost* h = (plFuzzHost*)user;
	PLEAT_FUZZ_REQUIRE( ptr != NULL );
	h->live_bytes -= (int64_t)size;
	h->live_blocks--;
	free( ptr );
}

// A task system without threads: ranges run on the caller, forward or reversed, at enqueue or at finish.
typedef struct plFuzzTasks
{
	uint32_t workers;
	int defer;
	int reverse;
	int pending;
	plTaskFn* task;
	void* task_context;
	uint32_t begins[4], ends[4], range_count;
} plFuzzTasks;

static void plFuzzRunRanges( plFuzzTasks* s )
{
	for ( uint32_t i = 0; i < s->range_count; ++i )
	{
		uint32_t r = s->reverse ? s->range_count - 1 - i : i;
		s->task( s->begins[r], s->ends[r], r, s->task_context );
	}
}

static void* plFuzzEnqueue( plTaskFn* task, uint32_t item_count, uint32_t min_range, void* task_context, void* user )
{
	plFuzzTasks* s = (plFuzzTasks*)user;
	uint32_t workers = s->workers;
	uint32_t least = min_range > 0 ? min_range : 1;
	while ( workers > 1 && item_count / workers < least )
	{
		workers--;
	}
	s->task = task;
	s->task_context = task_context;
	s->range_count = workers;
	uint32_t per = item_count / workers, extra = item_count % workers, begin = 0;
	for ( uint32_t w = 0; w < workers; ++w )
	{
		s->begins[w] = begin;
		begin += per + ( w < extra ? 1u : 0u );
		s->ends[w] = begin;
	}
	if ( s->defer && !s->pending )
	{
		s->pending = 1;
		return s;
	}
	plFuzzRunRanges( s );
	return NULL;
}

static void plFuzzFinish( void* user_task, void* user )
{
	plFuzzTasks* s = (plFuzzTasks*)user;
	PLEAT_FUZZ_REQUIRE( user_task == s && s->pending );
	plFuzzRunRanges( s );
	s->pending = 0;
}

static void plFuzzLog( plLogLevel level, plLogItem item, const char* message, void* user )
{
	(void)user;
	PLEAT_FUZZ_REQUIRE( level >= PLEAT_LOG_LEVEL_ERROR && level <= PLEAT_LOG_LEVEL_INFO );
	PLEAT_FUZZ_REQUIRE( strcmp( plLogItemString( item ), "unknown item" ) != 0 );
	PLEAT_FUZZ_REQUIRE( message != NULL && strlen( message ) < 4096 );
}

// ---- helpers ----

static char s_asset_path[64];
static const char* s_onnxruntime;

int LLVMFuzzerInitialize( int* argc, char*** argv )
{
	(void)argc;
	(void)argv;
	snprintf( s_asset_path, sizeof( s_asset_path ), "/tmp/pleat-fuzz-semantic-%ld.pleat", (long)getpid() );
	s_onnxruntime = getenv( "PLEAT_ONNXRUNTIME_LIBRARY" );
	return 0;
}

static int plAllFinite( const float* v, size_t count )
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

static float plClampf( float v, float lo, float hi )
{
	return v < lo ? lo : ( v > hi ? hi : v );
}

// Pose of frame `step` for the engine skeleton: unit quaternions at `stride_floats`, NaN in the padding and in every
// engine joint the map does not reference (the SDK must read neither).
static void plMakePose( const plFuzzControl* c, uint32_t step, uint32_t engine_joints, uint32_t stride_floats,
						const uint8_t* referenced, float* rotations )
{
	for ( uint32_t j = 0; j < engine_joints; ++j )
	{
		float* q = rotations + (size_t)j * stride_floats;
		for ( uint32_t k = 4; k < stride_floats; ++k )
		{
			q[k] = NAN;
		}
		if ( !referenced[j] )
		{
			q[0] = q[1] = q[2] = q[3] = NAN;
			continue;
		}
		double angle = ( (double)c->pose[( j + step ) % 16] - 128.0 ) / 128.0 * 3.14159265;
		double around = (double)c->pose[( j * 7 + 3 ) % 16] * 0.0245;
		double ax = cos( around ), ay = sin( around ), az = 0.5;
		double n = sqrt( ax * ax + ay * ay + az * az );
		double s = sin( 0.5 * angle ) / n;
		double scale = ( c->flags2 & PLEAT_FUZZ2_OFF_UNIT_QUATS ) ? 1.0004 : 1.0;
		q[0] = (float)( ax * s * scale );
		q[1] = (float)( ay * s * scale );
		q[2] = (float)( az * s * scale );
		q[3] = (float)( cos( 0.5 * angle ) * scale );
	}
}

typedef struct plFuzzOutput
{
	uint8_t* buffer;
	size_t bytes;
	plStepOutput spans;
	int use;
	int too_small;
	uint32_t pos_offset, pos_stride, nrm_offset, nrm_stride; // stride 0 = stream not written
} plFuzzOutput;

static void plFuzzOutput_Init( plFuzzOutput* o, uint32_t mode, uint32_t vertex_count )
{
	memset( o, 0, sizeof( *o ) );
	uint32_t stride = 12;
	switch ( mode % 6 )
	{
		case 0:
			return;
		case 1: // planar: positions then normals, tightly packed
			o->pos_stride = o->nrm_stride = 12;
			o->pos_offset = 0;
			o->nrm_offset = 12 * vertex_count;
			stride = 24;
			break;
		case 2: // interleaved position, normal
			o->pos_stride = o->nrm_stride = 24;
			o->pos_offset = 0;
			o->nrm_offset = 12;
			stride = 24;
			break;
		case 3: // positions only, vec4-like
			o->pos_stride = 16;
			stride = 16;
			break;
		case 4: // normals only, 32-byte vertices
			o->nrm_stride = 32;
			o->nrm_offset = 4;
			stride = 32;
			break;
		default: // interleaved, one vertex short
			o->pos_stride = o->nrm_stride = 24;
			o->nrm_offset = 12;
			stride = 24;
			o->too_small = 1;
			break;
	}
	o->use = 1;
	o->bytes = (size_t)stride * ( vertex_count + 2 );
	o->buffer = (uint8_t*)malloc( o->bytes );
	PLEAT_FUZZ_REQUIRE( o->buffer != NULL );
	o->spans.vertex_capacity = o->too_small ? vertex_count - 1 : vertex_count + 1;
	if ( o->pos_stride != 0 )
	{
		o->spans.positions = (float*)( o->buffer + o->pos_offset );
		o->spans.position_stride_bytes = o->pos_stride == 12 ? 0 : o->pos_stride;
	}
	if ( o->nrm_stride != 0 )
	{
		o->spans.normals = (float*)( o->buffer + o->nrm_offset );
		o->spans.normal_stride_bytes = o->nrm_stride;
	}
}

// After a successful step: the spans hold exactly the instance's buffers and nothing else was written.
static void plFuzzOutput_Check( const plFuzzOutput* o, const float* positions, const float* normals, uint32_t n )
{
	for ( size_t b = 0; b < o->bytes; ++b )
	{
		int written = 0;
		if ( o->pos_stride != 0 && b >= o->pos_offset && ( b - o->pos_offset ) / o->pos_stride < n &&
			 ( b - o->pos_offset ) % o->pos_stride < 12 )
		{
			size_t v = ( b - o->pos_offset ) / o->pos_stride, k = ( b - o->pos_offset ) % o->pos_stride;
			PLEAT_FUZZ_REQUIRE( o->buffer[b] == ( (const uint8_t*)( positions + v * 3 ) )[k] );
			written = 1;
		}
		if ( o->nrm_stride != 0 && b >= o->nrm_offset && ( b - o->nrm_offset ) / o->nrm_stride < n &&
			 ( b - o->nrm_offset ) % o->nrm_stride < 12 )
		{
			size_t v = ( b - o->nrm_offset ) / o->nrm_stride, k = ( b - o->nrm_offset ) % o->nrm_stride;
			PLEAT_FUZZ_REQUIRE( o->buffer[b] == ( (const uint8_t*)( normals + v * 3 ) )[k] );
			written = 1;
		}
		if ( !written )
		{
			PLEAT_FUZZ_REQUIRE( o->buffer[b] == 0xA5 );
		}
	}
}

// ---- one run of the scenario the control block describes ----

typedef struct plFuzzRun
{
	uint64_t hash;      // results and outputs of every step
	int complete;       // every call ran (no injected allocation failure, no backend refusal)
} plFuzzRun;

static plResult plFuzzLoad( const plFuzzControl* c, plContext context, const uint8_t* block, size_t size,
							plAsset* asset )
{
	plAssetDef adef = plDefaultAssetDef();
	if ( c->flags & PLEAT_FUZZ_LOAD_FROM_FILE )
	{
		FILE* file = fopen( s_asset_path, "wb" );
		PLEAT_FUZZ_REQUIRE( file != NULL );
		PLEAT_FUZZ_REQUIRE( fwrite( block, 1, size, file ) == size );
		fclose( file );
		adef.path = s_asset_path;
	}
	else
	{
		adef.data = block;
		adef.size = size;
		adef.flags = ( c->flags & PLEAT_FUZZ_IN_PLACE ) ? PLEAT_ASSET_FLAG_USE_IN_PLACE : 0u;
	}
	return plLoadAsset( context, &adef, asset );
}

// Asset queries: every count and index the loader accepted is safe to use.
static void plFuzzCheckAsset( plAsset asset, const plAssetInfo* info )
{
	const uint32_t* faces = NULL;
	uint32_t face_count = 0;
	PLEAT_FUZZ_REQUIRE( plAsset_GetFaces( asset, &faces, &face_count ) == PLEAT_RESULT_OK && face_count == info->face_count );
	for ( size_t i = 0; i < (size_t)face_count * 3; ++i )
	{
		PLEAT_FUZZ_REQUIRE( faces[i] < info->vertex_count );
	}
	const float* rest = NULL;
	uint32_t vertex_count = 0;
	PLEAT_FUZZ_REQUIRE( plAsset_GetTemplatePositions( asset, &rest, &vertex_count ) == PLEAT_RESULT_OK &&
				vertex_count == info->vertex_count && plAllFinite( rest, (size_t)vertex_count * 3 ) );
	PLEAT_FUZZ_REQUIRE( info->joint_count >= 1 && info->joint_count <= PLEAT_MAX_JOINTS );
	PLEAT_FUZZ_REQUIRE( info->beta_count <= PLEAT_MAX_BETAS && info->dt_min_s > 0.0f && info->dt_min_s <= info->dt_max_s );
	for ( uint32_t j = 0; j < info->joint_count; ++j )
	{
		const char* name = NULL;
		PLEAT_FUZZ_REQUIRE( plAsset_GetJointName( asset, j, &name ) == PLEAT_RESULT_OK && name != NULL );
		PLEAT_FUZZ_REQUIRE( strlen( name ) < PLEAT_JOINT_NAME_SIZE );
		int32_t found = -1;
		PLEAT_FUZZ_REQUIRE( plAsset_FindJoint( asset, name, &found ) == PLEAT_RESULT_OK );
		const char* found_name = NULL;
		PLEAT_FUZZ_REQUIRE( found >= 0 && (uint32_t)found <= j );
		PLEAT_FUZZ_REQUIRE( plAsset_GetJointName( asset, (uint32_t)found, &found_name ) == PLEAT_RESULT_OK );
		PLEAT_FUZZ_REQUIRE( strcmp( name, found_name ) == 0 );
	}
	const char* none = NULL;
	PLEAT_FUZZ_REQUIRE( plAsset_GetJointName( asset, info->joint_count, &none ) < 0 );
}

// The rest poses: parents as the loader checked them (root first, parents before children), a capacity one short
// refused, and for β = 0 the instance's J(β) is the asset's mean-body pose exactly.
static void plFuzzCheckRestPose( plAsset asset, plInstance instance, const plAssetInfo* info, const float* beta )
{
	plRestJoint mean[PLEAT_MAX_JOINTS], shaped[PLEAT_MAX_JOINTS];
	uint32_t J = info->joint_count;
	PLEAT_FUZZ_REQUIRE( plAsset_GetRestPose( asset, mean, J ) == PLEAT_RESULT_OK );
	PLEAT_FUZZ_REQUIRE( plInstance_GetRestPose( instance, shaped, J ) == PLEAT_RESULT_OK );
	PLEAT_FUZZ_REQUIRE( plInstance_GetRestPose( instance, shaped, J - 1 ) == PLEAT_RESULT_BUFFER_TOO_SMALL );
	int beta_zero = 1;
	for ( uint32_t b = 0; b < info->beta_count; ++b )
	{
		beta_zero &= beta[b] == 0.0f;
	}
	for ( uint32_t k = 0; k < J; ++k )
	{
		PLEAT_FUZZ_REQUIRE( k == 0 ? mean[k].parent == -1 : ( mean[k].parent >= 0 && mean[k].parent < (int32_t)k ) );
		PLEAT_FUZZ_REQUIRE( shaped[k].parent == mean[k].parent );
		if ( beta_zero )
		{
			PLEAT_FUZZ_REQUIRE( shaped[k].position.x == mean[k].position.x && shaped[k].position.y == mean[k].position.y &&
								shaped[k].position.z == mean[k].position.z );
		}
	}
}

static void plFuzzCheckShape( plInstance instance, const plAssetInfo* info, const float* expected_beta,
							  const float* expected_material )
{
	float beta[PLEAT_MAX_BETAS], material[4];
	PLEAT_FUZZ_REQUIRE( plInstance_GetShape( instance, beta, info->beta_count, material ) == PLEAT_RESULT_OK );
	for ( uint32_t b = 0; b < info->beta_count; ++b )
	{
		PLEAT_FUZZ_REQUIRE( beta[b] == expected_beta[b] );
	}
	for ( int m = 0; m < 4; ++m )
	{
		PLEAT_FUZZ_REQUIRE( material[m] == expected_material[m] );
	}
}

static void plFuzzScenario( const plFuzzControl* c, const uint8_t* block, size_t size, int reference_run,
							plFuzzRun* run )
{
	run->hash = 1469598103934665603ull;
	run->complete = 1;
	plFuzzHost host;
	memset( &host, 0, sizeof( host ) );
	if ( !reference_run && c->fail_allocation >= 1 && c->fail_allocation <= 32 )
	{
		host.fail_at = c->fail_allocation;
	}
	plFuzzTasks tasks;
	memset( &tasks, 0, sizeof( tasks ) );
	tasks.workers = reference_run ? 1u : 1u + c->workers % 4u;
	tasks.defer = ( c->flags & PLEAT_FUZZ_DEFER_TASKS ) != 0;
	tasks.reverse = ( c->flags & PLEAT_FUZZ_REVERSE_RANGES ) != 0;

	plContextDef cdef = plDefaultContextDef();
	cdef.alloc = plFuzzAlloc;
	cdef.free = plFuzzFree;
	cdef.allocator_context = &host;
	cdef.log = plFuzzLog;
	cdef.force_scalar = ( c->flags & PLEAT_FUZZ_FORCE_SCALAR ) != 0;
	if ( tasks.workers > 1 )
	{
		cdef.enqueue_task = plFuzzEnqueue;
		cdef.finish_task = plFuzzFinish;
		cdef.task_context = &tasks;
		cdef.worker_count = tasks.workers;
	}
	plContext context;
	uint64_t failed_before = host.failed;
	plResult r = plCreateContext( &cdef, &context );
	if ( r != PLEAT_RESULT_OK )
	{
		PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_OUT_OF_MEMORY && host.failed > failed_before );
		PLEAT_FUZZ_REQUIRE( context.index1 == 0 && !plContext_IsValid( context ) );
		PLEAT_FUZZ_REQUIRE( host.live_bytes == 0 && host.live_blocks == 0 );
		run->complete = 0;
		return;
	}
	uint64_t live = 1;
	PLEAT_FUZZ_REQUIRE( plContext_GetLiveBytes( context, &live ) == PLEAT_RESULT_OK && live == 0 );

	plAsset asset;
	failed_before = host.failed;
	r = plFuzzLoad( c, context, block, size, &asset );
	plInstance instance;
	memset( &instance, 0, sizeof( instance ) );
	plAssetInfo info;
	float* rotations = NULL;
	float* bad_rotations = NULL;
	plFuzzOutput output;
	memset( &output, 0, sizeof( output ) );
	if ( r != PLEAT_RESULT_OK )
	{
		PLEAT_FUZZ_REQUIRE( r < 0 && asset.index1 == 0 && !plAsset_IsValid( asset ) );
		PLEAT_FUZZ_REQUIRE( host.failed == failed_before || r == PLEAT_RESULT_OUT_OF_MEMORY );
		run->complete = 0;
		run->hash ^= (uint64_t)(uint32_t)r;
		goto done;
	}
	PLEAT_FUZZ_REQUIRE( plAsset_GetInfo( asset, &info ) == PLEAT_RESULT_OK );
	plFuzzCheckAsset( asset, &info );

	// Instance def.
	uint32_t J = info.joint_count, N = info.vertex_count, B = info.beta_count;
	uint32_t engine_joints = J;
	int32_t joint_map[PLEAT_MAX_JOINTS];
	uint8_t referenced[PLEAT_MAX_JOINTS + 8];
	memset( referenced, 1, sizeof( referenced ) );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	uint32_t map_mode = c->joint_map_mode % 5u;
	if ( map_mode != 0 )
	{
		idef.joint_map = joint_map;
		idef.joint_map_count = J;
		memset( referenced, 0, sizeof( referenced ) );
		if ( map_mode == 2 || map_mode == 4 )
		{
			engine_joints = J + c->extra_joints % 8u;
		}
		for ( uint32_t j = 0; j < J; ++j )
		{
			if ( map_mode == 1 )
			{
				joint_map[j] = ( j % 2 ) ? -1 : (int32_t)j;
			}
			else if ( map_mode == 2 )
			{
				joint_map[j] = (int32_t)( engine_joints - 1 - j );
			}
			else if ( map_mode == 3 )
			{
				const char* name = NULL;
				PLEAT_FUZZ_REQUIRE( plAsset_GetJointName( asset, j, &name ) == PLEAT_RESULT_OK );
				PLEAT_FUZZ_REQUIRE( plAsset_FindJoint( asset, name, &joint_map[j] ) == PLEAT_RESULT_OK );
			}
			else
			{
				joint_map[j] = j + 1 == J ? (int32_t)engine_joints : (int32_t)j; // one entry out of range
			}
			if ( joint_map[j] >= 0 && joint_map[j] < (int32_t)engine_joints )
			{
				referenced[joint_map[j]] = 1;
			}
		}
		idef.engine_joint_count = engine_joints;
	}
	float beta[PLEAT_MAX_BETAS + 1] = { 0 }, clamped_beta[PLEAT_MAX_BETAS] = { 0 }, material[4], clamped_material[4];
	for ( uint32_t b = 0; b < PLEAT_MAX_BETAS; ++b )
	{
		beta[b] = (float)c->beta[b] / 16.0f;
	}
	for ( int m = 0; m < 4; ++m )
	{
		float fraction = ( (float)c->material[m] - 28.0f ) / 200.0f;
		material[m] = info.material_min[m] + fraction * ( info.material_max[m] - info.material_min[m] );
		if ( !isfinite( material[m] ) )
		{
			material[m] = info.material_default[m];
		}
		clamped_material[m] = info.material_default[m];
	}
	uint32_t beta_count = c->beta_count % ( B + 2u ); // B + 1: one too many
	int initial_shape = ( c->flags2 & PLEAT_FUZZ2_INITIAL_SHAPE ) != 0;
	int initial_clamped = 0;
	for ( uint32_t b = 0; b < B; ++b )
	{
		// Missing entries are 0, and 0 is clamped too when the asset's β range excludes it.
		float given = initial_shape && b < beta_count ? beta[b] : 0.0f;
		clamped_beta[b] = plClampf( given, info.beta_min, info.beta_max );
		initial_clamped |= clamped_beta[b] != given;
	}
	if ( initial_shape )
	{
		idef.beta = beta;
		idef.beta_count = beta_count;
		idef.material = material;
		for ( int m = 0; m < 4; ++m )
		{
			clamped_material[m] = plClampf( material[m], info.material_min[m], info.material_max[m] );
			initial_clamped |= clamped_material[m] != material[m];
		}
	}
	idef.network_rate_hz = s_rates[c->network_rate % 8u];
	int onnxruntime = ( c->flags & PLEAT_FUZZ_ONNXRUNTIME ) && s_onnxruntime != NULL && info.has_onnx_lp &&
					  info.has_onnx_decoder;
	if ( onnxruntime )
	{
		idef.mlp_backend = PLEAT_MLP_BACKEND_ONNXRUNTIME;
	}
	if ( c->flags & PLEAT_FUZZ_BAD_INPUT_PROBES )
	{
		// Defs that must be refused before anything is allocated.
		uint64_t allocations = host.allocations;
		plInstanceDef base = idef;
		base.beta_count = base.beta_count > B ? B : base.beta_count; // only the one fault under test
		plInstanceDef bad = base;
		bad.joint_map = NULL;
		bad.engine_joint_count = 0;
		float bad_values[PLEAT_MAX_BETAS + 4];
		memcpy( bad_values, beta, PLEAT_MAX_BETAS * sizeof( float ) );
		bad_values[0] = NAN;
		bad.beta = bad_values;
		bad.beta_count = B > 0 ? 1 : 0;
		bad.material = B > 0 ? material : bad_values;
		PLEAT_FUZZ_REQUIRE( plCreateInstance( context, &bad, &instance ) == PLEAT_RESULT_NON_FINITE_INPUT );
		bad = base;
		bad.network_rate_hz = -1.0f;
		PLEAT_FUZZ_REQUIRE( plCreateInstance( context, &bad, &instance ) == PLEAT_RESULT_INVALID_DEF );
		bad = base;
		bad.joint_map = joint_map;
		bad.joint_map_count = J + 1;
		PLEAT_FUZZ_REQUIRE( plCreateInstance( context, &bad, &instance ) == PLEAT_RESULT_JOINT_COUNT_MISMATCH );
		bad = base;
		bad.joint_map = NULL;
		bad.engine_joint_count = J + 1;
		PLEAT_FUZZ_REQUIRE( plCreateInstance( context, &bad, &instance ) == PLEAT_RESULT_JOINT_COUNT_MISMATCH );
		bad = base;
		bad.internal_cookie = 0;
		PLEAT_FUZZ_REQUIRE( plCreateInstance( context, &bad, &instance ) == PLEAT_RESULT_INVALID_DEF );
		PLEAT_FUZZ_REQUIRE( instance.index1 == 0 && host.allocations == allocations );
	}
	failed_before = host.failed;
	r = plCreateInstance( context, &idef, &instance );
	run->hash ^= (uint64_t)(uint32_t)r;
	if ( idef.beta_count > B )
	{
		PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_INVALID_DEF );
	}
	else if ( map_mode == 4 )
	{
		PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	}
	if ( r >= 0 )
	{
		PLEAT_FUZZ_REQUIRE( r == ( initial_clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK ) );
	}
	else
	{
		PLEAT_FUZZ_REQUIRE( instance.index1 == 0 && !plInstance_IsValid( instance ) );
		PLEAT_FUZZ_REQUIRE( host.failed == failed_before || r == PLEAT_RESULT_OUT_OF_MEMORY );
		PLEAT_FUZZ_REQUIRE( onnxruntime || r == PLEAT_RESULT_OUT_OF_MEMORY || map_mode == 4 || idef.beta_count > B );
		run->complete = 0;
		goto done;
	}
	plFuzzCheckShape( instance, &info, clamped_beta, clamped_material );
	plFuzzCheckRestPose( asset, instance, &info, clamped_beta );
	{
		// Before the first step the positions are the shaped rest template.
		const float* positions = NULL;
		uint32_t count = 0;
		PLEAT_FUZZ_REQUIRE( plInstance_GetPositions( instance, &positions, &count ) == PLEAT_RESULT_OK && count == N );
	}
	if ( c->flags2 & PLEAT_FUZZ2_DESTROY_IN_USE )
	{
		PLEAT_FUZZ_REQUIRE( plDestroyAsset( asset ) == PLEAT_RESULT_ASSET_IN_USE && plAsset_IsValid( asset ) );
	}

	// Steps.
	uint32_t stride_floats = 4u + c->input_stride % 5u;
	rotations = (float*)malloc( (size_t)( engine_joints + 1 ) * stride_floats * sizeof( float ) );
	bad_rotations = (float*)malloc( (size_t)( engine_joints + 1 ) * stride_floats * sizeof( float ) );
	PLEAT_FUZZ_REQUIRE( rotations != NULL && bad_rotations != NULL );
	plFuzzOutput_Init( &output, c->output_mode, N );
	float* latent = (float*)malloc( ( info.latent_count + (size_t)info.blend_count + 2 ) * sizeof( float ) );
	float* blend_weights = latent + info.latent_count + 1;
	float* latent_probe = (float*)malloc( ( info.latent_count + 1 ) * sizeof( float ) );
	float* before = (float*)malloc( (size_t)N * 6 * sizeof( float ) + sizeof( float ) );
	PLEAT_FUZZ_REQUIRE( latent != NULL && latent_probe != NULL && before != NULL );
	uint32_t steps = 1u + c->step_count % 6u;
	for ( uint32_t s = 0; s < steps; ++s )
	{
		if ( c->setter_steps & ( 1u << s ) )
		{
			uint32_t kind = ( c->setter_kinds >> ( 2 * ( s % 4 ) ) ) & 3u;
			if ( kind == 0 )
			{
				float scaled[PLEAT_MAX_BETAS + 1];
				for ( uint32_t b = 0; b < PLEAT_MAX_BETAS; ++b )
				{
					scaled[b] = beta[b] * (float)( s + 1 );
				}
				scaled[PLEAT_MAX_BETAS] = 0.0f;
				r = plInstance_SetShape( instance, scaled, beta_count );
				if ( beta_count > B )
				{
					PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_INVALID_ARGUMENT ); // and nothing changed:
				}
				else
				{
					int any_clamped = 0;
					for ( uint32_t b = 0; b < B; ++b )
					{
						float given = b < beta_count ? scaled[b] : 0.0f;
						clamped_beta[b] = plClampf( given, info.beta_min, info.beta_max );
						any_clamped |= clamped_beta[b] != given;
					}
					PLEAT_FUZZ_REQUIRE( r == ( any_clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK ) );
				}
				plFuzzCheckShape( instance, &info, clamped_beta, clamped_material );
				plFuzzCheckRestPose( asset, instance, &info, clamped_beta );
			}
			else if ( kind == 1 )
			{
				r = plInstance_SetMaterial( instance, material );
				int any_clamped = 0;
				for ( int m = 0; m < 4; ++m )
				{
					clamped_material[m] = plClampf( material[m], info.material_min[m], info.material_max[m] );
					any_clamped |= clamped_material[m] != material[m];
				}
				PLEAT_FUZZ_REQUIRE( r == ( any_clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK ) );
				plFuzzCheckShape( instance, &info, clamped_beta, clamped_material );
			}
			else if ( kind == 2 )
			{
				PLEAT_FUZZ_REQUIRE( plInstance_SetNetworkRate( instance, NAN ) == PLEAT_RESULT_INVALID_ARGUMENT );
				PLEAT_FUZZ_REQUIRE( plInstance_SetNetworkRate( instance, s_rates[( c->network_rate + s ) % 8u] ) ==
							PLEAT_RESULT_OK );
			}
			else
			{
				PLEAT_FUZZ_REQUIRE( plInstance_Reset( instance ) == PLEAT_RESULT_OK );
			}
			run->hash = plTestHash( &r, sizeof( r ), run->hash );
		}

		plMakePose( c, s, engine_joints, stride_floats, referenced, rotations );
		plFrameInput in;
		memset( &in, 0, sizeof( in ) );
		in.joint_rotations = rotations;
		in.joint_count = engine_joints;
		in.joint_stride_bytes = stride_floats * 4u;
		float speed = ( (float)c->root[0] - 128.0f ) / 64.0f;
		in.root_translation.x = speed * 0.1f * (float)s;
		in.root_translation.y = ( (float)c->root[1] - 128.0f ) / 1024.0f;
		in.root_translation.z = ( (float)c->root[2] - 128.0f ) / 256.0f * (float)s;
		if ( !( c->flags2 & PLEAT_FUZZ2_ZERO_ROOT_ROTATION ) )
		{
			float yaw = ( (float)c->root[3] - 128.0f ) / 128.0f * 0.2f * (float)s;
			in.root_rotation.y = sinf( 0.5f * yaw );
			in.root_rotation.w = cosf( 0.5f * yaw );
		}
		in.dt_s = s_dts[( c->dt + s * ( c->dt >> 3 ) ) % 8u];
		if ( output.use )
		{
			memset( output.buffer, 0xA5, output.bytes );
		}

		const float *positions = NULL, *normals = NULL;
		uint32_t count = 0;
		PLEAT_FUZZ_REQUIRE( plInstance_GetPositions( instance, &positions, &count ) == PLEAT_RESULT_OK && count == N );
		PLEAT_FUZZ_REQUIRE( plInstance_GetNormals( instance, &normals, &count ) == PLEAT_RESULT_OK && count == N );
		if ( c->flags & PLEAT_FUZZ_BAD_INPUT_PROBES )
		{
			// A rejected step changes nothing: not the outputs, not the latent, not the history (the hash of the
			// next steps must match the reference run, which never sees the probe).
			memcpy( before, positions, (size_t)N * 3 * sizeof( float ) );
			memcpy( before + (size_t)N * 3, normals, (size_t)N * 3 * sizeof( float ) );
			PLEAT_FUZZ_REQUIRE( plInstance_GetLatent( instance, latent, info.latent_count ) == PLEAT_RESULT_OK );
			plFrameInput bad = in;
			bad.dt_s = NAN;
			PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, output.use ? &output.spans : NULL ) ==
						( output.too_small ? PLEAT_RESULT_BUFFER_TOO_SMALL : PLEAT_RESULT_NON_FINITE_INPUT ) );
			bad.dt_s = 1.5f;
			PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, NULL ) == PLEAT_RESULT_INVALID_DT );
			bad.dt_s = in.dt_s;
			bad.joint_count = engine_joints + 1;
			PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, NULL ) == PLEAT_RESULT_JOINT_COUNT_MISMATCH );
			bad.joint_count = engine_joints;
			bad.root_rotation.w = 2.0f;
			PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, NULL ) == PLEAT_RESULT_INVALID_QUATERNION );
			bad.root_rotation = in.root_rotation;
			uint32_t probe_joint = 0;
			while ( probe_joint + 1 < engine_joints && !referenced[probe_joint] )
			{
				probe_joint++;
			}
			if ( referenced[probe_joint] )
			{
				size_t rotation_floats = (size_t)engine_joints * stride_floats;
				memcpy( bad_rotations, rotations, rotation_floats * sizeof( float ) );
				bad.joint_rotations = bad_rotations;
				bad_rotations[(size_t)probe_joint * stride_floats + 3] *= 1.5f;
				bad_rotations[(size_t)probe_joint * stride_floats + 3] += 0.5f; // never unit, even from w = 0
				PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, NULL ) == PLEAT_RESULT_INVALID_QUATERNION );
				bad_rotations[(size_t)probe_joint * stride_floats + 1] = INFINITY;
				PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &bad, NULL ) == PLEAT_RESULT_NON_FINITE_INPUT );
			}
			PLEAT_FUZZ_REQUIRE( memcmp( before, positions, (size_t)N * 3 * sizeof( float ) ) == 0 );
			PLEAT_FUZZ_REQUIRE( memcmp( before + (size_t)N * 3, normals, (size_t)N * 3 * sizeof( float ) ) == 0 );
			PLEAT_FUZZ_REQUIRE( plInstance_GetLatent( instance, latent_probe, info.latent_count ) == PLEAT_RESULT_OK );
			PLEAT_FUZZ_REQUIRE( memcmp( latent, latent_probe, info.latent_count * sizeof( float ) ) == 0 );
			if ( output.use )
			{
				for ( size_t b = 0; b < output.bytes; ++b )
				{
					PLEAT_FUZZ_REQUIRE( output.buffer[b] == 0xA5 );
				}
			}
		}

		uint64_t allocations = host.allocations;
		r = plInstance_Step( instance, &in, output.use ? &output.spans : NULL );
		PLEAT_FUZZ_REQUIRE( host.allocations == allocations ); // a step allocates nothing
		run->hash = plTestHash( &r, sizeof( r ), run->hash );
		if ( output.too_small )
		{
			PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_BUFFER_TOO_SMALL );
			// Run the step without spans so the later steps still see a history.
			r = plInstance_Step( instance, &in, NULL );
		}
		if ( r < 0 )
		{
			// Valid inputs: only a backend may fail at run time.
			PLEAT_FUZZ_REQUIRE( onnxruntime );
			run->complete = 0;
			continue;
		}
		PLEAT_FUZZ_REQUIRE( r == PLEAT_RESULT_OK || r == PLEAT_RESULT_CLAMPED || r == PLEAT_RESULT_NUMERIC_RESET );
		PLEAT_FUZZ_REQUIRE( plInstance_GetPositions( instance, &positions, &count ) == PLEAT_RESULT_OK && count == N );
		PLEAT_FUZZ_REQUIRE( plInstance_GetNormals( instance, &normals, &count ) == PLEAT_RESULT_OK && count == N );
		if ( r != PLEAT_RESULT_NUMERIC_RESET )
		{
			PLEAT_FUZZ_REQUIRE( plAllFinite( positions, (size_t)N * 3 ) && plAllFinite( normals, (size_t)N * 3 ) );
		}
		if ( output.use && !output.too_small )
		{
			plFuzzOutput_Check( &output, positions, normals, N );
		}
		PLEAT_FUZZ_REQUIRE( plInstance_GetLatent( instance, latent, info.latent_count ) == PLEAT_RESULT_OK );
		PLEAT_FUZZ_REQUIRE( plInstance_GetBlendWeights( instance, blend_weights, info.blend_count ) == PLEAT_RESULT_OK );
		float skin[PLEAT_MAX_JOINTS * 12];
		PLEAT_FUZZ_REQUIRE( plInstance_GetSkinMatrices( instance, skin, J ) == PLEAT_RESULT_OK );
		run->hash = plTestHash( positions, (size_t)N * 3 * sizeof( float ), run->hash );
		run->hash = plTestHash( normals, (size_t)N * 3 * sizeof( float ), run->hash );
		run->hash = plTestHash( latent, info.latent_count * sizeof( float ), run->hash );
		run->hash = plTestHash( blend_weights, info.blend_count * sizeof( float ), run->hash );
		run->hash = plTestHash( skin, (size_t)J * 12 * sizeof( float ), run->hash );
	}
	free( latent );
	free( latent_probe );
	free( before );
	{
		plAsset of_instance;
		PLEAT_FUZZ_REQUIRE( plInstance_GetAsset( instance, &of_instance ) == PLEAT_RESULT_OK );
		PLEAT_FUZZ_REQUIRE( memcmp( &of_instance, &asset, sizeof( asset ) ) == 0 );
	}
	PLEAT_FUZZ_REQUIRE( plDestroyInstance( instance ) == PLEAT_RESULT_OK && !plInstance_IsValid( instance ) );
	{
		plFrameInput in;
		memset( &in, 0, sizeof( in ) );
		in.joint_rotations = rotations;
		in.joint_count = engine_joints;
		in.dt_s = 1.0f / 30.0f;
		PLEAT_FUZZ_REQUIRE( plInstance_Step( instance, &in, NULL ) == PLEAT_RESULT_INVALID_HANDLE );
	}

done:
	if ( asset.index1 != 0 )
	{
		PLEAT_FUZZ_REQUIRE( plDestroyAsset( asset ) == PLEAT_RESULT_OK && !plAsset_IsValid( asset ) );
	}
	PLEAT_FUZZ_REQUIRE( plContext_GetLiveBytes( context, &live ) == PLEAT_RESULT_OK && live == 0 );
	PLEAT_FUZZ_REQUIRE( plDestroyContext( context ) == PLEAT_RESULT_OK && !plContext_IsValid( context ) );
	PLEAT_FUZZ_REQUIRE( host.live_bytes == 0 && host.live_blocks == 0 );
	if ( host.failed != 0 )
	{
		run->complete = 0;
	}
	free( rotations );
	free( bad_rotations );
	free( output.buffer );
}

int LLVMFuzzerTestOneInput( const uint8_t* data, size_t size )
{
	if ( size < PLEAT_FUZZ_CONTROL_SIZE + 128 )
	{
		return 0;
	}
	plFuzzControl control;
	memcpy( &control, data, sizeof( control ) );
	size_t asset_size = size - PLEAT_FUZZ_CONTROL_SIZE;
	uint8_t* block = (uint8_t*)aligned_alloc( 64, ( asset_size + 63 ) & ~(size_t)63 );
	if ( block == NULL )
	{
		return 0;
	}
	memcpy( block, data + PLEAT_FUZZ_CONTROL_SIZE, asset_size );
	plTestAsset_FixChecksum( block, asset_size ); // mutations change meaning, not the CRC's verdict
	plFuzzRun run;
	plFuzzScenario( &control, block, asset_size, 0, &run );
	if ( ( control.flags & PLEAT_FUZZ_CHECK_DETERMINISM ) && run.complete )
	{
		plFuzzRun reference;
		plFuzzScenario( &control, block, asset_size, 1, &reference );
		PLEAT_FUZZ_REQUIRE( !reference.complete || reference.hash == run.hash );
	}
	free( block );
	return 0;
}

// ---- the mutator: meaning, not structure ----

static uint32_t plNext( uint32_t* state )
{
	uint32_t x = *state;
	x ^= x << 13;
	x ^= x >> 17;
	x ^= x << 5;
	*state = x != 0 ? x : 0x9E3779B9u;
	return *state;
}

static uint32_t plGetU32( const uint8_t* p )
{
	return (uint32_t)p[0] | ( (uint32_t)p[1] << 8 ) | ( (uint32_t)p[2] << 16 ) | ( (uint32_t)p[3] << 24 );
}

static void plPutU32( uint8_t* p, uint32_t v )
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)( v >> 8 );
	p[2] = (uint8_t)( v >> 16 );
	p[3] = (uint8_t)( v >> 24 );
}

// Mutates bytes [0, size) in place with libFuzzer's own mutations, keeping the length.
static void plMutateInPlace( uint8_t* bytes, size_t size )
{
	if ( size == 0 )
	{
		return;
	}
	uint8_t* scratch = (uint8_t*)malloc( size );
	if ( scratch == NULL )
	{
		return;
	}
	memcpy( scratch, bytes, size );
	size_t n = LLVMFuzzerMutate( scratch, size, size );
	memcpy( bytes, scratch, n < size ? n : size );
	free( scratch );
}

// One typed change to element `index` of a section: indices to their boundaries, floats to special values.
static void plMutateElement( uint8_t* p, uint32_t dtype, uint32_t* rng, const uint8_t* conf )
{
	uint32_t choice = plNext( rng ) % 12u;
	uint32_t N = conf != NULL ? plGetU32( conf ) : 16u, F = conf != NULL ? plGetU32( conf + 4 ) : 16u;
	uint32_t J = conf != NULL ? plGetU32( conf + 8 ) : 8u;
	if ( dtype == 1 ) // f32
	{
		static const uint32_t specials[12] = { 0x00000000u, 0x80000000u, 0x3F800000u, 0xBF800000u,
											   0x7FC00000u, 0x7F800000u, 0xFF800000u, 0x7149F2CAu,
											   0x00000001u, 0x7F7FFFFFu, 0x3A83126Fu, 0x447A0000u };
		if ( choice < 10 )
		{
			plPutU32( p, specials[plNext( rng ) % 12u] );
		}
		else
		{
			plPutU32( p, plGetU32( p ) ^ ( 1u << ( plNext( rng ) % 32u ) ) ); // a small or large nudge
		}
	}
	else if ( dtype == 2 || dtype == 4 ) // f16, u16
	{
		static const uint16_t specials[8] = { 0x0000, 0x3C00, 0x7C00, 0x7E00, 0xFBFF, 0x0001, 0xFFFF, 0x8000 };
		uint16_t v = (uint16_t)( p[0] | ( p[1] << 8 ) );
		if ( dtype == 4 && choice < 6 )
		{
			uint16_t js[6] = { 0, 1, (uint16_t)( J - 1 ), (uint16_t)J, (uint16_t)( J + 1 ), (uint16_t)( v + 1 ) };
			v = js[choice];
		}
		else
		{
			v = choice < 8 ? specials[choice] : (uint16_t)( v ^ ( 1u << ( plNext( rng ) % 16u ) ) );
		}
		p[0] = (uint8_t)v;
		p[1] = (uint8_t)( v >> 8 );
	}
	else if ( dtype == 3 || dtype == 5 ) // u32, i32
	{
		uint32_t v = plGetU32( p );
		uint32_t values[12] = { 0, 1, N - 1, N, F - 1, F, 3 * F, J, 0xFFFFFFFFu, 0x7FFFFFFFu, v + 1, v - 1 };
		plPutU32( p, values[choice] );
	}
	else
	{
		p[0] = (uint8_t)plNext( rng );
	}
}

size_t LLVMFuzzerCustomMutator( uint8_t* data, size_t size, size_t max_size, unsigned int seed )
{
	uint32_t rng = seed * 2654435761u + 1u;
	uint32_t what = plNext( &rng ) % 100u;
	uint8_t* asset = data + PLEAT_FUZZ_CONTROL_SIZE;
	size_t asset_size = size > PLEAT_FUZZ_CONTROL_SIZE ? size - PLEAT_FUZZ_CONTROL_SIZE : 0;
	uint32_t section_count = asset_size >= 128 ? plGetU32( asset + 24 ) : 0;
	uint64_t table = asset_size >= 128 ? (uint64_t)plGetU32( asset + 32 ) | ( (uint64_t)plGetU32( asset + 36 ) << 32 ) : 0;
	int structured = asset_size >= 128 && memcmp( asset, "PLEATAST", 8 ) == 0 && section_count >= 1 &&
					 section_count <= 256 && table <= asset_size && section_count * 48ull <= asset_size - table;
	if ( what < 4 || !structured )
	{
		// Now and then (or when the structure is gone) anything goes, the length included.
		return LLVMFuzzerMutate( data, size, max_size );
	}
	if ( what < 24 )
	{
		if ( what < 14 )
		{
			plMutateInPlace( data, PLEAT_FUZZ_CONTROL_SIZE );
		}
		else
		{
			data[plNext( &rng ) % PLEAT_FUZZ_CONTROL_SIZE] = (uint8_t)plNext( &rng );
		}
		return size;
	}
	// Pick a section whose data lies inside the asset.
	const uint8_t* conf = NULL;
	for ( uint32_t i = 0; i < section_count; ++i )
	{
		const uint8_t* e = asset + table + (uint64_t)i * 48;
		uint64_t offset = (uint64_t)plGetU32( e + 16 ) | ( (uint64_t)plGetU32( e + 20 ) << 32 );
		if ( memcmp( e, "CONF", 4 ) == 0 && offset <= asset_size && asset_size - offset >= 256 )
		{
			conf = asset + offset;
		}
	}
	for ( int attempt = 0; attempt < 8; ++attempt )
	{
		const uint8_t* e = asset + table + (uint64_t)( plNext( &rng ) % section_count ) * 48;
		uint32_t dtype = plGetU32( e + 4 );
		uint64_t offset = (uint64_t)plGetU32( e + 16 ) | ( (uint64_t)plGetU32( e + 20 ) << 32 );
		uint64_t bytes = (uint64_t)plGetU32( e + 24 ) | ( (uint64_t)plGetU32( e + 28 ) << 32 );
		if ( offset > asset_size || bytes > asset_size - offset || bytes == 0 )
		{
			continue;
		}
		uint8_t* section = asset + offset;
		uint32_t element = dtype == 1 || dtype == 3 || dtype == 5 ? 4u : ( dtype == 2 || dtype == 4 ? 2u : 1u );
		if ( bytes < element )
		{
			continue;
		}
		if ( memcmp( e, "CONF", 4 ) == 0 && bytes >= 128 )
		{
			// CONF: one field (u32 counts or f32 ranges) at a time.
			uint32_t field = plNext( &rng ) % 30u;
			uint8_t* p = section + 4 * field;
			uint32_t v = plGetU32( p );
			uint32_t how = plNext( &rng ) % 4u;
			if ( field < 13 )
			{
				plPutU32( p, how == 0 ? v + 1 : how == 1 ? v - 1 : how == 2 ? 0 : v * 2 );
			}
			else
			{
				plMutateElement( p, 1, &rng, NULL );
			}
		}
		else if ( what < 60 )
		{
			uint64_t count = bytes / element;
			uint32_t changes = 1 + plNext( &rng ) % 3u;
			for ( uint32_t k = 0; k < changes; ++k )
			{
				plMutateElement( section + ( plNext( &rng ) % count ) * element, dtype, &rng, conf );
			}
		}
		else if ( what < 72 )
		{
			// Swap two elements (orderings: adjacency, input joints, parents).
			uint64_t count = bytes / element;
			uint8_t* a = section + ( plNext( &rng ) % count ) * element;
			uint8_t* b = section + ( plNext( &rng ) % count ) * element;
			uint8_t tmp[4];
			memcpy( tmp, a, element );
			memcpy( a, b, element );
			memcpy( b, tmp, element );
		}
		else
		{
			// libFuzzer's byte mutations inside a window of the section.
			uint64_t window = bytes < 256 ? bytes : 256;
			uint64_t start = bytes > window ? plNext( &rng ) % ( bytes - window + 1 ) : 0;
			plMutateInPlace( section + start, (size_t)window );
		}
		break;
	}
	plTestAsset_FixChecksum( asset, asset_size );
	return size;
}
