// One list of stages for any group of instances of one asset (step.h): plInstance_Step steps a group of one,
// plStepInstances groups a crowd (batch.c), the scene's LBS-only level a group with the networks off. Each stage has a
// single-stream form (instance_step.c, instance_deform.c: one instance at a time, its work split over the host's
// workers when it is alone) and, for the networks, blend and geometry, a wide form (step_lanes.c: the group at once,
// the batched kernels); the group's `lanes` picks. Both forms do per instance the same arithmetic, so an instance's
// bits do not depend on its group (test_batch_step_matches_single).
//
//     ① prepare   per instance (workers take whole instances): validate → rate decision → forward kinematics → X_c
//     ② networks  f_LP → finite y? → latent guard → f_dec → finite w and M?       (wide: f_LP, f_dec for the group)
//     ③ blend     T_def of the instances that blend                               (single: inside ④, range by range)
//     ④ geometry  skinning → body contact → normals → finite? → commit            (wide: 8 or 16 instances per vector)
//                 GPU modes: the deformation on the GPU (wide: one dispatch per shader for the group), then the commit
//     ⑤ resets    the numeric reset of each instance that needs it, on the calling thread
//
// An instance whose stage fails carries its error past the later stages; nothing of it has changed, as the commit is
// its last stage. A job that rejects the spans the SDK built is PLEAT_RESULT_INTERNAL_ERROR.
#include "step.h"

#include "step_lanes.h"
#include "core/step_phases.h"

#include <string.h>

// The crowd stages' timing (step_phases.h) marks wide groups only: a group of one is the single step, timed by its
// own marks.
#define PLEAT_GROUP_PHASE( g, phase )                                                                                  \
	do                                                                                                                 \
	{                                                                                                                  \
		if ( ( g )->lanes != NULL )                                                                                    \
		{                                                                                                              \
			PLEAT_BATCH_PHASE( phase );                                                                                \
		}                                                                                                              \
	} while ( 0 )

void plStepGroup_Init( plStepGroup* g, plContextData* ctx, const plAssetData* asset, plStepEntry* entries,
					   int networks, const plTaskRunner* runner, const char* function )
{
	g->ctx = ctx;
	g->asset = asset;
	g->runner = runner;
	g->networks = networks;
	g->function = function;
	g->entries = entries;
	g->count = 0;
	g->capacity = PLEAT_BATCH_MAX;
	g->lanes = NULL;
	g->member_count = 0;
	g->members = g->inline_members;
	g->member_insts = g->inline_member_insts;
	g->gl_members = NULL;
	g->gl_flags = NULL;
}

void plStepGroup_InitGpu( plStepGroup* g, plContextData* ctx, const plAssetData* asset, void* block,
						  const plTaskRunner* runner, const char* function, uint32_t** out_indices )
{
	// The block, carved: entries, GL members, member instances (8-byte items first), then the 4-byte arrays.
	enum
	{
		N = PLEAT_GPU_GROUP_MAX
	};
	_Static_assert( N * ( sizeof( plStepEntry ) + sizeof( plGlBatchMember ) + sizeof( plInstanceData* ) +
						  3 * sizeof( uint32_t ) ) <= PLEAT_GPU_GROUP_FLOATS * sizeof( float ),
					"a GPU group fits its scratch block" );
	uint8_t* p = (uint8_t*)block;
	plStepEntry* entries = (plStepEntry*)p;
	p += N * sizeof( plStepEntry );
	plStepGroup_Init( g, ctx, asset, entries, 1, runner, function );
	g->capacity = N;
	g->gl_members = (plGlBatchMember*)p;
	p += N * sizeof( plGlBatchMember );
	g->member_insts = (plInstanceData**)p;
	p += N * sizeof( plInstanceData* );
	g->members = (uint32_t*)p;
	p += N * sizeof( uint32_t );
	g->gl_flags = (int*)p;
	p += N * sizeof( int );
	*out_indices = (uint32_t*)p;
}

plStepEntry* plStepGroup_Add( plStepGroup* g, plInstanceData* inst, const plFrameInput* input,
							  const plStepOutput* output )
{
	plStepEntry* e = &g->entries[g->count++];
	memset( e, 0, sizeof( *e ) );
	e->inst = inst;
	e->input = input;
	e->output = output;
	e->positions = inst->positions;
	e->normals = inst->normals;
	e->read_back = plWantsReadBack( inst, output );
	e->result = PLEAT_RESULT_OK;
	return e;
}

// Whether the entry is still in the step: no error, no numeric reset pending.
static int plStepping( const plStepEntry* e )
{
	return e->result == PLEAT_RESULT_OK && !e->needs_reset;
}

// fn over the entries, whole instances per worker; a lone instance on the calling thread (its own work is split
// inside the stages).
static void plForEachEntry( plStepGroup* g, plTaskFn* fn )
{
	if ( g->count == 1 )
	{
		fn( 0, 1, 0, g );
		return;
	}
	plRunTask( g->runner, fn, g->count, 1, g );
}

// ---- ① prepare ----

static void plPrepareEntry( const plStepGroup* g, plStepEntry* e )
{
	plInstanceData* inst = e->inst;
	const plAssetData* a = inst->asset;
	plStepPose pose;
	e->result = plValidateStep( inst, e->input, e->output, &pose );
	if ( e->result != PLEAT_RESULT_OK )
	{
		return;
	}
	// Networks off, the decision of a first frame with nothing pending: the frame's dt, clamped as the networks'
	// would be, for the forward kinematics.
	e->update = g->networks ? plDecideNetworkUpdate( inst->network_interval_s - inst->network_lead_s,
													 inst->network_pending_s, e->input->dt_s, !inst->history_valid,
													 a->dt_min_s, a->dt_max_s )
							: plDecideNetworkUpdate( 0.0, 0.0, e->input->dt_s, 1, a->dt_min_s, a->dt_max_s );
	PLEAT_STEP_PHASE( PLEAT_PHASE_VALIDATE );
	// Nothing has changed so far, and nothing but scratch changes until the commit.
	int history = inst->history_valid;
	e->result = plRunForwardKinematics( inst, &pose, e->update.dt_s, history ? inst->history[0].yaw : 0.0 );
	if ( e->result != PLEAT_RESULT_OK || !g->networks || !e->update.run )
	{
		return;
	}
	e->result = plAssembleNetworkInput( inst, history ? &inst->history[0] : NULL, history ? &inst->history[1] : NULL,
										inst->latent );
}

static void plPrepareTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plStepGroup* g = (plStepGroup*)context;
	for ( uint32_t i = begin; i < end; ++i )
	{
		plPrepareEntry( g, &g->entries[i] );
	}
}

// ---- ② networks ----

// Members = the entries still stepping whose networks run (networks) or that blend.
static void plSelectMembers( plStepGroup* g, int networks )
{
	g->member_count = 0;
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plStepEntry* e = &g->entries[i];
		if ( plStepping( e ) && ( networks ? e->update.run : e->blend ) )
		{
			g->members[g->member_count] = i;
			g->member_insts[g->member_count++] = e->inst;
		}
	}
}

static void plFailMembers( plStepGroup* g, plResult r )
{
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		g->entries[g->members[m]].result = r;
	}
}

// The wide form: f_LP for the members, the finite check of y and the latent guard per instance, f_dec for those
// left, the finite check of the weights and skinning matrices — plRunNetworks's order for each instance.
static void plNetworksWide( plStepGroup* g )
{
	const plAssetData* a = g->asset;
	plSelectMembers( g, 1 );
	if ( g->member_count == 0 )
	{
		return;
	}
	plResult r = plRunNetworkLanes( g->ctx, g->lanes, a, g->member_insts, g->member_count, 1 );
	if ( r != PLEAT_RESULT_OK )
	{
		plFailMembers( g, r );
		return;
	}
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plStepEntry* e = &g->entries[g->members[m]];
		if ( !plAllFiniteFloats( e->inst->y, a->latent_count ) )
		{
			e->needs_reset = 1; // before the guard: its clamp would turn an overflow into a bound
			continue;
		}
		e->result = plGuardLatent( e->inst );
	}
	plSelectMembers( g, 1 );
	if ( g->member_count == 0 )
	{
		return;
	}
	r = plRunNetworkLanes( g->ctx, g->lanes, a, g->member_insts, g->member_count, 0 );
	if ( r != PLEAT_RESULT_OK )
	{
		plFailMembers( g, r );
		return;
	}
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plStepEntry* e = &g->entries[g->members[m]];
		e->needs_reset = !( plAllFiniteFloats( e->inst->next_weights, a->blend_count ) &&
							plAllFiniteFloats( e->inst->next_skin_matrices, (size_t)a->joint_count * 12 ) );
	}
}

// The GPU backend's groups: their networks run in the geometry stage's batch of dispatches (plGeometryGpu). A group is
// all one backend (plGlDeformer_CanBatch compares the networks).
static int plGpuNetworks( const plStepGroup* g )
{
	return g->count > 0 && plGlDeformer_HasNetworks( g->entries[0].inst->gl );
}

static void plStageNetworks( plStepGroup* g )
{
	if ( !g->networks || plGpuNetworks( g ) )
	{
		return;
	}
	if ( g->lanes != NULL )
	{
		plNetworksWide( g );
		return;
	}
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plStepEntry* e = &g->entries[i];
		if ( plStepping( e ) && e->update.run )
		{
			int finite = 0;
			e->result = plRunNetworks( e->inst, &finite );
			e->needs_reset = e->result == PLEAT_RESULT_OK && !finite;
		}
	}
}

// ---- ③ blend ----

static void plStageBlend( plStepGroup* g )
{
	if ( !g->networks )
	{
		return; // the shaped template is skinned as it is
	}
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plStepEntry* e = &g->entries[i];
		e->blend = plStepping( e ) && plBeginBlend( e->inst, e->update.run );
	}
	if ( g->lanes == NULL || g->entries[0].inst->gl != NULL )
	{
		return; // the single-stream blend runs inside the geometry, range by range; the GPU blends on the GPU
	}
	plSelectMembers( g, 0 );
	if ( g->member_count == 0 )
	{
		return;
	}
	plResult r = plBlendLanes( g->lanes, g->asset, g->member_insts, g->member_count, g->runner );
	if ( r != PLEAT_RESULT_OK )
	{
		plFailMembers( g, r );
		return;
	}
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		g->entries[g->members[m]].blend = 0; // T_def is written: the geometry skins it
	}
}

// ---- ④ geometry and commit ----

// After its geometry: the finite check and the commit (networks off: the outputs are the caller's, nothing commits).
static void plFinishEntry( const plStepGroup* g, plStepEntry* e, int finite )
{
	if ( !g->networks || e->result != PLEAT_RESULT_OK )
	{
		return;
	}
	if ( !finite )
	{
		e->needs_reset = 1;
		return;
	}
	plCommit( e->inst, e->update.run, 0, e->input->dt_s, e->read_back, e->output );
	e->result = plStepResult( e->inst, 0, &e->update, e->input->dt_s );
}

// The single-stream form of one entry's geometry, its work split over runner.
static void plGeometryEntry( const plStepGroup* g, plStepEntry* e, const plTaskRunner* runner )
{
	plInstanceData* inst = e->inst;
	int finite = 1;
	if ( g->networks )
	{
		e->result = plDeform( inst, e->blend, e->read_back, runner, &finite );
	}
	else
	{
		plDeformSpans spans = { NULL, inst->next_skin_matrices, 0, inst->shaped_template, e->positions, e->normals, 1 };
		e->result = plDeformCpu( inst, &spans, runner );
	}
	plFinishEntry( g, e, finite );
}

static void plGeometryEntriesTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plStepGroup* g = (plStepGroup*)context;
	for ( uint32_t m = begin; m < end; ++m )
	{
		plGeometryEntry( g, &g->entries[g->members[m]], NULL );
	}
}

// Lane groups [begin, end) of the members. Each finishes right after its lanes, while their positions and normals are
// still in this core's cache (after the whole group's geometry they were out in L3).
static void plGeometryLanesTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plStepGroup* g = (plStepGroup*)context;
	uint32_t lanes = g->lanes->geometry_lanes;
	for ( uint32_t lane_group = begin; lane_group < end; ++lane_group )
	{
		uint32_t m0 = lane_group * lanes;
		uint32_t n = g->member_count - m0 < lanes ? g->member_count - m0 : lanes;
		const float* in[PLEAT_BATCH_MAX];
		float* positions[PLEAT_BATCH_MAX];
		float* normals[PLEAT_BATCH_MAX];
		for ( uint32_t k = 0; k < n; ++k )
		{
			const plStepEntry* e = &g->entries[g->members[m0 + k]];
			in[k] = g->networks ? e->inst->deformed : e->inst->shaped_template;
			positions[k] = e->positions;
			normals[k] = e->normals;
		}
		plResult r = plGeometryLanes( g->ctx, g->lanes, g->asset, !g->networks, g->member_insts + m0, in, positions,
									  normals, n );
		for ( uint32_t k = 0; k < n; ++k )
		{
			plStepEntry* e = &g->entries[g->members[m0 + k]];
			e->result = r;
			if ( r == PLEAT_RESULT_OK && g->networks )
			{
				size_t n3 = (size_t)g->asset->vertex_count * 3;
				plFinishEntry( g, e, plAllFiniteFloats( e->positions, n3 ) && plAllFiniteFloats( e->normals, n3 ) );
			}
		}
	}
}

// The GPU modes: the held weights between network updates (plStageBlend), then the deformation of the group with read-
// backs into scratch (one batch of dispatches for a wide group), then each commit. A GL error leaves the instance as
// it was. On the GPU backend the batch runs the networks of the members whose networks run this step (X_c from ①),
// then reads back Z_t+1, w and y's finite flag: the same checks as plRunNetworks's decide each member's numeric reset,
// after which ⑤ deforms it again from the reset.
static void plGeometryGpu( plStepGroup* g )
{
	int gpu_networks = g->networks && plGpuNetworks( g );
	if ( g->lanes == NULL && !gpu_networks )
	{
		for ( uint32_t m = 0; m < g->member_count; ++m )
		{
			plStepEntry* e = &g->entries[g->members[m]];
			int finite = 1;
			e->result = plLogIfNoGlContext( e->inst, plDeform( e->inst, 0, e->read_back, g->runner, &finite ),
											g->function );
			plFinishEntry( g, e, finite );
		}
		return;
	}
	plGlBatchMember stack_members[PLEAT_BATCH_MAX];
	int stack_flags[PLEAT_BATCH_MAX];
	plGlBatchMember* members = g->gl_members != NULL ? g->gl_members : stack_members;
	int* latent_finite = g->gl_flags != NULL ? g->gl_flags : stack_flags;
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		const plStepEntry* e = &g->entries[g->members[m]];
		plInstanceData* inst = e->inst;
		plGlBatchMember* b = &members[m];
		b->deformer = inst->gl;
		b->shaped_template = inst->shaped_template;
		b->body_anchors = inst->shaped_anchors; // its first P rows: the body points of the committed β
		b->blend_weights = inst->next_weights;
		b->skin_matrices = inst->next_skin_matrices;
		b->positions = e->read_back ? inst->deformed : NULL;
		b->normals = e->read_back ? inst->gl_normals : NULL;
		int runs = gpu_networks && e->update.run;
		b->network_input = runs ? inst->x : NULL;
		b->latent_out = runs ? inst->next_latent : NULL;
		b->weights_out = runs ? inst->next_weights : NULL;
		b->latent_finite_out = runs ? &latent_finite[m] : NULL;
		latent_finite[m] = 1;
	}
	plResult r = plGlDeformer_RunBatch( members[0].deformer, members, g->member_count );
	const plAssetData* a = g->asset;
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plStepEntry* e = &g->entries[g->members[m]];
		e->result = plLogIfNoGlContext( e->inst, r, g->function );
		int finite = 1;
		if ( e->result == PLEAT_RESULT_OK && members[m].network_input != NULL )
		{
			finite = latent_finite[m] && plAllFiniteFloats( e->inst->next_weights, a->blend_count ) &&
					 plAllFiniteFloats( e->inst->next_skin_matrices, (size_t)a->joint_count * 12 );
		}
		plFinishEntry( g, e, finite );
	}
}

static void plStageGeometry( plStepGroup* g )
{
	g->member_count = 0;
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plStepEntry* e = &g->entries[i];
		if ( plStepping( e ) )
		{
			g->members[g->member_count] = i;
			g->member_insts[g->member_count++] = e->inst;
		}
	}
	if ( g->member_count == 0 )
	{
		return;
	}
	if ( g->networks && g->entries[0].inst->gl != NULL )
	{
		plGeometryGpu( g ); // a group is all CPU or all one GPU mode
	}
	else if ( g->lanes != NULL && g->lanes->geometry_lanes > 1 )
	{
		uint32_t lanes = g->lanes->geometry_lanes;
		plRunTask( g->runner, plGeometryLanesTask, ( g->member_count + lanes - 1 ) / lanes, 1, g );
	}
	else if ( g->count == 1 )
	{
		plGeometryEntry( g, &g->entries[0], g->runner ); // a lone instance: its vertices and faces over the workers
	}
	else
	{
		plRunTask( g->runner, plGeometryEntriesTask, g->member_count, 1, g ); // workers take whole instances
	}
}

// ---- ⑤ numeric resets ----

static void plResetEntry( plStepEntry* e )
{
	plInstanceData* inst = e->inst;
	plStepPose pose;
	plResult r = plValidateStep( inst, e->input, e->output, &pose ); // passed before: the same pose again
	if ( r == PLEAT_RESULT_OK )
	{
		r = plStepFromReset( inst, &pose, e->update.dt_s, e->read_back );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		e->result = r;
		return;
	}
	plCommit( inst, 1, 1, e->input->dt_s, e->read_back, e->output );
	e->result = plStepResult( inst, 1, &e->update, e->input->dt_s );
}

// ---- the stage list ----

void plRunStepGroup( plStepGroup* g )
{
	g->lanes = g->count > 1 ? g->ctx->kernels.batch : NULL;
	if ( g->lanes != NULL )
	{
		PLEAT_BATCH_PHASE_START();
	}
	plForEachEntry( g, plPrepareTask );
	PLEAT_GROUP_PHASE( g, PLEAT_BATCH_PHASE_PREPARE );
	plStageNetworks( g );
	PLEAT_GROUP_PHASE( g, PLEAT_BATCH_PHASE_NETWORKS );
	plStageBlend( g );
	PLEAT_GROUP_PHASE( g, PLEAT_BATCH_PHASE_BLEND );
	plStageGeometry( g );
	PLEAT_GROUP_PHASE( g, PLEAT_BATCH_PHASE_GEOMETRY );
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		if ( g->entries[i].result == PLEAT_RESULT_OK && g->entries[i].needs_reset )
		{
			plResetEntry( &g->entries[i] );
		}
	}
	PLEAT_GROUP_PHASE( g, PLEAT_BATCH_PHASE_FINISH );
}

plResult plInstance_Step( plInstance handle, const plFrameInput* input, const plStepOutput* output )
{
	PLEAT_STEP_PHASE_START();
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	plStepEntry entry;
	plStepGroup g;
	plStepGroup_Init( &g, inst->ctx, inst->asset, &entry, 1, &inst->ctx->runner, __func__ );
	plStepGroup_Add( &g, inst, input, output );
	plRunStepGroup( &g );
	return entry.result;
}
