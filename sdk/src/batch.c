// plStepInstances: many instances stepped in one call. Instances of the same asset are gathered into groups of up to
// PLEAT_BATCH_MAX and each group runs plInstance_Step's row of jobs with the two memory-bound stages batched:
//
//     per instance (workers take whole instances):  validate → network rate decision → forward kinematics → X_c
//     per group (workers take rows / vertices):      f_LP  →  [latent guard per instance]  →  f_dec  →  blend shapes
//     per lane group (workers take 8 instances):    skinning → normals, the instances as vector lanes
//     per instance (workers take whole instances):  guards → commit
//
// f_LP and f_dec become matrix-matrix products and the blend a small GEMM (jobs_batch.h), so each weight and each
// blend shape is read once per group instead of once per instance; skinning and normals run one vector operation for
// 8 instances where the single kernels spend their lanes on one vertex. Every stage is the single step's own (the same
// jobs and instance_step.c's validation, forward kinematics, reset and commit), and the batched kernels do per
// instance exactly the single kernels' arithmetic, so every instance ends bit-identical to stepping it alone
// (test_batch_step_matches_single). Instances in a GPU mode form groups of their own (per asset and mode): their
// networks run batched on the CPU as above, and then one plGlDeformer_RunBatch does the deformation of the whole group
// with one dispatch per shader (gl_deformer.h). What the batch does not batch it hands to plInstance_Step unchanged:
// instances on the ONNX Runtime backend, and the numeric-reset retry (rare; it runs on the calling thread after the
// group, before that instance's commit, exactly as inside plInstance_Step).
#include "instance.h"

#include "jobs_batch.h"
#include "step_phases.h"

#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

// Instances looked at together when forming groups (a bitmap of this many bits on the stack).
#define PLEAT_BATCH_WINDOW 1024

typedef struct plBatchEntry
{
	plInstanceData* inst;
	const plFrameInput* input;
	const plStepOutput* output;
	plNetworkUpdate update;
	plResult result;   // < 0: the instance's error (nothing of it changed); else its result once finished
	int needs_reset;   // a non-finite value appeared: the numeric reset runs for it on the calling thread
	int blend;         // the blend stage writes its T_def this step
	int geometry_done; // the batched skinning and normals wrote its positions and normals this step
	int finished;      // plFinishEntry ran (in the geometry task, right after its lane group)
	int read_back;     // GPU modes: the outputs are wanted on the CPU (as plInstance_Step decides it)
} plBatchEntry;

typedef struct plBatchGroup
{
	plContextData* ctx;
	const plAssetData* asset;
	const plBatchKernels* kernels;
	plBatchEntry entries[PLEAT_BATCH_MAX];
	uint32_t count;
	// The instances a batched stage takes (indices into entries) and their spans.
	uint32_t members[PLEAT_BATCH_MAX];
	uint32_t member_count;
	plConstSpan in_spans[PLEAT_BATCH_MAX];
	plSpan out_spans[PLEAT_BATCH_MAX];
	plSpan scratch_spans[PLEAT_BATCH_MAX];
	atomic_int blend_result; // a blend or geometry job's error, from whichever worker saw it
} plBatchGroup;

// ---- per instance, before the networks: what plInstance_Step does up to X_c ----

static void plPrepareEntry( plBatchEntry* e )
{
	plInstanceData* inst = e->inst;
	const plAssetData* a = inst->asset;
	plStepPose pose;
	e->result = plValidateStep( inst, e->input, e->output, &pose );
	if ( e->result != PLEAT_RESULT_OK )
	{
		return;
	}
	e->update = plDecideNetworkUpdate( inst->network_interval_s - inst->network_lead_s, inst->network_pending_s,
									   e->input->dt_s,
									   !inst->history_valid, a->dt_min_s, a->dt_max_s );
	e->result = plRunForwardKinematics( inst, &pose, e->update.dt_s, inst->history_valid ? inst->history[0].yaw : 0.0 );
	if ( e->result != PLEAT_RESULT_OK || !e->update.run )
	{
		return;
	}
	int history = inst->history_valid;
	e->result = plAssembleNetworkInput( inst, history ? &inst->history[0] : NULL, history ? &inst->history[1] : NULL,
										inst->latent );
}

static void plPrepareTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plBatchGroup* g = (plBatchGroup*)context;
	for ( uint32_t i = begin; i < end; ++i )
	{
		plPrepareEntry( &g->entries[i] );
	}
}

// ---- per group: the networks and the blend, batched ----

// f_LP (lp = 1) or f_dec over the members: inputs X (normalised) or Z_t+1, outputs y or w, in each instance's buffers.
static plResult plRunBatchedNetwork( plBatchGroup* g, int lp )
{
	const plAssetData* a = g->asset;
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plInstanceData* inst = g->entries[g->members[m]].inst;
		g->in_spans[m] = lp ? plMakeConstSpan( inst->x, a->input_count, 4 )
							: plMakeConstSpan( inst->next_latent, a->latent_count, 4 );
		g->out_spans[m] = lp ? plMakeSpan( inst->y, a->latent_count, 4 ) : plMakeSpan( inst->next_weights, a->blend_count, 4 );
		g->scratch_spans[m] = plMakeSpan( inst->mlp_scratch, inst->mlp_scratch_count, 4 );
	}
	plMlpBatchJob job = { lp ? a->lp : a->dec,
						  lp ? a->lp_layer_count : a->dec_layer_count,
						  lp ? a->lp_activation : a->dec_activation,
						  g->member_count,
						  g->in_spans,
						  g->out_spans,
						  g->scratch_spans,
						  g->kernels,
						  &g->ctx->runner,
						  NULL,
						  0 };
	int slot = -1;
	if ( g->kernels->mat_mat_lanes != NULL )
	{
		// the transposed chain's scratch (without it the job runs the row-tile kernels: the same results)
		size_t floats = plMlpBatchLanesFloats( job.layers, job.layer_count, job.batch_count );
		slot = plClaimBatchScratch( g->ctx, floats );
		if ( slot >= 0 )
		{
			job.lanes = g->ctx->batch_scratch[slot];
			job.lanes_floats = floats;
		}
	}
	plResult r = plMlpBatchJob_Run( &job );
	if ( slot >= 0 )
	{
		plReleaseBatchScratch( g->ctx, slot );
	}
	return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

static void plBlendTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plBatchGroup* g = (plBatchGroup*)context;
	const plAssetData* a = g->asset;
	plConstSpan templates[PLEAT_BATCH_MAX], weights[PLEAT_BATCH_MAX];
	plSpan outputs[PLEAT_BATCH_MAX];
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plInstanceData* inst = g->entries[g->members[m]].inst;
		templates[m] = plMakeConstSpan( inst->shaped_template, a->vertex_count, 12 );
		weights[m] = plMakeConstSpan( inst->next_weights, a->blend_count, 4 );
		outputs[m] = plMakeSpan( inst->deformed, a->vertex_count, 12 );
	}
	plBlendShapesBatchJob job = { g->member_count, templates,     weights, outputs, a->blend_shapes, a->blend_shapes_fp16,
								  a->vertex_count, begin,         end,     g->kernels };
	if ( plBlendShapesBatchJob_Run( &job ) != PLEAT_RESULT_OK )
	{
		atomic_store_explicit( &g->blend_result, (int)PLEAT_RESULT_INTERNAL_ERROR, memory_order_relaxed );
	}
}

// Members = the entries that passed so far and satisfy want (run the networks, or blend).
static void plSelectMembers( plBatchGroup* g, int networks )
{
	g->member_count = 0;
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		const plBatchEntry* e = &g->entries[i];
		if ( e->result == PLEAT_RESULT_OK && !e->needs_reset && ( networks ? e->update.run : e->blend ) )
		{
			g->members[g->member_count++] = i;
		}
	}
}

static void plFailMembers( plBatchGroup* g, plResult r )
{
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		g->entries[g->members[m]].result = r;
	}
}

// The networks of plInstance_Step's first attempt (plEvaluateNetworks) for every member at once: f_LP, the finite
// check of y and the latent guard per instance, f_dec, the finite check of the weights and skinning matrices.
static void plRunNetworks( plBatchGroup* g )
{
	const plAssetData* a = g->asset;
	plSelectMembers( g, 1 );
	if ( g->member_count == 0 )
	{
		return;
	}
	plResult r = plRunBatchedNetwork( g, 1 );
	if ( r != PLEAT_RESULT_OK )
	{
		plFailMembers( g, r );
		return;
	}
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plBatchEntry* e = &g->entries[g->members[m]];
		if ( !plAllFiniteFloats( e->inst->y, a->latent_count ) )
		{
			e->needs_reset = 1; // before the guard, as in the single step: the clamp would hide an overflow
			continue;
		}
		e->result = plGuardLatent( e->inst );
	}
	plSelectMembers( g, 1 );
	if ( g->member_count == 0 )
	{
		return;
	}
	r = plRunBatchedNetwork( g, 0 );
	if ( r != PLEAT_RESULT_OK )
	{
		plFailMembers( g, r );
		return;
	}
	for ( uint32_t m = 0; m < g->member_count; ++m )
	{
		plBatchEntry* e = &g->entries[g->members[m]];
		e->needs_reset = !( plAllFiniteFloats( e->inst->next_weights, a->blend_count ) &&
							plAllFiniteFloats( e->inst->next_skin_matrices, (size_t)a->joint_count * 12 ) );
	}
}

// The entry's instance if it deforms this step (NULL when it failed or waits for a numeric reset), its blend weights
// held (next = current) between network updates, as plDeform does.
static plInstanceData* plDeformingInstance( const plAssetData* a, plBatchEntry* e )
{
	if ( e->result != PLEAT_RESULT_OK || e->needs_reset )
	{
		return NULL;
	}
	plInstanceData* inst = e->inst;
	if ( !e->update.run )
	{
		memcpy( inst->next_weights, inst->blend_weights, a->blend_count * sizeof( float ) );
	}
	return inst;
}

// Which instances blend this step (plDeform's rule): after a network update always; between updates (the held
// weights) only when T_def is not already the committed one.
static void plRunBlend( plBatchGroup* g )
{
	const plAssetData* a = g->asset;
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plBatchEntry* e = &g->entries[i];
		plInstanceData* inst = plDeformingInstance( a, e );
		if ( inst == NULL )
		{
			continue;
		}
		e->blend = e->update.run || !inst->deformed_is_committed;
		if ( e->blend )
		{
			inst->deformed_is_committed = 0; // until this step commits
		}
	}
	plSelectMembers( g, 0 );
	if ( g->member_count == 0 )
	{
		return;
	}
	atomic_init( &g->blend_result, (int)PLEAT_RESULT_OK );
	plRunTask( &g->ctx->runner, plBlendTask, a->vertex_count, 256, g );
	if ( atomic_load_explicit( &g->blend_result, memory_order_relaxed ) != (int)PLEAT_RESULT_OK )
	{
		plFailMembers( g, PLEAT_RESULT_INTERNAL_ERROR );
	}
}

// ---- GPU modes: the group's deformation in one batch of dispatches ----

// What plInstance_Step's plDeform does on the GPU path, for every member at once: the held weights between network
// updates, then one plGlDeformer_RunBatch (read-backs into deformed and gl_normals, as Run's), then each commit.
static void plRunGpu( plBatchGroup* g )
{
	const plAssetData* a = g->asset;
	plGlBatchMember members[PLEAT_BATCH_MAX];
	uint32_t count = 0;
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plBatchEntry* e = &g->entries[i];
		plInstanceData* inst = plDeformingInstance( a, e );
		if ( inst == NULL )
		{
			continue;
		}
		plGlBatchMember* m = &members[count];
		m->deformer = inst->gl;
		m->shaped_template = inst->shaped_template;
		m->body_anchors = inst->shaped_anchors; // its first P rows: the body points of the committed β
		m->blend_weights = inst->next_weights;
		m->skin_matrices = inst->next_skin_matrices;
		m->positions = e->read_back ? inst->deformed : NULL;
		m->normals = e->read_back ? inst->gl_normals : NULL;
		g->members[count++] = i;
	}
	if ( count == 0 )
	{
		return;
	}
	plResult r = plGlDeformer_RunBatch( members[0].deformer, members, count );
	for ( uint32_t k = 0; k < count; ++k )
	{
		plBatchEntry* e = &g->entries[g->members[k]];
		if ( r != PLEAT_RESULT_OK )
		{
			e->result = r; // as plInstance_Step: the error, nothing committed
			continue;
		}
		plCommit( e->inst, e->update.run, 0, e->input->dt_s, e->read_back, e->output );
		e->result = plStepResult( e->inst, 0, &e->update, e->input->dt_s );
	}
}

// ---- per lane group, after the blend: skinning and normals with the instances as vector lanes ----

int plGeometryLanes( plContextData* ctx, const plBatchKernels* kernels, const plAssetData* a, int fast_contact,
					 plInstanceData* const* insts, const float* const* in, float* const* positions,
					 float* const* normals, uint32_t count )
{
	const float* matrices[PLEAT_BATCH_MAX] = { NULL }; // (all of count filled below; GCC's scalar build cannot tell)
	// The lanes with body contact, by which contact they run (plRunsFastContact): the fast one and the full one.
	plInstanceData* contact_insts[2][PLEAT_BATCH_MAX];
	float* contact_positions[2][PLEAT_BATCH_MAX];
	const float* contact_points[2][PLEAT_BATCH_MAX];
	const float* contact_matrices[2][PLEAT_BATCH_MAX];
	float contact_offsets[2][PLEAT_BATCH_MAX];
	uint32_t contact_count[2] = { 0, 0 };
	enum
	{
		FAST = 0,
		FULL = 1
	};
	for ( uint32_t k = 0; k < count; ++k )
	{
		matrices[k] = insts[k]->next_skin_matrices;
		if ( insts[k]->body_contact )
		{
			int kind = plRunsFastContact( insts[k], fast_contact ) ? FAST : FULL;
			uint32_t i = contact_count[kind]++;
			contact_insts[kind][i] = insts[k];
			contact_positions[kind][i] = positions[k];
			contact_points[kind][i] = insts[k]->shaped_anchors;
			contact_matrices[kind][i] = matrices[k];
			contact_offsets[kind][i] = insts[k]->body_contact_offset_m;
		}
	}
	kernels->skinning_batch( positions, in, count, a->skin_indices, a->skin_weights, a->influence_count, matrices,
							 a->joint_count, 0, a->vertex_count );
	// What plDeformCpu runs between skinning and normals, with each lane getting its lone step's bits. The fast
	// contact in lanes (its batched kernel gives each lane the single kernel's bits).
	if ( contact_count[FAST] > 0 )
	{
		kernels->body_contact_fast_batch( contact_positions[FAST], contact_points[FAST], contact_offsets[FAST],
										  contact_count[FAST], a->body_anchor_normals, a->body_anchor_skin_indices,
										  a->body_anchor_skin_weights, a->body_anchor_influence_count,
										  contact_matrices[FAST], a->joint_count, 0, a->vertex_count );
	}
	// The full contact: in lanes where the set has the kernel and a scratch block is free, else instance by instance.
	// (The jobs only refuse spans the instance did not build: the result says nothing about the input.)
	int contact_slot = contact_count[FULL] > 1 && kernels->body_contact_batch != NULL
						   ? plClaimBatchScratch( ctx, plBodyContactBatchScratchFloats( a->body_point_count ) )
						   : -1;
	if ( contact_slot >= 0 )
	{
		kernels->body_contact_batch( contact_positions[FULL], contact_points[FULL], contact_offsets[FULL],
									 contact_count[FULL], a->body_anchor_normals, a->body_anchor_skin_indices,
									 a->body_anchor_skin_weights, a->body_anchor_influence_count,
									 contact_matrices[FULL], a->joint_count, a->body_point_count,
									 a->body_anchor_candidates, a->body_anchor_candidate_count, a->body_anchor_ring,
									 a->body_anchor_ring_count, a->vertex_count, ctx->batch_scratch[contact_slot] );
		plReleaseBatchScratch( ctx, contact_slot );
	}
	else
	{
		for ( uint32_t i = 0; i < contact_count[FULL]; ++i )
		{
			(void)plRunBodyContact( contact_insts[FULL][i], contact_positions[FULL][i], contact_matrices[FULL][i], 0 );
		}
	}
	int slot = plClaimBatchScratch( ctx, plNormalsBatchScratchFloats( a->vertex_count, kernels->geometry_lanes ) );
	if ( slot < 0 )
	{
		return 0;
	}
	kernels->normals_batch( normals, (const float* const*)positions, count, a->vertex_count, a->faces, a->face_count,
							ctx->batch_scratch[slot] );
	plReleaseBatchScratch( ctx, slot );
	return 1;
}

// ---- per instance, after the geometry: guards, commit ----

static void plFinishEntry( plBatchEntry* e )
{
	if ( e->finished || e->result != PLEAT_RESULT_OK || e->needs_reset )
	{
		return;
	}
	plInstanceData* inst = e->inst;
	if ( !e->geometry_done )
	{
		// The blend already wrote T_def; skinning (with body contact) and normals of this worker's whole instance run
		// unsplit here (their results do not depend on the split).
		plResult r = plDeformCpu( inst, inst->next_weights, inst->next_skin_matrices, 0, NULL );
		if ( r != PLEAT_RESULT_OK )
		{
			e->result = r;
			return;
		}
	}
	size_t n3 = (size_t)inst->asset->vertex_count * 3;
	if ( !( plAllFiniteFloats( inst->positions, n3 ) && plAllFiniteFloats( inst->normals, n3 ) ) )
	{
		e->needs_reset = 1;
		return;
	}
	plCommit( inst, e->update.run, 0, e->input->dt_s, 1, e->output );
	e->result = plStepResult( inst, 0, &e->update, e->input->dt_s );
}

// Lane groups [begin, end) of the members through plGeometryLanes. Every instance keeps its own positions and normals
// buffers; only the normals' lanes live in the context's scratch.
static void plGeometryTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plBatchGroup* g = (plBatchGroup*)context;
	uint32_t lanes = g->kernels->geometry_lanes;
	for ( uint32_t lane_group = begin; lane_group < end; ++lane_group )
	{
		uint32_t m0 = lane_group * lanes;
		uint32_t n = g->member_count - m0 < lanes ? g->member_count - m0 : lanes;
		plInstanceData* insts[PLEAT_BATCH_MAX];
		const float* in[PLEAT_BATCH_MAX];
		float* positions[PLEAT_BATCH_MAX];
		float* normals[PLEAT_BATCH_MAX];
		for ( uint32_t k = 0; k < n; ++k )
		{
			insts[k] = g->entries[g->members[m0 + k]].inst;
			in[k] = insts[k]->deformed;
			positions[k] = insts[k]->positions;
			normals[k] = insts[k]->normals;
		}
		if ( plGeometryLanes( g->ctx, g->kernels, g->asset, 0, insts, in, positions, normals, n ) )
		{
			// The finish (finite check, commit, copy out) while the lane group's positions and normals are still in
			// this core's cache: after the whole batch's geometry they were out in L3 (a finish stage of 2.8 µs an
			// instance for the shipped t-shirt).
			for ( uint32_t k = 0; k < n; ++k )
			{
				plBatchEntry* e = &g->entries[g->members[m0 + k]];
				plFinishEntry( e );
				e->finished = 1;
			}
			continue;
		}
		for ( uint32_t k = 0; k < n; ++k )
		{
			// No scratch free: each instance's own normals (the single step's kernels, the same bits).
			if ( plNormalsSerial( insts[k] ) != PLEAT_RESULT_OK )
			{
				atomic_store_explicit( &g->blend_result, (int)PLEAT_RESULT_INTERNAL_ERROR, memory_order_relaxed );
			}
		}
	}
}

// Members = the entries whose skinning and normals run batched (the batched kernels have lanes: not the scalar set);
// body contact runs in between, as in plDeformCpu.
static void plRunGeometry( plBatchGroup* g )
{
	g->member_count = 0;
	if ( g->kernels->geometry_lanes <= 1 )
	{
		return;
	}
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		plBatchEntry* e = &g->entries[i];
		if ( e->result == PLEAT_RESULT_OK && !e->needs_reset )
		{
			g->members[g->member_count++] = i;
			e->geometry_done = 1;
		}
	}
	if ( g->member_count == 0 )
	{
		return;
	}
	uint32_t lanes = g->kernels->geometry_lanes;
	atomic_init( &g->blend_result, (int)PLEAT_RESULT_OK );
	plRunTask( &g->ctx->runner, plGeometryTask, ( g->member_count + lanes - 1 ) / lanes, 1, g );
	if ( atomic_load_explicit( &g->blend_result, memory_order_relaxed ) != (int)PLEAT_RESULT_OK )
	{
		for ( uint32_t m = 0; m < g->member_count; ++m )
		{
			plBatchEntry* e = &g->entries[g->members[m]];
			e->result = e->finished ? e->result : PLEAT_RESULT_INTERNAL_ERROR; // (a finished one has committed)
		}
	}
}

static void plFinishTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plBatchGroup* g = (plBatchGroup*)context;
	for ( uint32_t i = begin; i < end; ++i )
	{
		plFinishEntry( &g->entries[i] );
	}
}

// The numeric reset of plInstance_Step, on the calling thread (it splits its own work over the workers).
static void plResetEntry( plBatchEntry* e )
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

static void plRunGroup( plBatchGroup* g )
{
	PLEAT_BATCH_PHASE_START();
	plRunTask( &g->ctx->runner, plPrepareTask, g->count, 1, g );
	PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_PREPARE );
	plRunNetworks( g );
	PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_NETWORKS );
	if ( g->asset != NULL && g->entries[0].inst->gl != NULL )
	{
		plRunGpu( g ); // a group is all CPU or all one GPU mode
		PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_GEOMETRY );
	}
	else
	{
		plRunBlend( g );
		PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_BLEND );
		plRunGeometry( g );
		PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_GEOMETRY );
		plRunTask( &g->ctx->runner, plFinishTask, g->count, 1, g );
	}
	for ( uint32_t i = 0; i < g->count; ++i )
	{
		if ( g->entries[i].result == PLEAT_RESULT_OK && g->entries[i].needs_reset )
		{
			plResetEntry( &g->entries[i] );
		}
	}
	PLEAT_BATCH_PHASE( PLEAT_BATCH_PHASE_FINISH );
}

// ---- the call ----

// The instance behind a handle of this context, or NULL.
static plInstanceData* plLookup( plContext context, plInstance handle )
{
	if ( handle.context.index1 != context.index1 || handle.context.generation != context.generation )
	{
		return NULL;
	}
	return plGetInstanceData( handle );
}

static int plBatchable( const plInstanceData* inst )
{
	return inst->ort_lp == NULL && inst->ort_dec == NULL;
}

// Non-zero if inst can join a group that first leads: the same asset, and both on the CPU or both in a GPU mode that
// can share one batch of dispatches.
static int plSameGroup( const plInstanceData* first, const plInstanceData* inst )
{
	if ( inst->asset != first->asset || !plBatchable( inst ) )
	{
		return 0;
	}
	if ( first->gl == NULL || inst->gl == NULL )
	{
		return first->gl == NULL && inst->gl == NULL;
	}
	return plGlDeformer_CanBatch( first->gl, inst->gl );
}

typedef struct plBatchOutcome
{
	uint32_t error_index, note_index; // lowest list index with an error / a note (UINT32_MAX: none)
	plResult error, note;
} plBatchOutcome;

static void plRecord( plBatchOutcome* outcome, plResult* out_results, uint32_t index, plResult r )
{
	if ( out_results != NULL )
	{
		out_results[index] = r;
	}
	if ( r < 0 && index < outcome->error_index )
	{
		outcome->error_index = index;
		outcome->error = r;
	}
	else if ( r > 0 && index < outcome->note_index )
	{
		outcome->note_index = index;
		outcome->note = r;
	}
}

plResult plStepInstances( plContext context, const plInstance* instances, const plFrameInput* inputs,
						  const plStepOutput* outputs, plResult* out_results, uint32_t count )
{
	plContextData* ctx = plGetContext( context );
	if ( ctx == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( count == 0 )
	{
		return PLEAT_RESULT_OK;
	}
	if ( instances == NULL || inputs == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const plBatchKernels* kernels = ctx->kernels.batch; // the context's, chosen at its creation
	int batched_kernels = kernels != NULL;
	plBatchOutcome outcome = { UINT32_MAX, UINT32_MAX, PLEAT_RESULT_OK, PLEAT_RESULT_OK };
	plBatchGroup group;
	group.ctx = ctx;
	group.kernels = kernels;
	for ( uint32_t w0 = 0; w0 < count; w0 += PLEAT_BATCH_WINDOW )
	{
		uint32_t w1 = count - w0 > PLEAT_BATCH_WINDOW ? w0 + PLEAT_BATCH_WINDOW : count;
		uint8_t done[PLEAT_BATCH_WINDOW / 8];
		memset( done, 0, sizeof( done ) );
#define PLEAT_DONE_( i ) ( done[( ( i ) - w0 ) >> 3] & ( 1u << ( ( ( i ) - w0 ) & 7u ) ) )
#define PLEAT_MARK_( i ) ( done[( ( i ) - w0 ) >> 3] |= (uint8_t)( 1u << ( ( ( i ) - w0 ) & 7u ) ) )
		for ( uint32_t s = w0; s < w1; ++s )
		{
			if ( PLEAT_DONE_( s ) )
			{
				continue;
			}
			PLEAT_MARK_( s );
			plInstanceData* first = plLookup( context, instances[s] );
			const plStepOutput* out = outputs != NULL ? &outputs[s] : NULL;
			if ( first == NULL )
			{
				char detail[64];
				snprintf( detail, sizeof( detail ), "at instances[%u] is stale or of another context", s );
				plLogStaleInstance( ctx, instances[s], __func__, detail );
				plRecord( &outcome, out_results, s, PLEAT_RESULT_INVALID_HANDLE );
				continue;
			}
			if ( !batched_kernels || !plBatchable( first ) )
			{
				plRecord( &outcome, out_results, s, plInstance_Step( instances[s], &inputs[s], out ) );
				continue;
			}
			// A group: this instance and the next unprocessed ones of the same asset, each at most once (a second
			// listing of an instance waits for a later group, so it is stepped after the first, in list order).
			group.asset = first->asset;
			group.count = 0;
			uint32_t indices[PLEAT_BATCH_MAX];
			for ( uint32_t t = s; t < w1 && group.count < PLEAT_BATCH_MAX; ++t )
			{
				plInstanceData* inst = t == s ? first : ( PLEAT_DONE_( t ) ? NULL : plLookup( context, instances[t] ) );
				if ( inst == NULL || !plSameGroup( first, inst ) )
				{
					continue;
				}
				int duplicate = 0;
				for ( uint32_t k = 0; k < group.count && !duplicate; ++k )
				{
					duplicate = group.entries[k].inst == inst;
				}
				if ( duplicate )
				{
					continue;
				}
				PLEAT_MARK_( t );
				plBatchEntry* e = &group.entries[group.count];
				memset( e, 0, sizeof( *e ) );
				e->inst = inst;
				e->input = &inputs[t];
				e->output = outputs != NULL ? &outputs[t] : NULL;
				e->read_back = inst->gl == NULL || ( e->output != NULL && ( e->output->positions != NULL ||
																			 e->output->normals != NULL ) );
				indices[group.count++] = t;
			}
			if ( group.count == 1 )
			{
				// Nothing to share: the single step itself (the same result; its kernels stream a lone instance's
				// weights faster than the batched ones, which are built for many).
				plRecord( &outcome, out_results, s, plInstance_Step( instances[s], &inputs[s], out ) );
				continue;
			}
			plRunGroup( &group );
			for ( uint32_t k = 0; k < group.count; ++k )
			{
				plRecord( &outcome, out_results, indices[k], group.entries[k].result );
			}
		}
#undef PLEAT_DONE_
#undef PLEAT_MARK_
	}
	return outcome.error_index != UINT32_MAX ? outcome.error : outcome.note;
}
